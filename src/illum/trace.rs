//! The particle pass (forward Monte-Carlo ray tracing, the paper's section 2): particles
//! leave the lights, and at every hit from their second on (generation >= 1) deposit their
//! power in the hit cell, then go on by Russian roulette on the material until absorbed,
//! lost, or past the last generation.
//!
//! Generation 0's hits are direct light, which the renderer computes exactly with shadow
//! rays: they deposit nothing, so that no light is counted twice. At a hit the particle goes
//! on by one of the material's parts, chosen with probabilities equal to the channel means
//! of the diffuse albedo (`Material::albedo`), of the mirror reflection weight and of the
//! refraction weight (with the Fresnel factor as `Material::shade` applies it), scaled down
//! when they sum past 1: diffuse (a cosine-weighted direction around the shading normal on
//! the side the particle came from), mirror reflection, refraction, or absorption. Its power
//! is multiplied by the part's weight over its probability, so for grey materials it never
//! changes. The Phong specular lobe is left out of particle transport, and so are tabulated
//! BDFs beyond their material's diffuse colour. A particle whose diffuse direction falls
//! below the geometric surface, whose refraction is totally reflected, or whose numbers are
//! not finite is dropped.
//!
//! Particles are cut into chunks of `MapOptions::chunk` ids, run in parallel in the current
//! rayon pool, each generation by generation: order the live rays ([`Mode`]), trace them in
//! packets of the backend's width, then process each hit in scalar code. Random numbers are
//! keyed by (seed, particle id, generation, dimension) alone, never by mode, thread or packet,
//! and deposits are integer sums ([`Deposits`]), so every mode and thread count gives the
//! same map bit for bit on a backend whose hits do not depend on a packet's other lanes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use coherent_accel::{Aabb, Accel, Hits, Rays, Work};
use coherent_simd::scalar::Scalar;
use coherent_simd::{Backend, BackendError, Kernel, Lanes, SimdF32, SimdI32, Vec3s};
use glam::Vec3;
use rayon::prelude::*;

use super::cells::{CellLayout, DEFAULT_CELLS, MAP_BUDGET};
use super::emit::{EMIT_DIMS, Emitter};
use super::map::{Deposits, IllumMap};
use super::stats::{GenerationStats, TraceStats, add3};
use super::{IllumError, Mode, order};
use crate::accel_any::AnyAccel;
use crate::material::fresnel_dielectric;
use crate::render::rng::hash1;
use crate::render::{Differentials, Geometry};
use crate::scene::RenderScene;

/// Particles traced by default.
pub const DEFAULT_PARTICLES: u64 = 1 << 20;
/// Generations traced at most by default.
pub const DEFAULT_MAX_GENERATIONS: u32 = 64;
/// Rays in a thread's buffer by default.
pub const DEFAULT_CHUNK: usize = 4096;
/// The largest chunk taken (its buffers are allocated per thread).
pub const MAX_CHUNK: usize = 1 << 20;

/// The random number dimensions of a bounce (emission takes `0..EMIT_DIMS` of generation 0).
const DIM_ROULETTE: u32 = 16;
const DIM_DIR: u32 = 17;

/// What a particle pass traces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapOptions {
    /// Particles in all.
    pub particles: u64,
    /// The cells target of the map ([`CellLayout`]).
    pub cells: u64,
    /// How rays are grouped into packets.
    pub mode: Mode,
    /// The seed of every random number.
    pub seed: u32,
    /// Generations traced at most (generation 0 leaves the lights).
    pub max_generations: u32,
    /// Count traversal work (`Accel::intersect_work`) into the statistics.
    pub count_work: bool,
    /// Particle ids per chunk: a thread's buffer of rays.
    pub chunk: usize,
    /// Keep the particles whose first bounce is a mirror reflection or a refraction
    /// (caustics). Without them the map holds only the light a path tracer whose lights are
    /// not geometry can find, which is how it is checked against one.
    pub caustics: bool,
}

impl Default for MapOptions {
    fn default() -> Self {
        MapOptions {
            particles: DEFAULT_PARTICLES,
            cells: DEFAULT_CELLS,
            mode: Mode::default(),
            seed: 0,
            max_generations: DEFAULT_MAX_GENERATIONS,
            count_work: false,
            chunk: DEFAULT_CHUNK,
            caustics: true,
        }
    }
}

