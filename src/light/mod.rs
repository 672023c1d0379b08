//! Coherent lights (paper section 5): the eight kinds of the paper and HDR environments,
//! each evaluated for a packet of shading points under a mask, one light at a time.
//! Lanes that need no lighting (outside the mask, facing away from the sample, outside a
//! spot's cone) are masked off and get zero radiance.
//!
//! Units: point lights carry a radiant intensity `I` (W/sr per RGB channel), parallel
//! lights an irradiance `E` (W/m^2 on a surface facing them), surface lights and the
//! environment a radiance `L` (W/(m^2 sr)). Goniodiagram files are photometric (candela):
//! [`photometry::WATTS_PER_LUMEN`] is the one place the units are converted.
//!
//! A light gives, per shading point, [`Light::samples`] samples; each sample is a direction
//! `wi`, a distance for the shadow ray and `li`, the incident radiance times the sample's
//! weight, so that the reflected radiance is `sum_k f(wi_k, wo) cos(theta_k) li_k`.

// Index loops, not iterator adapters, in the per-packet code (see `tabulated`).
#![allow(clippy::needless_range_loop)]

pub mod circular;
pub mod direct;
pub mod environment;
pub mod goniodiagram;
pub mod ies;
pub mod ldt;
pub mod linear;
pub mod omni;
pub mod parallel;
pub mod photometry;
pub mod rectangular;
pub mod sincos;
pub mod spot;
pub mod strata;

use std::path::PathBuf;

use coherent_accel::Rays;
use coherent_simd::{Lanes, Rgbs, SimdF32, SimdMask, Vec3s};
use glam::Vec3;
use thiserror::Error;

pub use circular::Circular;
pub use direct::Direct;
pub use environment::Environment;
pub use goniodiagram::{GonioLookup, Goniodiagram};
pub use linear::Linear;
pub use omni::Omni;
pub use parallel::Parallel;
pub use rectangular::Rectangular;
pub use spot::{Spot, SpotFalloff};
pub use strata::Strata;

/// A light of any kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    Omni(Omni),
    Spot(Spot),
    Parallel(Parallel),
    Direct(Direct),
    Linear(Linear),
    Circular(Circular),
    Rectangular(Rectangular),
    Goniodiagram(Goniodiagram),
    Environment(Environment),
}

/// The kinds of light, by the names used in scene files and results.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum LightKind {
    Omni,
    Spot,
    Parallel,
    Direct,
    Linear,
    Circular,
    Rectangular,
    Goniodiagram,
    Environment,
}

impl LightKind {
    /// Every kind, in the paper's Table 2 order (the environment last).
    pub const ALL: [LightKind; 9] = [
        LightKind::Omni,
        LightKind::Spot,
        LightKind::Parallel,
        LightKind::Direct,
        LightKind::Linear,
        LightKind::Circular,
        LightKind::Rectangular,
        LightKind::Goniodiagram,
        LightKind::Environment,
    ];

    /// The name used in scene files and results.
    pub fn name(self) -> &'static str {
        match self {
            LightKind::Omni => "omni",
            LightKind::Spot => "spot",
            LightKind::Parallel => "parallel",
            LightKind::Direct => "direct",
            LightKind::Linear => "linear",
            LightKind::Circular => "circular",
            LightKind::Rectangular => "rectangular",
            LightKind::Goniodiagram => "goniodiagram",
            LightKind::Environment => "environment",
        }
    }
}

impl std::fmt::Display for LightKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LightKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        LightKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = LightKind::ALL.iter().map(|k| k.name()).collect();
                format!("unknown light kind `{s}`; kinds: {}", names.join(", "))
            })
    }
}

/// One sample of a light for a packet of shading points (see the module documentation).
pub struct LightSample<L: Lanes> {
    /// Lanes this sample lights (facing it, inside the cone, non-zero); the rest are zero.
    pub active: L::Mask,
    /// Unit direction from the shading point towards the sample (the normal on inactive lanes).
    pub wi: Vec3s<L>,
    /// Distance to the sample point (`f32::INFINITY` for parallel and environment; 0 on
    /// inactive lanes).
    pub dist: L::F32s,
    /// Incident radiance times the sample's weight.
    pub li: Rgbs<L>,
}

