//! Experiment `regroup`: does compacting the active lanes of secondary packets across the
//! packets of a tile pay? The paper keeps a packet's lanes together through every bounce;
//! a reflection or refraction packet then carries the idle lanes of its parent that hit
//! something else. Regrouping (the renderer's `regroup` switch, `coherent render --regroup`)
//! gathers the lanes of one node of the ray tree from every packet of a tile into full
//! packets, at the cost of copying them out and back.
//!
//! Protocol: the scenes and frames of `table3` (same plan) that trace reflection or
//! refraction rays, the BSP, the preferred backend of 4, 8 and 16 lanes usable here (hand-written on x86-64).
//! Per scene and backend, one untimed frame each way (the images, compared by PSNR as
//! displayed: tone-mapped, channels clipped to [0, 1]; and the packet counts), then
//! `ROUNDS` rounds alternate the two (which goes first alternates too); `seconds` is the
//! median, `speedup` = seconds without regrouping / this row's, `spread` = the slowest round
//! / the fastest: this machine's run-to-run noise, measured on the very frames compared.

use std::collections::BTreeMap;
use std::fmt::Display;

use coherent::accel_any::AccelKind;
use coherent::render::RenderStats;
use coherent::render::centres::psnr;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::{self, Plan};
use crate::plot::BarChart;
use crate::table::{fmt_num, markdown_table};
use crate::timing::{median, speedup};

pub const EXPERIMENT: Experiment = Experiment {
    name: "regroup",
    description: "secondary packets regrouped across a tile's packets, or not",
    paper: "beyond the paper (its packets keep their lanes through every bounce)",
    csv: &[FILE],
    plots: &["regroup_speedup"],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

const FILE: &str = "regroup.csv";
const HEADER: &[&str] = &[
    "scene",
    "backend",
    "lanes",
    "regroup",
    "seconds",
    "speedup",
    "secondary_packets",
    "secondary_lanes",
    "psnr_db",
    "spread",
];

/// Timed rounds per scene and backend, each way.
const ROUNDS: usize = 5;

/// The packet widths compared, each on its preferred backend usable here
/// ([`Backend::preferred_for_lanes`]: the hand-written one on x86-64, pulp4 or wide on aarch64).
const WIDTHS: [usize; 3] = [4, 8, 16];

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let plan = crate::table3::plan(ctx);
    let mut backends = Vec::new();
    for n in WIDTHS {
        match Backend::preferred_for_lanes(n) {
            Some(b) => backends.push(b),
            None => ctx.note(format!("regroup: no {n}-lane backend usable here")),
        }
    }
    if backends.is_empty() {
        ctx.note("regroup: no packet backend usable here; nothing to compare");
        return Ok(());
    }
    run_plan(ctx, &plan, &backends)
}

