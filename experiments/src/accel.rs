//! Experiment `accel`: the two-level BSP of paper section 3 on the built-in generated scenes
//! (`coherent::accel::scenes`: spheres, terrain, room, blob) and on the real meshes
//! `scripts/native.py` fetched (`coherent::mesh_file`: bunny, dragon, armadillo, elephant;
//! quick: the bunny) for primary, shadow and diffuse rays, one ray at a time (width 1) and in
//! coherent packets of 4, 8 and 16 lanes; build time and memory per scene; and the same for
//! Embree 4 and obvhs across the same interface (`accel` column: bsp, embree, obvhs). Also the
//! BSP's packet-to-single-ray switch threshold per width (`accel_threshold.csv`) and traversal
//! counters with the mailbox hit rate (`accel_traversal.csv`).
//!
//! Protocol: width 1 is the single-ray traversal (`Accel::intersect1`/`occluded1`), the
//! scalar baseline; widths 4, 8, 16 run the packet traversal on one backend each: the
//! hand-written or run-time dispatched one (sse, avx2, avx512), else the `wide` one. Primary
//! rays go through the pixel centres, ordered in screen tiles of the packet's shape (4x4 tiles
//! for width 1); shadow rays go from the primary hits to the scene's point light (any-hit);
//! diffuse rays from the primary hits over the cosine hemisphere, seeded per pixel, so every
//! width traces the same rays. Rays are packed before timing: `Rays<L>` for the BSP, Embree's
//! own `RTCRayHitK` packets (`PacketK`) for Embree's packet rows. A timed pass holds the
//! queries and the per-packet work every structure needs (Embree: reset each packet's far
//! bounds and hit ids; everyone: read the answers back into a hit count and a sum of `t`).
//! Samples (one pass over all rays, the thread's CPU time) are interleaved round-robin over
//! the accelerators and widths of a scene and ray kind, and each row reports the median. One
//! thread. Every row's hits and `t` sum are checked against the BSP's single rays; the run
//! fails on a disagreement beyond the edge tolerance ([`HIT_TOLERANCE`], [`T_TOLERANCE`]).
//!
//! The others: Embree gets packets of the same width (`rtcIntersect4/8/16`, the COHERENT
//! flag for primary and shadow rays, not for diffuse rays), built with one thread, quality
//! `high` for meshes and `low` for the top level, without the filter-function scene flag
//! (only all-hits queries need it); its build time excludes creating the device. Beside its
//! rows, `accel_embree.csv` times a plain C-API loop over the same packed packets and the
//! `Accel` trait path, so the harness's cost is measured. obvhs is the CWBVH with its
//! `medium` preset for meshes and `fast` for the top level, and traverses single rays only,
//! so it has width-1 rows only. A scene of one untransformed instance has no instance level in
//! any of them. All trace the same rays (the secondary rays come from the BSP's hits). An
//! accelerator that cannot run here (Embree without its library) and a mesh that is not
//! fetched are noted and left out. What Embree runs (version, ISA, native packet widths) goes
//! into `machine.json` (key `embree`; every run writes which build measured under `build`).
//!
//! Beams (`query` column `beam`; the packet rows say `lanes`): the BSP's beam traversal
//! ([`Accel::intersect_beam`]) on primary and shadow rays, with `width` the beam's ray count:
//! square screen tiles of 4x4 to 32x32 rays on the widest backend (the beam-size sweep), and
//! 8x8 and 16x16 on the scalar backend (one-lane packets under a shared beam: the culling
//! without SIMD). The rays are the same as every other row's, ordered tile by tile; the
//! beam rows are timed interleaved with the others and cross-checked like them.

use std::collections::BTreeMap;

use coherent::accel::scenes::{self, BuiltinScene, SceneSize};
use coherent::accel::workload::{self, Clock, PassResult, RayKind, TimeBeams, TimePackets};
use coherent::accel::{Accel, Ray1, Rays};
use coherent::accel_any::{AccelKind, AnyAccel};
use coherent::bsp::{Bsp, BspParams, TraversalStats};
use coherent::mesh_file::REAL_MESHES;
use coherent::simd::{Backend, Kernel, Lanes};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{fmt_num, markdown_table};
use crate::table5::MANYCORE;
use crate::timing::median;

pub const EXPERIMENT: Experiment = Experiment {
    name: "accel",
    description: "traversal speed, build time and memory per accel, ray kind and packet width",
    paper: "section 3 (two-level BSP), against Embree 4 and obvhs",
    csv: &[
        "accel.csv",
        "accel_threshold.csv",
        "accel_traversal.csv",
        "accel_simd_leaves.csv",
        "accel_mixed_signs.csv",
    ],
    plots: &[
        "accel_speedup_vs_width",
        "accel_mrays",
        "accel_primary",
        "accel_shadow",
        "accel_diffuse",
        "accel_build",
        "accel_memory",
    ],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

const HEADER: &[&str] = &[
    "scene",
    "accel",
    "rays",
    "width",
    "mrays_per_s",
    "build_ms",
    "memory_bytes",
    "hits",
    "t_sum",
    "query",
    "backend",
];
const LEAVES_HEADER: &[&str] = &[
    "scene",
    "rays",
    "leaf_test",
    "tree",
    "mrays_per_s",
    "bsp_over_embree",
    "tests_per_ray",
    "memory_bytes",
];
const EMBREE_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "harness_mrays_per_s",
    "plain_mrays_per_s",
    "accel_trait_mrays_per_s",
    "harness_over_plain",
];
const THRESHOLD_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "backend",
    "threshold",
    "mrays_per_s",
];
const MIXED_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "backend",
    "per_group_mrays_per_s",
    "together_mrays_per_s",
    "speedup",
    "sign_groups_per_packet",
];
const TRAVERSAL_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "inner_per_ray",
    "leaves_per_ray",
    "tests_per_ray",
    "lanes_per_test",
    "mailbox_hit_rate",
    "obvhs_tests_per_ray",
    "obvhs_nodes_per_ray",
    "query",
    "backend",
];

/// Width 1 (single rays, `None`) and each packet width with its backend.
fn widths(ctx: &mut Ctx) -> Vec<(usize, Option<Backend>)> {
    let mut v = vec![(1, None)];
    for w in [4, 8, 16] {
        match Backend::preferred_for_lanes(w) {
            Some(b) => v.push((w, Some(b))),
            None => ctx.note(format!("accel: no backend gives width {w} here")),
        }
    }
    v
}

/// The beams timed: (rays per beam, backend). Square tiles from 4x4 to 32x32 on the widest
/// backend; 8x8 and 16x16 on the scalar one.
fn beams() -> Vec<(usize, Backend)> {
    let widest = Backend::widest();
    let mut v: Vec<(usize, Backend)> = [16, 64, 256, 1024].map(|n| (n, widest)).to_vec();
    if widest != Backend::Scalar {
        v.extend([(64, Backend::Scalar), (256, Backend::Scalar)]);
    }
    v
}

/// The side of a square beam of `n` rays.
fn beam_side(n: usize) -> u32 {
    (n as f64).sqrt().round() as u32
}

/// The rays of one kind, ordered in screen tiles for packets of `width` lanes. Every width
/// gets the same rays (diffuse rays are seeded per pixel), in its own order.
pub(crate) fn rays(
    s: &BuiltinScene,
    bsp: &Bsp,
    kind: RayKind,
    w: u32,
    h: u32,
    width: usize,
) -> Vec<Ray1> {
    rays_in_tiles(
        s,
        bsp,
        kind,
        w,
        h,
        workload::tile_shape(if width == 1 { 16 } else { width }),
    )
}

/// The rays of one kind, ordered tile by tile (`tile`: width and height in pixels).
fn rays_in_tiles(
    s: &BuiltinScene,
    bsp: &Bsp,
    kind: RayKind,
    w: u32,
    h: u32,
    tile: (u32, u32),
) -> Vec<Ray1> {
    let primary = workload::primary_rays(&s.view, w, h, tile);
    match kind {
        RayKind::Primary => primary,
        RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
        RayKind::Diffuse => workload::diffuse_rays(bsp, &s.scene, &primary, 7),
    }
}

/// What the passes are timed with: the thread's CPU time, so that other processes sharing
/// the machine (time slices taken from this thread) do not count. Measured on the shared
/// 2-core machine with wall time, one quick run's Embree rows scattered by up to 10x between
/// widths of the same scene and ray kind.
const CLOCK: Clock = Clock::ThreadCpu;