impl<L: Lanes> Clone for LightSample<L> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lanes> Copy for LightSample<L> {}

impl<L: Lanes> std::fmt::Debug for LightSample<L> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LightSample")
            .field("active", &self.active.bitmask())
            .field("wi", &self.wi)
            .field("dist", &self.dist)
            .field("li", &self.li)
            .finish()
    }
}

/// A light that cannot be built: the light or file, the field (and line), the problem.
#[derive(Debug, Error)]
pub enum LightError {
    #[error("{light} light: {field} is {value}, {expected}")]
    BadParameter {
        light: &'static str,
        field: &'static str,
        value: String,
        expected: &'static str,
    },
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {field}: {problem}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        field: String,
        problem: String,
    },
    #[error("{}: {problem}", path.display())]
    File { path: PathBuf, problem: String },
}

impl LightError {
    pub(crate) fn bad(
        light: &'static str,
        field: &'static str,
        value: impl std::fmt::Debug,
        expected: &'static str,
    ) -> LightError {
        // A vector as the scene file writes it, `[x, y, z]`, not glam's `Vec3(x, y, z)`.
        let value = format!("{value:?}");
        let value = match value
            .strip_prefix("Vec3(")
            .and_then(|v| v.strip_suffix(')'))
        {
            Some(xyz) => format!("[{xyz}]"),
            None => value,
        };
        LightError::BadParameter {
            light,
            field,
            value,
            expected,
        }
    }
}

/// The most light samples one light may take per shading point (area lights' points,
/// the environment's samples). The paper's area lights take 7-21 and our scenes'
/// environments 8 (the convergence tests up to 18,900); a count far beyond this (a typo, a
/// value meant for another field) would take days per frame, or more memory than the
/// machine has, before anything said why.
pub const MAX_SAMPLES: u64 = 65_536;

/// Checks that a light's sample count (`count`, the product of `shown`'s factors) lies in
/// `1..=MAX_SAMPLES`.
pub(crate) fn check_samples(
    light: &'static str,
    field: &'static str,
    count: u64,
    shown: impl std::fmt::Debug,
) -> Result<(), LightError> {
    if count == 0 {
        return Err(LightError::bad(
            light,
            field,
            shown,
            "no samples (each count must be at least 1)",
        ));
    }
    if count > MAX_SAMPLES {
        return Err(LightError::bad(
            light,
            field,
            shown,
            "at most 65536 (`MAX_SAMPLES`) samples per shading point",
        ));
    }
    Ok(())
}

/// Checks that `v` is finite.
pub(crate) fn check_point(
    light: &'static str,
    field: &'static str,
    v: Vec3,
) -> Result<Vec3, LightError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(LightError::bad(light, field, v, "not a finite point"))
    }
}

/// Checks that `v` is finite and not zero, and returns it normalised.
pub(crate) fn check_dir(
    light: &'static str,
    field: &'static str,
    v: Vec3,
) -> Result<Vec3, LightError> {
    let n = v.normalize_or_zero();
    if v.is_finite() && n != Vec3::ZERO {
        Ok(n)
    } else {
        Err(LightError::bad(
            light,
            field,
            v,
            "not a finite non-zero direction",
        ))
    }
}

/// Checks that every channel of `c` is finite and non-negative.
pub(crate) fn check_colour(
    light: &'static str,
    field: &'static str,
    c: [f32; 3],
) -> Result<[f32; 3], LightError> {
    if c.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(c)
    } else {
        Err(LightError::bad(
            light,
            field,
            c,
            "not finite and non-negative in every channel",
        ))
    }
}

/// Checks that `x` is finite and positive.
pub(crate) fn check_positive(
    light: &'static str,
    field: &'static str,
    x: f32,
) -> Result<f32, LightError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(LightError::bad(
            light,
            field,
            x,
            "not a finite positive number",
        ))
    }
}