/// Runs the experiment over `plan` with these backends.
pub fn run_plan(ctx: &mut Ctx, plan: &Plan, backends: &[Backend]) -> anyhow::Result<()> {
    let pool = frames::pool(1)?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let specs = frames::scene_specs(plan);
    let bar = ctx.progress(specs.len() as u64, "regroup");
    for (name, spec) in &specs {
        bar.set_message(name.clone());
        let Some(scene) = frames::load_or_note(ctx, "regroup", plan, name, spec) else {
            bar.inc(1);
            continue;
        };
        if scene.depth == 0 {
            bar.inc(1);
            continue; // camera rays only: nothing to regroup
        }
        let mut r = frames::renderer(&scene, AccelKind::Bsp)?;
        for &b in backends {
            // Untimed: images and packet counts.
            let mut images = Vec::new();
            let mut stats: Vec<RenderStats> = Vec::new();
            for regroup in [false, true] {
                r.regroup = regroup;
                let (rendered, _) = frames::frame(&pool, b, &r, plan)?;
                images.push(rendered.displayed(Backend::Scalar)?);
                stats.push(rendered.stats);
            }
            if stats[0].depth.len() < 2 {
                // No surface reflects or refracts: no secondary packets, with any backend.
                break;
            }
            let mut seconds: BTreeMap<bool, Vec<f64>> = BTreeMap::new();
            for round in 0..ROUNDS {
                let order = if round % 2 == 0 {
                    [false, true]
                } else {
                    [true, false]
                };
                for regroup in order {
                    r.regroup = regroup;
                    let (_, s) = frames::frame(&pool, b, &r, plan)?;
                    seconds.entry(regroup).or_default().push(s);
                }
            }
            let off = median(&seconds[&false]);
            for (i, regroup) in [false, true].into_iter().enumerate() {
                let s = median(&seconds[&regroup]);
                let spread = spread(&seconds[&regroup]);
                let (packets, lanes) = secondary(&stats[i]);
                let db = if regroup {
                    psnr(&images[1], &images[0], 1.0)
                } else {
                    f64::INFINITY
                };
                let cells: [&dyn Display; 10] = [
                    name,
                    &b.name(),
                    &b.lanes(),
                    &if regroup { "on" } else { "off" },
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(off, s)),
                    &packets,
                    &format!("{:.3}", lanes as f64 / packets.max(1) as f64),
                    &format!("{db:.2}"),
                    &format!("{spread:.3}"),
                ];
                csv.row(&cells)?;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

/// What the rows say, from `(speedup, noise)` per row (`noise`: the larger `spread` of the
/// row's two ways, slowest round over fastest): the range and geometric mean of the
/// speedups, and which rows moved by more than their own rounds spread (a row whose speedup
/// `g` has `1/noise <= g <= noise` cannot tell regrouping from run-to-run noise).
fn verdict(rows: &[(f64, f64)]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &(g, _)| {
            (a.min(g), b.max(g))
        });
    let gm = (rows.iter().map(|&(g, _)| g.ln()).sum::<f64>() / rows.len() as f64).exp();
    let noise: Vec<f64> = rows.iter().map(|&(_, n)| n).collect();
    let (nlo, nhi) = noise
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &n| (a.min(n), b.max(n)));
    let outside: Vec<String> = rows
        .iter()
        .filter(|&&(g, n)| g > n || g < 1.0 / n)
        .map(|&(g, _)| format!("{g:.2}x"))
        .collect();
    let mut md = format!(
        "\nRegrouped over not: {lo:.2}x to {hi:.2}x, geometric mean {gm:.3}x over {} \
         row(s). The repeated rounds of one frame spread by {:.0}% to {:.0}% (slowest round \
         over fastest, median {:.0}%): that is this run's noise, measured on the frames \
         compared. {} row(s) moved by more than their own rounds spread{}.",
        rows.len(),
        (nlo - 1.0) * 100.0,
        (nhi - 1.0) * 100.0,
        (median(&noise) - 1.0) * 100.0,
        outside.len(),
        if outside.is_empty() {
            String::new()
        } else {
            format!(" ({})", outside.join(", "))
        }
    );
    md.push_str(
        " The renderer keeps it off by default (`coherent render --regroup` turns it on).\n",
    );
    md
}

/// The spread of repeated timings: the slowest over the fastest.
fn spread(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    hi / lo
}

/// Packets and active lanes of the reflection and refraction packets (depth 1 and deeper).
fn secondary(s: &RenderStats) -> (u64, u64) {
    s.depth
        .iter()
        .skip(1)
        .fold((0, 0), |(p, l), c| (p + c.packets, l + c.lanes))
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(());
    };
    let scenes = t.distinct("scene")?;
    let mut series = Vec::new();
    for b in t.distinct("backend")? {
        let mut v = Vec::new();
        for s in &scenes {
            let mut x = f64::NAN;
            for r in t.rows_where("scene", s)? {
                if t.get(r, "backend")? == b && t.get(r, "regroup")? == "on" {
                    x = t.f64(r, "speedup")?;
                }
            }
            v.push(x);
        }
        series.push((b, v));
    }
    if series.is_empty() {
        return Ok(());
    }
    ctx.bar_chart(
        "regroup_speedup",
        &BarChart {
            title: "Regrouped secondary packets: frame speedup over not regrouping (BSP)".into(),
            y_label: "speedup (1 = no change)".into(),
            categories: scenes,
            series,
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut md = format!(
        "The frames of `table3` that trace reflection or refraction rays (same scenes, size \
         and samples; BSP; one thread), each width's preferred backend with the renderer's \
         secondary packets as they come (`off`: a packet keeps its parent's lanes, as in the \
         paper) and regrouped (`on`: per node of the ray tree, the partial packets of a film \
         tile compacted into full packets; full ones pass as they are). One untimed frame each way gives the \
         packet counts and the images (PSNR of the regrouped image against the other as \
         displayed: they differ by rounding and by edge hits), then {ROUNDS} rounds alternate \
         them (which goes first alternates too); `seconds` is the median, `rounds spread` \
         the slowest round over the fastest of either way (the noise of that row). \
         `secondary lanes` is the average active lanes per reflection or refraction \
         packet.\n\n",
    );
    let mut rows = Vec::new();
    let mut gains = Vec::new();
    for s in t.distinct("scene")? {
        for b in t.distinct("backend")? {
            let mut off = None;
            let mut on = None;
            for r in t.rows_where("scene", &s)? {
                if t.get(r, "backend")? != b {
                    continue;
                }
                if t.get(r, "regroup")? == "on" {
                    on = Some(r);
                } else {
                    off = Some(r);
                }
            }
            let (Some(off), Some(on)) = (off, on) else {
                continue;
            };
            let lanes = t.get(on, "lanes")?.to_owned();
            let gain = t.f64(on, "speedup")?;
            let noise = t.f64(off, "spread")?.max(t.f64(on, "spread")?);
            gains.push((gain, noise));
            rows.push(vec![
                s.clone(),
                format!("{b} ({lanes})"),
                format!(
                    "{} / {}",
                    fmt_num(t.f64(off, "secondary_lanes")?),
                    fmt_num(t.f64(on, "secondary_lanes")?)
                ),
                format!(
                    "{} / {}",
                    t.get(off, "secondary_packets")?,
                    t.get(on, "secondary_packets")?
                ),
                format!(
                    "{} / {}",
                    fmt_num(t.f64(off, "seconds")?),
                    fmt_num(t.f64(on, "seconds")?)
                ),
                format!("{gain:.3}"),
                format!("{:.3}", noise),
                fmt_num(t.f64(on, "psnr_db")?),
            ]);
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "backend (lanes)",
            "secondary lanes off / on",
            "secondary packets off / on",
            "seconds off / on",
            "speedup",
            "rounds spread",
            "PSNR dB",
        ],
        &rows,
    ));
    md.push_str(&verdict(&gains));
    md.push_str(
        &ctx.plot_markdown(
            "regroup_speedup",
            "frame speedup of regrouped secondary packets",
        )
        .unwrap_or_default(),
    );
    Ok(Some(md))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_ways_per_backend_the_same_image_and_a_report() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let plan = Plan {
            builtins: true,
            scenes_dir: dir.path().join("no-scenes"),
            max_triangles: 1_000,
            width: 16,
            height: 12,
            spp: 1,
        };
        // The widest backend here (scalar in the build without SIMD backends: one lane, so
        // regrouping has nothing to fill, but the two ways must still agree).
        let b = frames::widest();
        run_plan(&mut ctx, &plan, &[b]).unwrap();
        let t = ctx.read_csv(FILE, HEADER).unwrap().unwrap();
        // spdemo (988 triangles, mirror spheres: depth 2) is the only built-in under 1,000.
        assert_eq!(t.distinct("scene").unwrap(), ["spdemo"]);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.get(0, "regroup").unwrap(), "off");
        assert_eq!(t.f64(0, "speedup").unwrap(), 1.0);
        let (off, on) = (
            t.f64(0, "secondary_lanes").unwrap(),
            t.f64(1, "secondary_lanes").unwrap(),
        );
        assert!(on >= off && on <= b.lanes() as f64, "{off} -> {on}");
        assert!(t.f64(1, "psnr_db").unwrap() >= 60.0);
        for row in 0..2 {
            assert!(t.f64(row, "spread").unwrap() >= 1.0);
        }
        let md = report(&ctx).unwrap().unwrap();
        let row = format!("| spdemo | {} ({}) |", b.name(), b.lanes());
        assert!(md.contains(&row), "{md}");
        assert!(md.contains("Regrouped over not:"), "{md}");
    }
}