/// One pass of `accel` over `rays` at a width: seconds, hits and the sum of hit `t`.
pub(crate) fn pass_any<A: Accel>(
    accel: &A,
    rays: &[Ray1],
    occlusion: bool,
    backend: Option<Backend>,
) -> anyhow::Result<PassResult> {
    Ok(match backend {
        None => workload::time_single(accel, rays, occlusion, 1, CLOCK),
        Some(b) => b.run(TimePackets {
            accel,
            rays,
            occlusion,
            repeats: 1,
            clock: CLOCK,
        })?,
    })
}

/// One pass of the BSP's beam traversal over `rays` in beams of `n` rays on `backend`.
fn pass_beam(
    bsp: &Bsp,
    rays: &[Ray1],
    occlusion: bool,
    (n, backend): (usize, Backend),
) -> anyhow::Result<PassResult> {
    Ok(backend.run(TimeBeams {
        accel: bsp,
        rays,
        beam: n,
        occlusion,
        repeats: 1,
        clock: CLOCK,
    })?)
}

/// Medians of interleaved samples of each configuration (`f(i)` runs configuration `i`
/// once), with each configuration's last result.
pub(crate) fn interleaved(
    n: usize,
    samples: usize,
    mut f: impl FnMut(usize) -> anyhow::Result<PassResult>,
) -> anyhow::Result<Vec<(f64, PassResult)>> {
    let mut last: Vec<PassResult> = (0..n).map(&mut f).collect::<anyhow::Result<_>>()?; // warm-up
    let mut s = vec![Vec::with_capacity(samples); n];
    for _ in 0..samples {
        for (i, v) in s.iter_mut().enumerate() {
            let r = f(i)?;
            v.push(r.seconds);
            last[i] = r;
        }
    }
    Ok(s.iter().map(|v| median(v)).zip(last).collect())
}

/// Embree's packets of one width, packed before timing.
#[cfg(feature = "embree")]
enum EmbreePackets {
    W4(Vec<coherent::embree::PacketK<4>>),
    W8(Vec<coherent::embree::PacketK<8>>),
    W16(Vec<coherent::embree::PacketK<16>>),
}

#[cfg(feature = "embree")]
impl EmbreePackets {
    fn new(e: &coherent::embree::Embree, rays: &[Ray1], width: usize) -> Option<Self> {
        use coherent::embree::PacketK;
        Some(match width {
            4 => Self::W4(PacketK::pack_all(e, rays)),
            8 => Self::W8(PacketK::pack_all(e, rays)),
            16 => Self::W16(PacketK::pack_all(e, rays)),
            _ => return None,
        })
    }

    /// One timed pass: the harness (`plain` false: per packet reset, query, read back every
    /// lane's answer, the same work the BSP's rows do) or the plain C-API loop (`plain`:
    /// reset and query only).
    fn pass(&mut self, e: &coherent::embree::Embree, occlusion: bool, plain: bool) -> PassResult {
        match self {
            Self::W4(p) => embree_pass(e, p, occlusion, plain),
            Self::W8(p) => embree_pass(e, p, occlusion, plain),
            Self::W16(p) => embree_pass(e, p, occlusion, plain),
        }
    }
}

#[cfg(feature = "embree")]
fn embree_pass<const K: usize>(
    e: &coherent::embree::Embree,
    packets: &mut [coherent::embree::PacketK<K>],
    occlusion: bool,
    plain: bool,
) -> PassResult {
    use std::hint::black_box;
    let t0 = CLOCK.now();
    if plain {
        e.trace_plain(black_box(packets), occlusion);
        return PassResult {
            seconds: CLOCK.now() - t0,
            ..PassResult::default()
        };
    }
    // Per-lane sums of `t`, added up after the clock stops, as `TimePackets` does for the
    // other structures' packets.
    let (hits, t_acc) = e.trace_read(black_box(packets), occlusion);
    let seconds = CLOCK.now() - t0;
    PassResult {
        seconds,
        hits,
        t_sum: t_acc.iter().map(|&t| f64::from(t)).sum(),
    }
}

/// The settings that depend on the kind of rays (Embree's COHERENT flag).
fn prepare(a: &mut AnyAccel, kind: RayKind) {
    a.set_coherent(kind != RayKind::Diffuse);
}

/// Whether the accelerator has a packet traversal of its own (obvhs has not: its packet
/// rows would time the single-ray fallback).
fn has_packets(a: &AnyAccel) -> bool {
    a.kind() != AccelKind::Obvhs
}

/// One timed pass over `rays`, single rays (`None`) or packets of `backend`'s width, on the
/// concrete accelerator inside the [`AnyAccel`] (the `match` is outside the timed loop).
#[cfg_attr(
    not(any(feature = "embree", feature = "obvhs")),
    allow(unused_variables)
)]
fn pass_of(
    a: &AnyAccel,
    rays: &[Ray1],
    kind: RayKind,
    backend: Option<Backend>,
) -> anyhow::Result<PassResult> {
    match a {
        AnyAccel::Bsp(a) => pass_any(a, rays, kind.occlusion(), backend),
        #[cfg(feature = "embree")]
        AnyAccel::Embree(a) => pass_any(a, rays, kind.occlusion(), backend),
        #[cfg(feature = "obvhs")]
        AnyAccel::Obvhs(a) => pass_any(a, rays, kind.occlusion(), backend),
        AnyAccel::Brute(_) => anyhow::bail!("brute force is a test reference, not timed"),
        // The accelerator is compiled into `coherent` (another crate asked for its feature)
        // but not into the experiments.
        #[allow(unreachable_patterns)]
        _ => anyhow::bail!("{} is not compiled into the experiments", a.name()),
    }
}

/// The median of `repeats` builds' own build time (`BuildStats::build_seconds`: Embree's
/// excludes creating its device), in milliseconds, and the last build.
fn build_timed<A: Accel>(
    scene: &coherent::accel::Scene,
    params: &A::Params,
    repeats: usize,
) -> Result<(A, f64), coherent::accel::AccelError> {
    let mut secs = Vec::new();
    let mut last = A::build(scene, params)?;
    secs.push(last.stats().build_seconds);
    for _ in 1..repeats {
        last = A::build(scene, params)?;
        secs.push(last.stats().build_seconds);
    }
    Ok((last, median(&secs) * 1e3))
}

/// Embree as the comparison builds it: its defaults (one build thread, high-quality meshes,
/// fast top level), and scenes without the filter-function flag that only all-hits queries
/// need (this experiment times first hits and occlusion).
#[cfg(feature = "embree")]
pub(crate) fn embree_params() -> coherent::embree::EmbreeParams {
    coherent::embree::EmbreeParams {
        all_hits: false,
        ..Default::default()
    }
}

/// Builds the other accelerators compiled in over `s`, each with the median build time of
/// `repeats` builds in milliseconds; one that cannot be built here (Embree without its
/// library) is noted and left out.
#[cfg_attr(
    not(any(feature = "embree", feature = "obvhs")),
    allow(unused_mut, unused_variables)
)]
fn build_others(ctx: &mut Ctx, s: &BuiltinScene, repeats: usize) -> Vec<(AnyAccel, f64)> {
    let mut out = Vec::new();
    #[cfg(feature = "embree")]
    {
        use coherent::embree::Embree;
        match build_timed::<Embree>(&s.scene, &embree_params(), repeats) {
            Ok((e, ms)) => out.push((AnyAccel::Embree(e), ms)),
            Err(e) => ctx.note(format!("accel: embree left out of scene {}: {e}", s.name)),
        }
    }
    #[cfg(not(feature = "embree"))]
    ctx.note("accel: embree not compiled in (cargo feature `embree`)".to_string());
    #[cfg(feature = "obvhs")]
    {
        use coherent::obvhs::Obvhs;
        match build_timed::<Obvhs>(&s.scene, &Default::default(), repeats) {
            Ok((o, ms)) => out.push((AnyAccel::Obvhs(o), ms)),
            Err(e) => ctx.note(format!("accel: obvhs left out of scene {}: {e}", s.name)),
        }
    }
    #[cfg(not(feature = "obvhs"))]
    ctx.note("accel: obvhs not compiled in (cargo feature `obvhs`)".to_string());
    out
}

/// The scenes: the built-in ones, then the real meshes (quick: the bunny only); a mesh that
/// is not fetched is noted and left out.
pub(crate) fn scene_list(ctx: &mut Ctx, size: SceneSize) -> Vec<BuiltinScene> {
    let mut list = scenes::all(size);
    let real = match size {
        SceneSize::Quick => &REAL_MESHES[..1],
        SceneSize::Full => &REAL_MESHES[..],
    };
    for m in real {
        match m.scene() {
            Ok(s) => list.push(s),
            Err(e) => ctx.note(format!("accel: scene {} left out: {e}", m.name)),
        }
    }
    list
}

