//! Experiment `accel`: the two-level BSP of paper section 3 on the built-in generated scenes
//! (`coherent::accel::scenes`: spheres, terrain, room, blob) for primary, shadow and diffuse
//! rays, one ray at a time (width 1) and in coherent packets of 4, 8 and 16 lanes; build time
//! and memory per scene. Also the packet-to-single-ray switch threshold per width
//! (`accel_threshold.csv`) and traversal counters with the mailbox hit rate
//! (`accel_traversal.csv`).
//!
//! Protocol: width 1 is the single-ray traversal (`Accel::intersect1`/`occluded1`), the
//! scalar baseline; widths 4, 8, 16 run the packet traversal on one backend each: the
//! hand-written or run-time dispatched one (sse, pulp8, pulp16), else the `wide` one. Primary
//! rays go through the pixel centres in screen tiles of the packet's shape (4x4 tiles for
//! width 1); shadow rays go from the primary hits to the scene's point light (any-hit);
//! diffuse rays from the primary hits over the cosine hemisphere. Samples (one pass over all
//! rays, wall clock) are interleaved round-robin over the widths and each row reports the
//! median. One thread.

use std::collections::BTreeMap;

use coherent::accel::scenes::{self, BuiltinScene, SceneSize};
use coherent::accel::workload::{self, Clock, RayKind, TimePackets};
use coherent::accel::{Accel, Ray1, Rays};
use coherent::bsp::{Bsp, BspParams, TraversalStats};
use coherent::simd::{Backend, Kernel, Lanes};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{fmt_num, markdown_table};

pub const EXPERIMENT: Experiment = Experiment {
    name: "accel",
    description: "traversal speed, build time and memory per accel, ray kind and packet width",
    paper: "section 3 (two-level BSP)",
    csv: &["accel.csv", "accel_threshold.csv", "accel_traversal.csv"],
    plots: &["accel_speedup_vs_width", "accel_mrays"],
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
const THRESHOLD_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "backend",
    "threshold",
    "mrays_per_s",
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
];

/// The backend measured at each packet width: the hand-written or run-time dispatched one
/// where usable, else `wide`.
fn backend_for(width: usize) -> Option<Backend> {
    let prefs: &[Backend] = match width {
        4 => &[Backend::Sse, Backend::Wide4],
        8 => &[Backend::Pulp8, Backend::Wide8],
        16 => &[Backend::Pulp16, Backend::Wide16],
        _ => &[],
    };
    prefs.iter().copied().find(|b| b.is_available())
}

/// Width 1 (single rays, `None`) and each packet width with its backend.
fn widths(ctx: &mut Ctx) -> Vec<(usize, Option<Backend>)> {
    let mut v = vec![(1, None)];
    for w in [4, 8, 16] {
        match backend_for(w) {
            Some(b) => v.push((w, Some(b))),
            None => ctx.note(format!("accel: no backend gives width {w} here")),
        }
    }
    v
}

/// The rays of one kind, ordered in screen tiles for packets of `width` lanes.
fn rays(s: &BuiltinScene, bsp: &Bsp, kind: RayKind, w: u32, h: u32, width: usize) -> Vec<Ray1> {
    let tile = workload::tile_shape(if width == 1 { 16 } else { width });
    let primary = workload::primary_rays(&s.view, w, h, tile);
    match kind {
        RayKind::Primary => primary,
        RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
        RayKind::Diffuse => workload::diffuse_rays(bsp, &s.scene, &primary, 7),
    }
}

