//! Experiment `accel`: the two-level BSP of paper section 3 on the built-in generated scenes
//! (`coherent_accel::scenes`: spheres, terrain, room, blob) and on the real meshes
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
//! fails on a disagreement beyond the edge tolerance (`HIT_TOLERANCE`, `T_TOLERANCE`).
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
//! ([`coherent::accel::Accel::intersect_beam`]) on primary and shadow rays, with `width` the beam's ray count:
//! square screen tiles of 4x4 to 32x32 rays on the widest backend (the beam-size sweep), and
//! 8x8 and 16x16 on the scalar backend (one-lane packets under a shared beam: the culling
//! without SIMD). The rays are the same as every other row's, ordered tile by tile; the
//! beam rows are timed interleaved with the others and cross-checked like them. obvhs has
//! beam rows too (`accel` obvhs, the same sizes and rays): its large-packet traversal over
//! a BVH2 built beside each of its CWBVHs (`coherent_obvhs::packet`; here obvhs is built
//! with them, so its `build_ms` and `memory_bytes` include them).
//!
//! Packet shapes (`accel_shapes.csv`): the BSP's 16-lane packets as rows of 8 x 2 and 16 x 1
//! rays, timed interleaved with the 4 x 4 rows of `accel.csv` over the same rays in their own
//! tile order: what the shape alone costs.

mod counters;
mod embree;
mod leaves;
mod measure;
mod plot;
mod rays;
mod report;
mod sweeps;

use coherent::accel_any::AccelKind;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use measure::{HIT_TOLERANCE, Outputs, Setup, T_TOLERANCE};

pub(crate) use measure::{disagreement, interleaved, pass_any};
pub(crate) use rays::{rays, scene_list};

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
        "accel_shapes.csv",
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
        plot: plot::plots,
        report: report::report,
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

const SHAPES_HEADER: &[&str] = &[
    "scene",
    "rays",
    "shape",
    "backend",
    "mrays_per_s",
    "over_square",
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
    "group_steps_per_ray",
    "limit_reductions_per_ray",
    "instance_lanes_per_ray",
    "packets_moved_per_ray",
    "setup_ns_per_ray",
    "ray_by_ray_lanes",
    "other_sign_lanes",
    "culled_per_ray",
    "reversed_lanes",
];

/// The trailing columns of [`TRAVERSAL_HEADER`] older files lack (the beams' own counters,
/// the last [`TRAVERSAL_CULL_COLUMNS`] of them added later).
const TRAVERSAL_BEAM_COLUMNS: usize = 9;
/// The beams' culling and reversal counters, the last columns of [`TRAVERSAL_HEADER`].
const TRAVERSAL_CULL_COLUMNS: usize = 2;

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let setup = Setup::new(ctx);
    let all = scene_list(ctx, setup.size);
    embree::record(ctx);
    for k in AccelKind::compared() {
        if let Some(why) = k.unavailable_reason() {
            ctx.note(format!("accel: {k} left out: {why}"));
        }
    }
    let bar = ctx.progress(all.len() as u64 * 3, "accel");
    let mut out = Outputs::open(ctx)?;
    let mut built = Vec::new();
    let mut disagreements = Vec::new();
    for s in &all {
        built.push(measure::scene(
            ctx,
            &setup,
            s,
            &mut out,
            &mut disagreements,
        )?);
        bar.inc(1);
    }
    out.finish()?;
    if !disagreements.is_empty() {
        anyhow::bail!(
            "accel: accelerators disagree with the BSP's single rays beyond the edge \
             tolerance (hits within {HIT_TOLERANCE} of the rays + 2, mean t within \
             {T_TOLERANCE} relative):\n  {}",
            disagreements.join("\n  ")
        );
    }
    sweeps::threshold(ctx, &setup, &all, &mut built, &bar)?;
    sweeps::mixed_signs(ctx, &setup, &all, &built, &bar)?;
    bar.finish_and_clear();
    Ok(())
}