impl Light {
    /// This light's kind.
    pub fn kind(&self) -> LightKind {
        match self {
            Light::Omni(_) => LightKind::Omni,
            Light::Spot(_) => LightKind::Spot,
            Light::Parallel(_) => LightKind::Parallel,
            Light::Direct(_) => LightKind::Direct,
            Light::Linear(_) => LightKind::Linear,
            Light::Circular(_) => LightKind::Circular,
            Light::Rectangular(_) => LightKind::Rectangular,
            Light::Goniodiagram(_) => LightKind::Goniodiagram,
            Light::Environment(_) => LightKind::Environment,
        }
    }

    /// Whether [`Light::sample`] uses its numbers `u`: the environment, and surface lights
    /// built to jitter their points.
    pub fn takes_random_numbers(&self) -> bool {
        match self {
            Light::Linear(x) => x.jittered(),
            Light::Circular(x) => x.jittered(),
            Light::Rectangular(x) => x.jittered(),
            Light::Environment(_) => true,
            _ => false,
        }
    }

    /// Sample points per shading point (1 for point lights).
    pub fn samples(&self) -> u32 {
        match self {
            Light::Omni(_)
            | Light::Spot(_)
            | Light::Parallel(_)
            | Light::Direct(_)
            | Light::Goniodiagram(_) => 1,
            Light::Linear(x) => x.samples(),
            Light::Circular(x) => x.samples(),
            Light::Rectangular(x) => x.samples(),
            Light::Environment(x) => x.samples(),
        }
    }

    /// Sample `k` (in `0..samples()`) of this light for the shading points `p` with unit
    /// normals `n`, on the lanes of `active`. `u` are per-lane uniform numbers in `[0, 1)`:
    /// surface lights jitter stratum `k` with them (when built to), the environment
    /// importance-samples with them inside stratum `k` of its grid; point lights ignore
    /// them.
    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
        k: u32,
        u: [L::F32s; 2],
    ) -> LightSample<L> {
        match self {
            Light::Omni(x) => x.sample(l, p, n, active),
            Light::Spot(x) => x.sample(l, p, n, active),
            Light::Parallel(x) => x.sample(l, p, n, active),
            Light::Direct(x) => x.sample(l, p, n, active),
            Light::Linear(x) => x.sample(l, p, n, active, k, u),
            Light::Circular(x) => x.sample(l, p, n, active, k, u),
            Light::Rectangular(x) => x.sample(l, p, n, active, k, u),
            Light::Goniodiagram(x) => x.sample(l, p, n, active),
            Light::Environment(x) => x.sample(l, p, n, active, k, u),
        }
    }

    /// The colour every sample of this light is a multiple of (its radiance or intensity
    /// times one number per lane: distance, angle, goniodiagram), or `None` when its colour
    /// varies (an environment map).
    pub fn colour(&self) -> Option<[f32; 3]> {
        match self {
            Light::Omni(x) => Some(x.intensity()),
            Light::Spot(x) => Some(x.intensity()),
            Light::Parallel(x) => Some(x.irradiance()),
            Light::Direct(x) => Some(x.intensity()),
            Light::Linear(x) => Some(x.intensity()),
            Light::Circular(x) => Some(x.radiance()),
            Light::Rectangular(x) => Some(x.radiance()),
            Light::Goniodiagram(x) => Some(x.scale()),
            Light::Environment(_) => None,
        }
    }

    /// What a ray in direction `dir` (unit) that misses everything sees of this light: the
    /// environment map's radiance, zero for the other kinds.
    #[inline(always)]
    pub fn radiance_seen<L: Lanes>(&self, l: L, dir: &Vec3s<L>) -> Rgbs<L> {
        match self {
            Light::Environment(x) => x.radiance(l, dir),
            _ => Rgbs::zero(l),
        }
    }
}

/// Relative offset of shadow ray origins along the normal (times `1 + max |p_i|`).
pub const SHADOW_OFFSET: f32 = 1e-4;
/// Shadow rays stop this fraction short of the sample point (which may lie on a surface).
pub const SHADOW_SHORTEN: f32 = 1e-4;

