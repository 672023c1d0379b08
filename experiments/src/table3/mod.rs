//! Experiment `table3`: the paper's Table 3 (section 7), whole-frame rendering time of the
//! test scenes per lane backend and accelerator, 1 thread, with the speedup over the scalar
//! backend (the same renderer, one ray at a time) and the PSNR of each image against the
//! scalar + BSP one; then where the time goes (per stage of the pipeline, from a separate
//! timed-stages run so the timed frames carry no clock reads) and how coherent the packets
//! stay (average active lanes per packet at each ray depth; the paper says coherence falls
//! with depth); and, for the scenes whose lights take random numbers, the BSP's frames again
//! with light samples shared per 4 x 4 pixel tile (`--light-samples tile`).
//!
//! Protocol: every scene (the built-ins, then the repository's `scenes/*.toml`; quick mode:
//! only scenes up to 20,000 triangles at 160 x 120) renders at 1024 x 768 with 1 sample per
//! pixel through the progressive film, as `coherent render --spp 1 --threads 1` does. Per
//! scene, every (accel, backend) pair renders once untimed (its image and statistics), then
//! 3 timed rounds visit every pair in turn; `seconds` is the median of the rounds.

mod measure;
mod plot;
mod report;

use coherent::accel_any::AccelKind;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::factors;
use crate::frames::{self, Loaded, Plan};
use crate::table::{PaperTable, Table};
use measure::{Outputs, SceneRun};

pub const EXPERIMENT: Experiment = Experiment {
    name: "table3",
    description: "rendering the test scenes per backend and accel",
    paper: "Table 3 (section 7)",
    csv: &[
        FILE,
        factors::FILE,
        BUILDS_FILE,
        BREAKDOWN_FILE,
        COHERENCE_FILE,
        LIGHT_SAMPLES_FILE,
        SKIPPED_FILE,
    ],
    plots: &[
        "table3_speedup",
        "table3_factors",
        "table3_breakdown",
        "table3_stage_efficiency",
        "table3_coherence",
        "table3_light_samples",
    ],
    status: Status::Ready {
        run,
        plot: plot::plots,
        report: report::report,
    },
};

pub(crate) const FILE: &str = "table3_scenes.csv";

/// The contract's columns, then rays per second, rays traced and the frame's size.
pub(crate) const HEADER: &[&str] = &[
    "scene", "backend", "lanes", "accel", "seconds", "speedup", "psnr_db", "mrays_s", "rays",
    "width", "height", "spp",
];

const BREAKDOWN_FILE: &str = "table3_breakdown.csv";

const BREAKDOWN_HEADER: &[&str] = &["scene", "backend", "stage", "seconds", "share"];

const COHERENCE_FILE: &str = "table3_coherence.csv";

const COHERENCE_HEADER: &[&str] = &[
    "scene",
    "backend",
    "lanes",
    "depth",
    "packets",
    "avg_active_lanes",
];

/// The BSP's frames of the scenes whose lights take random numbers (jittered area lights,
/// the environment) again with light samples shared per 4 x 4 tile ([`coherent::render::LightSamples::Tile`]), on
/// scalar and the hand-written backends.
const LIGHT_SAMPLES_FILE: &str = "table3_light_samples.csv";

const LIGHT_SAMPLES_HEADER: &[&str] = &[
    "scene",
    "backend",
    "lanes",
    "seconds",
    "speedup",
    "speedup_vs_pixel",
    "psnr_db",
    "psnr_vs_pixel_db",
];

/// Each accelerator's build per scene (the BSP with every preset, the default first): build
/// threads, seconds, bytes, the objects (instances, after the static ones are merged) and
/// triangles it was built over, the BSP's tree quality, and a frame on it at the widest
/// backend (seconds): build plus frame is the time to a first image.
const BUILDS_FILE: &str = "table3_builds.csv";

const BUILDS_HEADER: &[&str] = &[
    "scene",
    "accel",
    "preset",
    "threads",
    "build_s",
    "memory_bytes",
    "objects",
    "triangles",
    "nodes",
    "leaf_refs",
    "max_depth",
    "sah_cost",
    "frame_backend",
    "frame_s",
];

/// Scenes, accelerators and backends left out, and why.
const SKIPPED_FILE: &str = "table3_skipped.csv";

const SKIPPED_HEADER: &[&str] = &["item", "reason"];

/// The stages of the breakdown: the pipeline's own, then the film (sampling, accumulation,
/// scheduling: the frame's time outside the tracer) and tone mapping.
const STAGES: [&str; 7] = [
    "traversal",
    "shadows",
    "shading",
    "lights",
    "other",
    "film",
    "tonemap",
];

