//! Experiment `builds`: how long each structure takes to build, and what the BSP's two build
//! presets give (paper section 3: the object trees are built "carefully, once"; the build is
//! now most of the time to a first image of a new mesh).
//!
//! Per `accel` scene (the built-in ones and the real meshes), `builds.csv` has the median of a
//! few builds of each structure on one thread and on every core of the machine: the BSP with
//! the `exact` preset (the sweep at every node), the `binned` one (binned at every level) and
//! the `fast` one (binned SAH at large
//! nodes, subtrees in parallel), Embree at the quality the renderer asks of it, and obvhs.
//! Beside the BSP's builds, its trees' quality: nodes, leaf references, depth and SAH cost
//! (each object tree's, relative to its own root box, summed). `builds_presets.csv` then times
//! every preset's tree on the same rays (primary, shadow, diffuse; single rays and packets
//! of the widest backend), interleaved, one thread, and checks that they give the same
//! answers. `builds_phases.csv` splits each BSP build into its object trees, its top tree
//! and the rest (triangle records). `builds.csv`'s last column is the BSP build's peak
//! memory: the most bytes live at once during one more build, counted by this crate's
//! allocator (which counts nothing outside that build).

use coherent::accel::{Accel, AccelError};
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::bsp::{Bsp, BspParams, BuildPreset};
use coherent::simd::Backend;
use coherent_accel::alloc_count::{CountingAlloc, peak_bytes};
use coherent_accel::scenes::{BuiltinScene, SceneSize};
use coherent_accel::workload::RayKind;

use crate::accel::{disagreement, interleaved, pass_any, rays, scene_list};
use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::plot::BarChart;
use crate::table::{CsvOut, Table, fmt_num, markdown_table};
use crate::targets::{Check, condensed};
use crate::timing::median;

pub const EXPERIMENT: Experiment = Experiment {
    name: "builds",
    description: "build time per structure, preset and thread count; the BSP presets' trees",
    paper: "section 3 (the BSP's build), against Embree 4 and obvhs",
    csv: &[FILE, PRESETS_FILE, PHASES_FILE],
    plots: &[PLOT],
    status: Status::Ready { run, plot, report },
};

pub(crate) const FILE: &str = "builds.csv";
pub(crate) const HEADER: &[&str] = &[
    "scene",
    "accel",
    "preset",
    "threads",
    "build_ms",
    "memory_bytes",
    "triangles",
    "nodes",
    "leaf_refs",
    "max_depth",
    "sah_cost",
    "build_peak_bytes",
];
pub(crate) const PRESETS_FILE: &str = "builds_presets.csv";
pub(crate) const PRESETS_HEADER: &[&str] = &[
    "scene",
    "rays",
    "width",
    "backend",
    "exact_mrays_per_s",
    "fast_mrays_per_s",
    "fast_over_exact",
    "binned_mrays_per_s",
    "binned_over_exact",
];
/// Where each BSP build's time goes: the object trees (each tree's own time, summed over
/// trees built in parallel, so it can pass the wall time on several threads), the top tree,
/// and the rest (validation, triangle records, shared edges, cull boxes).
pub(crate) const PHASES_FILE: &str = "builds_phases.csv";
pub(crate) const PHASES_HEADER: &[&str] = &[
    "scene",
    "preset",
    "threads",
    "build_ms",
    "object_trees_ms",
    "top_ms",
    "other_ms",
];
pub(crate) const PLOT: &str = "builds";

/// The quality of a BSP's trees, summed (or, for the depth, the deepest) over its object
/// trees and its top tree.
pub(crate) struct TreeQuality {
    pub preset: &'static str,
    pub nodes: usize,
    pub leaf_refs: usize,
    pub max_depth: usize,
    /// Each object tree's SAH cost relative to its own root box, summed: comparable between
    /// presets of one scene, not between scenes.
    pub sah_cost: f64,
}