#[allow(clippy::single_match)] // matches over `AnyAccel`, whose variants come and go with features
fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let size = ctx.pick(SceneSize::Quick, SceneSize::Full);
    let (w, h): (u32, u32) = ctx.pick((256, 192), (1024, 768));
    let samples = ctx.pick(3, 7);
    let widths = widths(ctx);
    let beams: Vec<(usize, Backend)> = beams()
        .into_iter()
        .filter(|&(n, _)| w.is_multiple_of(beam_side(n)) && h.is_multiple_of(beam_side(n)))
        .collect();
    let all = scene_list(ctx, size);
    record_embree(ctx);
    let bar = ctx.progress(all.len() as u64 * 3, "accel");
    let mut csv = ctx.csv("accel.csv", HEADER)?;
    let mut trav = ctx.csv("accel_traversal.csv", TRAVERSAL_HEADER)?;
    #[cfg_attr(not(feature = "embree"), allow(unused_mut, unused_variables))]
    let mut emb = ctx.csv("accel_embree.csv", EMBREE_HEADER)?;
    let mut leaves = ctx.csv("accel_simd_leaves.csv", LEAVES_HEADER)?;
    let mut built = Vec::new();
    let mut disagreements = Vec::new();
    for s in &all {
        let repeats = ctx.pick(3, 2);
        let (bsp, build_ms) = build_timed::<Bsp>(&s.scene, &BspParams::default(), repeats)?;
        let memory = bsp.memory_bytes();
        let mut others = build_others(ctx, s, repeats);
        let four = simd_leaf_bsps(&s.scene)?;
        for kind in RayKind::ALL {
            let sets: Vec<Vec<Ray1>> = widths
                .iter()
                .map(|&(wd, _)| rays(s, &bsp, kind, w, h, wd))
                .collect();
            // Beams for coherent rays only: their rays in square tiles of the beam's size.
            let beam_sets: Vec<Vec<Ray1>> = if kind == RayKind::Diffuse {
                Vec::new()
            } else {
                beams
                    .iter()
                    .map(|&(n, _)| {
                        let side = beam_side(n);
                        rays_in_tiles(s, &bsp, kind, w, h, (side, side))
                    })
                    .collect()
            };
            for (o, _) in &mut others {
                prepare(o, kind);
            }
            // Embree's own packets of every packet width, packed before timing.
            #[cfg(feature = "embree")]
            let mut packed: Vec<Option<EmbreePackets>> = widths
                .iter()
                .enumerate()
                .map(|(i, &(wd, _))| {
                    others.iter().find_map(|(o, _)| match o {
                        AnyAccel::Embree(e) => EmbreePackets::new(e, &sets[i], wd),
                        #[allow(unreachable_patterns)]
                        _ => None,
                    })
                })
                .collect();
            // Every (accelerator, width): the BSP's widths first, then the others', then
            // Embree's plain C-API loop and its `Accel` trait path per packet width.
            let mut variants: Vec<(Who, usize)> =
                (0..widths.len()).map(|i| (Who::Bsp, i)).collect();
            variants.extend((0..beam_sets.len()).map(|b| (Who::Beam, b)));
            for (k, (o, _)) in others.iter().enumerate() {
                for (i, &(wd, _)) in widths.iter().enumerate() {
                    if wd == 1 || has_packets(o) {
                        variants.push((Who::Other(k), i));
                    }
                }
            }
            #[cfg(feature = "embree")]
            for (k, (o, _)) in others.iter().enumerate() {
                if let AnyAccel::Embree(_) = o {
                    for (i, &(wd, _)) in widths.iter().enumerate() {
                        if wd > 1 {
                            variants.push((Who::EmbreePlain(k), i));
                            variants.push((Who::EmbreeTrait(k), i));
                        }
                    }
                }
            }
            let res = interleaved(variants.len(), samples, |v| {
                let (who, i) = variants[v];
                let occ = kind.occlusion();
                match who {
                    Who::Bsp => pass_any(&bsp, &sets[i], occ, widths[i].1),
                    Who::Beam => pass_beam(&bsp, &beam_sets[i], occ, beams[i]),
                    #[cfg(feature = "embree")]
                    Who::Other(k) => match (&others[k].0, &mut packed[i]) {
                        // Embree's packet rows: its own packets, packed before timing.
                        (AnyAccel::Embree(e), Some(p)) => Ok(p.pass(e, occ, false)),
                        (o, _) => pass_of(o, &sets[i], kind, widths[i].1),
                    },
                    #[cfg(not(feature = "embree"))]
                    Who::Other(k) => pass_of(&others[k].0, &sets[i], kind, widths[i].1),
                    #[cfg(feature = "embree")]
                    Who::EmbreePlain(k) => match (&others[k].0, &mut packed[i]) {
                        (AnyAccel::Embree(e), Some(p)) => Ok(p.pass(e, occ, true)),
                        _ => Ok(PassResult::default()),
                    },
                    #[cfg(feature = "embree")]
                    Who::EmbreeTrait(k) => match &others[k].0 {
                        AnyAccel::Embree(e) => pass_any(e, &sets[i], occ, widths[i].1),
                        #[allow(unreachable_patterns)]
                        _ => Ok(PassResult::default()),
                    },
                }
            })?;
            let reference = res[0].1;
            for (v, &(who, i)) in variants.iter().enumerate() {
                let (name, build_ms, memory) = match who {
                    Who::Bsp | Who::Beam => ("bsp", build_ms, memory),
                    Who::Other(k) => (others[k].0.name(), others[k].1, others[k].0.memory_bytes()),
                    #[cfg(feature = "embree")]
                    Who::EmbreePlain(_) | Who::EmbreeTrait(_) => continue,
                };
                let (n, width, query, backend) = match who {
                    Who::Beam => (beam_sets[i].len(), beams[i].0, "beam", Some(beams[i].1)),
                    _ => (sets[i].len(), widths[i].0, "lanes", widths[i].1),
                };
                let (secs, r) = res[v];
                csv.row(&[
                    &s.name,
                    &name,
                    &kind.name(),
                    &width,
                    &format!("{:.3}", n as f64 / secs / 1e6),
                    &format!("{build_ms:.2}"),
                    &memory,
                    &r.hits,
                    &format!("{:.6e}", r.t_sum),
                    &query,
                    &backend.map_or("single", Backend::name),
                ])?;
                if let Some(why) = disagreement(&reference, &r, n) {
                    let on = match who {
                        Who::Beam => format!("beams of {width} on {}", beams[i].1.name()),
                        _ => format!("width {width}"),
                    };
                    disagreements.push(format!(
                        "{} {} rays, {name} at {on}: {why}",
                        s.name,
                        kind.name(),
                    ));
                }
            }
            // Embree: the harness beside the plain C-API loop and the `Accel` trait path.
            #[cfg(feature = "embree")]
            for (v, &(who, i)) in variants.iter().enumerate() {
                let Who::EmbreePlain(k) = who else { continue };
                let find = |want: Who| {
                    variants
                        .iter()
                        .position(|&(x, j)| x == want && j == i)
                        .map(|p| sets[i].len() as f64 / res[p].0 / 1e6)
                };
                let (Some(harness), Some(plain), Some(tr)) = (
                    find(Who::Other(k)),
                    Some(sets[i].len() as f64 / res[v].0 / 1e6),
                    find(Who::EmbreeTrait(k)),
                ) else {
                    continue;
                };
                emb.row(&[
                    &s.name,
                    &kind.name(),
                    &widths[i].0,
                    &format!("{harness:.3}"),
                    &format!("{plain:.3}"),
                    &format!("{tr:.3}"),
                    &format!("{:.3}", harness / plain),
                ])?;
            }
            // Traversal counters at width 1 and the widest width.
            for (i, &(wd, b)) in widths.iter().enumerate() {
                if wd != 1 && i != widths.len() - 1 {
                    continue;
                }
                let occ = kind.occlusion();
                let c = match b {
                    None => {
                        let mut c = TraversalStats::default();
                        for r in &sets[i] {
                            if occ {
                                bsp.occluded1_counted(r, &mut c);
                            } else {
                                bsp.intersect1_counted(r, &mut c);
                            }
                        }
                        c
                    }
                    Some(b) => b.run(Counted {
                        bsp: &bsp,
                        rays: &sets[i],
                        occlusion: occ,
                    })?,
                };
                let n = sets[i].len() as f64;
                // The BVH's side: obvhs' (CWBVH) triangle tests and 8-wide nodes per
                // single ray.
                #[cfg_attr(not(feature = "obvhs"), allow(unused_mut))]
                let (mut bvh_tests, mut bvh_nodes) = (String::from("-"), String::from("-"));
                #[cfg(feature = "obvhs")]
                if wd == 1 {
                    for (o, _) in &others {
                        match o {
                            AnyAccel::Obvhs(o) => {
                                let (t, nodes) = sets[i]
                                    .iter()
                                    .map(|r| o.counts1(r, occ))
                                    .fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
                                bvh_tests = format!("{:.3}", t as f64 / n);
                                bvh_nodes = format!("{:.3}", nodes as f64 / n);
                            }
                            #[allow(unreachable_patterns)]
                            _ => {}
                        }
                    }
                }
                trav.row(&[
                    &s.name,
                    &kind.name(),
                    &wd,
                    &format!("{:.3}", c.inner_nodes as f64 / n),
                    &format!("{:.3}", c.leaves as f64 / n),
                    &format!("{:.3}", c.tri_tests as f64 / n),
                    &format!("{:.3}", if wd == 1 { 1.0 } else { c.lanes_per_test() }),
                    &format!("{:.4}", c.mailbox_hit_rate()),
                    &bvh_tests,
                    &bvh_nodes,
                    &"lanes",
                    &b.map_or("single", Backend::name),
                ])?;
            }
            // The beams' counters: inner nodes count the beam's own steps with its packets'.
            for (b, &(n_beam, backend)) in beams.iter().enumerate().take(beam_sets.len()) {
                let c = backend.run(CountedBeam {
                    bsp: &bsp,
                    rays: &beam_sets[b],
                    beam: n_beam,
                    occlusion: kind.occlusion(),
                })?;
                let n = beam_sets[b].len() as f64;
                trav.row(&[
                    &s.name,
                    &kind.name(),
                    &n_beam,
                    &format!("{:.3}", (c.inner_nodes + c.beam_steps) as f64 / n),
                    &format!("{:.3}", c.leaves as f64 / n),
                    &format!("{:.3}", c.tri_tests as f64 / n),
                    &format!("{:.3}", c.lanes_per_test()),
                    &format!("{:.4}", c.mailbox_hit_rate()),
                    &"-",
                    &"-",
                    &"beam",
                    &backend.name(),
                ])?;
            }
            let mut ls = LeafSet {
                csv: &mut leaves,
                scene: s.name,
                kind,
                rays: &sets[0],
                samples,
                disagreements: &mut disagreements,
            };
            ls.rows(&bsp, &four, &others)?;
        }
        bar.inc(1);
        built.push(bsp);
    }
    csv.finish()?;
    trav.finish()?;
    emb.finish()?;
    leaves.finish()?;
    if !disagreements.is_empty() {
        anyhow::bail!(
            "accel: accelerators disagree with the BSP's single rays beyond the edge \
             tolerance (hits within {HIT_TOLERANCE} of the rays + 2, mean t within \
             {T_TOLERANCE} relative):\n  {}",
            disagreements.join("\n  ")
        );
    }

    // The switch threshold: packet subtrees with at most `t` active lanes continue ray by ray.
    let mut thr = ctx.csv("accel_threshold.csv", THRESHOLD_HEADER)?;
    for (s, bsp) in all.iter().zip(&mut built) {
        if s.name != "blob" && s.name != "room" {
            bar.inc(1);
            continue;
        }
        for kind in RayKind::ALL {
            for &(wd, b) in widths.iter().filter(|(wd, _)| *wd > 1) {
                let rays = rays(s, bsp, kind, w, h, wd);
                let ts: Vec<u32> = [0, 1, 2, 3, 4, 6, 8]
                    .into_iter()
                    .filter(|&t| t as usize <= wd / 2)
                    .collect();
                let secs = interleaved(ts.len(), samples, |i| {
                    bsp.set_traversal_params(true, Some(ts[i]));
                    pass_any(bsp, &rays, kind.occlusion(), b)
                })?;
                for (i, t) in ts.iter().enumerate() {
                    thr.row(&[
                        &s.name,
                        &kind.name(),
                        &wd,
                        &b.map_or("scalar", |b| b.name()),
                        t,
                        &format!("{:.3}", rays.len() as f64 / secs[i].0 / 1e6),
                    ])?;
                }
            }
        }
        bsp.set_traversal_params(true, None);
        bar.inc(1);
    }
    thr.finish()?;

    // Packets whose lanes differ in direction signs: walked together (the default) against
    // one walk per group of equal signs (the paper's way), on the same rays, interleaved.
    let mut mixed = ctx.csv("accel_mixed_signs.csv", MIXED_HEADER)?;
    for (s, bsp) in all.iter().zip(&built) {
        let split = Bsp::build(
            &s.scene,
            &BspParams {
                mixed_signs: false,
                ..BspParams::default()
            },
        )?;
        for kind in RayKind::ALL {
            for &(wd, b) in widths.iter().filter(|(wd, _)| *wd > 1) {
                let rays = rays(s, bsp, kind, w, h, wd);
                let res = interleaved(2, samples, |i| {
                    let a = if i == 0 { &split } else { &*bsp };
                    pass_any(a, &rays, kind.occlusion(), b)
                })?;
                if let Some(why) = disagreement(&res[0].1, &res[1].1, rays.len()) {
                    disagreements.push(format!(
                        "{} {} rays at width {wd}: together against per sign group: {why}",
                        s.name,
                        kind.name()
                    ));
                }
                let rate = |i: usize| rays.len() as f64 / res[i].0 / 1e6;
                mixed.row(&[
                    &s.name,
                    &kind.name(),
                    &wd,
                    &b.map_or("scalar", |b| b.name()),
                    &format!("{:.3}", rate(0)),
                    &format!("{:.3}", rate(1)),
                    &format!("{:.3}", rate(1) / rate(0)),
                    &format!("{:.3}", sign_groups_per_packet(&rays, wd)),
                ])?;
            }
        }
        bar.inc(1);
    }
    mixed.finish()?;
    if !disagreements.is_empty() {
        anyhow::bail!(
            "accel: the BSP's packets answer differently together and per sign group:\n  {}",
            disagreements.join("\n  ")
        );
    }
    bar.finish_and_clear();
    Ok(())
}