/// The backends the plots show, of those `present`: scalar and, at 4, 8 and 16 lanes, the
/// first present in [`Backend::preference`]'s order (sse, avx2, avx512 on x86-64; pulp4,
/// wide8, wide16 on aarch64).
fn plotted<S: AsRef<str>>(present: &[S]) -> Vec<&'static str> {
    let has = |b: &Backend| present.iter().any(|p| p.as_ref() == b.name());
    [1, 4, 8, 16]
        .into_iter()
        .filter_map(|n| {
            Backend::preference(n)
                .iter()
                .find(|b| has(b))
                .map(|b| b.name())
        })
        .collect()
}

/// The paper's Table 3.
pub(crate) const PAPER: PaperTable = PaperTable {
    caption: "Table 3: a 1024 x 768 frame, 1 CPU. Paper: Pentium III 933 MHz, its non-SSE vs \
              SSE renderer, its scenes (Car, SPDemo, Glass1, Room2); ours: scalar vs sse with \
              the BSP, 1 thread, our stand-ins of its scenes, on the machine of \
              `machine.json`. Seconds are not comparable (other machine, other scenes); the \
              speedups are.",
    key: "scene",
    columns: &["non-SSE s", "SSE s", "speedup"],
    rows: &[
        ("car", &[489.88, 82.11, 5.97]),
        ("spdemo", &[43.41, 2.63, 16.51]),
        ("glass1", &[52.66, 6.18, 8.52]),
        ("room2", &[35.12, 4.77, 7.36]),
    ],
};

/// Timed rounds per frame configuration (`seconds` is their median).
pub(crate) const ROUNDS: usize = 3;

/// The paper's SSE speedup for our stand-in `scene`, if the paper has the scene.
pub(crate) fn paper_speedup(scene: &str) -> Option<f64> {
    PAPER
        .rows
        .iter()
        .find(|(k, _)| *k == scene)
        .map(|(_, v)| v[2])
}

/// Speedup targets over scalar by lane count (`4 -> 4x`, `8 -> 6x`, `16 -> 8x`).
const TARGETS: &[(usize, f64)] = &[(4, 4.0), (8, 6.0), (16, 8.0)];

/// Every image within this PSNR of the scalar + BSP one.
const PSNR_TARGET: f64 = 40.0;

/// What the run renders: quick mode's small scenes and images, or the paper's frame.
pub fn plan(ctx: &Ctx) -> Plan {
    Plan {
        builtins: true,
        scenes_dir: frames::scenes_dir(),
        max_triangles: ctx.pick(20_000, usize::MAX),
        width: ctx.pick(160, 1024),
        height: ctx.pick(120, 768),
        spp: 1,
    }
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let (backends, mut skipped) = frames::backends();
    let (accels, s) = frames::accels();
    skipped.extend(s);
    let plan = plan(ctx);
    run_plan(ctx, &plan, &backends, &accels, skipped)
}

/// Runs the experiment over `plan` with these backends and accelerators (scalar and BSP
/// first: the references); `skipped` are the items already left out.
pub fn run_plan(
    ctx: &mut Ctx,
    plan: &Plan,
    backends: &[Backend],
    accels: &[AccelKind],
    mut skipped: Vec<(String, String)>,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        backends.first() == Some(&Backend::Scalar) && accels.first() == Some(&AccelKind::Bsp),
        "table3 needs scalar and bsp first (the references)"
    );
    for (item, why) in &skipped {
        ctx.note(format!("table3: {item} skipped: {why}"));
    }
    let pool = frames::pool(1)?;
    let mut out = Outputs::open(ctx)?;
    let specs = frames::scene_specs(plan);
    let bar = ctx.progress(specs.len() as u64, "table3");
    for (name, spec) in &specs {
        bar.set_message(name.clone());
        let scene = match frames::load(plan, spec) {
            Loaded::Scene(s) => s,
            Loaded::TooLarge { triangles } => {
                skipped.push((
                    format!("scene {name}"),
                    format!("{triangles} triangles: left out of --quick (full runs render it)"),
                ));
                bar.inc(1);
                continue;
            }
            Loaded::Failed(why) => {
                ctx.note(format!("table3: scene {name} skipped: {why}"));
                skipped.push((format!("scene {name}"), why));
                bar.inc(1);
                continue;
            }
        };
        let run = SceneRun {
            name,
            scene: &scene,
            plan,
            pool: &pool,
            backends,
        };
        run.measure(ctx, accels, &mut out, &mut skipped)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    out.finish()?;
    let mut csv = ctx.csv(SKIPPED_FILE, SKIPPED_HEADER)?;
    for (item, why) in &skipped {
        csv.row(&[item, why])?;
    }
    csv.finish()?;
    Ok(())
}

