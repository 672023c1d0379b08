//! Indirect light (paper section 2: higher-order light from illumination maps), beside the
//! exact direct light of the light passes and the Whitted mirror and refraction packets.
//!
//! - [`Indirect::None`] (the default): direct light only, every image as it was.
//! - [`Indirect::Map`]: at every hit of every segment, `throughput * albedo / pi * E` with
//!   `E` the illumination map's filtered irradiance there (`crate::illum`; the map leaves out
//!   the particles' first hits, which the light passes count exactly).
//! - [`Indirect::Path`]: a plain unbiased path tracer, the reference the maps are checked
//!   against. Every hit also spawns a diffuse bounce packet: a cosine-weighted direction about
//!   the shading normal on the incoming side, the throughput times the albedo (the cosine
//!   over the density cancels the albedo's `1 / pi`), Russian roulette from the
//!   [`RR_START`]-th bounce on (survival from the throughput, at most
//!   [`RR_MAX_SURVIVAL`]), at most `max_bounces` bounces whatever the scene's Whitted depth.
//!   A bounce that misses sees the scene's background but not the lights' radiance (an
//!   environment light was counted at the hit by the light passes; mirror rays still see
//!   it). Lights are not geometry: no bounce hits an emitter, so light that reaches a
//!   diffuse surface by way of a mirror or glass (a caustic) is missing here; the map has it.
//!
//! Both see a material through its diffuse albedo ([`crate::material::Material::albedo`]):
//! the Phong specular lobe's share of indirect light is left out (the map's particles bounce
//! diffusely or specularly, never into the lobe), so the two estimate the same quantity.
//! For the same reason a hit below a diffuse bounce reflects the lights by its albedo alone
//! (no lobe, no tabulated BDF) and shows no ambient term: the ambient term (the scenes'
//! stand-in for glowing surfaces) lights nothing else, as the particles do not leave it.
//! A bounce whose direction falls on the other side of the geometric surface than the viewer
//! (shading normals bent away from it) is dropped.
//!
//! A bounce's random numbers hash the sample's id with its node of the ray tree, so an
//! image does not depend on the packet width, the thread count or regrouping.

use std::sync::Arc;

use coherent_accel::{Accel, Rays};
use coherent_simd::{Lanes, Rgbs, SimdF32, SimdI32, SimdMask, Vec3s};

use super::colour::Colour;

use super::{Differentials, RayKind, Renderer, Segment, Surface, rng};
use crate::illum::IllumMap;
use crate::light::sincos::sincos;
use crate::material::ShadeHits;

/// Diffuse bounces of [`Indirect::Path`] unless told otherwise.
pub const DEFAULT_MAX_BOUNCES: u32 = 64;

/// The first bounce (counting from 0 at the camera's hit) whose continuation plays Russian
/// roulette: the first few bounces carry most of the light and are always traced.
pub const RR_START: u32 = 3;

/// The largest survival probability of Russian roulette: even a white path ends some time.
pub const RR_MAX_SURVIVAL: f32 = 0.95;

/// How the renderer adds indirect light (see the module documentation).
#[derive(Debug, Clone, Default)]
pub enum Indirect {
    /// Direct light only (the default).
    #[default]
    None,
    /// An illumination map's irradiance at every hit.
    Map(Arc<IllumMap>),
    /// A path tracer's diffuse bounces, at most `max_bounces` per path.
    Path { max_bounces: u32 },
}

impl Indirect {
    /// [`Indirect::Path`] with [`DEFAULT_MAX_BOUNCES`].
    pub fn path() -> Self {
        Indirect::Path {
            max_bounces: DEFAULT_MAX_BOUNCES,
        }
    }

    /// Which mode this is.
    pub fn mode(&self) -> IndirectMode {
        match self {
            Indirect::None => IndirectMode::None,
            Indirect::Map(_) => IndirectMode::Imap,
            Indirect::Path { .. } => IndirectMode::Path,
        }
    }
}

/// The modes of [`Indirect`] by their command-line names, without their data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum IndirectMode {
    #[default]
    None,
    Imap,
    Path,
}

impl IndirectMode {
    pub const ALL: [IndirectMode; 3] = [IndirectMode::None, IndirectMode::Imap, IndirectMode::Path];

    /// The name used on the command line and in results.
    pub fn name(self) -> &'static str {
        match self {
            IndirectMode::None => "none",
            IndirectMode::Imap => "imap",
            IndirectMode::Path => "path",
        }
    }
}

impl std::fmt::Display for IndirectMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for IndirectMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown indirect light `{s}`: none, imap or path"))
    }
}

/// The child of ray-tree node `path` that is its diffuse bounce. Hashed, not `3k + 2`: paths
/// of 64 bounces would overflow any counting scheme; a collision only correlates two
/// nodes' random numbers.
#[inline(always)]
fn diffuse_child(path: u32) -> u32 {
    rng::hash1(path ^ 0x2545_f491) | 0x8000_0000
}