impl TreeQuality {
    pub(crate) fn of(b: &Bsp) -> TreeQuality {
        let trees = b.mesh_trees().iter().map(|m| &m.tree).chain([b.top_tree()]);
        let mut q = TreeQuality {
            preset: b.params().object.build.name(),
            nodes: 0,
            leaf_refs: 0,
            max_depth: 0,
            sah_cost: b.mesh_trees().iter().map(|m| m.tree.stats.sah_cost).sum(),
        };
        for t in trees {
            q.nodes += t.stats.nodes;
            q.leaf_refs += t.stats.leaf_refs;
            q.max_depth = q.max_depth.max(t.stats.max_depth);
        }
        q
    }
}

/// The BSP's parameters with the object trees built by `preset`.
pub(crate) fn bsp_params(preset: BuildPreset) -> BspParams {
    let mut p = BspParams::default();
    p.object.build = preset;
    p
}

/// The median over `repeats` builds of `build` run in a pool of `threads` threads, in
/// seconds (the structure's own `build_seconds`), and the last build.
fn timed<A: Accel + Send>(
    threads: usize,
    repeats: usize,
    build: impl Fn() -> Result<A, AccelError> + Send + Sync,
) -> anyhow::Result<(A, f64)> {
    let pool = crate::frames::pool(threads)?;
    pool.install(|| {
        let mut secs = Vec::with_capacity(repeats);
        let mut last = None;
        for _ in 0..repeats.max(1) {
            let a = build()?;
            secs.push(a.stats().build_seconds);
            last = Some(a);
        }
        Ok((last.expect("at least one build"), median(&secs)))
    })
}

// Peak build memory: every allocation of the experiments counted while a build is measured
// (`coherent_accel::alloc_count`).
#[global_allocator]
static ALLOCATOR: CountingAlloc = CountingAlloc;

/// The peak bytes ([`peak_bytes`]) of one more BSP build of `scene` with `preset` in a pool
/// of `threads` threads, the finished structure included.
fn build_peak(
    threads: usize,
    scene: &coherent::accel::Scene,
    preset: BuildPreset,
) -> anyhow::Result<usize> {
    let pool = crate::frames::pool(threads)?;
    let (b, peak) = pool.install(|| peak_bytes(|| Bsp::build(scene, &bsp_params(preset))));
    b?;
    Ok(peak)
}

/// The thread counts measured: one, and every core when there are more.
fn thread_counts() -> Vec<usize> {
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    if all > 1 { vec![1, all] } else { vec![1] }
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let size = ctx.pick(SceneSize::Quick, SceneSize::Full);
    let (w, h): (u32, u32) = ctx.pick((256, 192), (1024, 768));
    let samples = ctx.pick(3, 7);
    let repeats = ctx.pick(2, 3);
    let all = scene_list(ctx, size);
    let bar = ctx.progress(all.len() as u64, "builds");
    let mut builds = ctx.csv(FILE, HEADER)?;
    let mut presets = ctx.csv(PRESETS_FILE, PRESETS_HEADER)?;
    let mut phases = ctx.csv(PHASES_FILE, PHASES_HEADER)?;
    for s in &all {
        run_scene(
            ctx,
            s,
            (w, h),
            (repeats, samples),
            (&mut builds, &mut presets, &mut phases),
        )?;
        bar.inc(1);
    }
    builds.finish()?;
    presets.finish()?;
    phases.finish()?;
    bar.finish_and_clear();
    Ok(())
}

