//! Experiment `maps`: where coherence breaks, per pixel. The paper says its packets lose
//! coherence with depth; the renderer's per-pixel maps (`coherent render --aov`, see
//! `coherent::render::aov`) show where on the image they do, for single rays, lane packets
//! and beams.
//!
//! Protocol: the paper's four scenes (our stand-ins, as `table3` renders them) at half
//! `table3`'s frame (quick: its frame), one sample per pixel, the BSP, one thread. Per scene
//! three ways: single rays (scalar), lane packets of the widest backend, and the same backend
//! with camera beams. One frame each with every map on; each map is written to
//! `images/maps/SCENE-WAY-KIND.png`, on one colour scale per scene and map across the three
//! ways (lanes: 0 to the backend's width), and summarised in `maps.csv` (mean, median, 95th
//! percentile and maximum over the pixels). The time maps are one frame's clock readings: noisy,
//! and they include the maps' own bookkeeping.

use std::fmt::Display;
use std::sync::Arc;

use coherent::accel_any::AccelKind;
use coherent::film::{scale_top, write_heatmap_png};
use coherent::render::{AovBuffer, AovKind, Packets};
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::{self, Plan};
use crate::table::{fmt_num, markdown_table};

pub const EXPERIMENT: Experiment = Experiment {
    name: "maps",
    description: "per-pixel maps of traversal steps, triangle tests, active lanes and time: single rays, lane packets, beams",
    paper: "beyond the paper (section 7: coherence falls with depth; here, where on the image)",
    csv: &[FILE],
    plots: &[],
    status: Status::Ready {
        run,
        plot: no_plots,
        report,
    },
};

const FILE: &str = "maps.csv";
const HEADER: &[&str] = &[
    "scene", "way", "backend", "packets", "kind", "mean", "p50", "p95", "max", "image",
];

/// A way of tracing: its name in results, backend and camera packets.
struct Way {
    name: &'static str,
    backend: Backend,
    packets: Packets,
}

fn ways() -> Vec<Way> {
    let wide = frames::widest();
    vec![
        Way {
            name: "single",
            backend: Backend::Scalar,
            packets: Packets::Lanes,
        },
        Way {
            name: "lanes",
            backend: wide,
            packets: Packets::Lanes,
        },
        Way {
            name: "beam",
            backend: wide,
            packets: Packets::Beam,
        },
    ]
}

/// The paper's scenes (our stand-ins), in the paper's order.
fn scenes() -> Vec<&'static str> {
    crate::table3::PAPER.rows.iter().map(|(s, _)| *s).collect()
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let mut plan = crate::table3::plan(ctx);
    if !ctx.quick {
        plan.width /= 2;
        plan.height /= 2;
    }
    run_plan(ctx, &plan, &scenes())
}

