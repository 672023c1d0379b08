//! Experiment `accel`: the paper's two-level BSP (section 3) against Embree 4 and obvhs,
//! across the same traversal interface: Mrays/s per scene, ray kind and packet width, build
//! time and memory.
//!
//! Protocol: each scene (the built-in ones, then the real meshes `scripts/native.py` fetched)
//! is built once per accelerator (one build thread; Embree's build quality `high` for meshes,
//! `low` for the top level; obvhs' CWBVH with its `medium` preset for meshes, `fast` for the
//! top level; the BSP's default parameters). Rays: primary rays of a `W x H` view in
//! packet-shaped tiles, shadow rays from the primary hits to the scene's light (occlusion),
//! diffuse rays from the primary hits over the cosine hemisphere; the secondary rays come from
//! the BSP's hits, so every accelerator traces the same rays. Widths: 1 (single-ray calls)
//! and 4, 8, 16 through a lane backend of that width (sse; pulp8 or wide8; pulp16 or wide16:
//! the first usable). Embree receives packets of the same width (`rtcIntersect4/8/16`, with
//! the COHERENT flag for primary and shadow rays, without it for diffuse rays); obvhs
//! traverses single rays only, so it has width 1 rows only. One sample is one pass over the
//! rays; samples of every (accelerator, width) are interleaved round-robin and each row
//! reports the median sample, single-threaded.

use std::collections::BTreeMap;

use coherent::mesh_file::REAL_MESHES;
use coherent::simd::Backend;
use coherent_accel::scenes::{self, BuiltinScene, SceneSize};
use coherent_accel::workload::{self, Clock, PassResult, RayKind, TimePackets};
use coherent_accel::{Accel, Ray1};
use coherent_bsp::{Bsp, BspParams};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::plot::BarChart;
use crate::table::{fmt_num, markdown_table};

pub const EXPERIMENT: Experiment = Experiment {
    name: "accel",
    description: "traversal speed, build time and memory per accel, ray kind and packet width",
    paper: "section 3 (two-level BSP), against Embree 4 and obvhs",
    csv: &["accel.csv"],
    plots: &[
        "accel_primary",
        "accel_shadow",
        "accel_diffuse",
        "accel_build",
        "accel_memory",
    ],
    status: Status::Ready { run, report },
};

const HEADER: &[&str] = &[
    "scene",
    "accel",
    "rays",
    "width",
    "mrays_per_s",
    "build_ms",
    "memory_bytes",
];

/// The packet widths measured, with the backends that give them, in order of preference.
const WIDTHS: [(usize, &[Backend]); 3] = [
    (4, &[Backend::Sse, Backend::Wide4]),
    (8, &[Backend::Pulp8, Backend::Wide8]),
    (16, &[Backend::Pulp16, Backend::Wide16]),
];

/// One built accelerator.
enum Built {
    Bsp(Bsp),
    #[cfg(feature = "embree")]
    Embree(coherent::embree::Embree),
    #[cfg(feature = "obvhs")]
    Obvhs(coherent::obvhs::Obvhs),
}

impl Built {
    fn name(&self) -> &'static str {
        match self {
            Built::Bsp(a) => a.name(),
            #[cfg(feature = "embree")]
            Built::Embree(a) => a.name(),
            #[cfg(feature = "obvhs")]
            Built::Obvhs(a) => a.name(),
        }
    }

    /// Whether it has packet traversal (obvhs has not).
    fn packets(&self) -> bool {
        match self {
            #[cfg(feature = "obvhs")]
            Built::Obvhs(_) => false,
            _ => true,
        }
    }

    fn build_ms(&self) -> f64 {
        let s = match self {
            Built::Bsp(a) => a.stats(),
            #[cfg(feature = "embree")]
            Built::Embree(a) => a.stats(),
            #[cfg(feature = "obvhs")]
            Built::Obvhs(a) => a.stats(),
        };
        s.build_seconds * 1e3
    }

    fn memory_bytes(&self) -> usize {
        match self {
            Built::Bsp(a) => a.memory_bytes(),
            #[cfg(feature = "embree")]
            Built::Embree(a) => a.memory_bytes(),
            #[cfg(feature = "obvhs")]
            Built::Obvhs(a) => a.memory_bytes(),
        }
    }

    /// Settings that depend on the kind of rays (Embree's COHERENT flag).
    fn prepare(&mut self, kind: RayKind) {
        #[cfg(feature = "embree")]
        if let Built::Embree(a) = self {
            a.set_coherent(kind != RayKind::Diffuse);
        }
        let _ = kind;
    }

    /// One timed pass over `rays`: single rays (`None`) or packets of `backend`'s width.
    fn pass(
        &self,
        rays: &[Ray1],
        kind: RayKind,
        backend: Option<Backend>,
    ) -> anyhow::Result<PassResult> {
        match self {
            Built::Bsp(a) => pass(a, rays, kind, backend),
            #[cfg(feature = "embree")]
            Built::Embree(a) => pass(a, rays, kind, backend),
            #[cfg(feature = "obvhs")]
            Built::Obvhs(a) => pass(a, rays, kind, backend),
        }
    }
}