/// Appends scene `s`'s build rows (the median of `repeats` builds each) to `out` and its
/// preset comparison (`samples` passes each, the rays of a `w` x `h` image) to `presets`.
fn run_scene(
    ctx: &mut Ctx,
    s: &BuiltinScene,
    (w, h): (u32, u32),
    (repeats, samples): (usize, usize),
    (out, presets, phases): (&mut CsvOut, &mut CsvOut, &mut CsvOut),
) -> anyhow::Result<()> {
    let mut trees: Vec<Bsp> = Vec::new();
    for preset in BuildPreset::ALL {
        for threads in thread_counts() {
            let (b, secs) = timed(threads, repeats, || {
                Bsp::build(&s.scene, &bsp_params(preset))
            })?;
            let q = TreeQuality::of(&b);
            let peak = build_peak(threads, &s.scene, preset)?;
            out.row(&[
                &s.name,
                &"bsp",
                &q.preset,
                &threads,
                &format!("{:.3}", secs * 1e3),
                &b.memory_bytes(),
                &b.stats().triangles,
                &q.nodes,
                &q.leaf_refs,
                &q.max_depth,
                &format!("{:.4}", q.sah_cost),
                &peak,
            ])?;
            let trees_s: f64 = b
                .mesh_trees()
                .iter()
                .map(|m| m.tree.stats.build_seconds)
                .sum();
            let top_s = b.top_tree().stats.build_seconds;
            let last_s = b.stats().build_seconds;
            phases.row(&[
                &s.name,
                &q.preset,
                &threads,
                &format!("{:.3}", last_s * 1e3),
                &format!("{:.3}", trees_s * 1e3),
                &format!("{:.3}", top_s * 1e3),
                &format!("{:.3}", (last_s - trees_s - top_s).max(0.0) * 1e3),
            ])?;
            if threads == 1 {
                trees.push(b);
            }
        }
    }
    others(ctx, s, repeats, out)?;

    // The two presets' trees on the same rays, interleaved.
    let widest = Backend::widest();
    let mut widths = vec![(1, None)];
    if widest != Backend::Scalar {
        widths.push((widest.lanes(), Some(widest)));
    }
    for kind in RayKind::ALL {
        for &(width, backend) in &widths {
            let r = rays(s, &trees[0], kind, w, h, width);
            let occ = kind.occlusion();
            let res = interleaved(trees.len(), samples, |i| {
                pass_any(&trees[i], &r, occ, backend)
            })?;
            for (i, preset) in BuildPreset::ALL.iter().enumerate().skip(1) {
                if let Some(why) = disagreement(&res[0].1, &res[i].1, r.len()) {
                    anyhow::bail!(
                        "{} {} rays at width {width}: the {preset} tree disagrees with the exact one: {why}",
                        s.name,
                        kind.name()
                    );
                }
            }
            let rate = |i: usize| r.len() as f64 / res[i].0 / 1e6;
            presets.row(&[
                &s.name,
                &kind.name(),
                &width,
                &backend.map_or("single", Backend::name),
                &format!("{:.3}", rate(0)),
                &format!("{:.3}", rate(1)),
                &format!("{:.3}", rate(1) / rate(0)),
                &format!("{:.3}", rate(2)),
                &format!("{:.3}", rate(2) / rate(0)),
            ])?;
        }
    }
    Ok(())
}

/// The build rows of every compared structure but the BSP for `s` (Embree, obvhs), on one
/// thread and every core; one that cannot be built here is noted and left out.
fn others(ctx: &mut Ctx, s: &BuiltinScene, repeats: usize, out: &mut CsvOut) -> anyhow::Result<()> {
    let mut kinds = Vec::new();
    for kind in AccelKind::compared().filter(|&k| k != AccelKind::Bsp) {
        match kind.unavailable_reason() {
            None => kinds.push(kind),
            Some(why) => ctx.note(format!("builds: {kind} left out of {}: {why}", s.name)),
        }
    }
    for threads in thread_counts() {
        for &kind in &kinds {
            let params = AnyParams::timed(kind, threads);
            match timed(threads, repeats, || AnyAccel::build(&s.scene, &params)) {
                Ok((a, secs)) => other_row(out, s, kind.name(), threads, &a, secs)?,
                Err(e) => ctx.note(format!("builds: {kind} left out of {}: {e}", s.name)),
            }
        }
    }
    Ok(())
}

