//! The report's accel section: the BSP's rates per width, the comparison with Embree and
//! obvhs, the beams, the sweeps, and the same experiment run elsewhere.

use std::collections::BTreeMap;

use coherent::accel_any::AccelKind;
use coherent::simd::Backend;
use coherent_accel::workload::RayKind;

use super::{
    EMBREE_HEADER, HEADER, LEAVES_HEADER, MIXED_HEADER, SHAPES_HEADER, THRESHOLD_HEADER,
    TRAVERSAL_HEADER,
};
use crate::ctx::Ctx;
use crate::manycore::{MANYCORE, manycore_machine};
use crate::table::{fmt_num, markdown_table};
use crate::timing::median;

/// Whether row `r` of an `accel.csv` is a beam row (files written before beams have no
/// `query` column: all lane packets).
pub(super) fn is_beam(t: &crate::Table, r: usize) -> bool {
    t.get(r, "query").is_ok_and(|q| q == "beam")
}

/// The beam rows of `accel.csv` as a table: per scene, ray kind and structure with beams
/// (the BSP's beam traversal, obvhs' large packets over its BVH2s), its fastest lane row
/// (packets for the BSP; obvhs has single rays only), its beams per size and backend, and
/// Embree's fastest row, Mrays/s.
fn beam_report(t: &crate::Table) -> anyhow::Result<Option<String>> {
    let mut sizes: Vec<(usize, String)> = Vec::new();
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for r in 0..t.rows.len() {
        if is_beam(t, r) {
            let k = (t.f64(r, "width")? as usize, t.get(r, "backend")?.to_owned());
            if !sizes.contains(&k) {
                sizes.push(k);
            }
            let key = (
                t.get(r, "scene")?.to_owned(),
                t.get(r, "rays")?.to_owned(),
                t.get(r, "accel")?.to_owned(),
            );
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
        "accel".to_owned(),
        "its fastest lanes".to_owned(),
        "Embree's fastest".to_owned(),
    ];
    header.extend(sizes.iter().map(|(n, b)| format!("beam {n} ({b})")));
    header.push("one packet / lanes".to_owned());
    header.push("best beam / lanes".to_owned());
    header.push("best beam / Embree".to_owned());
    // A beam of one packet is the control (its cost over the lane query), not a beam.
    let one_packet = |n: usize, b: &str| Backend::named(b).is_some_and(|b| b.lanes() == n);
    let mut rows = Vec::new();
    for (scene, rays, accel) in &keys {
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
        let lanes = of(&|r| Ok(t.get(r, "accel")? == accel && !is_beam(t, r)))?;
        let embree = of(&|r| Ok(t.get(r, "accel")? == "embree"))?;
        let mut row = vec![scene.clone(), rays.clone(), accel.clone()];
        row.push(lanes.map_or("-".into(), fmt_num));
        row.push(embree.map_or("-".into(), fmt_num));
        let mut best_beam: Option<f64> = None;
        let mut control: Option<f64> = None;
        for (n, b) in &sizes {
            let v = of(&|r| {
                Ok(is_beam(t, r)
                    && t.get(r, "accel")? == accel
                    && t.f64(r, "width")? as usize == *n
                    && t.get(r, "backend")? == b)
            })?;
            if one_packet(*n, b) {
                control = v;
            } else if b != "scalar" {
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
        row.push(ratio(control, lanes));
        row.push(ratio(best_beam, lanes));
        row.push(ratio(best_beam, embree));
        rows.push(row);
    }
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    Ok(Some(format!(
        "\nBeams (`query` = beam in `accel.csv`): Mrays/s of the BSP's beam traversal and of \
         obvhs' large packets (Wald et al. 2007, over the BVH2 each CWBVH is built from) on \
         square tiles of `width` rays (the beam-size sweep on the widest backend; the scalar \
         backend's beams cull without SIMD), beside the structure's own fastest lane row (BSP \
         packets; obvhs, single rays) and Embree's fastest row (any width). A beam of one \
         packet (as many rays as the backend's lanes) is the control: its rate over the lane \
         row is what entering a beam costs; the best beam is over the larger ones. The same \
         rays, one thread.\n\n{}",
        markdown_table(&header, &rows)
    )))
}

/// The BSP's `(scene, rays)` -> width -> Mrays/s, from `accel.csv`.
pub(super) fn rates(
    t: &crate::Table,
) -> anyhow::Result<BTreeMap<(String, String), BTreeMap<u32, f64>>> {
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

pub(super) fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
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
    if let Some(t) = ctx.read_csv("accel_shapes.csv", SHAPES_HEADER)? {
        md.push_str(
            "\nThe packets' shape alone (`accel_shapes.csv`): the BSP's 16-lane packets as rows \
             of a tile (8 x 2, 16 x 1) beside the same packets as 4 x 4 squares (`over_square`: \
             the row's rate over the square's), the same rays in each tile order, timed \
             interleaved with the rows above.\n\n",
        );
        md.push_str(&t.to_markdown());
    }
    if let Some(th) = ctx.read_csv("accel_threshold.csv", THRESHOLD_HEADER)? {
        md.push_str(&threshold_table(&th)?);
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

/// The switch-threshold sweep as a table: Mrays/s per threshold and the best.
fn threshold_table(th: &crate::Table) -> anyhow::Result<String> {
    let mut md = String::new();
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
            if th.get(r, "scene")? == s && th.get(r, "rays")? == ray && th.get(r, "width")? == wd {
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
    Ok(md)
}

/// `(scene, accel, rays, width) -> (mrays_per_s, build_ms, memory_bytes)` of the CSV.
pub(super) type Rows = BTreeMap<(String, String, String, usize), (f64, f64, f64)>;

pub(super) fn read_rows(ctx: &Ctx) -> anyhow::Result<Option<(Rows, Vec<String>)>> {
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
    md.push_str(&build_table(&rows, &scenes));
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

/// Build time and memory per scene and structure.
fn build_table(rows: &Rows, scenes: &[String]) -> String {
    let mut header = vec!["scene".to_owned()];
    for a in AccelKind::compared() {
        header.push(format!("{a} ms"));
        header.push(format!("{a} MB"));
    }
    let mut build = Vec::new();
    for s in scenes {
        let mut row = vec![s.clone()];
        for a in AccelKind::compared() {
            let r = rows.get(&(s.clone(), a.name().to_owned(), "primary".to_owned(), 1));
            row.push(r.map_or("-".into(), |r| fmt_num(r.1)));
            row.push(r.map_or("-".into(), |r| fmt_num(r.2 / 1e6)));
        }
        build.push(row);
    }
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    markdown_table(&header, &build)
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
    let about = manycore_machine(ctx, "accel");
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
pub(super) fn read_either(
    ctx: &Ctx,
    file: &str,
    header: &[&str],
) -> anyhow::Result<Option<crate::Table>> {
    // Older files lack the beams' counters, and older still the trailing `query` and
    // `backend` columns (and the cross-check's).
    const B: usize = super::TRAVERSAL_BEAM_COLUMNS;
    let older: &[usize] = if file.ends_with("traversal.csv") {
        &[super::TRAVERSAL_CULL_COLUMNS, B, B + 2, B + 3, B + 4]
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

    #[test]
    fn beams_are_reported_per_structure() {
        let csv = "scene,accel,rays,width,mrays_per_s,build_ms,memory_bytes,hits,t_sum,query,backend\n\
                   room,bsp,primary,16,10.0,1,1,5,0,lanes,avx512\n\
                   room,bsp,primary,16,9.0,1,1,5,0,beam,avx512\n\
                   room,bsp,primary,64,20.0,1,1,5,0,beam,avx512\n\
                   room,obvhs,primary,1,2.0,1,1,5,0,lanes,single\n\
                   room,obvhs,primary,64,6.0,1,1,5,0,beam,avx512\n\
                   room,embree,primary,16,30.0,1,1,5,0,lanes,avx512\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("accel.csv");
        std::fs::write(&path, csv).unwrap();
        let t = crate::Table::read(&path, HEADER).unwrap();
        let md = beam_report(&t).unwrap().unwrap();
        assert!(
            md.contains(
                "| room | primary | bsp | 10.0 | 30.0 | 9.00 | 20.0 | 0.90 | 2.00 | 0.67 |"
            ),
            "{md}"
        );
        // obvhs has no one-packet beam here: no control, and its beam of 64 is its best.
        assert!(
            md.contains("| room | primary | obvhs | 2.00 | 30.0 | - | 6.00 | - | 3.00 | 0.20 |"),
            "{md}"
        );
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