/// The shadow packet of a sample: origins moved off the surface along `n` by
/// `eps` = [`SHADOW_OFFSET`] times the point's magnitude plus one, directions `wi`, `t` in
/// `[eps, dist * (1 - SHADOW_SHORTEN))`. Trace it with `Accel::occluded` under `s.active`.
///
/// `tmin` is `eps`, not 0: a point on the seam where a floor meets a wall is found a rounding
/// error to either side of the wall's plane, and from the far side the shadow ray crossed
/// the wall within `1e-7` of its origin: a black pixel on the built-in Cornell box's seams
/// with one rounding (scalar, SSE) and a lit one with another (FMA), so images differed by
/// backend. Occluders closer than the offset itself are below what the offset resolves.
#[inline(always)]
pub fn shadow_rays<L: Lanes>(_l: L, p: &Vec3s<L>, n: &Vec3s<L>, s: &LightSample<L>) -> Rays<L> {
    let scale = p.x.abs().max(p.y.abs()).max(p.z.abs()) + 1.0;
    let eps = scale * SHADOW_OFFSET;
    let origin = n.mul_add(eps, *p);
    Rays {
        origin,
        dir: s.wi,
        tmin: eps,
        tmax: s.dist * (1.0 - SHADOW_SHORTEN),
    }
}

/// The direction and distance from shading points to sample points `q`, with the lanes
/// that face them.
pub(crate) struct Toward<L: Lanes> {
    pub active: L::Mask,
    pub wi: Vec3s<L>,
    pub dist: L::F32s,
    /// `1 / dist^2`.
    pub inv_d2: L::F32s,
}

/// From `p` (normals `n`) towards the points `q`: lanes at the point itself, behind the
/// surface (`n . wi <= 0`) or with a non-finite distance are masked off.
#[inline(always)]
pub(crate) fn toward<L: Lanes>(
    l: L,
    p: &Vec3s<L>,
    n: &Vec3s<L>,
    active: L::Mask,
    q: &Vec3s<L>,
) -> Toward<L> {
    let d = *q - *p;
    let d2 = d.length_squared();
    let dist = d2.sqrt();
    let inv = l.splat(1.0) / dist;
    let wi = d * inv;
    let zero = l.splat(0.0);
    let active = active & d2.gt(zero) & d2.lt(l.splat(f32::INFINITY)) & n.dot(wi).gt(zero);
    Toward {
        active,
        wi,
        dist,
        inv_d2: inv * inv,
    }
}

/// A sample from its parts, with the inactive lanes cleaned (direction `n`, distance 0,
/// radiance 0).
#[inline(always)]
pub(crate) fn finish<L: Lanes>(
    l: L,
    n: &Vec3s<L>,
    active: L::Mask,
    wi: Vec3s<L>,
    dist: L::F32s,
    li: Rgbs<L>,
) -> LightSample<L> {
    let zero = l.splat(0.0);
    LightSample {
        active,
        wi: Vec3s::select(active, wi, *n),
        dist: active.select(dist, zero),
        li: Rgbs::select(active, li, Rgbs::zero(l)),
    }
}

/// [`finish`] for a radiance `c * s` (one select on `s` instead of one per channel).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish_scaled<L: Lanes>(
    l: L,
    n: &Vec3s<L>,
    active: L::Mask,
    wi: Vec3s<L>,
    dist: L::F32s,
    c: [f32; 3],
    s: L::F32s,
) -> LightSample<L> {
    let s = active.select(s, l.splat(0.0));
    LightSample {
        active,
        wi: Vec3s::select(active, wi, *n),
        dist: active.select(dist, l.splat(0.0)),
        li: scaled(l, c, s),
    }
}

/// `c` scaled by one value per lane.
#[inline(always)]
pub(crate) fn scaled<L: Lanes>(l: L, c: [f32; 3], s: L::F32s) -> Rgbs<L> {
    Rgbs::new(l.splat(c[0]) * s, l.splat(c[1]) * s, l.splat(c[2]) * s)
}

