//! The measurements of one scene: every (accel, backend) frame untimed (images, statistics)
//! and timed in rounds, the builds, the factors, coherence by depth, the stage breakdown and
//! the tile-shared light samples.

use std::collections::BTreeMap;
use std::fmt::Display;

use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::bsp::BuildPreset;
use coherent::render::centres::psnr;
use coherent::render::{LightSamples, RenderStats, Renderer};
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use super::{
    BREAKDOWN_FILE, BREAKDOWN_HEADER, BUILDS_FILE, BUILDS_HEADER, COHERENCE_FILE, COHERENCE_HEADER,
    FILE, HEADER, LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER, ROUNDS, STAGES, plotted,
};
use crate::builds::TreeQuality;
use crate::ctx::Ctx;
use crate::factors;
use crate::frames::{self, Plan};
use crate::table::CsvOut;
use crate::timing::{median, speedup};

/// The files the run writes, but the list of what was skipped.
pub(super) struct Outputs {
    frames: CsvOut,
    breakdown: CsvOut,
    coherence: CsvOut,
    light_samples: CsvOut,
    factors: CsvOut,
    builds: CsvOut,
}

impl Outputs {
    pub(super) fn open(ctx: &Ctx) -> anyhow::Result<Self> {
        Ok(Self {
            frames: ctx.csv(FILE, HEADER)?,
            breakdown: ctx.csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)?,
            coherence: ctx.csv(COHERENCE_FILE, COHERENCE_HEADER)?,
            light_samples: ctx.csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)?,
            factors: ctx.csv(factors::FILE, factors::HEADER)?,
            builds: ctx.csv(BUILDS_FILE, BUILDS_HEADER)?,
        })
    }

    pub(super) fn finish(self) -> anyhow::Result<()> {
        self.frames.finish()?;
        self.breakdown.finish()?;
        self.coherence.finish()?;
        self.light_samples.finish()?;
        self.factors.finish()?;
        self.builds.finish()?;
        Ok(())
    }
}

/// Each accelerator's renderer over the scene, in the order of the accelerators asked for.
type Renderers<'s> = Vec<(AccelKind, Renderer<'s, AnyAccel>)>;

/// A renderer over the BSP built with one more preset, and the build's seconds.
type Built<'s> = (Renderer<'s, AnyAccel>, f64);

/// Per (index into the renderers, backend).
type PerFrame<T> = BTreeMap<(usize, Backend), T>;

/// What the untimed frames give: the reference image (scalar + BSP), each frame's PSNR
/// against it and its statistics.
struct FirstFrames {
    reference: Vec<[f32; 3]>,
    psnrs: PerFrame<f64>,
    stats: PerFrame<RenderStats>,
}

/// One scene of the run.
pub(super) struct SceneRun<'a> {
    pub name: &'a str,
    pub scene: &'a RenderScene,
    pub plan: &'a Plan,
    pub pool: &'a rayon::ThreadPool,
    pub backends: &'a [Backend],
}