fn pass<A: Accel>(
    a: &A,
    rays: &[Ray1],
    kind: RayKind,
    backend: Option<Backend>,
) -> anyhow::Result<PassResult> {
    let occlusion = kind.occlusion();
    Ok(match backend {
        None => workload::time_single(a, rays, occlusion, 1, Clock::Wall),
        Some(b) => b.run(TimePackets {
            accel: a,
            rays,
            occlusion,
            repeats: 1,
            clock: Clock::Wall,
        })?,
    })
}

/// Builds every accelerator compiled in over `s`; an accelerator that cannot be built here
/// (Embree without its library) is noted once and left out.
#[cfg_attr(
    not(any(feature = "embree", feature = "obvhs")),
    allow(unused_mut, unused_variables)
)]
fn build_all(ctx: &mut Ctx, s: &BuiltinScene, bsp: &Bsp) -> Vec<Built> {
    let mut out = vec![Built::Bsp(bsp.clone())];
    #[cfg(feature = "embree")]
    match coherent::embree::Embree::build(&s.scene, &Default::default()) {
        Ok(e) => out.push(Built::Embree(e)),
        Err(e) => ctx.note(format!("accel: embree left out of scene {}: {e}", s.name)),
    }
    #[cfg(not(feature = "embree"))]
    ctx.note("accel: embree not compiled in (cargo feature `embree`)".to_string());
    #[cfg(feature = "obvhs")]
    match coherent::obvhs::Obvhs::build(&s.scene, &Default::default()) {
        Ok(o) => out.push(Built::Obvhs(o)),
        Err(e) => ctx.note(format!("accel: obvhs left out of scene {}: {e}", s.name)),
    }
    #[cfg(not(feature = "obvhs"))]
    ctx.note("accel: obvhs not compiled in (cargo feature `obvhs`)".to_string());
    out
}

