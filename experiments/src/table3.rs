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

use std::collections::BTreeMap;
use std::fmt::Display;

use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::bsp::BuildPreset;
use coherent::render::centres::psnr;
use coherent::render::{LightSamples, RenderStats, Renderer};
use coherent::simd::Backend;

use crate::builds::TreeQuality;
use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::factors;
use crate::frames::{self, Loaded, Plan};
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{PaperTable, Table, fmt_num, markdown_table};
use crate::targets::{Check, condensed};
use crate::timing::{median, speedup};

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
        plot: plots,
        report,
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
/// the environment) again with light samples shared per 4 x 4 tile ([`LightSamples::Tile`]), on
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
/// Each accelerator's build per scene (the BSP with both presets): build threads, seconds,
/// bytes, the objects (instances, after the static ones are merged) and triangles it was
/// built over, the BSP's tree quality, and a frame on it at the widest backend (seconds):
/// build plus frame is the time to a first image.
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
    let rounds = ROUNDS;
    let pool = frames::pool(1)?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut breakdown = ctx.csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)?;
    let mut coherence = ctx.csv(COHERENCE_FILE, COHERENCE_HEADER)?;
    let mut shared = ctx.csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)?;
    let mut factor_rows = ctx.csv(factors::FILE, factors::HEADER)?;
    let mut builds = ctx.csv(BUILDS_FILE, BUILDS_HEADER)?;
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
        let mut renderers = Vec::new();
        let mut build_secs = Vec::new();
        let mut fast = None;
        for &kind in accels {
            match frames::renderer_timed(&scene, kind) {
                Ok((r, build_s)) => {
                    if kind == AccelKind::Bsp {
                        // The other preset, for the builds table only (the frames use the
                        // default one, as `coherent render` does).
                        let mut params = AnyParams::of(kind);
                        params.bsp.object.build = BuildPreset::Fast;
                        let start = std::time::Instant::now();
                        let a = AnyAccel::build(&scene.accel_scene(), &params)?;
                        let fast_s = start.elapsed().as_secs_f64();
                        fast = Some((Renderer::new(&scene, a, scene.width, scene.height)?, fast_s));
                    }
                    build_secs.push(build_s);
                    renderers.push((kind, r));
                }
                Err(e) => {
                    let why = format!("{e:#}");
                    ctx.note(format!("table3: scene {name} with {kind} skipped: {why}"));
                    skipped.push((format!("scene {name} accel {kind}"), why));
                }
            }
        }
        if renderers.first().map(|(k, _)| *k) != Some(AccelKind::Bsp) {
            bar.inc(1);
            continue;
        }

        // Untimed frames: the images (PSNR against scalar + BSP) and the statistics.
        let mut reference: Option<Vec<[f32; 3]>> = None;
        let mut psnrs = BTreeMap::new();
        let mut stats: BTreeMap<(usize, Backend), RenderStats> = BTreeMap::new();
        for (a, (_, r)) in renderers.iter().enumerate() {
            for &b in backends {
                let (rendered, _) = frames::frame(&pool, b, r, plan)?;
                let image = rendered.displayed(Backend::Scalar)?;
                let db = match &reference {
                    None => {
                        let png = format!("images/table3_{name}.png");
                        std::fs::create_dir_all(ctx.path("images"))?;
                        rendered.write_png(&ctx.path(&png))?;
                        reference = Some(image);
                        f64::INFINITY
                    }
                    Some(reference) => psnr(&image, reference, 1.0),
                };
                psnrs.insert((a, b), db);
                stats.insert((a, b), rendered.stats);
            }
        }
        // Timed frames: rounds over every (accel, backend) pair in turn.
        let mut seconds: BTreeMap<(usize, Backend), Vec<f64>> = BTreeMap::new();
        for _ in 0..rounds {
            for (a, (_, r)) in renderers.iter().enumerate() {
                for &b in backends {
                    let (_, s) = frames::frame(&pool, b, r, plan)?;
                    seconds.entry((a, b)).or_default().push(s);
                }
            }
        }
        for (a, (kind, _)) in renderers.iter().enumerate() {
            let scalar = median(&seconds[&(a, Backend::Scalar)]);
            for &b in backends {
                let s = median(&seconds[&(a, b)]);
                let rays = stats[&(a, b)].total_rays();
                let cells: [&dyn Display; 12] = [
                    name,
                    &b.name(),
                    &b.lanes(),
                    kind,
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(scalar, s)),
                    &format!("{:.2}", psnrs[&(a, b)]),
                    &format!("{:.3}", rays as f64 / s * 1e-6),
                    &rays,
                    &plan.width,
                    &plan.height,
                    &plan.spp,
                ];
                csv.row(&cells)?;
            }
        }
        // The builds, each with the time of a frame on its tree at the widest backend:
        // every structure's frames in rounds, the fast preset's tree among them.
        let widest = Some(frames::widest())
            .filter(|b| backends.contains(b))
            .unwrap_or(Backend::Scalar);
        let mut built: Vec<(&Renderer<'_, AnyAccel>, f64)> = renderers
            .iter()
            .zip(&build_secs)
            .map(|((_, r), &s)| (r, s))
            .collect();
        if let Some((r, s)) = &fast {
            built.push((r, *s));
        }
        let mut frame_secs = vec![Vec::with_capacity(rounds); built.len()];
        for _ in 0..rounds {
            for (i, (r, _)) in built.iter().enumerate() {
                frame_secs[i].push(frames::frame(&pool, widest, r, plan)?.1);
            }
        }
        for ((r, build_s), secs) in built.iter().zip(&frame_secs) {
            build_row(
                &mut builds,
                name,
                &scene,
                r.accel(),
                *build_s,
                (widest, median(secs)),
            )?;
        }
        drop(built);

        // Table 3 explained: arithmetic, culling, lanes and beams, each alone.
        factors::measure(
            &mut factor_rows,
            &pool,
            name,
            &mut renderers,
            backends,
            plan,
            reference.as_ref().expect("the scalar + BSP image"),
        )?;
        // Coherence by depth, once per packet width (the BSP's frames).
        let mut widths = Vec::new();
        for &b in backends {
            if widths.contains(&b.lanes()) {
                continue;
            }
            widths.push(b.lanes());
            for (d, c) in stats[&(0, b)].depth.iter().enumerate() {
                coherence.row(&[
                    name,
                    &b.name(),
                    &b.lanes(),
                    &d,
                    &c.packets,
                    &format!("{:.4}", c.average()),
                ])?;
            }
        }
        // Where the time goes: one frame per backend with the stage clocks on (BSP).
        let (_, r) = &mut renderers[0];
        r.time_stages = true;
        for &b in backends {
            let (rendered, frame_s) = frames::frame(&pool, b, r, plan)?;
            let t = std::time::Instant::now();
            std::hint::black_box(rendered.tone_mapped(b)?);
            let tonemap_s = t.elapsed().as_secs_f64();
            let st = &rendered.stats;
            // The stage clocks' own cost (per lap) is out of the stages, and out of the film's
            // remainder too.
            let mut secs = st.stage_seconds().to_vec();
            let traced: f64 = secs.iter().sum();
            secs.push((frame_s - traced - st.clock_seconds()).max(0.0));
            secs.push(tonemap_s);
            let total: f64 = secs.iter().sum();
            for (stage, s) in STAGES.iter().zip(&secs) {
                breakdown.row(&[
                    name,
                    &b.name(),
                    stage,
                    &format!("{s:.6e}"),
                    &format!("{:.4}", s / total),
                ])?;
            }
        }
        r.time_stages = false;

        // Light samples shared per tile: the same protocol on the BSP, for scenes with lights
        // that take random numbers (jittered area lights, the environment).
        let random_lights = scene.lights.iter().any(|x| x.takes_random_numbers());
        if random_lights {
            // The hand-written backends only (the plot's), to keep the run's length.
            let names: Vec<&str> = backends.iter().map(|b| b.name()).collect();
            let shown = plotted(&names);
            let backends: Vec<Backend> = backends
                .iter()
                .copied()
                .filter(|b| shown.contains(&b.name()))
                .collect();
            let backends = &backends[..];
            r.light_samples = LightSamples::Tile;
            let reference = reference.as_ref().expect("the scalar + BSP image");
            let mut images = BTreeMap::new();
            let mut tiled: Option<Vec<[f32; 3]>> = None;
            for &b in backends {
                let (rendered, _) = frames::frame(&pool, b, r, plan)?;
                let image = rendered.displayed(Backend::Scalar)?;
                let db = match &tiled {
                    None => f64::INFINITY,
                    Some(t) => psnr(&image, t, 1.0),
                };
                images.insert(b, (db, psnr(&image, reference, 1.0)));
                if tiled.is_none() {
                    tiled = Some(image);
                }
            }
            let mut secs: BTreeMap<Backend, Vec<f64>> = BTreeMap::new();
            for _ in 0..rounds {
                for &b in backends {
                    let (_, s) = frames::frame(&pool, b, r, plan)?;
                    secs.entry(b).or_default().push(s);
                }
            }
            r.light_samples = LightSamples::Pixel;
            let scalar = median(&secs[&Backend::Scalar]);
            for &b in backends {
                let s = median(&secs[&b]);
                let pixel = median(&seconds[&(0, b)]);
                let (db, vs_pixel) = images[&b];
                shared.row(&[
                    name,
                    &b.name(),
                    &b.lanes(),
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(scalar, s)),
                    &format!("{:.3}", speedup(pixel, s)),
                    &format!("{db:.2}"),
                    &format!("{vs_pixel:.2}"),
                ])?;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    breakdown.finish()?;
    coherence.finish()?;
    shared.finish()?;
    factor_rows.finish()?;
    builds.finish()?;
    let mut out = ctx.csv(SKIPPED_FILE, SKIPPED_HEADER)?;
    for (item, why) in &skipped {
        out.row(&[item, why])?;
    }
    out.finish()?;
    Ok(())
}

/// A row of the builds table: the accelerator `a` of `scene`, built in `seconds`, with the
/// median seconds of a frame on it at a backend; for the BSP, its object trees' preset and
/// tree quality ([`TreeQuality`]).
fn build_row(
    out: &mut crate::table::CsvOut,
    name: &str,
    scene: &coherent::scene::RenderScene,
    a: &AnyAccel,
    seconds: f64,
    (backend, frame_s): (Backend, f64),
) -> anyhow::Result<()> {
    let (preset, threads, quality) = match a {
        AnyAccel::Bsp(b) => {
            let q = TreeQuality::of(b);
            let cells = [
                q.nodes.to_string(),
                q.leaf_refs.to_string(),
                q.max_depth.to_string(),
                format!("{:.4}", q.sah_cost),
            ];
            (q.preset, rayon::current_num_threads(), cells)
        }
        // Embree as the renderer asks for it (one build thread); obvhs builds on one.
        _ => ("default", 1, Default::default()),
    };
    let [nodes, refs, depth, sah] = &quality;
    out.row(&[
        &name,
        &a.kind(),
        &preset,
        &threads,
        &format!("{seconds:.6e}"),
        &a.memory_bytes(),
        &scene.instances.len(),
        &scene.triangles(),
        nodes,
        refs,
        depth,
        sah,
        &backend.name(),
        &format!("{frame_s:.6e}"),
    ])
}

/// The built-in scene of many objects, whose targets compare the BSP with Embree per width.
const MANY_OBJECTS: &str = "city";

/// The report's builds section: per scene, each build's seconds and the time to a first
/// image (build plus one frame at the widest backend), the presets' SAH costs, and the
/// many-object scene's targets against Embree.
fn builds_md(b: &Table, frames: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nBuilds and the time to a first image (`table3_builds.csv`): each structure built \
         over the scene's objects once the static instances are merged per transform (as \
         `coherent render` does unless told `--no-merge`), then one frame on it at the widest \
         backend, one thread (median of the rounds). The BSP builds on every core with both \
         presets (the frames above use `exact`), Embree on one thread, as the renderer asks. \
         SAH: each BSP object tree's cost relative to its root box, summed.\n\n",
    );
    let mut rows = Vec::new();
    let mut fast_wins = (0, 0);
    let mut checks = Vec::new();
    for scene in b.distinct("scene")? {
        let get = |accel: &str, preset: &str| -> anyhow::Result<Option<(f64, f64, f64)>> {
            Ok(
                match find(
                    b,
                    &[("scene", &scene), ("accel", accel), ("preset", preset)],
                )? {
                    Some(r) => Some((
                        b.f64(r, "build_s")?,
                        b.f64(r, "frame_s")?,
                        b.f64(r, "sah_cost").unwrap_or(f64::NAN),
                    )),
                    None => None,
                },
            )
        };
        let (exact, fast, embree) = (
            get("bsp", "exact")?,
            get("bsp", "fast")?,
            get("embree", "default")?,
        );
        let r0 = b.rows_where("scene", &scene)?[0];
        let both = |v: Option<(f64, f64, f64)>| {
            v.map_or("—".to_owned(), |(bs, fs, _)| {
                format!("{} + {} s", fmt_num(bs), fmt_num(fs))
            })
        };
        if let (Some(x), Some(f)) = (exact, fast) {
            fast_wins.1 += 1;
            if f.0 + f.1 < x.0 + x.1 {
                fast_wins.0 += 1;
            }
        }
        rows.push(vec![
            scene.clone(),
            b.get(r0, "objects")?.to_owned(),
            b.get(r0, "triangles")?.to_owned(),
            both(exact),
            both(fast),
            both(embree),
            match (exact, fast) {
                (Some(x), Some(f)) if x.2 > 0.0 => format!("{:+.1} %", 100.0 * (f.2 / x.2 - 1.0)),
                _ => "—".to_owned(),
            },
        ]);
        if scene == MANY_OBJECTS {
            if let (Some(x), Some(e)) = (exact, embree) {
                checks.push(Check::at_most(
                    &scene,
                    "bsp build <= 1.5x embree's",
                    format!("{:.2}x", x.0 / e.0),
                    x.0 / e.0,
                    1.5,
                ));
            }
            for r in frames.rows_where("scene", &scene)? {
                if frames.get(r, "accel")? != "bsp" {
                    continue;
                }
                let backend = frames.get(r, "backend")?;
                if let Some(e) = find(
                    frames,
                    &[("scene", &scene), ("backend", backend), ("accel", "embree")],
                )? {
                    let (bs, es) = (frames.f64(r, "seconds")?, frames.f64(e, "seconds")?);
                    checks.push(Check::at_most(
                        &scene,
                        "bsp frame <= embree's, every backend",
                        format!("{backend} {:.2}x", bs / es),
                        bs / es,
                        1.0,
                    ));
                }
            }
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "objects",
            "triangles",
            "bsp exact: build + frame",
            "bsp fast: build + frame",
            "embree: build + frame",
            "SAH fast vs exact",
        ],
        &rows,
    ));
    md.push_str(&format!(
        "\nThe fast preset gives the shorter time to a first image on {} of {} scenes.\n",
        fast_wins.0, fast_wins.1
    ));
    if !checks.is_empty() {
        md.push_str("\nThe many-object scene against Embree:\n\n");
        md.push_str(&condensed("scene", &checks));
    }
    Ok(md)
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

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    factors::plot(ctx)?;
    if let Some(t) = ctx.read_csv(FILE, HEADER)?
        && !t.rows.is_empty()
    {
        let scenes = t.distinct("scene")?;
        let mut series = Vec::new();
        for b in t.distinct("backend")? {
            let mut v = Vec::new();
            for s in &scenes {
                v.push(
                    match find(&t, &[("scene", s), ("backend", &b), ("accel", "bsp")])? {
                        Some(r) => t.f64(r, "speedup")?,
                        None => f64::NAN,
                    },
                );
            }
            series.push((b, v));
        }
        series.push((
            "paper SSE".to_owned(),
            scenes
                .iter()
                .map(|s| paper_speedup(s).unwrap_or(f64::NAN))
                .collect(),
        ));
        ctx.bar_chart(
            "table3_speedup",
            &BarChart {
                title: "Table 3: whole-frame speedup over scalar (BSP, 1 thread)".into(),
                y_label: "speedup over scalar".into(),
                categories: scenes,
                series,
            },
        )?;
    }
    if let Some(t) = ctx.read_csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)?
        && !t.rows.is_empty()
    {
        // Speedup over scalar with per-pixel samples (from the main table) beside the same
        // with shared ones, per scene, for the hand-written backends.
        let main = ctx.read_csv(FILE, HEADER)?;
        let scenes = t.distinct("scene")?;
        let mut series = Vec::new();
        let present = t.distinct("backend")?;
        let shown = plotted(&present);
        for b in present {
            if b == "scalar" || !shown.contains(&b.as_str()) {
                continue;
            }
            let (mut pixel, mut tile) = (Vec::new(), Vec::new());
            for s in &scenes {
                tile.push(match find(&t, &[("scene", s), ("backend", &b)])? {
                    Some(r) => t.f64(r, "speedup")?,
                    None => f64::NAN,
                });
                pixel.push(match &main {
                    Some(m) => match find(m, &[("scene", s), ("backend", &b), ("accel", "bsp")])? {
                        Some(r) => m.f64(r, "speedup")?,
                        None => f64::NAN,
                    },
                    None => f64::NAN,
                });
            }
            series.push((format!("{b} pixel"), pixel));
            series.push((format!("{b} tile"), tile));
        }
        // Nothing to plot when scalar is the only backend (a build without SIMD backends).
        if !series.is_empty() {
            ctx.bar_chart(
                "table3_light_samples",
                &BarChart {
                    title:
                        "Light samples per pixel or shared per 4x4 tile: speedup over scalar (BSP)"
                            .into(),
                    y_label: "speedup over scalar".into(),
                    categories: scenes,
                    series,
                },
            )?;
        }
    }
    if let Some(t) = ctx.read_csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)?
        && !t.rows.is_empty()
    {
        let mut categories = Vec::new();
        let shown = plotted(&t.distinct("backend")?);
        for s in t.distinct("scene")? {
            for b in t.distinct("backend")? {
                // The plot keeps the native backends (the table has them all).
                if shown.contains(&b.as_str())
                    && find(&t, &[("scene", &s), ("backend", &b)])?.is_some()
                {
                    categories.push((s.clone(), b));
                }
            }
        }
        let mut series = Vec::new();
        for stage in STAGES {
            let mut v = Vec::new();
            for (s, b) in &categories {
                v.push(
                    match find(&t, &[("scene", s), ("backend", b), ("stage", stage)])? {
                        Some(r) => 100.0 * t.f64(r, "share")?,
                        None => f64::NAN,
                    },
                );
            }
            series.push((stage.to_owned(), v));
        }
        ctx.stacked_bar_chart(
            "table3_breakdown",
            &BarChart {
                title: "Where the time goes (BSP, 1 thread)".into(),
                y_label: "% of frame time".into(),
                categories: categories.iter().map(|(s, b)| format!("{s} {b}")).collect(),
                series,
            },
        )?;
        // Each stage's speedup over scalar per lane, median over the scenes, for the
        // hand-written backends: 1 is the full width.
        let scenes = t.distinct("scene")?;
        let mut categories: Vec<String> = STAGES.iter().map(|s| s.to_string()).collect();
        categories.push("frame".into());
        let mut series = Vec::new();
        for be in shown {
            let mut per_stage = vec![Vec::new(); categories.len()];
            for s in &scenes {
                if let Some(StageSpeedups {
                    stages,
                    frame,
                    lanes,
                }) = stage_speedups(&t, s, be)?
                {
                    for (i, x) in stages.iter().enumerate() {
                        if let Some(x) = x {
                            per_stage[i].push(x / lanes as f64);
                        }
                    }
                    per_stage[STAGES.len()].push(frame / lanes as f64);
                }
            }
            if per_stage.iter().any(|v| !v.is_empty()) {
                let v = per_stage.iter().map(|v| median(v)).collect();
                series.push((be.to_owned(), v));
            }
        }
        if !series.is_empty() {
            ctx.bar_chart(
                "table3_stage_efficiency",
                &BarChart {
                    title: "Each stage's speedup over scalar per lane (BSP, median over scenes; 1 = the full width)".into(),
                    y_label: "speedup / lanes".into(),
                    categories,
                    series,
                },
            )?;
        }
    }
    if let Some(t) = ctx.read_csv(COHERENCE_FILE, COHERENCE_HEADER)?
        && !t.rows.is_empty()
    {
        let mut series = Vec::new();
        for s in t.distinct("scene")? {
            for lanes in t.distinct("lanes")? {
                if lanes == "1" {
                    continue;
                }
                let mut pts = Vec::new();
                for r in t.rows_where("scene", &s)? {
                    if t.get(r, "lanes")? == lanes {
                        pts.push((
                            t.f64(r, "depth")?,
                            t.f64(r, "avg_active_lanes")? / t.f64(r, "lanes")?,
                        ));
                    }
                }
                if !pts.is_empty() {
                    series.push(Series::new(format!("{s} ({lanes} lanes)"), pts));
                }
            }
        }
        if !series.is_empty() {
            ctx.line_chart(
                "table3_coherence",
                &LineChart {
                    title: "Active lanes per packet by ray depth (fraction of the width)".into(),
                    x_label: "ray depth (0 = camera rays)".into(),
                    y_label: "active lanes / lanes".into(),
                    series,
                    log2_x: false,
                },
            )?;
        }
    }
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut md = String::new();
    let size = if t.rows.is_empty() {
        "no scene rendered".to_owned()
    } else {
        format!(
            "{} x {} pixels, {} sample(s) per pixel",
            t.get(0, "width")?,
            t.get(0, "height")?,
            t.get(0, "spp")?
        )
    };
    md.push_str(&format!(
        "Whole frames ({size}) through the progressive film, as `coherent render --spp N \
         --threads 1` renders them, 1 thread; every (accel, backend) pair renders once \
         untimed, then 3 rounds visit every pair in turn and `seconds` is the median. \
         `speedup` = the scalar row's seconds (same scene, same accel) / this row's; \
         `psnr_db` compares the image as displayed (tone-mapped, each channel clipped to [0, 1] \
         as the PNG encodes it) with the scalar + BSP one (peak 1). Quick \
         mode renders only the scenes up to 20,000 triangles, at 160 x 120.\n\n"
    ));
    let mut ours = Vec::new();
    for s in t.distinct("scene")? {
        let get = |b: &str, c: &str| -> anyhow::Result<Option<f64>> {
            Ok(
                match find(&t, &[("scene", &s), ("backend", b), ("accel", "bsp")])? {
                    Some(r) => Some(t.f64(r, c)?),
                    None => None,
                },
            )
        };
        ours.push((
            s.clone(),
            vec![
                get("scalar", "seconds")?,
                get("sse", "seconds")?,
                get("sse", "speedup")?,
            ],
        ));
    }
    md.push_str(&PAPER.beside(&ours));

    md.push_str(
        "\nEvery backend and accelerator: seconds (speedup over scalar with the same \
         accelerator; PSNR in dB against scalar + BSP).\n\n",
    );
    let backends = t.distinct("backend")?;
    let mut header = vec!["scene".to_owned(), "accel".to_owned()];
    header.extend(backends.iter().cloned());
    let mut rows = Vec::new();
    for s in t.distinct("scene")? {
        for a in t.distinct("accel")? {
            let mut row = vec![s.clone(), a.clone()];
            let mut any = false;
            for b in &backends {
                row.push(
                    match find(&t, &[("scene", &s), ("backend", b), ("accel", &a)])? {
                        Some(r) => {
                            any = true;
                            format!(
                                "{} s ({}x, {} dB)",
                                fmt_num(t.f64(r, "seconds")?),
                                fmt_num(t.f64(r, "speedup")?),
                                fmt_num(t.f64(r, "psnr_db")?)
                            )
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&h, &rows));

    md.push_str(&targets(&t)?);
    if let Some(p) = ctx.plot_markdown("table3_speedup", "whole-frame speedup per scene") {
        md.push_str(&p);
    }
    if let Some(f) = factors::report(ctx)? {
        md.push_str(&f);
    }
    if let Some(b) = ctx.read_csv(BUILDS_FILE, BUILDS_HEADER)?
        && !b.rows.is_empty()
    {
        md.push_str(&builds_md(&b, &t)?);
    }

    let scenes = t.distinct("scene")?;
    let images: Vec<String> = scenes
        .iter()
        .filter(|s| ctx.path(&format!("images/table3_{s}.png")).is_file())
        .map(|s| format!("![{s}](images/table3_{s}.png)"))
        .collect();
    if !images.is_empty() {
        md.push_str("\nThe scalar + BSP images:\n\n");
        md.push_str(&images.join("\n"));
        md.push('\n');
    }
    if let Some(sk) = ctx.read_csv(SKIPPED_FILE, SKIPPED_HEADER)?
        && !sk.rows.is_empty()
    {
        md.push_str("\nLeft out of this run:\n\n");
        md.push_str(&sk.to_markdown());
    }
    if let Some(b) = ctx.read_csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)? {
        md.push_str(&breakdown_md(ctx, &b)?);
    }
    if let Some(c) = ctx.read_csv(COHERENCE_FILE, COHERENCE_HEADER)? {
        md.push_str(&coherence_md(ctx, &c)?);
    }
    if let Some(x) = ctx.read_csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)?
        && !x.rows.is_empty()
    {
        md.push_str(&light_samples_md(ctx, &x)?);
    }
    Ok(Some(md))
}

fn light_samples_md(ctx: &Ctx, x: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nLight samples shared per 4 x 4 pixel tile (`table3_light_samples.csv`, `coherent \
         render --light-samples tile`): the scenes whose lights take random numbers (jittered \
         area lights, the environment) rendered again with the BSP, every sample of a tile using \
         the same light sample points and environment directions, as the paper's surface \
         lights use one fixed set of points; the shadow packets of an environment light then \
         run parallel. Same protocol as above, on scalar and the hand-written backends. `speedup` = over scalar with shared samples; \
         `vs pixel` = the same backend's per-pixel frame (the table above) / this one; \
         `psnr_db` against scalar with shared samples (every backend must give that image); \
         `vs pixel dB` against the scalar per-pixel image (the two differ in their noise \
         only: each pixel's estimate is unbiased either way, but a tile's noise is \
         correlated).\n\n",
    );
    let mut rows = Vec::new();
    for s in x.distinct("scene")? {
        for b in x.distinct("backend")? {
            if let Some(r) = find(x, &[("scene", &s), ("backend", &b)])? {
                rows.push(vec![
                    s.clone(),
                    b.clone(),
                    fmt_num(x.f64(r, "seconds")?),
                    fmt_num(x.f64(r, "speedup")?),
                    fmt_num(x.f64(r, "speedup_vs_pixel")?),
                    fmt_num(x.f64(r, "psnr_db")?),
                    fmt_num(x.f64(r, "psnr_vs_pixel_db")?),
                ]);
            }
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "backend",
            "seconds",
            "speedup",
            "vs pixel",
            "psnr_db",
            "vs pixel dB",
        ],
        &rows,
    ));
    if let Some(p) = ctx.plot_markdown(
        "table3_light_samples",
        "speedup over scalar, light samples per pixel and per tile",
    ) {
        md.push_str(&p);
    }
    Ok(md)
}

