//! The accel plots: the BSP's speedup per width, Mrays/s per scene, and per ray kind,
//! build time and memory per structure.

use coherent::accel_any::AccelKind;
use coherent_accel::workload::RayKind;

use super::HEADER;
use super::report::{rates, read_either, read_rows};
use crate::ctx::Ctx;
use crate::plot::{BarChart, LineChart, Series};

pub(super) fn plots(ctx: &Ctx) -> anyhow::Result<()> {
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
            log_y: false,
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
        for a in AccelKind::compared().map(AccelKind::name) {
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
        let series = AccelKind::compared()
            .map(AccelKind::name)
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