/// The average number of groups of equal direction signs in the packets of `width`
/// consecutive rays (what a walk per sign group walks per packet).
fn sign_groups_per_packet(rays: &[Ray1], width: usize) -> f64 {
    let packets = rays.chunks(width);
    let n = packets.len().max(1) as f64;
    let groups: usize = packets
        .map(|p| {
            let mut seen = [false; 8];
            for r in p {
                let d = r.dir.to_array();
                let k = (0..3).fold(0, |k, a| k | (usize::from(d[a].is_sign_negative()) << a));
                seen[k] = true;
            }
            seen.iter().filter(|&&x| x).count()
        })
        .sum();
    groups as f64 / n
}

/// The BSPs whose single rays test leaves four triangles at a time: on the default tree,
/// and on a tree whose leaves are priced per four triangles.
fn simd_leaf_bsps(scene: &coherent::accel::Scene) -> anyhow::Result<Vec<(&'static str, Bsp)>> {
    let mut p = BspParams {
        simd_leaves: true,
        ..BspParams::default()
    };
    let default = Bsp::build(scene, &p)?;
    p.object.leaf_group = 4;
    Ok(vec![
        ("default", default),
        ("per_four", Bsp::build(scene, &p)?),
    ])
}

/// The rows of `accel_simd_leaves.csv` for one scene and ray kind: the BSP's single rays one
/// triangle at a time (the `accel.csv` row's configuration) and four at a time, beside
/// Embree's single rays, timed interleaved over the same rays.
struct LeafSet<'a> {
    csv: &'a mut crate::table::CsvOut,
    scene: &'a str,
    kind: RayKind,
    rays: &'a [Ray1],
    samples: usize,
    disagreements: &'a mut Vec<String>,
}