impl MapOptions {
    /// Checks the options: particles, cells, generations and chunk at least 1, the chunk at
    /// most [`MAX_CHUNK`].
    pub fn check(&self) -> Result<(), IllumError> {
        let bad = |what, problem: String| Err(IllumError::Options { what, problem });
        if self.particles == 0 {
            return bad("particles", "0 particles; trace at least 1".into());
        }
        if self.cells == 0 {
            return bad(
                "cells",
                "a cells target of 0; ask for at least 1 cell".into(),
            );
        }
        if self.max_generations == 0 {
            return bad(
                "generations",
                "at most 0 generations; trace at least 1".into(),
            );
        }
        if self.chunk == 0 || self.chunk > MAX_CHUNK {
            return bad(
                "chunk",
                format!("{} rays per chunk; take 1 to {MAX_CHUNK}", self.chunk),
            );
        }
        Ok(())
    }
}

/// Builds the illumination map of `scene` by tracing `opts.particles` particles through
/// `accel` with `backend`'s packets, in parallel in the current rayon pool. `progress` gets
/// the number of particles finished so far after each chunk. Bad options, a backend that
/// cannot run here, a scene without emitting lights or a map over the memory budget are
/// errors found before any work.
pub fn build_map(
    backend: Backend,
    scene: &RenderScene,
    accel: &AnyAccel,
    opts: &MapOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(IllumMap, TraceStats), IllumError> {
    build_map_on::<{ Backend::bits(&Backend::ALL) }>(backend, scene, accel, opts, progress)
}

/// [`build_map`] with the traversal compiled for the backends of the set `BITS` alone (tests
/// narrow it: every backend's traversal is build time).
pub(crate) fn build_map_on<const BITS: u32>(
    backend: Backend,
    scene: &RenderScene,
    accel: &AnyAccel,
    opts: &MapOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(IllumMap, TraceStats), IllumError> {
    let count_work = opts.count_work;
    let trace = move |packed: &Packed, found: &mut Found| {
        backend.run(TraceKernel::<BITS> {
            accel,
            packed,
            found,
            count_work,
        })
    };
    run_pass(backend, scene, opts, progress, &trace)
}

/// The traversal of one generation's packets, in the backend's kernel.
type Trace<'a> = dyn Fn(&Packed, &mut Found) -> Result<Work, BackendError> + Sync + 'a;

/// The pass itself (not generic: one copy whatever the backends).
fn run_pass(
    backend: Backend,
    scene: &RenderScene,
    opts: &MapOptions,
    progress: &(dyn Fn(u64) + Sync),
    trace: &Trace<'_>,
) -> Result<(IllumMap, TraceStats), IllumError> {
    let start = Instant::now();
    opts.check()?;
    if let Some(reason) = backend.unavailable_reason() {
        return Err(BackendError::Unavailable {
            backend,
            reason,
            available: Backend::available()
                .iter()
                .map(|b| b.name())
                .collect::<Vec<_>>()
                .join(", "),
        }
        .into());
    }
    let layout = CellLayout::new(scene, opts.cells, MAP_BUDGET)?;
    let bounds = world_bounds(scene);
    let emitter = Emitter::new(scene, bounds)?;
    let pass = Pass {
        scene,
        geometry: Geometry::new(scene),
        deposits: Deposits::new(layout.cells(), emitter.power(), opts.particles),
        layout: &layout,
        emitter,
        opts,
        bounds,
        lanes: backend.lanes(),
    };
    let chunk = opts.chunk as u64;
    let chunks = opts.particles.div_ceil(chunk);
    let done = AtomicU64::new(0);
    let outs = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let first = c * chunk;
            let count = chunk.min(opts.particles - first);
            let s = pass.chunk(first, count as usize, trace)?;
            progress(done.fetch_add(count, Ordering::Relaxed) + count);
            Ok(s)
        })
        .collect::<Result<Vec<TraceStats>, IllumError>>()?;
    let mut stats = TraceStats::default();
    for s in &outs {
        stats.merge(s);
    }
    let irradiance = pass.deposits.irradiance(&layout);
    drop(pass);
    let map = IllumMap::from_cells(scene, layout, irradiance, opts.particles)?;
    stats.seconds = start.elapsed().as_secs_f64();
    stats.lanes = backend.lanes();
    Ok((map, stats))
}

/// The world bounds of every instance's triangles.
fn world_bounds(scene: &RenderScene) -> Aabb {
    let mut b = Aabb::from_points(std::iter::empty());
    for inst in &scene.instances {
        if let Some(m) = scene.meshes.get(inst.mesh) {
            b = b.union(m.mesh.bounds().transformed(&inst.world_from_object));
        }
    }
    b
}

