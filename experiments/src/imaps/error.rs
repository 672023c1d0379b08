//! The map's error against the particles traced (`imaps_error.csv`): a Monte-Carlo
//! estimate's error falls as one over the square root of its samples, so the fitted slope of
//! log error against log particles should be -1/2.
//!
//! Protocol, per scene (BSP, the widest backend, sorted streams; the map does not depend on
//! the mode): a reference map of 100 times the largest budget (every thread), then per
//! budget, over two decades, maps from several seeds independent of the reference's, each in
//! a pool of one thread. A map's error is [`relative_error`] against the reference; a
//! budget's is the root mean square over its seeds (an estimate of the expected squared
//! error, which the slope is about), with the smallest and largest beside it.

use std::fmt::Display;
use std::time::Instant;

use anyhow::{Context, ensure};
use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::illum::{IllumMap, MapOptions, Mode, build_map};
use coherent::median::median;
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use crate::ctx::Ctx;

pub const FILE: &str = "imaps_error.csv";
pub const HEADER: &[&str] = &[
    "scene",
    "accel",
    "backend",
    "mode",
    "particles",
    "seeds",
    "rel_error",
    "rel_error_min",
    "rel_error_max",
    "seconds",
    "reference_particles",
    "reference_s",
];

/// How many times the largest budget's particles the reference traces.
pub const REFERENCE_FACTOR: u64 = 100;

/// The seed of the reference's particles; the budgets' seeds count up from 1.
const REFERENCE_SEED: u32 = 0x5eed;

/// The mode the maps are built in (any gives the same map).
const MODE: Mode = Mode::Sorted;

/// The relative error of `map` against `reference`, cell by cell over the same cells: the
/// root mean square, over cells weighted by their area, of the irradiance difference (its
/// three channels' squares averaged), over the reference's mean irradiance weighted alike
/// (its three channels averaged). 0 for equal maps; about 1 for an empty map against a
/// uniform reference.
pub fn relative_error(map: &IllumMap, reference: &IllumMap) -> anyhow::Result<f64> {
    let (e, r) = (map.cell_irradiance(), reference.cell_irradiance());
    let (a, ra) = (map.cell_area(), reference.cell_area());
    ensure!(
        e.len() == r.len() && a.len() == e.len() && ra.len() == r.len(),
        "the maps compared have different cells ({} and {})",
        e.len(),
        r.len()
    );
    let (mut area, mut sq, mut mean) = (0.0f64, 0.0f64, 0.0f64);
    for ((e, r), &a) in e.iter().zip(r).zip(ra) {
        let a = f64::from(a);
        let d: f64 = (0..3)
            .map(|c| (f64::from(e[c]) - f64::from(r[c])).powi(2))
            .sum();
        area += a;
        sq += a * d / 3.0;
        mean += a * r.iter().map(|&v| f64::from(v)).sum::<f64>() / 3.0;
    }
    ensure!(
        area > 0.0 && mean > 0.0,
        "the reference map receives no light"
    );
    Ok((sq / area).sqrt() / (mean / area))
}

/// The least-squares slope of `ln y` against `ln x` over the points with both positive and
/// finite; NaN with fewer than two distinct x.
pub fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if pts.len() < 2 || sxx <= 0.0 {
        return f64::NAN;
    }
    sxy / sxx
}

/// The particle budgets: two decades, half a decade apart (quick: one and a half decades
/// from a smaller start).
fn budgets(ctx: &Ctx) -> Vec<u64> {
    ctx.pick(
        vec![500, 1_581, 5_000, 15_811],
        vec![1_000, 3_162, 10_000, 31_623, 100_000],
    )
}

pub(super) fn run(ctx: &mut Ctx, scenes: &[(String, Box<RenderScene>)]) -> anyhow::Result<()> {
    let budgets = budgets(ctx);
    let seeds: u32 = ctx.pick(2, 4);
    run_with(ctx, scenes, &budgets, seeds)
}

/// Measures `scenes` at these particle budgets, `seeds` maps each.
pub(super) fn run_with(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    budgets: &[u64],
    seeds: u32,
) -> anyhow::Result<()> {
    let largest = budgets.iter().copied().max().unwrap_or(0);
    let reference_particles = REFERENCE_FACTOR * largest;
    let backend = Backend::widest();
    let one = crate::frames::pool(1)?;
    let every = crate::frames::pool(
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
    )?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress(scenes.len() as u64, "imaps err");
    for (name, scene) in scenes {
        bar.set_message(name.clone());
        let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))
            .with_context(|| format!("building the BSP for {name}"))?;
        let build = |pool: &rayon::ThreadPool,
                     particles: u64,
                     seed: u32|
         -> anyhow::Result<(IllumMap, f64)> {
            let opts = MapOptions {
                particles,
                mode: MODE,
                seed,
                ..MapOptions::default()
            };
            let start = Instant::now();
            let (map, _) = pool
                .install(|| build_map(backend, scene, &accel, &opts, &|_| {}))
                .with_context(|| {
                    format!("the illumination map of {name}, {particles} particles")
                })?;
            Ok((map, start.elapsed().as_secs_f64()))
        };
        let (reference, reference_s) = build(&every, reference_particles, REFERENCE_SEED)?;
        for &particles in budgets {
            let mut errors = Vec::new();
            let mut seconds = Vec::new();
            for seed in 1..=seeds {
                let (map, s) = build(&one, particles, seed)?;
                errors.push(relative_error(&map, &reference)?);
                seconds.push(s);
            }
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
            let (lo, hi) = errors
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &e| (a.min(e), b.max(e)));
            let cells: [&dyn Display; 12] = [
                name,
                &AccelKind::Bsp.name(),
                &backend.name(),
                &MODE.name(),
                &particles,
                &seeds,
                &format!("{rms:.5e}"),
                &format!("{lo:.5e}"),
                &format!("{hi:.5e}"),
                &format!("{:.6}", median(&seconds)),
                &reference_particles,
                &format!("{reference_s:.3}"),
            ];
            csv.row(&cells)?;
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e3, 1e4, 1e5]
            .iter()
            .map(|&n: &f64| (n, 3.0 / n.sqrt()))
            .collect();
        assert!((log_log_slope(&pts) + 0.5).abs() < 1e-12);
        assert!(log_log_slope(&pts[..1]).is_nan());
        assert!(log_log_slope(&[(1.0, 1.0), (1.0, 2.0)]).is_nan());
    }
}