impl LeafSet<'_> {
    #[cfg_attr(not(feature = "embree"), allow(unused_variables))]
    fn rows(
        &mut self,
        one: &Bsp,
        four: &[(&'static str, Bsp)],
        others: &[(AnyAccel, f64)],
    ) -> anyhow::Result<()> {
        let occ = self.kind.occlusion();
        let bsps: Vec<(&str, &str, &Bsp)> = std::iter::once(("one", "default", one))
            .chain(four.iter().map(|(t, b)| ("four", *t, b)))
            .collect();
        #[cfg(feature = "embree")]
        let embree = others
            .iter()
            .map(|(o, _)| o)
            .find(|o| matches!(o, AnyAccel::Embree(_)));
        #[cfg(not(feature = "embree"))]
        let embree: Option<&AnyAccel> = None;
        let n = bsps.len() + embree.is_some() as usize;
        let res = interleaved(n, self.samples, |v| match (bsps.get(v), embree) {
            (Some((_, _, b)), _) => pass_any(*b, self.rays, occ, None),
            (None, Some(e)) => pass_of(e, self.rays, self.kind, None),
            (None, None) => unreachable!("one variant per BSP, then Embree's if built"),
        })?;
        let rate = |v: usize| self.rays.len() as f64 / res[v].0 / 1e6;
        for (v, (test, tree, b)) in bsps.iter().enumerate() {
            let mut c = TraversalStats::default();
            for r in self.rays {
                if occ {
                    b.occluded1_counted(r, &mut c);
                } else {
                    b.intersect1_counted(r, &mut c);
                }
            }
            let vs = embree.map_or("-".to_owned(), |_| format!("{:.3}", rate(v) / rate(n - 1)));
            self.csv.row(&[
                &self.scene,
                &self.kind.name(),
                test,
                tree,
                &format!("{:.3}", rate(v)),
                &vs,
                &format!("{:.3}", c.tri_tests as f64 / self.rays.len() as f64),
                &b.memory_bytes(),
            ])?;
            if let Some(why) = disagreement(&res[0].1, &res[v].1, self.rays.len()) {
                self.disagreements.push(format!(
                    "{} {} rays, BSP with leaves tested {test} at a time ({tree} tree): {why}",
                    self.scene,
                    self.kind.name()
                ));
            }
        }
        Ok(())
    }
}

/// Which configuration a timed sample runs.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Who {
    Bsp,
    /// The BSP's beams: `beams()[i]`.
    Beam,
    /// `others[k]`.
    Other(usize),
    /// Embree (`others[k]`): the plain C-API loop over its packed packets.
    #[cfg(feature = "embree")]
    EmbreePlain(usize),
    /// Embree (`others[k]`): packets through the `Accel` trait, packed per call.
    #[cfg(feature = "embree")]
    EmbreeTrait(usize),
}

/// How far the hit count of a pass may be from the BSP's single-ray pass over the same rays,
/// as a share of the rays (plus 2). The interface lets a hit within `EDGE_EPS` of a
/// triangle's edge be missed (`coherent_accel::Accel`), and the structures use different
/// triangle tests (Embree's and obvhs' are not the projection test with its tolerance band),
/// so rays grazing a silhouette edge may count differently; measured: at most 0.01% of the
/// rays on every scene of the quick run.
const HIT_TOLERANCE: f64 = 1e-3;

/// How far the mean `t` of the hits may be from the BSP's, relative: the triangle tests
/// round differently (about 1e-6 relative), and the few edge rays above may hit a
/// different, farther surface.
const T_TOLERANCE: f64 = 1e-3;

/// Why `r` disagrees with `reference` over `rays` rays, if it does beyond the tolerances.
pub(crate) fn disagreement(reference: &PassResult, r: &PassResult, rays: usize) -> Option<String> {
    let dh = r.hits.abs_diff(reference.hits) as f64;
    if dh > HIT_TOLERANCE * rays as f64 + 2.0 {
        return Some(format!(
            "{} hits against the BSP's {}",
            r.hits, reference.hits
        ));
    }
    let mean = |p: &PassResult| {
        if p.hits == 0 {
            0.0
        } else {
            p.t_sum / p.hits as f64
        }
    };
    let (a, b) = (mean(r), mean(reference));
    if (a - b).abs() > T_TOLERANCE * b.abs().max(1e-30) {
        return Some(format!("mean hit t {a:.6} against the BSP's {b:.6}"));
    }
    None
}

/// Writes what Embree runs here into `machine.json` (key `embree`: version, isa,
/// native_packets; see [`crate::machine_keys`]) and notes it.
fn record_embree(ctx: &mut Ctx) {
    #[cfg(feature = "embree")]
    {
        let path = ctx.path("machine.json");
        let Ok(text) = std::fs::read_to_string(&path) else {
            return;
        };
        match coherent::embree::info() {
            Ok(i) => {
                ctx.note(format!(
                    "accel: Embree {} runs its {} kernels here, native packets of {:?}",
                    i.version, i.isa, i.native_packets
                ));
                let value = serde_json::json!({
                    "version": i.version,
                    "isa": i.isa,
                    "native_packets": i.native_packets,
                });
                let text = crate::machine_keys::set_key(&text, "embree", &value.to_string());
                let _ = std::fs::write(&path, text);
            }
            Err(e) => ctx.note(format!("accel: no Embree to describe: {e}")),
        }
    }
    #[cfg(not(feature = "embree"))]
    let _ = ctx;
}

/// Traversal counters over packets of the backend's width.
struct Counted<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
    occlusion: bool,
}

impl Kernel for Counted<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for ch in self.rays.chunks(L::N) {
            let p = Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]);
            let m = l.mask_from_fn(|i| i < ch.len());
            if self.occlusion {
                self.bsp.occluded_counted(l, &p, m, &mut c);
            } else {
                self.bsp.intersect_counted(l, &p, m, &mut c);
            }
        }
        c
    }
}

/// Traversal counters over beams of `beam` rays in packets of the backend's width.
struct CountedBeam<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
    beam: usize,
    occlusion: bool,
}

impl Kernel for CountedBeam<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        let per_beam = self.beam.div_ceil(L::N).max(1);
        for group in self.rays.chunks(per_beam * L::N) {
            // Loops, not iterator adaptors: those stay out of line, outside the kernel.
            let mut p: Vec<Rays<L>> = Vec::new();
            let mut m: Vec<L::Mask> = Vec::new();
            for ch in group.chunks(L::N) {
                p.push(Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]));
                m.push(l.mask_from_fn(|i| i < ch.len()));
            }
            if self.occlusion {
                let mut o = vec![l.splat_mask(false); p.len()];
                self.bsp.occluded_beam_counted(l, &p, &m, &mut o, &mut c);
            } else {
                let mut h = vec![coherent::accel::Hits::miss(l); p.len()];
                self.bsp.intersect_beam_counted(l, &p, &m, &mut h, &mut c);
            }
        }
        c
    }
}

/// Whether row `r` of an `accel.csv` is a beam row (files written before beams have no
/// `query` column: all lane packets).
fn is_beam(t: &crate::Table, r: usize) -> bool {
    t.get(r, "query").is_ok_and(|q| q == "beam")
}

/// The beam rows of `accel.csv` as a table: per scene and ray kind, the BSP's lane packets
/// at the widest width, its beams per size and backend, and Embree's fastest row, Mrays/s.
fn beam_report(t: &crate::Table) -> anyhow::Result<Option<String>> {
    let mut sizes: Vec<(usize, String)> = Vec::new();
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in 0..t.rows.len() {
        if is_beam(t, r) {
            let k = (t.f64(r, "width")? as usize, t.get(r, "backend")?.to_owned());
            if !sizes.contains(&k) {
                sizes.push(k);
            }
            let key = (t.get(r, "scene")?.to_owned(), t.get(r, "rays")?.to_owned());
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
    }
    if sizes.is_empty() {
        return Ok(None);
    }
    sizes.sort_by_key(|a| (a.1 == "scalar", a.0));
    let mut header = vec![
        "scene".to_owned(),
        "rays".to_owned(),
        "lane packets (widest)".to_owned(),
        "Embree's fastest".to_owned(),
    ];
    header.extend(sizes.iter().map(|(n, b)| format!("beam {n} ({b})")));
    header.push("best beam / packets".to_owned());
    header.push("best beam / Embree".to_owned());
    let mut rows = Vec::new();
    for (scene, rays) in &keys {
        let of = |pred: &dyn Fn(usize) -> anyhow::Result<bool>| -> anyhow::Result<Option<f64>> {
            let mut best: Option<f64> = None;
            for r in 0..t.rows.len() {
                if t.get(r, "scene")? == scene && t.get(r, "rays")? == rays && pred(r)? {
                    let v = t.f64(r, "mrays_per_s")?;
                    best = Some(best.map_or(v, |b: f64| b.max(v)));
                }
            }
            Ok(best)
        };
        let lanes = of(&|r| Ok(t.get(r, "accel")? == "bsp" && !is_beam(t, r)))?;
        let embree = of(&|r| Ok(t.get(r, "accel")? == "embree"))?;
        let mut row = vec![scene.clone(), rays.clone()];
        row.push(lanes.map_or("-".into(), fmt_num));
        row.push(embree.map_or("-".into(), fmt_num));
        let mut best_beam: Option<f64> = None;
        for (n, b) in &sizes {
            let v = of(&|r| {
                Ok(is_beam(t, r) && t.f64(r, "width")? as usize == *n && t.get(r, "backend")? == b)
            })?;
            if b != "scalar" {
                best_beam = match (best_beam, v) {
                    (Some(x), Some(y)) => Some(x.max(y)),
                    (x, y) => x.or(y),
                };
            }
            row.push(v.map_or("-".into(), fmt_num));
        }
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => format!("{:.2}", a / b),
            _ => "-".into(),
        };
        row.push(ratio(best_beam, lanes));
        row.push(ratio(best_beam, embree));
        rows.push(row);
    }
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    Ok(Some(format!(
        "\nBeams (`query` = beam in `accel.csv`): Mrays/s of the BSP's beam traversal on \
         square tiles of `width` rays (the beam-size sweep on the widest backend; the scalar \
         backend's beams cull without SIMD), beside its fastest lane packets and Embree's \
         fastest row (any width). The same rays, one thread.\n\n{}",
        markdown_table(&header, &rows)
    )))
}