impl SceneRun<'_> {
    /// Every measurement of the scene; a scene whose BSP cannot be built is left out (the
    /// reason is in `skipped`).
    pub(super) fn measure(
        &self,
        ctx: &mut Ctx,
        accels: &[AccelKind],
        out: &mut Outputs,
        skipped: &mut Vec<(String, String)>,
    ) -> anyhow::Result<()> {
        let (mut renderers, build_secs, presets) = self.renderers(ctx, accels, skipped)?;
        if renderers.first().map(|(k, _)| *k) != Some(AccelKind::Bsp) {
            return Ok(());
        }
        let first = self.first_frames(ctx, &renderers)?;
        let seconds = self.timed_frames(&renderers)?;
        self.frame_rows(&mut out.frames, &renderers, &first, &seconds)?;
        self.build_rows(&mut out.builds, &renderers, &build_secs, &presets)?;
        // Table 3 explained: arithmetic, culling, lanes and beams, each alone.
        factors::measure(
            &mut out.factors,
            self.pool,
            self.name,
            &mut renderers,
            self.backends,
            self.plan,
            &first.reference,
        )?;
        self.coherence_rows(&mut out.coherence, &first.stats)?;
        let (_, r) = &mut renderers[0];
        self.breakdown_rows(&mut out.breakdown, r)?;
        // Light samples shared per tile: the same protocol on the BSP, for scenes with lights
        // that take random numbers (jittered area lights, the environment).
        if self.scene.lights.iter().any(|x| x.takes_random_numbers()) {
            self.light_sample_rows(&mut out.light_samples, r, &first.reference, &seconds)?;
        }
        Ok(())
    }

    /// The renderers of `accels` with their build times, and the BSP built with each of the
    /// other presets ([`BuildPreset::ALL`] but the default) with its build time, timed as the
    /// default's is (for the builds table only: the frames use the default preset, as
    /// `coherent render` does).
    fn renderers(
        &self,
        ctx: &mut Ctx,
        accels: &[AccelKind],
        skipped: &mut Vec<(String, String)>,
    ) -> anyhow::Result<(Renderers<'_>, Vec<f64>, Vec<Built<'_>>)> {
        let (name, scene) = (self.name, self.scene);
        let mut renderers = Vec::new();
        let mut build_secs = Vec::new();
        let mut presets = Vec::new();
        for &kind in accels {
            match frames::renderer_timed(scene, kind) {
                Ok((r, build_s)) => {
                    if kind == AccelKind::Bsp {
                        let default = AnyParams::of(kind).bsp.object.build;
                        for preset in BuildPreset::ALL.into_iter().filter(|&p| p != default) {
                            let mut params = AnyParams::of(kind);
                            params.bsp.object.build = preset;
                            let start = std::time::Instant::now();
                            let a = AnyAccel::build(&scene.accel_scene(), &params)?;
                            let s = start.elapsed().as_secs_f64();
                            presets.push((Renderer::new(scene, a, scene.width, scene.height)?, s));
                        }
                    }
                    build_secs.push(build_s);
                    renderers.push((kind, r));
                }
                Err(e) => {
                    let why = format!("{e:#}");
                    ctx.note(format!("table3: scene {name} with {kind} skipped: {why}"));
                    skipped.push((format!("scene {name} accel {kind}"), why));
                }
            }
        }
        Ok((renderers, build_secs, presets))
    }

    /// Untimed frames: the images (PSNR against scalar + BSP, whose image is written) and
    /// the statistics.
    fn first_frames(&self, ctx: &Ctx, renderers: &Renderers<'_>) -> anyhow::Result<FirstFrames> {
        let mut reference: Option<Vec<[f32; 3]>> = None;
        let mut psnrs = BTreeMap::new();
        let mut stats = BTreeMap::new();
        for (a, (_, r)) in renderers.iter().enumerate() {
            for &b in self.backends {
                let (rendered, _) = frames::frame(self.pool, b, r, self.plan)?;
                let image = rendered.displayed(Backend::Scalar)?;
                let db = match &reference {
                    None => {
                        let png = format!("images/table3_{}.png", self.name);
                        std::fs::create_dir_all(ctx.path("images"))?;
                        rendered.write_png(&ctx.path(&png))?;
                        reference = Some(image);
                        f64::INFINITY
                    }
                    Some(reference) => psnr(&image, reference, 1.0),
                };
                psnrs.insert((a, b), db);
                stats.insert((a, b), rendered.stats);
            }
        }
        Ok(FirstFrames {
            reference: reference.expect("the scalar + BSP image"),
            psnrs,
            stats,
        })
    }

    /// Timed frames: rounds over every (accel, backend) pair in turn.
    fn timed_frames(&self, renderers: &Renderers<'_>) -> anyhow::Result<PerFrame<Vec<f64>>> {
        let mut seconds: PerFrame<Vec<f64>> = BTreeMap::new();
        for _ in 0..ROUNDS {
            for (a, (_, r)) in renderers.iter().enumerate() {
                for &b in self.backends {
                    let (_, s) = frames::frame(self.pool, b, r, self.plan)?;
                    seconds.entry((a, b)).or_default().push(s);
                }
            }
        }
        Ok(seconds)
    }

    /// The rows of `table3_scenes.csv`.
    fn frame_rows(
        &self,
        csv: &mut CsvOut,
        renderers: &Renderers<'_>,
        first: &FirstFrames,
        seconds: &PerFrame<Vec<f64>>,
    ) -> anyhow::Result<()> {
        let plan = self.plan;
        for (a, (kind, _)) in renderers.iter().enumerate() {
            let scalar = median(&seconds[&(a, Backend::Scalar)]);
            for &b in self.backends {
                let s = median(&seconds[&(a, b)]);
                let rays = first.stats[&(a, b)].total_rays();
                let cells: [&dyn Display; 12] = [
                    &self.name,
                    &b.name(),
                    &b.lanes(),
                    kind,
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(scalar, s)),
                    &format!("{:.2}", first.psnrs[&(a, b)]),
                    &format!("{:.3}", rays as f64 / s * 1e-6),
                    &rays,
                    &plan.width,
                    &plan.height,
                    &plan.spp,
                ];
                csv.row(&cells)?;
            }
        }
        Ok(())
    }

    /// The builds, each with the time of a frame on its tree at the widest backend: every
    /// structure's frames in rounds, the BSP's other presets' trees among them.
    fn build_rows(
        &self,
        csv: &mut CsvOut,
        renderers: &Renderers<'_>,
        build_secs: &[f64],
        presets: &[Built<'_>],
    ) -> anyhow::Result<()> {
        let widest = Some(frames::widest())
            .filter(|b| self.backends.contains(b))
            .unwrap_or(Backend::Scalar);
        let mut built: Vec<(&Renderer<'_, AnyAccel>, f64)> = renderers
            .iter()
            .zip(build_secs)
            .map(|((_, r), &s)| (r, s))
            .collect();
        built.extend(presets.iter().map(|(r, s)| (r, *s)));
        let mut frame_secs = vec![Vec::with_capacity(ROUNDS); built.len()];
        for _ in 0..ROUNDS {
            for (i, (r, _)) in built.iter().enumerate() {
                frame_secs[i].push(frames::frame(self.pool, widest, r, self.plan)?.1);
            }
        }
        for ((r, build_s), secs) in built.iter().zip(&frame_secs) {
            build_row(
                csv,
                self.name,
                self.scene,
                r.accel(),
                *build_s,
                (widest, median(secs)),
            )?;
        }
        Ok(())
    }

    /// Coherence by depth, once per packet width (the BSP's frames).
    fn coherence_rows(
        &self,
        csv: &mut CsvOut,
        stats: &PerFrame<RenderStats>,
    ) -> anyhow::Result<()> {
        let mut widths = Vec::new();
        for &b in self.backends {
            if widths.contains(&b.lanes()) {
                continue;
            }
            widths.push(b.lanes());
            for (d, c) in stats[&(0, b)].depth.iter().enumerate() {
                csv.row(&[
                    &self.name,
                    &b.name(),
                    &b.lanes(),
                    &d,
                    &c.packets,
                    &format!("{:.4}", c.average()),
                ])?;
            }
        }
        Ok(())
    }

    /// Where the time goes: one frame per backend with the stage clocks on (BSP).
    fn breakdown_rows(
        &self,
        csv: &mut CsvOut,
        r: &mut Renderer<'_, AnyAccel>,
    ) -> anyhow::Result<()> {
        r.time_stages = true;
        for &b in self.backends {
            let (rendered, frame_s) = frames::frame(self.pool, b, r, self.plan)?;
            let t = std::time::Instant::now();
            std::hint::black_box(rendered.tone_mapped(b)?);
            let tonemap_s = t.elapsed().as_secs_f64();
            let st = &rendered.stats;
            // The stage clocks' own cost (per lap) is out of the stages, and out of the film's
            // remainder too.
            let mut secs = st.stage_seconds().to_vec();
            let traced: f64 = secs.iter().sum();
            secs.push((frame_s - traced - st.clock_seconds()).max(0.0));
            secs.push(tonemap_s);
            let total: f64 = secs.iter().sum();
            for (stage, s) in STAGES.iter().zip(&secs) {
                csv.row(&[
                    &self.name,
                    &b.name(),
                    stage,
                    &format!("{s:.6e}"),
                    &format!("{:.4}", s / total),
                ])?;
            }
        }
        r.time_stages = false;
        Ok(())
    }

    /// The BSP's frames with light samples shared per tile, on the hand-written backends
    /// only (the plot's, to keep the run's length), beside its per-pixel frames.
    fn light_sample_rows(
        &self,
        csv: &mut CsvOut,
        r: &mut Renderer<'_, AnyAccel>,
        reference: &[[f32; 3]],
        pixel_seconds: &PerFrame<Vec<f64>>,
    ) -> anyhow::Result<()> {
        let names: Vec<&str> = self.backends.iter().map(|b| b.name()).collect();
        let shown = plotted(&names);
        let backends: Vec<Backend> = self
            .backends
            .iter()
            .copied()
            .filter(|b| shown.contains(&b.name()))
            .collect();
        r.light_samples = LightSamples::Tile;
        let mut images = BTreeMap::new();
        let mut tiled: Option<Vec<[f32; 3]>> = None;
        for &b in &backends {
            let (rendered, _) = frames::frame(self.pool, b, r, self.plan)?;
            let image = rendered.displayed(Backend::Scalar)?;
            let db = match &tiled {
                None => f64::INFINITY,
                Some(t) => psnr(&image, t, 1.0),
            };
            images.insert(b, (db, psnr(&image, reference, 1.0)));
            if tiled.is_none() {
                tiled = Some(image);
            }
        }
        let mut secs: BTreeMap<Backend, Vec<f64>> = BTreeMap::new();
        for _ in 0..ROUNDS {
            for &b in &backends {
                let (_, s) = frames::frame(self.pool, b, r, self.plan)?;
                secs.entry(b).or_default().push(s);
            }
        }
        r.light_samples = LightSamples::Pixel;
        let scalar = median(&secs[&Backend::Scalar]);
        for &b in &backends {
            let s = median(&secs[&b]);
            let pixel = median(&pixel_seconds[&(0, b)]);
            let (db, vs_pixel) = images[&b];
            csv.row(&[
                &self.name,
                &b.name(),
                &b.lanes(),
                &format!("{s:.6e}"),
                &format!("{:.3}", speedup(scalar, s)),
                &format!("{:.3}", speedup(pixel, s)),
                &format!("{db:.2}"),
                &format!("{vs_pixel:.2}"),
            ])?;
        }
        Ok(())
    }
}

/// A row of the builds table: the accelerator `a` of `scene`, built in `seconds`, with the
/// median seconds of a frame on it at a backend; for the BSP, its object trees' preset and
/// tree quality ([`TreeQuality`]).
fn build_row(
    out: &mut crate::table::CsvOut,
    name: &str,
    scene: &coherent::scene::RenderScene,
    a: &AnyAccel,
    seconds: f64,
    (backend, frame_s): (Backend, f64),
) -> anyhow::Result<()> {
    let (preset, threads, quality) = match a {
        AnyAccel::Bsp(b) => {
            let q = TreeQuality::of(b);
            let cells = [
                q.nodes.to_string(),
                q.leaf_refs.to_string(),
                q.max_depth.to_string(),
                format!("{:.4}", q.sah_cost),
            ];
            (q.preset, rayon::current_num_threads(), cells)
        }
        // Embree as the renderer asks for it (one build thread); obvhs builds on one.
        _ => ("default", 1, Default::default()),
    };
    let [nodes, refs, depth, sah] = &quality;
    out.row(&[
        &name,
        &a.kind(),
        &preset,
        &threads,
        &format!("{seconds:.6e}"),
        &a.memory_bytes(),
        &scene.instances.len(),
        &scene.triangles(),
        nodes,
        refs,
        depth,
        sah,
        &backend.name(),
        &format!("{frame_s:.6e}"),
    ])
}
