//! Frames per colour form (`spectral_frames.csv`): what a spectral frame costs beside the
//! RGB frame of the same scene and backend, and where the time goes.
//!
//! Protocol, per scene (the paper's four, at the plan's size, 1 sample per pixel, BSP, a
//! pool of one thread) and hand-written backend: per form (rgb, hero, bins32 over rays and
//! over wavelengths) one untimed frame with the stage clocks on (`Renderer::time_stages`,
//! as `coherent render --stages`), which gives the stage shares and the rays traced (every
//! kind: camera, shadow, reflection, refraction); then `rounds`
//! rounds of one frame per backend and form with the clocks off, the forms' order rotating
//! from round to round; medians. `ratio` = this row's seconds over the `rgb` row's of the
//! same scene and backend. The shares are each stage's seconds (the clock's own cost taken
//! out) over their sum.

use std::collections::BTreeMap;
use std::fmt::Display;

use coherent::accel_any::AccelKind;
use coherent::median::median;
use coherent::render::Stage;
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::frames::{self as film_frames, Plan};

pub const FILE: &str = "spectral_frames.csv";
/// The shares are one per [`Stage`], in `Stage::ALL`'s order (a test checks).
pub const HEADER: &[&str] = &[
    "scene",
    "backend",
    "lanes",
    "colour",
    "channels",
    "layout",
    "width",
    "height",
    "spp",
    "threads",
    "seconds",
    "ratio",
    "rays",
    "rounds",
    "share_traversal",
    "share_shadows",
    "share_shading",
    "share_lights",
    "share_other",
];

/// The frames' size and samples (the scenes load at this size).
pub(super) fn plan(ctx: &Ctx) -> Plan {
    let (width, height) = ctx.pick((64, 48), (256, 192));
    Plan {
        builtins: true,
        scenes_dir: film_frames::scenes_dir(),
        max_triangles: usize::MAX,
        width,
        height,
        spp: 1,
    }
}

pub(super) fn run(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    backends: &[Backend],
    plan: &Plan,
) -> anyhow::Result<()> {
    let rounds = ctx.pick(2, 3);
    run_with(ctx, scenes, backends, plan, rounds)
}

/// Measures `scenes` (loaded at the plan's size) on `backends` (hand-written ones), `rounds`
/// timed rounds.
pub(super) fn run_with(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    backends: &[Backend],
    plan: &Plan,
    rounds: usize,
) -> anyhow::Result<()> {
    let forms = super::frame_forms();
    let one = film_frames::pool(1)?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress((scenes.len() * (1 + rounds)) as u64, "spec frm");
    for (name, scene) in scenes {
        bar.set_message(name.clone());
        let mut r = film_frames::renderer(scene, AccelKind::Bsp)?;
        // The untimed frames with the stage clocks on: shares and rays.
        let mut staged: BTreeMap<(Backend, usize), ([f64; Stage::COUNT], u64)> = BTreeMap::new();
        r.time_stages = true;
        for &b in backends {
            for (k, form) in forms.iter().enumerate() {
                r.set_colour(*form)?;
                let (rendered, _) = film_frames::frame(&one, b, &r, plan)?;
                let secs = rendered.stats.stage_seconds();
                let total: f64 = secs.iter().sum();
                let shares = secs.map(|s| if total > 0.0 { s / total } else { f64::NAN });
                staged.insert((b, k), (shares, rendered.stats.total_rays()));
            }
        }
        bar.inc(1);
        r.time_stages = false;
        let mut seconds: BTreeMap<(Backend, usize), Vec<f64>> = BTreeMap::new();
        for round in 0..rounds {
            for &b in backends {
                for i in 0..forms.len() {
                    let k = (i + round) % forms.len();
                    r.set_colour(forms[k])?;
                    let (_, s) = film_frames::frame(&one, b, &r, plan)?;
                    seconds.entry((b, k)).or_default().push(s);
                }
            }
            bar.inc(1);
        }
        for &b in backends {
            let rgb = median(&seconds[&(b, 0)]);
            for (k, form) in forms.iter().enumerate() {
                let s = median(&seconds[&(b, k)]);
                let (shares, rays) = staged[&(b, k)];
                let shares: Vec<String> = shares.iter().map(|x| format!("{x:.4}")).collect();
                let (backend, lanes) = (b.name(), b.lanes());
                let label = form.label();
                let channels = form.channels();
                let layout = super::layout_name(form);
                let (seconds, ratio) = (format!("{s:.6}"), format!("{:.4}", s / rgb));
                let mut cells: Vec<&dyn Display> = vec![
                    name,
                    &backend,
                    &lanes,
                    &label,
                    &channels,
                    &layout,
                    &plan.width,
                    &plan.height,
                    &plan.spp,
                    &1,
                    &seconds,
                    &ratio,
                    &rays,
                    &rounds,
                ];
                cells.extend(shares.iter().map(|s| s as &dyn Display));
                csv.row(&cells)?;
            }
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}