/// The BSP's `(scene, rays)` -> width -> Mrays/s, from `accel.csv`.
fn rates(t: &crate::Table) -> anyhow::Result<BTreeMap<(String, String), BTreeMap<u32, f64>>> {
    let mut m: BTreeMap<(String, String), BTreeMap<u32, f64>> = BTreeMap::new();
    for r in 0..t.rows.len() {
        if t.get(r, "accel")? != "bsp" || is_beam(t, r) {
            continue;
        }
        m.entry((t.get(r, "scene")?.to_owned(), t.get(r, "rays")?.to_owned()))
            .or_default()
            .insert(t.f64(r, "width")? as u32, t.f64(r, "mrays_per_s")?);
    }
    Ok(m)
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = read_either(ctx, "accel.csv", HEADER)? else {
        return Ok(());
    };
    let rates = rates(&t)?;
    let mut series = Vec::new();
    for ((scene, rays), by_w) in &rates {
        let Some(&one) = by_w.get(&1) else { continue };
        let pts = by_w.iter().map(|(&w, &r)| (w as f64, r / one)).collect();
        series.push(Series::new(format!("{scene} {rays}"), pts));
    }
    series.push(Series::reference(
        "ideal (= width)",
        vec![(1.0, 1.0), (4.0, 4.0), (8.0, 8.0), (16.0, 16.0)],
    ));
    ctx.line_chart(
        "accel_speedup_vs_width",
        &LineChart {
            title: "BSP: packet speedup over single-ray traversal".into(),
            x_label: "packet width (lanes)".into(),
            y_label: "Mrays/s over width 1".into(),
            series,
            log2_x: true,
        },
    )?;
    let widths: Vec<u32> = {
        let mut w: Vec<u32> = rates.values().flat_map(|m| m.keys().copied()).collect();
        w.sort_unstable();
        w.dedup();
        w
    };
    let bars = widths
        .iter()
        .map(|w| {
            let v = rates
                .values()
                .map(|m| m.get(w).copied().unwrap_or(0.0))
                .collect();
            (format!("width {w}"), v)
        })
        .collect();
    compare_plots(ctx)?;
    ctx.bar_chart(
        "accel_mrays",
        &BarChart {
            title: "BSP: Mrays/s per scene and ray kind (one thread)".into(),
            y_label: "Mrays/s".into(),
            categories: rates.keys().map(|(s, r)| format!("{s} {r}")).collect(),
            series: bars,
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = read_either(ctx, "accel.csv", HEADER)? else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "Mrays/s of the two-level BSP, one thread, and in brackets the speedup over width 1 \
         (single-ray traversal) in the same run. Widths 4/8/16 use the sse/avx2/avx512 \
         backends where usable (else wide). The packet goals on primary rays: width 4 >= \
         2.5x, width 16 >= 5x. Every width traces the same rays (ordered in tiles of its \
         packet's shape).\n\n",
    );
    let rates = rates(&t)?;
    let widths: Vec<u32> = {
        let mut w: Vec<u32> = rates.values().flat_map(|m| m.keys().copied()).collect();
        w.sort_unstable();
        w.dedup();
        w
    };
    let mut header = vec!["scene".to_owned(), "rays".to_owned()];
    header.extend(widths.iter().map(|w| format!("width {w}")));
    let rows: Vec<Vec<String>> = rates
        .iter()
        .map(|((s, r), m)| {
            let one = m.get(&1).copied();
            let mut row = vec![s.clone(), r.clone()];
            for w in &widths {
                row.push(match (m.get(w), one) {
                    (Some(&v), Some(o)) if *w != 1 => {
                        format!("{} ({}x)", fmt_num(v), fmt_num(v / o))
                    }
                    (Some(&v), _) => fmt_num(v),
                    _ => "—".into(),
                });
            }
            row
        })
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));
    // Build time and memory, once per scene.
    let mut seen = Vec::new();
    let mut brows = Vec::new();
    for r in 0..t.rows.len() {
        let s = t.get(r, "scene")?.to_owned();
        if t.get(r, "accel")? == "bsp" && !seen.contains(&s) {
            seen.push(s.clone());
            brows.push(vec![
                s,
                fmt_num(t.f64(r, "build_ms")?),
                format!("{:.1}", t.f64(r, "memory_bytes")? / 1e6),
            ]);
        }
    }
    md.push_str("\nBuild (all object trees and the top level, one thread) and memory:\n\n");
    md.push_str(&markdown_table(&["scene", "build ms", "memory MB"], &brows));
    for (stem, alt) in [
        ("accel_speedup_vs_width", "speedup vs width"),
        ("accel_mrays", "Mrays/s"),
    ] {
        if let Some(p) = ctx.plot_markdown(stem, alt) {
            md.push_str(&p);
        }
    }
    if let Some(cmp) = compare_report(ctx)? {
        md.push_str(&cmp);
    }
    if let Some(b) = beam_report(&t)? {
        md.push_str(&b);
    }
    if let Some(th) = ctx.read_csv("accel_threshold.csv", THRESHOLD_HEADER)? {
        md.push_str(
            "\nThe packet-to-single-ray switch (`accel_threshold.csv`): Mrays/s when a packet \
             subtree with at most `threshold` active lanes continues ray by ray (0 = never). The \
             defaults in `coherent_bsp::default_single_ray_threshold` come from this sweep.\n\n",
        );
        let mut rows = Vec::new();
        let mut keys = Vec::new();
        for r in 0..th.rows.len() {
            let k = (
                th.get(r, "scene")?.to_owned(),
                th.get(r, "rays")?.to_owned(),
                th.get(r, "width")?.to_owned(),
            );
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        for (s, ray, wd) in keys {
            let mut cells: Vec<(u32, f64)> = Vec::new();
            for r in 0..th.rows.len() {
                if th.get(r, "scene")? == s
                    && th.get(r, "rays")? == ray
                    && th.get(r, "width")? == wd
                {
                    cells.push((th.f64(r, "threshold")? as u32, th.f64(r, "mrays_per_s")?));
                }
            }
            let best = cells
                .iter()
                .copied()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |c| c.0);
            let list = cells
                .iter()
                .map(|(t, v)| format!("{t}: {}", fmt_num(*v)))
                .collect::<Vec<_>>()
                .join(", ");
            rows.push(vec![s, ray, wd, list, best.to_string()]);
        }
        md.push_str(&markdown_table(
            &["scene", "rays", "width", "threshold: Mrays/s", "best"],
            &rows,
        ));
    }
    if let Some(t) = ctx.read_csv("accel_mixed_signs.csv", MIXED_HEADER)? {
        md.push_str(
            "\nPackets whose lanes differ in direction signs (`accel_mixed_signs.csv`): the \
             paper, after Wald et al., splits such a packet into groups of equal signs and walks \
             the tree once per group; by default the BSP walks them together, each lane taking \
             its own near child at every split (`BspParams::mixed_signs`). Mrays/s of both on \
             the same rays, interleaved, and the groups of equal signs per packet.\n\n",
        );
        md.push_str(&t.to_markdown());
    }
    if let Some(tr) = read_either(ctx, "accel_traversal.csv", TRAVERSAL_HEADER)? {
        md.push_str(
            "\nTraversal per ray (first-hit queries, any-hit for shadow rays; packet counts \
             divided by the rays in them): the BSP's inner nodes, leaves (from revision e106a42 on, \
             single rays skip empty leaves at their parent, so theirs count leaves with \
             triangles; packets, and single rays in runs before it, count every leaf they \
             enter), triangle tests, active \
             lanes per packet test, the share of triangle tests the intersection cache \
             (mailbox) saved, and for comparison the triangle tests and nodes per single ray of \
             a BVH over the same meshes (obvhs' CWBVH, counted with obvhs' own traversal \
             code). A BSP inner node is one split-plane test; a CWBVH node tests the boxes of \
             its up to 8 children at once, so the node columns count steps, not work \
             (`accel_traversal.csv`).\n\n",
        );
        md.push_str(&tr.to_markdown());
    }
    if let Some(t) = ctx.read_csv("accel_simd_leaves.csv", LEAVES_HEADER)? {
        md.push_str(
            "\nSingle rays testing a leaf's triangles four at a time (SSE, the leaf's \
             projection-test records copied into blocks of four; `leaf_test` four) beside one \
             at a time (the rows above), on the default tree and on a tree whose leaves are \
             priced per four triangles (`tree` per_four), timed interleaved with Embree's \
             single rays over the same rays; `tests_per_ray` counts blocks of four for `four` \
             (`accel_simd_leaves.csv`). The scalar baseline of the paper's tables keeps one \
             triangle at a time.\n\n",
        );
        md.push_str(&t.to_markdown());
    }
    Ok(Some(md))
}

