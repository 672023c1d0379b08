//! Frames with the map (`imaps_frames.csv`): what the map's indirect light costs a frame,
//! and, on cornell, whether it agrees with a path tracer's.
//!
//! Protocol, per scene: the map (BSP, the widest backend, sorted streams) is built first
//! with every thread and timed apart. Then, in a pool of one thread, one untimed frame each
//! way (direct light only, and with the map), then `rounds` rounds of one frame each way,
//! which goes first alternating; medians. On cornell, with every thread: a path-traced
//! reference of `2 h` samples per pixel, its first half (`h` samples: the film's uniform
//! passes are the first `h` of the `2 h`) and the map's image at `2 h` samples. Images are
//! compared as the mean radiance (three channels averaged) of 8 x 8 pixel blocks: the map's
//! disagreement is the mean absolute difference of its blocks from the reference's; the
//! reference's own noise is that of the reference from its first half (which is half the
//! difference of its two independent halves), both over the reference's mean.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::sync::Arc;

use anyhow::Context;
use coherent::accel_any::AccelKind;
use coherent::film::{FilmOptions, Method};
use coherent::illum::{MapOptions, Mode, build_map};
use coherent::median::median;
use coherent::render::{Indirect, render_frame};
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::frames::{self as film_frames, Plan};

pub const FILE: &str = "imaps_frames.csv";
pub const HEADER: &[&str] = &[
    "scene",
    "backend",
    "accel",
    "width",
    "height",
    "spp",
    "particles",
    "map_s",
    "direct_s",
    "imap_s",
    "ratio",
    "rounds",
    "path_spp",
    "block_diff",
    "path_noise",
];

/// The scene whose map is checked against path tracing.
const AGREEMENT_SCENE: &str = "cornell";

/// The side of the square blocks images are compared over, in pixels.
const BLOCK: usize = 8;

/// The frames' size and samples (the scenes load at this size).
pub(super) fn plan(ctx: &Ctx) -> Plan {
    let (width, height) = ctx.pick((128, 96), (320, 240));
    Plan {
        builtins: true,
        scenes_dir: film_frames::scenes_dir(),
        max_triangles: usize::MAX,
        width,
        height,
        spp: 1,
    }
}

pub(super) fn run(ctx: &mut Ctx, scenes: &[(String, Box<RenderScene>)]) -> anyhow::Result<()> {
    let plan = plan(ctx);
    let particles: u64 = ctx.pick(400_000, 4_000_000);
    let rounds = ctx.pick(3, 5);
    let half: u32 = ctx.pick(8, 64);
    run_with(ctx, scenes, &plan, particles, rounds, half)
}

/// Measures `scenes` (loaded at the plan's size) with maps of `particles` particles,
/// `rounds` timed rounds, and a path-traced reference of `2 half` samples per pixel.
pub(super) fn run_with(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    plan: &Plan,
    particles: u64,
    rounds: usize,
    half: u32,
) -> anyhow::Result<()> {
    let backend = Backend::widest();
    let one = film_frames::pool(1)?;
    let every = film_frames::pool(
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
    )?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress(scenes.len() as u64, "imaps frm");
    for (name, scene) in scenes {
        bar.set_message(name.clone());
        let mut r = film_frames::renderer(scene, AccelKind::Bsp)?;
        // Without caustics: the path tracer it is checked against cannot find light that
        // reaches a diffuse surface through a mirror or glass first (lights are not geometry).
        let opts = MapOptions {
            particles,
            mode: Mode::Sorted,
            caustics: false,
            ..MapOptions::default()
        };
        let start = std::time::Instant::now();
        let (map, _) = every
            .install(|| build_map(backend, scene, r.accel(), &opts, &|_| {}))
            .with_context(|| format!("the illumination map of {name}"))?;
        let map_s = start.elapsed().as_secs_f64();
        let imap = Indirect::Map(Arc::new(map));

        let ways = [Indirect::None, imap.clone()];
        for w in &ways {
            r.indirect = w.clone();
            film_frames::frame(&one, backend, &r, plan)?;
        }
        let mut seconds: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
        for round in 0..rounds {
            for k in 0..ways.len() {
                let i = (k + round) % ways.len();
                r.indirect = ways[i].clone();
                let (_, s) = film_frames::frame(&one, backend, &r, plan)?;
                seconds.entry(i).or_default().push(s);
            }
        }
        let (direct_s, imap_s) = (median(&seconds[&0]), median(&seconds[&1]));

        let (mut diff, mut noise, mut path_spp) = (f64::NAN, f64::NAN, 0);
        if name == AGREEMENT_SCENE {
            path_spp = 2 * half;
            let render = |r: &coherent::render::Renderer<'_, _>, spp: u32| {
                let opts = FilmOptions::new(plan.width, plan.height, Method::Uniform { spp });
                every.install(|| render_frame(backend, r, &opts, &|_| {}))
            };
            r.indirect = Indirect::path();
            let reference = render(&r, path_spp)?.image();
            let first_half = render(&r, half)?.image();
            r.indirect = imap;
            let mapped = render(&r, path_spp)?.image();
            let w = plan.width as usize;
            let (b_ref, mean) = blocks(&reference, w);
            let (b_half, _) = blocks(&first_half, w);
            let (b_map, _) = blocks(&mapped, w);
            diff = mean_abs(&b_map, &b_ref) / mean;
            noise = mean_abs(&b_half, &b_ref) / mean;
        }
        let cells: [&dyn Display; 15] = [
            name,
            &backend.name(),
            &AccelKind::Bsp.name(),
            &plan.width,
            &plan.height,
            &plan.spp,
            &particles,
            &format!("{map_s:.4}"),
            &format!("{direct_s:.6}"),
            &format!("{imap_s:.6}"),
            &format!("{:.4}", imap_s / direct_s),
            &rounds,
            &path_spp,
            &format!("{diff:.5}"),
            &format!("{noise:.5}"),
        ];
        csv.row(&cells)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

/// The mean radiance (channels averaged) of each whole `BLOCK` x `BLOCK` block of an image
/// `width` pixels wide, row by row, and the image's mean over those blocks.
fn blocks(px: &[[f32; 3]], width: usize) -> (Vec<f64>, f64) {
    let height = px.len() / width.max(1);
    let (bw, bh) = (width / BLOCK, height / BLOCK);
    let mut out = Vec::with_capacity(bw * bh);
    for by in 0..bh {
        for bx in 0..bw {
            let mut sum = 0.0f64;
            for y in by * BLOCK..(by + 1) * BLOCK {
                for x in bx * BLOCK..(bx + 1) * BLOCK {
                    let p = px[y * width + x];
                    sum += f64::from(p[0] + p[1] + p[2]) / 3.0;
                }
            }
            out.push(sum / (BLOCK * BLOCK) as f64);
        }
    }
    let mean = out.iter().sum::<f64>() / out.len().max(1) as f64;
    (out, mean)
}

/// The mean absolute difference of two lists of the same length.
fn mean_abs(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| (a - b).abs()).sum::<f64>() / a.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_average_whole_blocks_only() {
        // 17 x 9 pixels: two whole blocks across, one down; the last column and row dropped.
        let w = 17;
        let px: Vec<[f32; 3]> = (0..w * 9)
            .map(|i| {
                let x = i % w;
                let v = if x < BLOCK { 1.0 } else { 3.0 };
                [v, v, v]
            })
            .collect();
        let (b, mean) = blocks(&px, w);
        assert_eq!(b, vec![1.0, 3.0]);
        assert_eq!(mean, 2.0);
        assert_eq!(mean_abs(&b, &[2.0, 2.0]), 1.0);
    }
}