#[cfg(test)]
pub(crate) mod test_util;

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_accel::{Accel, BruteForce, Mesh, Scene};
    use coherent_simd::scalar::Scalar;
    use glam::Vec3;

    /// Whether the shadow ray from `p` (normal +y) towards a light at the room's top centre is
    /// blocked, in a corner where a floor (y = 0) meets a wall (x = -1).
    fn shadowed(p: Vec3) -> bool {
        let v = Vec3::new;
        let corner = Mesh::new(
            "corner",
            vec![
                v(-1., 0., 1.),
                v(1., 0., 1.),
                v(1., 0., -1.),
                v(-1., 0., -1.),
                v(-1., 2., -1.),
                v(-1., 2., 1.),
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]],
        );
        let accel = BruteForce::build(&Scene::single(corner), &()).unwrap();
        let l = Scalar;
        let to = v(0.0, 1.9, 0.0) - p;
        let s = LightSample {
            active: l.splat_mask(true),
            wi: Vec3s::splat(l, to.normalize()),
            dist: to.length(),
            li: Rgbs::zero(l),
        };
        let rays = shadow_rays(l, &Vec3s::splat(l, p), &Vec3s::splat(l, Vec3::Y), &s);
        accel.occluded(l, &rays, l.splat_mask(true)).any()
    }

    /// Every sample of a light whose colour is one throughout is that colour times a number
    /// (what the spectral forms rely on to upsample the colour once): each light of the
    /// paper's four scenes, which use every kind, from points on their surfaces.
    #[test]
    fn samples_are_multiples_of_the_lights_colour() {
        let l = Scalar;
        let y = |c: [f32; 3]| Rgbs::splat(l, c).luminance();
        let mut lit = std::collections::BTreeMap::new();
        for name in ["car", "spdemo", "glass1", "room2"] {
            let scene = crate::scene::builtin::by_name(name).unwrap();
            let points: Vec<Vec3> = scene
                .meshes
                .iter()
                .flat_map(|m| m.mesh.positions.iter().step_by(97).copied())
                .collect();
            for light in &scene.lights {
                let Some(c) = light.colour() else {
                    assert_eq!(light.kind(), LightKind::Environment);
                    continue;
                };
                for (j, p) in points.iter().enumerate() {
                    let n = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z][j % 6];
                    let u = [0.37 * (j % 7) as f32 / 7.0, (j % 11) as f32 / 11.0];
                    let s = light.sample(l, &Vec3s::splat(l, *p), &Vec3s::splat(l, n), true, 0, u);
                    if !s.active || y([s.li.r, s.li.g, s.li.b]) <= 0.0 {
                        continue;
                    }
                    let k = y([s.li.r, s.li.g, s.li.b]) / y(c);
                    for (got, want) in [s.li.r, s.li.g, s.li.b].into_iter().zip(c) {
                        assert!(
                            (got - want * k).abs() <= 1e-5 * got.abs().max(want * k),
                            "{name} {:?}: {:?} is not a multiple of {c:?}",
                            light.kind(),
                            s.li
                        );
                    }
                    *lit.entry(light.kind()).or_insert(0) += 1;
                }
            }
        }
        let kinds: Vec<LightKind> = LightKind::ALL
            .into_iter()
            .filter(|k| *k != LightKind::Environment)
            .collect();
        for k in kinds {
            assert!(
                lit.get(&k).is_some_and(|n| *n > 0),
                "no lit sample of {k:?}"
            );
        }
    }

    /// A shading point on the seam, found a rounding error behind the wall's plane (as a
    /// camera ray through the seam finds it with one rounding and not another), is not
    /// shadowed by the wall it touches: the built-in Cornell box had black seam pixels on the
    /// scalar and SSE backends and lit ones with FMA. A point really behind the wall is.
    #[test]
    fn a_seam_point_is_not_shadowed_by_the_wall_it_touches() {
        for x in [
            -1.0f32,
            (-1.0f32).next_down(),
            (-1.0f32).next_down().next_down(),
        ] {
            assert!(!shadowed(Vec3::new(x, 0.0, 0.25)), "x = {x}");
        }
        assert!(shadowed(Vec3::new(-1.01, 0.0, 0.25)));
    }
}