/// A uniform number in `[0, 1)` for (seed, particle, generation, dimension).
#[inline]
fn uniform(seed: u32, id: u64, generation: u32, dim: u32) -> f32 {
    let mut h = hash1(seed ^ 0x9e37_79b9);
    h = hash1(h ^ id as u32);
    h = hash1(h ^ (id >> 32) as u32);
    h = hash1(h ^ generation.wrapping_mul(0x85eb_ca6b) ^ dim);
    // The top 24 bits, exactly representable.
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A generation's rays packed for the kernel: packet `p` holds lanes `p * lanes ..`, its
/// active lanes in `bits[p]`.
#[derive(Debug, Default)]
pub(super) struct Packed {
    lanes: usize,
    bits: Vec<u32>,
    origin: [Vec<f32>; 3],
    dir: [Vec<f32>; 3],
}

/// The kernel's hits, laid out as [`Packed`].
#[derive(Debug, Default)]
pub(super) struct Found {
    t: Vec<f32>,
    u: Vec<f32>,
    v: Vec<f32>,
    prim: Vec<i32>,
    inst: Vec<i32>,
}

/// The traversal loop over a generation's packets: the only code compiled per backend.
struct TraceKernel<'a, const BITS: u32> {
    accel: &'a AnyAccel,
    packed: &'a Packed,
    found: &'a mut Found,
    count_work: bool,
}

impl<const BITS: u32> Kernel for TraceKernel<'_, BITS> {
    type Output = Work;
    const BACKENDS: u32 = BITS;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Work {
        let mut work = Work::default();
        let (p, f) = (self.packed, self.found);
        debug_assert_eq!(p.lanes, L::N);
        let (zero, inf) = (l.splat(0.0), l.splat(f32::INFINITY));
        for (k, &bits) in p.bits.iter().enumerate() {
            let b = k * L::N;
            let rays = Rays {
                origin: Vec3s::new(
                    l.load(&p.origin[0][b..]),
                    l.load(&p.origin[1][b..]),
                    l.load(&p.origin[2][b..]),
                ),
                dir: Vec3s::new(
                    l.load(&p.dir[0][b..]),
                    l.load(&p.dir[1][b..]),
                    l.load(&p.dir[2][b..]),
                ),
                tmin: zero,
                tmax: inf,
            };
            let active = l.mask_from_bits(bits);
            // Out of the kernel, as the renderer's queries (docs/architecture.md).
            let h: Hits<L> = if self.count_work {
                l.apart(
                    #[inline(always)]
                    |l| self.accel.intersect_work(l, &rays, active, &mut work),
                )
            } else {
                l.apart(
                    #[inline(always)]
                    |l| self.accel.intersect(l, &rays, active),
                )
            };
            h.t.store(&mut f.t[b..]);
            h.u.store(&mut f.u[b..]);
            h.v.store(&mut f.v[b..]);
            h.prim.store(&mut f.prim[b..]);
            h.inst.store(&mut f.inst[b..]);
        }
        work
    }
}

/// What every chunk shares.
struct Pass<'a> {
    scene: &'a RenderScene,
    geometry: Geometry,
    layout: &'a CellLayout,
    deposits: Deposits,
    emitter: Emitter,
    opts: &'a MapOptions,
    bounds: Aabb,
    lanes: usize,
}

/// A chunk's live particles, in particle order.
#[derive(Debug, Default)]
struct Stream {
    ids: Vec<u64>,
    origin: Vec<Vec3>,
    dir: Vec<Vec3>,
    power: Vec<[f32; 3]>,
}

impl Stream {
    fn clear(&mut self) {
        self.ids.clear();
        self.origin.clear();
        self.dir.clear();
        self.power.clear();
    }

    fn push(&mut self, id: u64, origin: Vec3, dir: Vec3, power: [f32; 3]) {
        self.ids.push(id);
        self.origin.push(origin);
        self.dir.push(dir);
        self.power.push(power);
    }
}

/// One hit as the kernel found it.
#[derive(Debug, Clone, Copy)]
struct Hit {
    t: f32,
    u: f32,
    v: f32,
    prim: i32,
    inst: i32,
}