/// The scenes: the built-in ones, then the real meshes (quick: the bunny only); a mesh that
/// is not fetched is noted and left out.
fn scene_list(ctx: &mut Ctx) -> Vec<BuiltinScene> {
    let size = if ctx.quick {
        SceneSize::Quick
    } else {
        SceneSize::Full
    };
    let mut list = scenes::all(size);
    let real = if ctx.quick {
        &REAL_MESHES[..1]
    } else {
        &REAL_MESHES[..]
    };
    for m in real {
        match m.scene() {
            Ok(s) => list.push(s),
            Err(e) => ctx.note(format!("accel: scene {} left out: {e}", m.name)),
        }
    }
    list
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let (w, h) = ctx.pick((256u32, 192u32), (1024, 768));
    let samples = ctx.pick(3, 7);
    let mut widths: Vec<(usize, Option<Backend>)> = vec![(1, None)];
    for (lanes, choices) in WIDTHS {
        match choices.iter().find(|b| b.is_available()) {
            Some(&b) => widths.push((lanes, Some(b))),
            None => {
                let why: Vec<String> = choices
                    .iter()
                    .map(|b| format!("{b}: {}", b.unavailable_reason().unwrap_or_default()))
                    .collect();
                ctx.note(format!("accel: width {lanes} skipped ({})", why.join("; ")));
            }
        }
    }
    let list = scene_list(ctx);
    let mut csv = ctx.csv("accel.csv", HEADER)?;
    let bar = ctx.progress((list.len() * RayKind::ALL.len()) as u64, "accel");
    for s in &list {
        let bsp = Bsp::build(&s.scene, &BspParams::default())?;
        let mut accels = build_all(ctx, s, &bsp);
        for kind in RayKind::ALL {
            // The rays of each width (tile order differs), from the BSP's primary hits.
            let rays: BTreeMap<usize, Vec<Ray1>> = widths
                .iter()
                .map(|&(lanes, _)| {
                    let primary =
                        workload::primary_rays(&s.view, w, h, workload::tile_shape(lanes));
                    let r = match kind {
                        RayKind::Primary => primary,
                        RayKind::Shadow => workload::shadow_rays(&bsp, &s.scene, &primary, s.light),
                        RayKind::Diffuse => workload::diffuse_rays(&bsp, &s.scene, &primary, 1),
                    };
                    (lanes, r)
                })
                .collect();
            for a in &mut accels {
                a.prepare(kind);
            }
            // (accel index, width, backend) of every row, then interleaved samples.
            let variants: Vec<(usize, usize, Option<Backend>)> = accels
                .iter()
                .enumerate()
                .flat_map(|(i, a)| {
                    widths
                        .iter()
                        .filter(move |(lanes, _)| *lanes == 1 || a.packets())
                        .map(move |&(lanes, b)| (i, lanes, b))
                })
                .collect();
            let mut seconds = vec![Vec::new(); variants.len()];
            let mut hits = vec![0u64; variants.len()];
            for round in 0..=samples {
                for (v, &(i, lanes, b)) in variants.iter().enumerate() {
                    let p = accels[i].pass(&rays[&lanes], kind, b)?;
                    // Round 0 warms the caches up and is not counted.
                    if round > 0 {
                        seconds[v].push(p.seconds);
                    }
                    hits[v] = p.hits;
                }
            }
            // Every accelerator answers the same rays: hit counts may differ only by rays
            // grazing an edge (their triangle tests differ there). The BSP (accel 0) has
            // every width; the rays of a width are the same for all.
            for (v, &(i, lanes, _)) in variants.iter().enumerate() {
                let Some(reference) = variants
                    .iter()
                    .position(|&(j, l, _)| j == 0 && l == lanes)
                    .map(|r| hits[r])
                else {
                    continue;
                };
                let n = rays[&lanes].len() as u64;
                if hits[v].abs_diff(reference) * 1000 > n.max(1) {
                    ctx.note(format!(
                        "accel: {} {} {} width {lanes}: {} hits where the BSP has {reference} \
                         (of {n} rays)",
                        s.name,
                        accels[i].name(),
                        kind.name(),
                        hits[v]
                    ));
                }
            }
            for (v, &(i, lanes, _)) in variants.iter().enumerate() {
                let n = rays[&lanes].len() as f64;
                let a = &accels[i];
                csv.row(&[
                    &s.name,
                    &a.name(),
                    &kind.name(),
                    &lanes,
                    &format!("{:.3}", n / median(&seconds[v]) / 1e6),
                    &format!("{:.1}", a.build_ms()),
                    &a.memory_bytes(),
                ])?;
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    plots(ctx)?;
    Ok(())
}

/// `(scene, accel, rays, width) -> (mrays_per_s, build_ms, memory_bytes)` of the CSV.
type Rows = BTreeMap<(String, String, String, usize), (f64, f64, f64)>;

fn read_rows(ctx: &Ctx) -> anyhow::Result<Option<(Rows, Vec<String>)>> {
    let Some(t) = ctx.read_csv("accel.csv", HEADER)? else {
        return Ok(None);
    };
    let mut rows = Rows::new();
    let mut scenes: Vec<String> = Vec::new();
    for r in 0..t.rows.len() {
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

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
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

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some((rows, scenes)) = read_rows(ctx)? else {
        return Ok(None);
    };
    let get = |s: &str, a: &str, k: &str, w: usize| {
        rows.get(&(s.to_string(), a.to_string(), k.to_string(), w))
            .map(|r| r.0)
    };
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => format!("{:.2}x", a / b),
        _ => "-".into(),
    };
    let num = |v: Option<f64>| v.map_or("-".into(), fmt_num);
    let mut md = String::new();
    md.push_str(
        "Primary rays, Mrays/s on one thread. Targets: the BSP at width W against Embree at \
         width W (>= 0.5x now, 1.0x the goal), and the BSP's single rays against obvhs' \
         (>= 2x). obvhs traverses single rays only.\n\n",
    );
    let mut table = Vec::new();
    for s in &scenes {
        for w in [1, 4, 8, 16] {
            let (b, e) = (get(s, "bsp", "primary", w), get(s, "embree", "primary", w));
            if b.is_none() && e.is_none() {
                continue;
            }
            let o = (w == 1).then(|| get(s, "obvhs", "primary", 1)).flatten();
            table.push(vec![
                s.clone(),
                w.to_string(),
                num(b),
                num(e),
                ratio(b, e),
                num(o),
                if w == 1 { ratio(b, o) } else { String::new() },
            ]);
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "width",
            "bsp",
            "embree",
            "bsp / embree",
            "obvhs",
            "bsp / obvhs",
        ],
        &table,
    ));
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
    for stem in EXPERIMENT.plots {
        if let Some(p) = ctx.plot_markdown(stem, stem) {
            md.push('\n');
            md.push_str(&p);
            md.push('\n');
        }
    }
    Ok(Some(md))
}