fn other_row(
    out: &mut CsvOut,
    s: &BuiltinScene,
    accel: &str,
    threads: usize,
    a: &impl Accel,
    secs: f64,
) -> anyhow::Result<()> {
    out.row(&[
        &s.name,
        &accel,
        &"default",
        &threads,
        &format!("{:.3}", secs * 1e3),
        &a.memory_bytes(),
        &a.stats().triangles,
        &"",
        &"",
        &"",
        &"",
        &"",
    ])
}

/// The value in `column` of the row of (scene, accel, preset, threads), if there is one.
fn cell(t: &Table, key: [&str; 4], column: &str) -> Option<f64> {
    let [scene, accel, preset, threads] = key;
    let keys = [
        ("scene", scene),
        ("accel", accel),
        ("preset", preset),
        ("threads", threads),
    ];
    let r = crate::table3::find(t, &keys).ok()??;
    t.f64(r, column).ok()
}

/// The build time of (accel, preset, threads) on `scene`, in milliseconds.
fn build_ms(t: &Table, scene: &str, accel: &str, preset: &str, threads: &str) -> Option<f64> {
    cell(t, [scene, accel, preset, threads], "build_ms")
}

/// The thread counts in the table, fewest first.
fn threads_in(t: &Table) -> anyhow::Result<Vec<String>> {
    let mut th = t.distinct("threads")?;
    th.sort_by_key(|s| s.parse::<usize>().unwrap_or(0));
    Ok(th)
}

/// The build-time chart: per scene, each structure's build on every core.
fn plot(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(());
    };
    let scenes = t.distinct("scene")?;
    let threads = threads_in(&t)?;
    let mut series = Vec::new();
    // Every (structure, preset) the file has, in its order.
    let mut pairs: Vec<(String, String)> = Vec::new();
    for r in 0..t.rows.len() {
        let pair = (
            t.get(r, "accel")?.to_owned(),
            t.get(r, "preset")?.to_owned(),
        );
        if !pairs.contains(&pair) {
            pairs.push(pair);
        }
    }
    for (accel, preset) in &pairs {
        let (accel, preset) = (accel.as_str(), preset.as_str());
        for th in &threads {
            let v: Vec<f64> = scenes
                .iter()
                .map(|s| build_ms(&t, s, accel, preset, th).unwrap_or(f64::NAN))
                .collect();
            if v.iter().any(|x| x.is_finite()) {
                let who = if accel == "bsp" {
                    format!("bsp {preset}")
                } else {
                    accel.to_owned()
                };
                series.push((format!("{who}, {th} thread(s)"), v));
            }
        }
    }
    ctx.bar_chart(
        PLOT,
        &BarChart {
            title: "Build time per structure, preset and threads".into(),
            y_label: "ms".into(),
            categories: scenes,
            series,
        },
    )?;
    Ok(())
}