impl Pass<'_> {
    /// Traces particles `first .. first + count` generation by generation.
    fn chunk(&self, first: u64, count: usize, trace: &Trace<'_>) -> Result<TraceStats, IllumError> {
        let opts = self.opts;
        let mut stats = TraceStats {
            particles: count as u64,
            ..TraceStats::default()
        };
        let mut live = Stream::default();
        let mut next = Stream::default();
        for id in first..first + count as u64 {
            let u: [f32; EMIT_DIMS] = std::array::from_fn(|k| uniform(opts.seed, id, 0, k as u32));
            let p = self.emitter.emit(u, opts.particles);
            for c in 0..3 {
                stats.emitted[c] += f64::from(p.power[c]);
            }
            if finite(p.origin) && finite(p.dir) && p.dir.length_squared() > 0.0 {
                live.push(id, p.origin, p.dir, p.power);
            }
        }
        let mut perm = Vec::new();
        let mut pos = Vec::new();
        let mut packed = Packed {
            lanes: self.lanes,
            ..Packed::default()
        };
        let mut found = Found::default();
        for generation in 0..opts.max_generations {
            if live.ids.is_empty() {
                break;
            }
            let n = live.ids.len();
            let mut g = GenerationStats {
                generation,
                rays: n as u64,
                active_lanes: n as u64,
                ..GenerationStats::default()
            };
            let t0 = Instant::now();
            match opts.mode {
                Mode::Single | Mode::Packets => {
                    perm.clear();
                    perm.extend(0..n as u32);
                }
                Mode::Sorted => order::sorted(&live.origin, &live.dir, &self.bounds, &mut perm),
                Mode::Octant => order::by_octant(&live.dir, &mut perm),
            }
            let per_packet = if opts.mode == Mode::Single {
                1
            } else {
                self.lanes
            };
            pack(&live, &perm, per_packet, &mut packed, &mut found, &mut pos);
            g.packets = packed.bits.len() as u64;
            let t1 = Instant::now();
            g.work = trace(&packed, &mut found)?;
            let t2 = Instant::now();
            next.clear();
            let mut deposited = [0.0f64; 3];
            for (r, &k) in pos.iter().enumerate() {
                let hit = Hit {
                    t: found.t[k],
                    u: found.u[k],
                    v: found.v[k],
                    prim: found.prim[k],
                    inst: found.inst[k],
                };
                let id = live.ids[r];
                if let Some((o, d, p)) = self.bounce(
                    generation,
                    id,
                    live.origin[r],
                    live.dir[r],
                    live.power[r],
                    hit,
                    &mut deposited,
                ) {
                    next.push(id, o, d, p);
                }
            }
            let t3 = Instant::now();
            g.sort_ns = (t1 - t0).as_nanos() as u64;
            g.trace_ns = (t2 - t1).as_nanos() as u64;
            g.shade_ns = (t3 - t2).as_nanos() as u64;
            stats.generations.push(g);
            stats.deposited_by_generation.push(deposited);
            add3(&mut stats.deposited, &deposited);
            std::mem::swap(&mut live, &mut next);
        }
        Ok(stats)
    }

    /// Deposits a ray's power at its hit (from generation 1 on) and continues the particle,
    /// or `None` where it ends. `deposited` gets the power deposited.
    #[allow(clippy::too_many_arguments)]
    fn bounce(
        &self,
        generation: u32,
        id: u64,
        origin: Vec3,
        dir: Vec3,
        power: [f32; 3],
        hit: Hit,
        deposited: &mut [f64; 3],
    ) -> Option<(Vec3, Vec3, [f32; 3])> {
        if hit.prim < 0 || hit.inst < 0 {
            return None;
        }
        let cell = self
            .layout
            .cell(hit.inst as u32, hit.prim as u32, hit.u, hit.v)?;
        if generation >= 1 {
            let d = self.deposits.add(cell, power);
            for c in 0..3 {
                deposited[c] += d[c];
            }
        }
        if generation + 1 >= self.opts.max_generations {
            return None;
        }
        let l = Scalar;
        let hits = Hits::<Scalar> {
            t: hit.t,
            u: hit.u,
            v: hit.v,
            prim: l.splat_i32(hit.prim),
            inst: l.splat_i32(hit.inst),
        };
        let z = Vec3s::splat(l, Vec3::ZERO);
        let diff = Differentials {
            dorigin_dx: z,
            dorigin_dy: z,
            ddir_dx: z,
            ddir_dy: z,
        };
        let o = Vec3s::splat(l, origin);
        let d = Vec3s::splat(l, dir);
        let surf = self.geometry.surface(l, &hits, &o, &d, &diff);
        let material = self.scene.materials.get(surf.material.lane(0) as usize)?;
        let p = surf.p.lane(0);
        let (ng, ns) = (surf.ng.lane(0), surf.ns.lane(0));
        if !(finite(p) && finite(ng) && finite(ns)) {
            return None;
        }
        let albedo = material.albedo(l, surf.s, surf.t, 0.0).lane(0);
        let o = &material.optics;
        let (refl, refr) = if o.fresnel {
            let cos_o = -dir.dot(ns);
            let eta = if cos_o < 0.0 { 1.0 / o.ior } else { o.ior };
            let f = fresnel_dielectric(l, cos_o.abs(), eta);
            (
                o.reflectance.map(|c| c * f),
                o.transmittance.map(|c| c * (1.0 - f)),
            )
        } else {
            (o.reflectance, o.transmittance)
        };
        let mean = |c: [f32; 3]| (c[0] + c[1] + c[2]) / 3.0;
        let mut probs = [mean(albedo), mean(refl), mean(refr)];
        let total: f32 = probs.iter().sum();
        if !total.is_finite() {
            return None;
        }
        if total > 1.0 {
            probs = probs.map(|p| p / total);
        }
        let seed = self.opts.seed;
        let xi = uniform(seed, id, generation, DIM_ROULETTE);
        let eps = (p.x.abs().max(p.y.abs()).max(p.z.abs()) + 1.0) * 1e-4;
        let (new_dir, weight, prob, ng_side) = if xi < probs[0] {
            // Diffuse, on the side the particle came from.
            let flip = dir.dot(ng) > 0.0;
            let (nf, gf) = if flip { (-ns, -ng) } else { (ns, ng) };
            let u1 = uniform(seed, id, generation, DIM_DIR);
            let u2 = uniform(seed, id, generation, DIM_DIR + 1);
            let w = cosine_direction(nf, u1, u2);
            if w.dot(gf) <= 0.0 {
                return None;
            }
            (w, albedo, probs[0], gf)
        } else if generation == 0 && !self.opts.caustics {
            // A mirror or refraction first: a caustic, left out.
            return None;
        } else if xi < probs[0] + probs[1] {
            let r = dir - ns * (2.0 * dir.dot(ns));
            let side = if ng.dot(r) < 0.0 { -ng } else { ng };
            (r, refl, probs[1], side)
        } else if xi < probs[0] + probs[1] + probs[2] {
            let (t, _, tir) = crate::render::refract(l, &d, &Vec3s::splat(l, ns), l.splat(o.ior));
            if tir {
                return None;
            }
            let t = t.lane(0);
            let side = if ng.dot(t) < 0.0 { -ng } else { ng };
            (t, refr, probs[2], side)
        } else {
            return None;
        };
        let new_power = [0, 1, 2].map(|c| power[c] * weight[c] / prob);
        let origin = p + ng_side * eps;
        let ok = finite(new_dir)
            && finite(origin)
            && new_dir.length_squared() > 0.0
            && new_power.iter().all(|c| c.is_finite() && *c >= 0.0)
            && new_power.iter().any(|&c| c > 0.0);
        ok.then_some((origin, new_dir, new_power))
    }
}