/// The row of `t` with these key cells.
pub(crate) fn find(t: &Table, keys: &[(&str, &str)]) -> anyhow::Result<Option<usize>> {
    'rows: for r in 0..t.rows.len() {
        for (c, v) in keys {
            if t.get(r, c)? != *v {
                continue 'rows;
            }
        }
        return Ok(Some(r));
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::report::{report, stage_speedups, stage_speedups_md};
    use super::*;

    /// A scene file that loads, and one whose mesh is missing.
    const GOOD: &str = r#"
resolution = [16, 12]
depth = 1

[camera]
position = [0.3, 1.1, 4]
look_at = [0, 1, 0]

[materials.red]
type = "phong"
diffuse = [0.7, 0.1, 0.1]

[materials.mirror]
type = "mirror"

[[objects]]
shape = "quad"
material = "red"
scale = [10, 1, 10]

[[objects]]
shape = "sphere"
material = "mirror"
translate = [0, 1, 0]

[[lights]]
type = "omni"
position = [0, 3, 0]
intensity = [10, 10, 10]
"#;

    #[test]
    fn renders_scene_files_and_lists_those_that_fail() {
        let dir = tempfile::tempdir().unwrap();
        let scenes = dir.path().join("scenes");
        std::fs::create_dir(&scenes).unwrap();
        std::fs::write(scenes.join("ball.toml"), GOOD).unwrap();
        // The same under a sky (an environment map: its lights take random numbers).
        exr::prelude::write_rgb_file(scenes.join("sky.exr"), 8, 4, |_, y| {
            (1.0f32, 0.9, 0.6 + 0.1 * y as f32)
        })
        .unwrap();
        let sky = GOOD.replace(
            "type = \"omni\"\nposition = [0, 3, 0]\nintensity = [10, 10, 10]",
            "type = \"environment\"\nfile = \"sky.exr\"\nsamples = 4",
        );
        assert_ne!(sky, GOOD);
        std::fs::write(scenes.join("sky.toml"), sky).unwrap();
        std::fs::write(
            scenes.join("broken.toml"),
            GOOD.replace("shape = \"quad\"", "mesh = \"missing-asset.obj\""),
        )
        .unwrap();
        let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let plan = Plan {
            builtins: false,
            scenes_dir: scenes,
            max_triangles: usize::MAX,
            width: 16,
            height: 12,
            spp: 1,
        };
        let simd = frames::widest();
        let mut backends = vec![Backend::Scalar];
        if simd != Backend::Scalar {
            backends.push(simd);
        }
        run_plan(&mut ctx, &plan, &backends, &[AccelKind::Bsp], Vec::new()).unwrap();
        let t = ctx.read_csv(FILE, HEADER).unwrap().unwrap();
        assert_eq!(t.rows.len(), 2 * backends.len());
        let r = find(&t, &[("scene", "ball"), ("backend", simd.name())])
            .unwrap()
            .unwrap();
        assert!(t.f64(r, "seconds").unwrap() > 0.0);
        assert!(
            t.f64(r, "psnr_db").unwrap() >= PSNR_TARGET,
            "{:?}",
            t.rows[r]
        );
        // The BSP's build with every preset, the default (the frames') first, per scene that
        // rendered.
        let builds = ctx.read_csv(BUILDS_FILE, BUILDS_HEADER).unwrap().unwrap();
        let presets: Vec<&str> = builds
            .rows_where("scene", "ball")
            .unwrap()
            .iter()
            .map(|&r| builds.get(r, "preset").unwrap())
            .collect();
        let default = coherent::bsp::BuildPreset::default();
        let mut expected = vec![default.name()];
        expected.extend(
            coherent::bsp::BuildPreset::ALL
                .iter()
                .filter(|&&p| p != default)
                .map(|p| p.name()),
        );
        assert_eq!(presets, expected);
        for r in builds.rows_where("scene", "ball").unwrap() {
            assert!(builds.f64(r, "sah_cost").unwrap() > 0.0);
            assert!(builds.f64(r, "frame_s").unwrap() > 0.0);
            assert_eq!(builds.get(r, "frame_backend").unwrap(), simd.name());
        }
        // The factor table starts with the exact scalar reference.
        let f = ctx
            .read_csv(factors::FILE, factors::HEADER)
            .unwrap()
            .unwrap();
        let r = find(&f, &[("scene", "ball")]).unwrap().unwrap();
        assert_eq!(f.get(r, "arithmetic").unwrap(), "exact");
        assert_eq!(f.f64(r, "speedup_vs_scalar").unwrap(), 1.0);
        let sk = ctx.read_csv(SKIPPED_FILE, SKIPPED_HEADER).unwrap().unwrap();
        assert_eq!(sk.rows.len(), 1);
        assert_eq!(sk.get(0, "item").unwrap(), "scene broken");
        assert!(sk.get(0, "reason").unwrap().contains("missing-asset.obj"));
        // Depth 0 is every packet of camera rays: full but for the frame's edge.
        let c = ctx
            .read_csv(COHERENCE_FILE, COHERENCE_HEADER)
            .unwrap()
            .unwrap();
        let r0 = find(&c, &[("scene", "ball"), ("lanes", "1"), ("depth", "0")])
            .unwrap()
            .unwrap();
        assert_eq!(c.f64(r0, "avg_active_lanes").unwrap(), 1.0);
        // The breakdown's shares add up to 1 per scene and backend.
        let b = ctx
            .read_csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)
            .unwrap()
            .unwrap();
        let total: f64 = b
            .rows_where("backend", "scalar")
            .unwrap()
            .iter()
            .filter(|&&r| b.get(r, "scene").unwrap() == "ball")
            .map(|&r| b.f64(r, "share").unwrap())
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        // Light samples shared per tile: the sky scene only (the omni light takes no
        // random numbers), every backend the same image, which is not the per-pixel one.
        let x = ctx
            .read_csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)
            .unwrap()
            .unwrap();
        assert_eq!(x.distinct("scene").unwrap(), vec!["sky".to_owned()]);
        assert_eq!(x.rows.len(), backends.len(), "{:?}", x.rows);
        for r in 0..x.rows.len() {
            assert!(x.f64(r, "seconds").unwrap() > 0.0);
            assert!(
                x.f64(r, "psnr_db").unwrap() >= PSNR_TARGET,
                "{:?}",
                x.rows[r]
            );
            assert!(
                x.f64(r, "psnr_vs_pixel_db").unwrap().is_finite(),
                "{:?}",
                x.rows[r]
            );
        }
        let md = report(&ctx).unwrap().unwrap();
        assert!(md.contains("table3_light_samples.csv"), "{md}");
        if simd != Backend::Scalar {
            assert!(md.contains("frame / lanes, %"), "{md}");
        }
        assert!(md.contains("images/table3_ball.png"), "{md}");
        // The image's use of the display, read back from the PNG: lit, not black.
        let line = md
            .lines()
            .find(|l| l.starts_with("| ball | 0."))
            .unwrap_or_else(|| panic!("no exposure row for ball: {md}"));
        let mean: f64 = line.split('|').nth(2).unwrap().trim().parse().unwrap();
        assert!(mean > 0.02, "{line}");
        assert!(md.contains("scene broken"), "{md}");
        assert!(ctx.path("images/table3_ball.png").is_file());
    }

    #[test]
    fn stage_speedups_divide_by_the_scalar_stage() {
        let row = |b: &str, stage: &str, s: f64| {
            vec![
                "x".into(),
                b.into(),
                stage.into(),
                s.to_string(),
                "0".into(),
            ]
        };
        let t = Table {
            file: "table3_breakdown.csv".into(),
            header: BREAKDOWN_HEADER.iter().map(|h| h.to_string()).collect(),
            rows: vec![
                row("scalar", "traversal", 4.0),
                row("scalar", "shading", 4.0),
                row("sse", "traversal", 2.0),
                row("sse", "shading", 1.0),
            ],
        };
        assert!(stage_speedups(&t, "x", "scalar").unwrap().is_none());
        assert!(
            stage_speedups(&t, "x", "no-such-backend")
                .unwrap()
                .is_none()
        );
        let x = stage_speedups(&t, "x", "sse").unwrap().unwrap();
        assert_eq!(x.stages[..3], [Some(2.0), None, Some(4.0)]);
        assert_eq!((x.frame, x.lanes), (8.0 / 3.0, 4));
        let md = stage_speedups_md(&t).unwrap();
        assert!(md.contains("| x | sse | 4 | 2.00 | — | 4.00 |"), "{md}");
        assert!(md.contains("| 2.67 | 67 |"), "{md}");
    }
}