/// The report: build times against Embree, the presets' tree quality and trace
/// speed, and the build targets.
fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let threads = threads_in(&t)?;
    let (one, all) = (
        threads.first().cloned().unwrap_or_default(),
        threads.last().cloned().unwrap_or_default(),
    );
    let mut md = format!(
        "Builds (`{FILE}`): the median of a few builds per structure, on {one} thread and \
         on {all}; the BSP with every build preset. `exact` sweeps every candidate plane at \
         every node; `fast` bins the SAH at large nodes and builds their subtrees in \
         parallel. SAH cost: each object tree's, relative to its own root box, summed.\n\n"
    );
    let mut rows = Vec::new();
    let mut checks = Vec::new();
    let bytes = |scene: &str, accel: &str, preset: &str| -> Option<(f64, f64)> {
        let key = [scene, accel, preset, one.as_str()];
        Some((cell(&t, key, "memory_bytes")?, cell(&t, key, "triangles")?))
    };
    let sah =
        |scene: &str, preset: &str| cell(&t, [scene, "bsp", preset, one.as_str()], "sah_cost");
    for s in t.distinct("scene")? {
        let ms = |a: &str, p: &str, th: &str| build_ms(&t, &s, a, p, th);
        let cell = |v: Option<f64>| v.map_or("—".to_owned(), fmt_num);
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => format!("{:.2}x", a / b),
            _ => "—".to_owned(),
        };
        let (e1, ea) = (ms("embree", "default", &one), ms("embree", "default", &all));
        let (f1, fa) = (ms("bsp", "fast", &one), ms("bsp", "fast", &all));
        let (x1, xa) = (ms("bsp", "exact", &one), ms("bsp", "exact", &all));
        let (sx, sf) = (sah(&s, "exact"), sah(&s, "fast"));
        rows.push(vec![
            s.clone(),
            cell(x1),
            cell(f1),
            cell(xa),
            cell(fa),
            cell(e1),
            cell(ea),
            cell(ms("obvhs", "default", &one)),
            ratio(f1, e1),
            ratio(fa, ea),
            match (sx, sf) {
                (Some(x), Some(f)) if x > 0.0 => format!("{:+.1} %", 100.0 * (f / x - 1.0)),
                _ => "—".to_owned(),
            },
        ]);
        if let (Some(f), Some(e)) = (fa, ea) {
            checks.push(Check::at_most(
                &s,
                &format!("bsp fast build <= 1.5x embree's, {all} threads"),
                format!("{:.2}x", f / e),
                f / e,
                1.5,
            ));
        }
        if let (Some(f), Some(e)) = (f1, e1) {
            checks.push(Check::at_most(
                &s,
                "bsp fast build <= 2x embree's, 1 thread",
                format!("{:.2}x", f / e),
                f / e,
                2.0,
            ));
        }
        if let (Some((bb, bt)), Some((eb, et))) =
            (bytes(&s, "bsp", "exact"), bytes(&s, "embree", "default"))
            && bt > 0.0
            && et > 0.0
        {
            let r = (bb / bt) / (eb / et);
            checks.push(Check::at_most(
                &s,
                "bsp bytes per triangle <= 1.5x embree's",
                format!("{r:.2}x"),
                r,
                1.5,
            ));
        }
    }
    let h1 = format!("exact, {one} thr.");
    let hf1 = format!("fast, {one} thr.");
    let ha = format!("exact, {all} thr.");
    let hfa = format!("fast, {all} thr.");
    let he1 = format!("embree, {one} thr.");
    let hea = format!("embree, {all} thr.");
    let ho = format!("obvhs, {one} thr.");
    let hr1 = format!("fast / embree, {one} thr.");
    let hra = format!("fast / embree, {all} thr.");
    md.push_str(&markdown_table(
        &[
            "scene (build ms)",
            &h1,
            &hf1,
            &ha,
            &hfa,
            &he1,
            &hea,
            &ho,
            &hr1,
            &hra,
            "SAH fast vs exact",
        ],
        &rows,
    ));
    if let Some(p) = ctx.plot_markdown(PLOT, "build time per structure") {
        md.push_str(&p);
    }
    binned_report(&t, [&one, &all], &mut md, &mut checks)?;
    presets_report(ctx, &mut md, &mut checks)?;
    if !checks.is_empty() {
        md.push_str("\nThe build targets:\n\n");
        md.push_str(&condensed("scene", &checks));
    }
    Ok(Some(md))
}