fn finite(v: Vec3) -> bool {
    v.is_finite()
}

/// A cosine-distributed unit direction around the unit normal `n` (Duff et al.'s frame).
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    let r = u1.sqrt();
    let phi = 2.0 * core::f32::consts::PI * u2;
    (t * (r * phi.cos()) + bt * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// Packs the rays of `live` in the order `perm`, `per_packet` to a packet (1: one active
/// lane each), sized for `packed.lanes`; `pos[r]` gets ray `r`'s lane index in the buffers.
fn pack(
    live: &Stream,
    perm: &[u32],
    per_packet: usize,
    packed: &mut Packed,
    found: &mut Found,
    pos: &mut Vec<usize>,
) {
    let lanes = packed.lanes;
    let n = perm.len();
    let packets = n.div_ceil(per_packet);
    let len = packets * lanes;
    packed.bits.clear();
    packed.bits.resize(packets, 0);
    for k in 0..3 {
        packed.origin[k].clear();
        packed.origin[k].resize(len, 0.0);
        packed.dir[k].clear();
        packed.dir[k].resize(len, if k == 2 { 1.0 } else { 0.0 });
    }
    pos.clear();
    pos.resize(n, 0);
    for (q, &r) in perm.iter().enumerate() {
        let (p, lane) = (q / per_packet, q % per_packet);
        let at = p * lanes + lane;
        let (o, d) = (live.origin[r as usize], live.dir[r as usize]);
        for k in 0..3 {
            packed.origin[k][at] = o[k];
            packed.dir[k][at] = d[k];
        }
        packed.bits[p] |= 1 << lane;
        pos[r as usize] = at;
    }
    found.t.resize(len, 0.0);
    found.u.resize(len, 0.0);
    found.v.resize(len, 0.0);
    found.prim.resize(len, -1);
    found.inst.resize(len, -1);
}
