//! The table3 plots: speedup per scene and backend, the factors, the breakdown and stage
//! efficiency, coherence by depth and the tile-shared light samples.

use super::report::{StageSpeedups, stage_speedups};
use super::*;
use crate::ctx::Ctx;
use crate::factors;
use crate::plot::{BarChart, LineChart, Series};
use crate::timing::median;

pub(super) fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    factors::plot(ctx)?;
    speedup(ctx)?;
    light_samples(ctx)?;
    breakdown(ctx)?;
    coherence(ctx)
}

/// Table 3's speedups per scene and backend, beside the paper's.
fn speedup(ctx: &Ctx) -> anyhow::Result<()> {
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
    Ok(())
}

/// Speedup over scalar with per-pixel light samples beside shared ones.
fn light_samples(ctx: &Ctx) -> anyhow::Result<()> {
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
    Ok(())
}

/// Where the time goes, and each stage's speedup per lane.
fn breakdown(ctx: &Ctx) -> anyhow::Result<()> {
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
    Ok(())
}

/// Active lanes per packet by ray depth.
fn coherence(ctx: &Ctx) -> anyhow::Result<()> {
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
                    log_y: false,
                },
            )?;
        }
    }
    Ok(())
}