/// The report's part on the build binned at every level: its times against Embree's and the
/// exact build's, its SAH cost against the exact tree's, and their targets.
fn binned_report(
    t: &Table,
    [one, all]: [&str; 2],
    md: &mut String,
    checks: &mut Vec<Check>,
) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    for s in t.distinct("scene")? {
        let ms = |a: &str, p: &str, th: &str| build_ms(t, &s, a, p, th);
        let Some(b1) = ms("bsp", "binned", one) else {
            continue;
        };
        let (ba, e1, ea) = (
            ms("bsp", "binned", all),
            ms("embree", "default", one),
            ms("embree", "default", all),
        );
        let x1 = ms("bsp", "exact", one);
        let sah = |p: &str| cell(t, [&s, "bsp", p, one], "sah_cost");
        let num = |v: Option<f64>| v.map_or("—".to_owned(), fmt_num);
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => Some(a / b),
            _ => None,
        };
        let fmt = |r: Option<f64>| r.map_or("—".to_owned(), |r| format!("{r:.2}x"));
        let sah_ratio = ratio(sah("binned"), sah("exact"));
        // The build's peak bytes over the finished structure's, the worse thread count.
        let peak = [one, all]
            .iter()
            .filter_map(|th| {
                let key = [s.as_str(), "bsp", "binned", th];
                ratio(
                    cell(t, key, "build_peak_bytes"),
                    cell(t, key, "memory_bytes"),
                )
            })
            .max_by(f64::total_cmp);
        rows.push(vec![
            s.clone(),
            num(Some(b1)),
            num(ba),
            fmt(ratio(Some(b1), x1)),
            fmt(ratio(Some(b1), e1)),
            fmt(ratio(ba, ea)),
            sah_ratio.map_or("—".to_owned(), |r| format!("{:+.1} %", 100.0 * (r - 1.0))),
            fmt(peak),
        ]);
        if let Some(r) = peak {
            checks.push(Check::at_most(
                &s,
                "bsp binned build's peak memory <= 2x the structure's bytes",
                format!("{r:.2}x"),
                r,
                2.0,
            ));
        }
        if let Some(r) = ratio(Some(b1), e1) {
            checks.push(Check::at_most(
                &s,
                "bsp binned build <= 1.5x embree's, 1 thread",
                format!("{r:.2}x"),
                r,
                1.5,
            ));
        }
        if let Some(r) = ratio(ba, ea) {
            checks.push(Check::at_most(
                &s,
                &format!("bsp binned build <= 1.2x embree's, {all} threads"),
                format!("{r:.2}x"),
                r,
                1.2,
            ));
        }
        if let Some(r) = sah_ratio {
            checks.push(Check::at_most(
                &s,
                "binned tree's SAH cost <= 1.05x the exact tree's",
                format!("{r:.3}x"),
                r,
                1.05,
            ));
        }
    }
    if rows.is_empty() {
        return Ok(());
    }
    md.push_str(
        "\nThe build binned at every level (`binned`: min-max bins down to a few references, \
         a sweep below, references partitioned in place, large nodes across threads):\n\n",
    );
    let h = [
        "scene".to_owned(),
        format!("binned ms, {one} thr."),
        format!("binned ms, {all} thr."),
        format!("binned / exact, {one} thr."),
        format!("binned / embree, {one} thr."),
        format!("binned / embree, {all} thr."),
        "SAH binned vs exact".to_owned(),
        "build peak / structure bytes".to_owned(),
    ];
    let h: Vec<&str> = h.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&h, &rows));
    Ok(())
}