/// Seconds of one pass over `rays` at a width.
fn pass(
    bsp: &Bsp,
    rays: &[Ray1],
    occlusion: bool,
    backend: Option<Backend>,
) -> anyhow::Result<f64> {
    Ok(match backend {
        None => workload::time_single(bsp, rays, occlusion, 1, Clock::Wall).seconds,
        Some(b) => {
            b.run(TimePackets {
                accel: bsp,
                rays,
                occlusion,
                repeats: 1,
                clock: Clock::Wall,
            })?
            .seconds
        }
    })
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// Medians of interleaved samples of each configuration (`f(i)` times configuration `i`).
fn interleaved(
    n: usize,
    samples: usize,
    mut f: impl FnMut(usize) -> anyhow::Result<f64>,
) -> anyhow::Result<Vec<f64>> {
    for i in 0..n {
        f(i)?; // warm-up
    }
    let mut s = vec![Vec::with_capacity(samples); n];
    for _ in 0..samples {
        for (i, v) in s.iter_mut().enumerate() {
            v.push(f(i)?);
        }
    }
    Ok(s.iter_mut().map(|v| median(v)).collect())
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let size = ctx.pick(SceneSize::Quick, SceneSize::Full);
    let (w, h) = ctx.pick((256, 192), (1024, 768));
    let samples = ctx.pick(3, 7);
    let widths = widths(ctx);
    let all = scenes::all(size);
    let bar = ctx.progress(all.len() as u64 * 2, "accel");
    let mut csv = ctx.csv("accel.csv", HEADER)?;
    let mut trav = ctx.csv("accel_traversal.csv", TRAVERSAL_HEADER)?;
    let mut built = Vec::new();
    for s in &all {
        let params = BspParams::default();
        let build = crate::timing::time(0, ctx.pick(3, 2), || Bsp::build(&s.scene, &params));
        let bsp = Bsp::build(&s.scene, &params)?;
        let build_ms = build.median * 1e3;
        let memory = bsp.memory_bytes();
        for kind in RayKind::ALL {
            let sets: Vec<Vec<Ray1>> = widths
                .iter()
                .map(|&(wd, _)| rays(s, &bsp, kind, w, h, wd))
                .collect();
            let secs = interleaved(widths.len(), samples, |i| {
                pass(&bsp, &sets[i], kind.occlusion(), widths[i].1)
            })?;
            for (i, &(wd, _)) in widths.iter().enumerate() {
                csv.row(&[
                    &s.name,
                    &"bsp",
                    &kind.name(),
                    &wd,
                    &format!("{:.3}", sets[i].len() as f64 / secs[i] / 1e6),
                    &format!("{build_ms:.2}"),
                    &memory,
                ])?;
            }
            // Traversal counters (first-hit queries) at width 1 and the widest width.
            if !kind.occlusion() {
                for (i, &(wd, b)) in widths.iter().enumerate() {
                    if wd != 1 && i != widths.len() - 1 {
                        continue;
                    }
                    let c = match b {
                        None => {
                            let mut c = TraversalStats::default();
                            for r in &sets[i] {
                                bsp.intersect1_counted(r, &mut c);
                            }
                            c
                        }
                        Some(b) => b.run(Counted {
                            bsp: &bsp,
                            rays: &sets[i],
                        })?,
                    };
                    let n = sets[i].len() as f64;
                    trav.row(&[
                        &s.name,
                        &kind.name(),
                        &wd,
                        &format!("{:.3}", c.inner_nodes as f64 / n),
                        &format!("{:.3}", c.leaves as f64 / n),
                        &format!("{:.3}", c.tri_tests as f64 / n),
                        &format!("{:.3}", if wd == 1 { 1.0 } else { c.lanes_per_test() }),
                        &format!("{:.4}", c.mailbox_hit_rate()),
                    ])?;
                }
            }
        }
        bar.inc(1);
        built.push(bsp);
    }
    csv.finish()?;
    trav.finish()?;

    // The switch threshold: packet subtrees with at most `t` active lanes continue ray by ray.
    let mut thr = ctx.csv("accel_threshold.csv", THRESHOLD_HEADER)?;
    for (s, bsp) in all.iter().zip(&mut built) {
        if s.name != "blob" && s.name != "room" {
            bar.inc(1);
            continue;
        }
        for kind in [RayKind::Primary, RayKind::Diffuse] {
            for &(wd, b) in widths.iter().filter(|(wd, _)| *wd > 1) {
                let rays = rays(s, bsp, kind, w, h, wd);
                let ts: Vec<u32> = [0, 1, 2, 3, 4, 6, 8]
                    .into_iter()
                    .filter(|&t| t as usize <= wd / 2)
                    .collect();
                let secs = interleaved(ts.len(), samples, |i| {
                    bsp.set_traversal_params(true, Some(ts[i]));
                    pass(bsp, &rays, false, b)
                })?;
                for (i, t) in ts.iter().enumerate() {
                    thr.row(&[
                        &s.name,
                        &kind.name(),
                        &wd,
                        &b.map_or("scalar", |b| b.name()),
                        t,
                        &format!("{:.3}", rays.len() as f64 / secs[i] / 1e6),
                    ])?;
                }
            }
        }
        bsp.set_traversal_params(true, None);
        bar.inc(1);
    }
    thr.finish()?;
    bar.finish_and_clear();
    plots(ctx)?;
    Ok(())
}

/// Traversal counters over packets of the backend's width.
struct Counted<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
}

impl Kernel for Counted<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for ch in self.rays.chunks(L::N) {
            let p = Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]);
            self.bsp
                .intersect_counted(l, &p, l.mask_from_fn(|i| i < ch.len()), &mut c);
        }
        c
    }
}

/// `(scene, rays)` -> width -> Mrays/s, from `accel.csv`.
fn rates(t: &crate::Table) -> anyhow::Result<BTreeMap<(String, String), BTreeMap<u32, f64>>> {
    let mut m: BTreeMap<(String, String), BTreeMap<u32, f64>> = BTreeMap::new();
    for r in 0..t.rows.len() {
        m.entry((t.get(r, "scene")?.to_owned(), t.get(r, "rays")?.to_owned()))
            .or_default()
            .insert(t.f64(r, "width")? as u32, t.f64(r, "mrays_per_s")?);
    }
    Ok(m)
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv("accel.csv", HEADER)? else {
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
    let Some(t) = ctx.read_csv("accel.csv", HEADER)? else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "Mrays/s of the two-level BSP, one thread, and in brackets the speedup over width 1 \
         (single-ray traversal) in the same run. Widths 4/8/16 use the sse/pulp8/pulp16 \
         backends where usable (else wide). Issue 3's targets on primary rays: width 4 >= 2.5x, \
         width 16 >= 5x; for scale, Embree 4.4 on the Stanford bunny (69,666 triangles) at \
         1024x768 gives 13 / 24 / 36 / 55 Mrays/s at widths 1 / 4 / 8 / 16 (`blob` is our \
         bunny-sized stand-in: 81,920 triangles).\n\n",
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
        if !seen.contains(&s) {
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
    if let Some(tr) = ctx.read_csv("accel_traversal.csv", TRAVERSAL_HEADER)? {
        md.push_str(
            "\nTraversal per ray (first-hit queries; packet counts divided by the rays in them): \
             inner nodes, leaves, triangle tests, active lanes per packet test, and the share of \
             triangle tests the intersection cache (mailbox) saved (`accel_traversal.csv`).\n\n",
        );
        md.push_str(&tr.to_markdown());
    }
    Ok(Some(md))
}