/// The targets: speedup over scalar per lane count (BSP), PSNR, BSP no slower than Embree;
/// one row per scene and kind of target (see [`crate::targets`]).
fn targets(t: &Table) -> anyhow::Result<String> {
    const SPEEDUP: &str = "speedup over scalar, bsp";
    const EMBREE: &str = "bsp seconds <= embree's, same backend";
    let mut checks = Vec::new();
    for r in 0..t.rows.len() {
        let lanes = t.f64(r, "lanes")? as usize;
        let (scene, backend, accel) =
            (t.get(r, "scene")?, t.get(r, "backend")?, t.get(r, "accel")?);
        if accel == "bsp"
            && let Some((_, target)) = TARGETS.iter().find(|(l, _)| *l == lanes)
        {
            let s = t.f64(r, "speedup")?;
            checks.push(Check::at_least(
                scene,
                SPEEDUP,
                format!("{backend} {}x (>= {}x)", fmt_num(s), fmt_num(*target)),
                s,
                *target,
            ));
        }
        if accel == "embree"
            && let Some(b) = find(
                t,
                &[("scene", scene), ("backend", backend), ("accel", "bsp")],
            )?
        {
            let (bsp, embree) = (t.f64(b, "seconds")?, t.f64(r, "seconds")?);
            checks.push(Check::at_most(
                scene,
                EMBREE,
                format!("{backend} {} s vs {} s", fmt_num(bsp), fmt_num(embree)),
                bsp,
                embree,
            ));
        }
    }
    for s in t.distinct("scene")? {
        let mut worst = f64::INFINITY;
        let mut which = String::new();
        for r in t.rows_where("scene", &s)? {
            let db = t.f64(r, "psnr_db")?;
            if db < worst {
                worst = db;
                which = format!("{} + {}", t.get(r, "backend")?, t.get(r, "accel")?);
            }
        }
        checks.push(Check::at_least(
            &s,
            &format!("PSNR >= {PSNR_TARGET} dB, every backend and accel"),
            format!("lowest {} dB ({which})", fmt_num(worst)),
            worst,
            PSNR_TARGET,
        ));
    }
    let mut md = String::from(
        "\nTargets (sse >= 4x, 8 lanes >= 6x, 16 lanes >= 8x over scalar; PSNR >= 40 dB; BSP \
         frame time <= Embree's at the same width), one row per scene and kind of target: how \
         many of its checks (one per backend) are met, and the figure closest to its target \
         (the nearest miss, or the narrowest pass when all are met); every figure is in the \
         table above:\n\n",
    );
    md.push_str(&condensed("scene", &checks));
    Ok(md)
}

