//! The plots of `imaps`, from its CSV files: rays per second per generation and mode (one
//! plot per scene), and the map's error against particles and against seconds (log-log,
//! with the 1/sqrt line the error should follow).

use coherent::simd::Backend;

use super::{error, speed};
use crate::ctx::Ctx;
use crate::plot::{LineChart, Series};
use crate::table::Table;

/// The backend the speed plots and the sorted-streams target read: the preferred 16-lane
/// backend among those in the CSV (avx512, then pulp16, then wide16), else the widest there.
pub fn target_backend(t: &Table) -> anyhow::Result<Option<String>> {
    let names = t.distinct("backend")?;
    for lanes in [16, 8, 4, 1] {
        if let Some(b) = Backend::preference(lanes)
            .into_iter()
            .find(|b| names.iter().any(|n| n == b.name()))
        {
            return Ok(Some(b.name().to_owned()));
        }
    }
    // Backends outside the preferences: the one with the most lanes.
    let mut best: Option<(f64, String)> = None;
    for r in 0..t.len() {
        let lanes = t.f64(r, "lanes")?;
        if best.as_ref().is_none_or(|(l, _)| lanes > *l) {
            best = Some((lanes, t.get(r, "backend")?.to_owned()));
        }
    }
    Ok(best.map(|(_, b)| b))
}

/// The stem of the rays-per-second plot of `scene`.
pub fn rays_stem(scene: &str) -> String {
    format!("imaps_rays_{scene}")
}

pub const ERROR_PARTICLES: &str = "imaps_error_particles";
pub const ERROR_SECONDS: &str = "imaps_error_seconds";

pub(super) fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    if let Some(t) = ctx.read_csv(speed::FILE, speed::HEADER)? {
        rays(ctx, &t)?;
    }
    if let Some(t) = ctx.read_csv(error::FILE, error::HEADER)? {
        errors(ctx, &t)?;
    }
    Ok(())
}

/// Per scene, Mrays/s against generation, one line per mode and accelerator, at the
/// [`target_backend`].
fn rays(ctx: &Ctx, t: &Table) -> anyhow::Result<()> {
    let Some(backend) = target_backend(t)? else {
        return Ok(());
    };
    for scene in t.distinct("scene")? {
        let rows = t.rows_where("scene", &scene)?;
        let mut series = Vec::new();
        for accel in t.distinct("accel")? {
            for mode in t.distinct("mode")? {
                let mut points = Vec::new();
                for &r in &rows {
                    if t.get(r, "accel")? == accel
                        && t.get(r, "mode")? == mode
                        && t.get(r, "backend")? == backend
                    {
                        points.push((t.f64(r, "generation")?, t.f64(r, "mrays_per_s")?));
                    }
                }
                if !points.is_empty() {
                    series.push(Series::new(format!("{mode} ({accel})"), points));
                }
            }
        }
        if series.is_empty() {
            continue;
        }
        ctx.line_chart(
            &rays_stem(&scene),
            &LineChart {
                title: format!(
                    "Illumination map, {scene}: particle rays per second ({backend}, 1 thread)"
                ),
                x_label: format!(
                    "generation (the last point sums generations {} on)",
                    speed::KEPT_GENERATIONS
                ),
                y_label: "million rays per second (tracing)".into(),
                series,
                log2_x: false,
                log_y: false,
            },
        )?;
    }
    Ok(())
}

/// The error against particles and against seconds, one line per scene, and a dashed
/// 1/sqrt line through the scenes' geometric mean at the smallest x.
fn errors(ctx: &Ctx, t: &Table) -> anyhow::Result<()> {
    for (stem, x_col, x_label) in [
        (ERROR_PARTICLES, "particles", "particles"),
        (ERROR_SECONDS, "seconds", "seconds (1 thread)"),
    ] {
        let mut series = Vec::new();
        for scene in t.distinct("scene")? {
            let mut points = Vec::new();
            for r in t.rows_where("scene", &scene)? {
                points.push((t.f64(r, x_col)?, t.f64(r, "rel_error")?));
            }
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            series.push(Series::new(scene, points));
        }
        if let Some(line) = sqrt_line(&series) {
            series.push(Series::reference("1/sqrt", line));
        }
        if series.is_empty() {
            continue;
        }
        ctx.line_chart(
            stem,
            &LineChart {
                title: format!("Illumination map: relative error against {x_label}"),
                x_label: x_label.into(),
                y_label: "relative RMS error against the reference map".into(),
                series,
                log2_x: true,
                log_y: true,
            },
        )?;
    }
    Ok(())
}

/// `c / sqrt(x)` over the range of the series' x, through the geometric mean of their first
/// points.
fn sqrt_line(series: &[Series]) -> Option<Vec<(f64, f64)>> {
    let firsts: Vec<(f64, f64)> = series
        .iter()
        .filter_map(|s| s.points.first().copied())
        .filter(|&(x, y)| x > 0.0 && y > 0.0)
        .collect();
    if firsts.is_empty() {
        return None;
    }
    let n = firsts.len() as f64;
    let x0 = (firsts.iter().map(|p| p.0.ln()).sum::<f64>() / n).exp();
    let y0 = (firsts.iter().map(|p| p.1.ln()).sum::<f64>() / n).exp();
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (lo, hi) = xs
        .filter(|&x| x > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    Some(
        [lo, hi]
            .iter()
            .map(|&x| (x, y0 * (x0 / x).sqrt()))
            .collect(),
    )
}