/// `(scene, accel, rays, width) -> (mrays_per_s, build_ms, memory_bytes)` of the CSV.
type Rows = BTreeMap<(String, String, String, usize), (f64, f64, f64)>;

fn read_rows(ctx: &Ctx) -> anyhow::Result<Option<(Rows, Vec<String>)>> {
    read_rows_of(ctx, "accel.csv")
}

/// [`read_rows`] of `file` (a path in the output folder).
fn read_rows_of(ctx: &Ctx, file: &str) -> anyhow::Result<Option<(Rows, Vec<String>)>> {
    let Some(t) = read_either(ctx, file, HEADER)? else {
        return Ok(None);
    };
    let mut rows = Rows::new();
    let mut scenes: Vec<String> = Vec::new();
    for r in 0..t.rows.len() {
        if is_beam(&t, r) {
            continue;
        }
        let scene = t.get(r, "scene")?.to_string();
        if !scenes.contains(&scene) {
            scenes.push(scene.clone());
        }
        let key = (
            scene,
            t.get(r, "accel")?.to_string(),
            t.get(r, "rays")?.to_string(),
            t.f64(r, "width")? as usize,
        );
        rows.insert(
            key,
            (
                t.f64(r, "mrays_per_s")?,
                t.f64(r, "build_ms")?,
                t.f64(r, "memory_bytes")?,
            ),
        );
    }
    Ok(Some((rows, scenes)))
}

const ACCELS: [&str; 3] = ["bsp", "embree", "obvhs"];

/// The comparison plots: Mrays/s per scene, accelerator and width for each kind of rays;
/// build time and memory per scene and accelerator.
fn compare_plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some((rows, scenes)) = read_rows(ctx)? else {
        return Ok(());
    };
    let get = |s: &str, a: &str, k: &str, w: usize| {
        rows.get(&(s.to_string(), a.to_string(), k.to_string(), w))
    };
    for kind in RayKind::ALL {
        let mut series = Vec::new();
        for a in ACCELS {
            for w in [1, 4, 8, 16] {
                let v: Vec<f64> = scenes
                    .iter()
                    .map(|s| get(s, a, kind.name(), w).map_or(f64::NAN, |r| r.0))
                    .collect();
                if v.iter().any(|x| x.is_finite()) {
                    series.push((format!("{a} x{w}"), v));
                }
            }
        }
        ctx.bar_chart(
            &format!("accel_{}", kind.name()),
            &BarChart {
                title: format!(
                    "{} rays: Mrays/s per scene, accelerator and width",
                    kind.name()
                ),
                y_label: "Mrays/s (one thread)".into(),
                categories: scenes.clone(),
                series,
            },
        )?;
    }
    for (stem, title, y, pick) in [
        ("accel_build", "build time", "ms (one thread)", 1usize),
        ("accel_memory", "memory", "MB", 2),
    ] {
        let series = ACCELS
            .iter()
            .filter_map(|a| {
                let v: Vec<f64> = scenes
                    .iter()
                    .map(|s| {
                        get(s, a, "primary", 1).map_or(f64::NAN, |r| match pick {
                            1 => r.1,
                            _ => r.2 / 1e6,
                        })
                    })
                    .collect();
                v.iter().any(|x| x.is_finite()).then(|| (a.to_string(), v))
            })
            .collect();
        ctx.bar_chart(
            stem,
            &BarChart {
                title: format!("{title} per scene and accelerator"),
                y_label: y.into(),
                categories: scenes.clone(),
                series,
            },
        )?;
    }
    Ok(())
}

/// BSP / Embree per scene, ray kind and width, and BSP / obvhs single rays, each ratio below
/// its target marked with `!`.
fn ratio_table(rows: &Rows, scenes: &[String]) -> String {
    let get = |s: &str, a: &str, k: &str, w: usize| {
        rows.get(&(s.to_string(), a.to_string(), k.to_string(), w))
            .map(|r| r.0)
    };
    let target = |kind: &str, w: usize| match (kind, w) {
        ("diffuse", _) => 0.7,
        (_, 1) => 0.8,
        _ => 1.0,
    };
    let mut table = Vec::new();
    for s in scenes {
        for kind in RayKind::ALL {
            let k = kind.name();
            let mut row = vec![s.clone(), k.to_string()];
            for w in [1, 4, 8, 16] {
                row.push(match (get(s, "bsp", k, w), get(s, "embree", k, w)) {
                    (Some(b), Some(e)) => {
                        let r = b / e;
                        let miss = if r < target(k, w) { " !" } else { "" };
                        format!("{r:.2}{miss}")
                    }
                    _ => "-".into(),
                });
            }
            row.push(match (get(s, "bsp", k, 1), get(s, "obvhs", k, 1)) {
                (Some(b), Some(o)) => {
                    let miss = if b / o < 2.0 { " !" } else { "" };
                    format!("{:.2}{miss}", b / o)
                }
                _ => "-".into(),
            });
            table.push(row);
        }
    }
    markdown_table(
        &[
            "scene",
            "rays",
            "bsp/embree x1",
            "x4",
            "x8",
            "x16",
            "bsp/obvhs x1",
        ],
        &table,
    )
}

/// The comparison tables: the BSP against Embree per scene, ray kind and width with the
/// targets, the cross-check, Embree's harness against a plain C-API loop, the native build
/// beside the portable one, build time and memory, and a run on another machine.
fn compare_report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some((rows, scenes)) = read_rows(ctx)? else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(&embree_facts(ctx));
    md.push_str(
        "\nThe BSP against Embree 4 at equal width (Mrays/s ratio, one thread, the same rays; \
         Embree's packet rows trace its own packets packed before timing), and the BSP's \
         single rays against obvhs (CWBVH, single rays only). Targets: primary and shadow \
         rays >= 1.0 at widths 4, 8, 16 and >= 0.8 single; diffuse rays >= 0.7 at every \
         width; against obvhs >= 2 (in the native build). A ratio below its target is marked \
         with `!`.\n\n",
    );
    md.push_str(&ratio_table(&rows, &scenes));
    md.push_str(
        "\nCross-check: every row of `accel.csv` carries the hits and the sum of hit `t` over \
         its rays (`hits`, `t_sum`); the run fails when any accelerator or width differs from \
         the BSP's single rays by more than 0.1% of the rays + 2 in hits or 0.1% in mean `t` \
         (rays within the edge tolerance of a silhouette may count differently).\n",
    );
    if let Some(e) = ctx.read_csv("accel_embree.csv", EMBREE_HEADER)? {
        md.push_str(
            "\nEmbree's packet rows beside a plain C-API loop over the same packed packets \
             (reset far bounds and hit ids, call `rtcIntersectK`/`rtcOccludedK`, read nothing \
             back), and beside packets handed through the `Accel` trait (packed from our \
             `Rays` on every call), Mrays/s (`accel_embree.csv`). The harness reads each \
             packet's answers back after the next packet's query, not straight after its own: \
             read at once, 8-wide first hits ran at 0.75-0.9 of the plain loop's rate on Zen 4 \
             (likely because Embree writes the answers with masked vector stores, which the \
             loads right after them cannot take from the store buffer):\n\n",
        );
        md.push_str(&e.to_markdown());
    }
    if let Some(n) = native_report(ctx, &rows)? {
        md.push_str(&n);
    }
    md.push_str("\nBuild (ms, one thread) and memory (MB):\n\n");
    let mut build = Vec::new();
    for s in &scenes {
        let mut row = vec![s.clone()];
        for a in ACCELS {
            let r = rows.get(&(s.clone(), a.to_string(), "primary".to_string(), 1));
            row.push(r.map_or("-".into(), |r| fmt_num(r.1)));
            row.push(r.map_or("-".into(), |r| fmt_num(r.2 / 1e6)));
        }
        build.push(row);
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "bsp ms",
            "bsp MB",
            "embree ms",
            "embree MB",
            "obvhs ms",
            "obvhs MB",
        ],
        &build,
    ));
    for stem in [
        "accel_primary",
        "accel_shadow",
        "accel_diffuse",
        "accel_build",
        "accel_memory",
    ] {
        if let Some(p) = ctx.plot_markdown(stem, stem) {
            md.push('\n');
            md.push_str(&p);
            md.push('\n');
        }
    }
    if let Some(m) = manycore_report(ctx)? {
        md.push_str(&m);
    }
    Ok(Some(md))
}