/// The report's presets part: the fast tree's trace speed over the exact tree's, and its
/// targets.
fn presets_report(ctx: &Ctx, md: &mut String, checks: &mut Vec<Check>) -> anyhow::Result<()> {
    let Some(p) = ctx.read_csv(PRESETS_FILE, PRESETS_HEADER)? else {
        return Ok(());
    };
    md.push_str(&format!(
        "\nThe fast tree's trace speed over the exact tree's, same rays, one thread \
         (`{PRESETS_FILE}`):\n\n"
    ));
    let mut cols: Vec<(String, String)> = Vec::new();
    for r in 0..p.rows.len() {
        let c = (p.get(r, "rays")?.to_owned(), p.get(r, "width")?.to_owned());
        if !cols.contains(&c) {
            cols.push(c);
        }
    }
    let mut prow = Vec::new();
    for s in p.distinct("scene")? {
        let mut row = vec![s.clone()];
        for (k, w) in &cols {
            let r = crate::table3::find(&p, &[("scene", &s), ("rays", k), ("width", w)])?;
            row.push(r.map_or(Ok("—".to_owned()), |r| {
                p.f64(r, "fast_over_exact").map(|v| format!("{v:.2}x"))
            })?);
        }
        prow.push(row);
    }
    let mut header = vec!["scene".to_owned()];
    header.extend(cols.iter().map(|(k, w)| format!("{k}, width {w}")));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &prow));
    for r in 0..p.rows.len() {
        let (s, k, w) = (p.get(r, "scene")?, p.get(r, "rays")?, p.get(r, "width")?);
        let v = p.f64(r, "fast_over_exact")?;
        checks.push(Check::at_least(
            s,
            "fast tree traces >= 0.9x the exact tree",
            format!("{k} width {w}: {v:.2}x"),
            v,
            0.9,
        ));
        if let Ok(b) = p.f64(r, "binned_over_exact") {
            checks.push(Check::at_least(
                s,
                "binned tree traces >= 0.95x the exact tree",
                format!("{k} width {w}: {b:.2}x"),
                b,
                0.95,
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_sets_the_builds_against_embree_and_the_targets() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let mut out = ctx.csv(FILE, HEADER).unwrap();
        let rows: [(&str, &str, usize, f64, &str); 7] = [
            ("bsp", "exact", 1, 40.0, "2.0"),
            ("bsp", "exact", 2, 38.0, "2.0"),
            ("bsp", "fast", 1, 30.0, "2.1"),
            ("bsp", "fast", 2, 18.0, "2.1"),
            ("embree", "default", 1, 20.0, ""),
            ("embree", "default", 2, 12.0, ""),
            ("obvhs", "default", 1, 4.0, ""),
        ];
        for (accel, preset, threads, ms, sah) in rows {
            let bytes = if accel == "bsp" { 3000 } else { 1000 };
            out.row(&[
                &"mesh", &accel, &preset, &threads, &ms, &bytes, &100, &"", &"", &"", &sah, &"",
            ])
            .unwrap();
        }
        out.finish().unwrap();
        let mut p = ctx.csv(PRESETS_FILE, PRESETS_HEADER).unwrap();
        p.row(&[
            &"mesh", &"primary", &1, &"single", &1.0, &0.95, &0.95, &1.0, &1.0,
        ])
        .unwrap();
        p.row(&[
            &"mesh", &"primary", &16, &"avx512", &4.0, &3.2, &0.8, &4.0, &1.0,
        ])
        .unwrap();
        p.finish().unwrap();
        let md = report(&ctx).unwrap().unwrap();
        // fast / embree: 30 / 20 on one thread, 18 / 12 on two; SAH +5 %.
        assert!(
            md.contains(
                "| mesh | 40.0 | 30.0 | 38.0 | 18.0 | 20.0 | 12.0 | 4.00 | 1.50x | 1.50x | +5.0 % |"
            ),
            "{md}"
        );
        assert!(md.contains("| 0.95x | 0.80x |"), "{md}");
        // Met: both build ratios; missed: the bytes (3x) and the packet trace (0.8x).
        assert!(
            md.contains("bsp fast build <= 1.5x embree's, 2 threads | met"),
            "{md}"
        );
        assert!(
            md.contains("bsp fast build <= 2x embree's, 1 thread | met"),
            "{md}"
        );
        assert!(
            md.contains("embree's | not met | nearest miss: 3.00x"),
            "{md}"
        );
        assert!(
            md.contains("1 of 2 met | nearest miss: primary width 16: 0.80x"),
            "{md}"
        );
    }
}