fn breakdown_md(ctx: &Ctx, b: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nWhere the time goes (`table3_breakdown.csv`): one more frame per backend with the \
         BSP and the renderer's stage clocks on. They read the clock several times per packet, \
         which makes these frames slower than the timed ones above; each stage's time has that \
         cost taken out (an empty lap of the clock, measured on this machine, per lap), and so \
         has the film's. `traversal` = first-hit \
         queries of camera, reflection and refraction packets; `shadows` = occlusion queries; \
         `shading` = material passes (textures and tabulated BDFs included); `lights` = light \
         sampling and shadow-ray set-up; `other` = camera rays, the hit-to-surface gather and \
         secondary-ray set-up; `film` = the frame's time outside the tracer (Halton sampling, \
         accumulation, scheduling); `tonemap` = tone mapping the frame. Share of the total, \
         %:\n\n",
    );
    let mut rows = Vec::new();
    for s in b.distinct("scene")? {
        for be in b.distinct("backend")? {
            let mut row = vec![s.clone(), be.clone()];
            let mut any = false;
            for stage in STAGES {
                row.push(
                    match find(b, &[("scene", &s), ("backend", &be), ("stage", stage)])? {
                        Some(r) => {
                            any = true;
                            format!("{:.1}", 100.0 * b.f64(r, "share")?)
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let mut header = vec!["scene", "backend"];
    header.extend(STAGES);
    md.push_str(&markdown_table(&header, &rows));
    if let Some(p) = ctx.plot_markdown("table3_breakdown", "share of frame time per stage") {
        md.push_str(&p);
    }
    md.push_str(&stage_speedups_md(b)?);
    if let Some(p) = ctx.plot_markdown(
        "table3_stage_efficiency",
        "each stage's speedup over scalar per lane",
    ) {
        md.push_str(&p);
    }
    Ok(md)
}

/// Seconds per stage of one scene and backend in the breakdown, in [`STAGES`] order (`None`
/// where a stage has no row), and their sum.
fn stage_seconds(b: &Table, scene: &str, backend: &str) -> anyhow::Result<([Option<f64>; 7], f64)> {
    let mut out = [None; 7];
    let mut total = 0.0;
    for (i, stage) in STAGES.iter().enumerate() {
        if let Some(r) = find(
            b,
            &[("scene", scene), ("backend", backend), ("stage", stage)],
        )? {
            let s = b.f64(r, "seconds")?;
            out[i] = Some(s);
            total += s;
        }
    }
    Ok((out, total))
}

/// One scene and backend of the breakdown against the scalar backend.
#[derive(Debug, PartialEq)]
struct StageSpeedups {
    /// Each stage's speedup over the scalar backend's same stage, in [`STAGES`] order.
    stages: [Option<f64>; 7],
    /// The whole breakdown frame's speedup.
    frame: f64,
    lanes: usize,
}

/// Per scene and backend: each stage's speedup over the scalar backend's same stage (the
/// breakdown frames) and the whole breakdown frame's. `None` for the scalar rows and for
/// backends whose name is unknown.
fn stage_speedups(b: &Table, scene: &str, backend: &str) -> anyhow::Result<Option<StageSpeedups>> {
    let Ok(be) = backend.parse::<Backend>() else {
        return Ok(None);
    };
    if be.lanes() == 1 {
        return Ok(None);
    }
    let (base, base_total) = stage_seconds(b, scene, "scalar")?;
    let (this, total) = stage_seconds(b, scene, backend)?;
    if base_total <= 0.0 || total <= 0.0 {
        return Ok(None);
    }
    let mut out = [None; 7];
    for i in 0..STAGES.len() {
        if let (Some(a), Some(t)) = (base[i], this[i])
            && t > 0.0
        {
            out[i] = Some(a / t);
        }
    }
    Ok(Some(StageSpeedups {
        stages: out,
        frame: base_total / total,
        lanes: be.lanes(),
    }))
}

fn stage_speedups_md(b: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nEach stage's speedup over the scalar backend's same stage (the frames above), and \
         the whole frame's as a share of the lane count. A packet of N lanes that does the \
         work of its N rays with one instruction stream gains at most N times over them one \
         at a time, unless it does less work than its rays alone: a frame gains N times only \
         if every stage does. The stages below the lane count are where \
         a frame's speedup is lost:\n\n",
    );
    let mut rows = Vec::new();
    for s in b.distinct("scene")? {
        for be in b.distinct("backend")? {
            let Some(StageSpeedups {
                stages,
                frame,
                lanes,
            }) = stage_speedups(b, &s, &be)?
            else {
                continue;
            };
            let mut row = vec![s.clone(), be.clone(), lanes.to_string()];
            row.extend(
                stages
                    .iter()
                    .map(|x| x.map_or_else(|| "—".into(), |v| format!("{v:.2}"))),
            );
            row.push(format!("{frame:.2}"));
            row.push(format!("{:.0}", 100.0 * frame / lanes as f64));
            rows.push(row);
        }
    }
    if rows.is_empty() {
        return Ok(String::new());
    }
    let mut header = vec!["scene", "backend", "lanes"];
    header.extend(STAGES);
    header.extend(["frame", "frame / lanes, %"]);
    md.push_str(&markdown_table(&header, &rows));
    Ok(md)
}

fn coherence_md(ctx: &Ctx, c: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nCoherence by ray depth (`table3_coherence.csv`): average active lanes per traced \
         packet (camera rays at depth 0, then reflection and refraction packets; shadow packets \
         are not counted here), per packet width. Secondary packets keep their parent's lanes, \
         so a lane that missed, or whose surface neither reflects nor refracts, stays empty \
         below it (the `regroup` experiment compacts them across packets and measures \
         whether that pays):\n\n",
    );
    let depths = c.distinct("depth")?;
    let mut header = vec!["scene".to_owned(), "lanes".to_owned()];
    header.extend(depths.iter().map(|d| format!("depth {d}")));
    let mut rows = Vec::new();
    for s in c.distinct("scene")? {
        for lanes in c.distinct("lanes")? {
            let mut row = vec![s.clone(), lanes.clone()];
            let mut any = false;
            for d in &depths {
                row.push(
                    match find(c, &[("scene", &s), ("lanes", &lanes), ("depth", d)])? {
                        Some(r) => {
                            any = true;
                            format!(
                                "{} ({} packets)",
                                fmt_num(c.f64(r, "avg_active_lanes")?),
                                c.get(r, "packets")?
                            )
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&h, &rows));
    if let Some(p) = ctx.plot_markdown("table3_coherence", "active lanes per packet by depth") {
        md.push_str(&p);
    }
    Ok(md)
}

#[cfg(test)]
mod tests {
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
        // The BSP's build with both presets, per scene that rendered.
        let builds = ctx.read_csv(BUILDS_FILE, BUILDS_HEADER).unwrap().unwrap();
        let presets: Vec<&str> = builds
            .rows_where("scene", "ball")
            .unwrap()
            .iter()
            .map(|&r| builds.get(r, "preset").unwrap())
            .collect();
        assert_eq!(presets, ["exact", "fast"]);
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