impl<A: Accel> Renderer<'_, A> {
    /// The diffuse albedo of the lanes of `mask` (zero elsewhere), one material at a time
    /// under its mask, at the mip levels the material pass without a light left in `ctx`.
    /// Not counted in `stats.materials`: those count the shading passes of direct light.
    #[inline(always)]
    pub(super) fn albedo_materials<L: Lanes>(
        &self,
        l: L,
        ctx: &ShadeHits<L>,
        mask: L::Mask,
    ) -> Rgbs<L> {
        let mut out = Rgbs::zero(l);
        let mut todo = mask;
        while todo.any() {
            let id = ctx.material.lane(todo.bitmask().trailing_zeros() as usize);
            let mine = todo & ctx.material.eq(l.splat_i32(id));
            let a = self.scene.materials[id as usize].albedo(l, ctx.s, ctx.t, ctx.lod);
            out = Rgbs::select(mine, a, out);
            todo = todo.and_not(mine);
        }
        out
    }

    /// Pushes the diffuse bounce packet of the lanes of `hit` with some albedo: `ns` and `ng`
    /// are the normals as the segment shaded with them (opaque ones facing the viewer,
    /// transmissive ones outward).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn spawn_diffuse<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        w: &C::Waves,
        seg: &Segment<L, C>,
        surf: &Surface<L>,
        ns: &Vec3s<L>,
        ng: &Vec3s<L>,
        albedo: &Rgbs<L>,
        hit: L::Mask,
        pending: &mut Vec<Segment<L, C>>,
    ) {
        let zero = l.splat(0.0);
        let one = l.splat(1.0);
        let wo = -seg.rays.dir;
        let mut tp = seg.throughput.times(l, t, w, *albedo);
        let mut on = hit & tp.max_channel(l, t).gt(zero);
        if on.none() {
            return;
        }
        let stream = rng::hash1(seg.path.wrapping_mul(0x85eb_ca6b) ^ 0xd1ff_05e0);
        if seg.bounces >= RR_START {
            let q = tp.max_channel(l, t).min(l.splat(RR_MAX_SURVIVAL));
            let u = rng::uniform(l, seg.ids, stream ^ 0x3333_3333);
            on &= u.lt(q);
            if on.none() {
                return;
            }
            tp.scale(l, t, one / on.select(q, one));
        }
        // Cosine-weighted about the shading normal on the viewer's side.
        let n = Vec3s::select(ns.dot(wo).lt(zero), -*ns, *ns);
        let u1 = rng::uniform(l, seg.ids, stream);
        let u2 = rng::uniform(l, seg.ids, stream ^ 0x5555_5555);
        let r = u1.sqrt();
        let (sin, cos) = sincos(l, (u2 + u2 - one) * std::f32::consts::PI);
        let z = (one - u1).max(zero).sqrt();
        let bitangent = n.cross(surf.tangent);
        let dir = (surf.tangent * (r * cos) + bitangent * (r * sin) + n * z).normalize();
        // The bounce leaves on the viewer's side of the geometric surface, or not at all.
        let (side_o, side_d) = (ng.dot(wo), ng.dot(dir));
        on &= (side_o * side_d).gt(zero);
        if on.none() {
            return;
        }
        let eps = (surf.p.x.abs().max(surf.p.y.abs()).max(surf.p.z.abs()) + 1.0) * 1e-4;
        let side = side_d.lt(zero).select(-eps, eps);
        let zero3 = Vec3s::splat(l, glam::Vec3::ZERO);
        pending.push(Segment {
            rays: Rays {
                origin: ng.mul_add(side, surf.p),
                dir,
                tmin: zero,
                tmax: l.splat(f32::INFINITY),
            },
            // The footprint where the bounce leaves, not spreading: textures seen through a
            // bounce are looked up about as sharp as at its origin.
            diff: Differentials {
                dorigin_dx: surf.dp_dx,
                dorigin_dy: surf.dp_dy,
                ddir_dx: zero3,
                ddir_dy: zero3,
            },
            active: on,
            throughput: tp,
            wave: seg.wave,
            depth: seg.depth,
            bounces: seg.bounces + 1,
            kind: RayKind::Diffuse,
            path: diffuse_child(seg.path),
            light_ids: seg.light_ids,
            ids: seg.ids,
            slot: seg.slot,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_round_trip_and_unknown_ones_are_refused() {
        for m in IndirectMode::ALL {
            assert_eq!(m.name().parse::<IndirectMode>().unwrap(), m);
        }
        let e = "photons".parse::<IndirectMode>().unwrap_err();
        assert!(e.contains("none, imap or path"), "{e}");
        assert_eq!(Indirect::default().mode(), IndirectMode::None);
        assert_eq!(Indirect::path().mode(), IndirectMode::Path);
    }

    #[test]
    fn diffuse_children_leave_the_mirror_tree_s_node_ids() {
        // Mirror nodes are 1 .. 2^depth (depth well under 31): a bounce's id has its top bit.
        for p in 1..10_000u32 {
            assert!(diffuse_child(p) >= 0x8000_0000);
        }
    }
}