/// What Embree ran (from `machine.json`'s `embree` key), as a sentence.
fn embree_facts(ctx: &Ctx) -> String {
    embree_facts_of(ctx, "machine.json")
}

/// [`embree_facts`] from the `machine.json` at `file` in the output folder.
fn embree_facts_of(ctx: &Ctx, file: &str) -> String {
    let json = std::fs::read_to_string(ctx.path(file))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    let Some(j) = json else {
        return String::new();
    };
    let build = j["build"].as_str().unwrap_or("portable");
    match j.get("embree") {
        Some(e) => format!(
            "\nEmbree {} ran its {} kernels (native packets of {}); this is the {build} build \
             (RUSTFLAGS `{}`).\n",
            e["version"].as_str().unwrap_or("?"),
            e["isa"].as_str().unwrap_or("?"),
            e["native_packets"],
            j["rustflags"].as_str().unwrap_or("")
        ),
        None => format!("\nNo Embree was loaded; this is the {build} build.\n"),
    }
}

/// The ratios of the same experiment run on another machine (`manycore/accel.csv`), and how
/// Embree's rates through the harness compared with a plain C-API loop there.
fn manycore_report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some((rows, scenes)) = read_rows_of(ctx, &format!("{MANYCORE}/accel.csv"))? else {
        return Ok(None);
    };
    let about = crate::table5::manycore_machine(ctx, "accel");
    let mut md = format!(
        "\n### On another machine\n\nThe same rays, widths and protocol (portable build, one \
         thread) on {about} (`{MANYCORE}/`: its own [README]({MANYCORE}/README.md#accel--traversal-speed-build-time-and-memory-per-accel-ray-kind-and-packet-width), \
         `machine.json`, CSV files and plots). That machine was lent for a session, so these \
         rows come from another CPU than the rest of this report.\n"
    );
    md.push_str(&embree_facts_of(ctx, &format!("{MANYCORE}/machine.json")));
    md.push('\n');
    md.push_str(&ratio_table(&rows, &scenes));
    if let Some(e) = ctx.read_csv(&format!("{MANYCORE}/accel_embree.csv"), EMBREE_HEADER)? {
        let mut ratios = Vec::new();
        for r in 0..e.rows.len() {
            ratios.push(e.f64(r, "harness_over_plain")?);
        }
        ratios.sort_by(f64::total_cmp);
        if let (Some(lo), Some(hi)) = (ratios.first(), ratios.last()) {
            md.push_str(&format!(
                "\nEmbree through the harness over a plain C-API loop there \
                 (`{MANYCORE}/accel_embree.csv`, {} rows): median {:.3}, range {lo:.3}-{hi:.3}.\n",
                ratios.len(),
                median(&ratios),
            ));
        }
    }
    Ok(Some(md))
}

/// The portable build beside the native one (`native/accel.csv`, written by
/// `scripts/reproduce.sh --native`), Mrays/s per scene, accelerator, ray kind and width.
fn native_report(ctx: &Ctx, rows: &Rows) -> anyhow::Result<Option<String>> {
    let Some(t) = read_either(ctx, "native/accel.csv", HEADER)? else {
        return Ok(None);
    };
    let mut table = Vec::new();
    for r in 0..t.rows.len() {
        let key = (
            t.get(r, "scene")?.to_string(),
            t.get(r, "accel")?.to_string(),
            t.get(r, "rays")?.to_string(),
            t.f64(r, "width")? as usize,
        );
        let native = t.f64(r, "mrays_per_s")?;
        let Some(p) = rows.get(&key) else { continue };
        table.push(vec![
            key.0,
            key.1,
            key.2,
            key.3.to_string(),
            fmt_num(p.0),
            fmt_num(native),
            format!("{:.2}", native / p.0),
        ]);
    }
    let mut md = String::from(
        "\nThe portable build (no RUSTFLAGS) beside the native one (`-C target-cpu=native`, \
         `native/`), Mrays/s; separate processes, so compare ratios with care:\n\n",
    );
    md.push_str(&markdown_table(
        &[
            "scene",
            "accel",
            "rays",
            "width",
            "portable",
            "native",
            "native/portable",
        ],
        &table,
    ));
    Ok(Some(md))
}

/// Reads `file` with `header`, or, for results written before the last columns were added
/// (`hits,t_sum` in `accel.csv`, `obvhs_tests_per_ray` and then `obvhs_nodes_per_ray` in
/// `accel_traversal.csv`), with the header they had; the report then shows what those files
/// hold.
fn read_either(ctx: &Ctx, file: &str, header: &[&str]) -> anyhow::Result<Option<crate::Table>> {
    // Older files lack the trailing `query` and `backend` columns (and older still the
    // cross-check's).
    let older: &[usize] = if file.ends_with("traversal.csv") {
        &[2, 3, 4]
    } else {
        &[2, 4]
    };
    match ctx.read_csv(file, header) {
        Ok(t) => Ok(t),
        Err(e) => older
            .iter()
            .find_map(|&k| ctx.read_csv(file, &header[..header.len() - k]).ok())
            .ok_or(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pass(hits: u64, t_sum: f64) -> PassResult {
        PassResult {
            seconds: 1.0,
            hits,
            t_sum,
        }
    }

    #[test]
    fn the_cross_check_allows_edge_rays_and_nothing_more() {
        let bsp = pass(10_000, 50_000.0);
        // Same answers, rounding in t, a few edge rays: agree.
        assert_eq!(disagreement(&bsp, &pass(10_000, 50_000.4), 20_000), None);
        assert_eq!(disagreement(&bsp, &pass(10_019, 50_095.0), 20_000), None);
        // Missing hits beyond 0.1% of the rays + 2.
        assert!(disagreement(&bsp, &pass(9_970, 49_850.0), 20_000).is_some());
        // Right count, wrong (farther) hits.
        assert!(disagreement(&bsp, &pass(10_000, 50_100.0), 20_000).is_some());
        // Occlusion rows (t_sum 0) compare counts only.
        assert_eq!(
            disagreement(&pass(7107, 0.0), &pass(7106, 0.0), 10_000),
            None
        );
        assert!(disagreement(&pass(7107, 0.0), &pass(7000, 0.0), 10_000).is_some());
    }

    #[test]
    fn a_run_on_another_machine_is_reported_with_that_machine() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let rows = "scene,accel,rays,width,mrays_per_s,build_ms,memory_bytes,hits,t_sum\n\
                    room,bsp,shadow,4,12.0,1,1,5,0\n\
                    room,embree,shadow,4,10.0,1,1,5,0\n";
        std::fs::write(ctx.path("accel.csv"), rows).unwrap();
        let md = compare_report(&ctx).unwrap().unwrap();
        assert!(!md.contains("On another machine"), "{md}");

        std::fs::create_dir(ctx.path(MANYCORE)).unwrap();
        let other = rows.replace("12.0", "6.0");
        std::fs::write(ctx.path(&format!("{MANYCORE}/accel.csv")), other).unwrap();
        std::fs::write(
            ctx.path(&format!("{MANYCORE}/machine.json")),
            r#"{"cpu": "Other CPU", "cores": 16, "threads": 16, "git_rev": "new", "date": "now",
                "embree": {"version": "4.4.0", "isa": "avx512", "native_packets": [4, 8, 16]},
                "runs": {"accel": {"git_rev": "abc", "date": "then"}}}"#,
        )
        .unwrap();
        let md = compare_report(&ctx).unwrap().unwrap();
        let (here, there) = md.split_once("### On another machine").unwrap();
        assert!(here.contains("| room | shadow | - | 1.20 |"), "{here}");
        assert!(there.contains("| room | shadow | - | 0.60 ! |"), "{there}");
        assert!(
            there.contains("Other CPU with 16 cores (16 hardware threads), git revision `abc`"),
            "{there}"
        );
        assert!(
            there.contains("Embree 4.4.0 ran its avx512 kernels"),
            "{there}"
        );
    }
}