/// Runs the experiment over `scenes` (built-in names or files of `plan`).
pub fn run_plan(ctx: &mut Ctx, plan: &Plan, scenes: &[&str]) -> anyhow::Result<()> {
    let pool = frames::pool(1)?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    std::fs::create_dir_all(ctx.path("images/maps"))?;
    let ways = ways();
    let bar = ctx.progress(scenes.len() as u64, "maps");
    for &name in scenes {
        bar.set_message(name.to_owned());
        let Some(scene) = frames::load_or_note(ctx, "maps", plan, name, name) else {
            bar.inc(1);
            continue;
        };
        let mut r = frames::renderer(&scene, AccelKind::Bsp)?;
        let (w, h) = (plan.width, plan.height);
        // Every way's maps first: the colour scale is shared.
        let mut maps: Vec<Vec<Vec<f32>>> = Vec::new();
        for way in &ways {
            let buf = Arc::new(AovBuffer::new(w, h));
            r.aov = Some(buf.clone());
            r.packets = way.packets;
            frames::frame(&pool, way.backend, &r, plan)?;
            maps.push(AovKind::ALL.iter().map(|&k| buf.map(k)).collect());
        }
        r.aov = None;
        for (ki, &kind) in AovKind::ALL.iter().enumerate() {
            let top = match kind {
                AovKind::Lanes => frames::widest().lanes() as f32,
                _ => {
                    let all: Vec<f32> = maps.iter().flat_map(|m| m[ki].iter().copied()).collect();
                    scale_top(&all)
                }
            };
            for (way, m) in ways.iter().zip(&maps) {
                let image = format!("images/maps/{name}-{}-{}.png", way.name, kind.name());
                write_heatmap_png(&ctx.path(&image), &m[ki], w, h, top, kind.label())?;
                let s = summary(&m[ki]);
                let cells: [&dyn Display; 10] = [
                    &name,
                    &way.name,
                    &way.backend.name(),
                    &way.packets.name(),
                    &kind.name(),
                    &format!("{:.4}", s[0]),
                    &format!("{:.4}", s[1]),
                    &format!("{:.4}", s[2]),
                    &format!("{:.4}", s[3]),
                    &image,
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

/// Mean, median, 95th percentile and maximum of a map's pixels.
fn summary(v: &[f32]) -> [f64; 4] {
    if v.is_empty() {
        return [f64::NAN; 4];
    }
    let mut s: Vec<f64> = v.iter().map(|&x| f64::from(x)).collect();
    s.sort_unstable_by(f64::total_cmp);
    let at = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
    [
        s.iter().sum::<f64>() / s.len() as f64,
        at(0.5),
        at(0.95),
        s[s.len() - 1],
    ]
}

fn no_plots(_: &Ctx) -> anyhow::Result<()> {
    // The maps are pictures written by the run (they need the frames, not the CSV).
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut md = String::from(
        "Per pixel, what the packets that traced its rays did (the renderer's `--aov` maps, \
         `coherent::render::aov`): inner nodes visited and triangle tests per sample, charged \
         in full to every lane of a packet (what a ray sits through when it travels in that \
         packet), active lanes of those packets, and nanoseconds per sample. Single rays \
         (scalar) show what each ray needs alone; lane packets add the union of their rays' \
         paths where rays diverge; beams share the steps their rays take alike. One colour \
         scale per scene and map; one frame at 1 sample per pixel, the BSP, one thread.\n\n",
    );
    let scenes = t.distinct("scene")?;
    let ways = t.distinct("way")?;
    // The means, one row per scene and map.
    let mut rows = Vec::new();
    for s in &scenes {
        for k in AovKind::ALL {
            let mut row = vec![s.clone(), k.name().to_owned()];
            for way in &ways {
                let cell = (0..t.rows.len())
                    .find(|&r| {
                        t.get(r, "scene").ok() == Some(s)
                            && t.get(r, "way").ok() == Some(way)
                            && t.get(r, "kind").ok() == Some(k.name())
                    })
                    .map(|r| t.f64(r, "mean"))
                    .transpose()?;
                row.push(cell.map_or_else(|| "-".into(), fmt_num));
            }
            rows.push(row);
        }
    }
    let mut header = vec!["scene", "map (mean over pixels)"];
    header.extend(ways.iter().map(String::as_str));
    md.push_str(&markdown_table(&header, &rows));
    // The pictures: per scene, maps down, ways across.
    for s in &scenes {
        md.push_str(&format!("\n**{s}**\n\n"));
        let mut rows = Vec::new();
        for k in AovKind::ALL {
            let mut row = vec![k.name().to_owned()];
            for way in &ways {
                let image = format!("images/maps/{s}-{way}-{}.png", k.name());
                row.push(if ctx.path(&image).is_file() {
                    format!("<img src=\"{image}\" width=\"300\">")
                } else {
                    "-".into()
                });
            }
            rows.push(row);
        }
        let mut header = vec!["map"];
        header.extend(ways.iter().map(String::as_str));
        md.push_str(&markdown_table(&header, &rows));
    }
    Ok(Some(md))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_scene_gets_every_map_for_every_way() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let plan = Plan {
            builtins: true,
            scenes_dir: dir.path().join("none"),
            max_triangles: usize::MAX,
            width: 24,
            height: 16,
            spp: 1,
        };
        run_plan(&mut ctx, &plan, &["spdemo"]).unwrap();
        let t = ctx.read_csv(FILE, HEADER).unwrap().unwrap();
        assert_eq!(t.rows.len(), 3 * AovKind::ALL.len());
        for r in 0..t.rows.len() {
            assert!(ctx.path(t.get(r, "image").unwrap()).is_file());
            let kind: AovKind = t.get(r, "kind").unwrap().parse().unwrap();
            let mean = t.f64(r, "mean").unwrap();
            // Every pixel's camera ray enters the tree and meets a triangle.
            if kind != AovKind::Time {
                assert!(mean > 0.0, "{kind} of {}", t.get(r, "way").unwrap());
            }
            if kind == AovKind::Lanes && t.get(r, "way").unwrap() == "single" {
                assert_eq!(mean, 1.0);
            }
        }
        let md = report(&ctx).unwrap().unwrap();
        assert!(md.contains("images/maps/spdemo-beam-steps.png"), "{md}");
    }
}
