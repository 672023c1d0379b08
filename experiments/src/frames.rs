//! Whole frames of the test scenes (paper section 7, Tables 3 and 5), shared by the `table3`
//! and `table5` experiments: which scenes there are (the built-ins, then every `*.toml` of
//! the repository's `scenes/` folder), loading them with a message instead of a failure when
//! their assets are missing, and rendering one frame through the same code path as
//! `coherent render` (the progressive film with a fixed number of samples per pixel, in a
//! rayon pool of T threads).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method, Rendered};
use coherent::render::{RenderStats, Renderer, render_frame};
use coherent::scene::RenderScene;
use coherent::simd::Backend;

pub use coherent::scene::scenes_dir;

/// Which scenes an experiment renders and how.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Include the built-in scenes (`coherent scenes`).
    pub builtins: bool,
    /// Folder whose `*.toml` files are scenes too (a missing folder holds none).
    pub scenes_dir: PathBuf,
    /// Scenes with more triangles are left out (quick mode renders the small scenes).
    pub max_triangles: usize,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (uniform, one pass per sample).
    pub spp: u32,
}

/// A scene ready to render, or why not.
pub enum Loaded {
    Scene(Box<RenderScene>),
    /// Left out by the plan (too large for quick mode): not an error.
    TooLarge {
        triangles: usize,
    },
    /// Failed to load (missing or corrupt assets): the message names the file.
    Failed(String),
}

/// The scenes of `plan`, by name (built-ins by their name, files by their stem), in order:
/// built-ins as `coherent scenes` lists them (but the showcases, made to be looked at, not
/// timed), then the files sorted by name.
pub fn scene_specs(plan: &Plan) -> Vec<(String, String)> {
    let mut specs = Vec::new();
    if plan.builtins {
        for (name, _) in coherent::scene::builtin_names() {
            if !coherent::scene::builtin::SHOWCASES.contains(&name) {
                specs.push((name.to_owned(), name.to_owned()));
            }
        }
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&plan.scenes_dir)
        .map(|dir| {
            dir.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    for f in files {
        let stem = f
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        specs.push((stem, f.to_string_lossy().into_owned()));
    }
    specs
}

/// Loads the scene `spec` at the plan's resolution and samples, its static instances merged
/// per transform ([`RenderScene::merge_static`], as `coherent render` renders it).
pub fn load(plan: &Plan, spec: &str) -> Loaded {
    let mut scene = match coherent::scene::load(spec) {
        Ok(s) => s,
        Err(e) => return Loaded::Failed(format!("{e:#}")),
    };
    let triangles = scene.triangles();
    if triangles > plan.max_triangles {
        return Loaded::TooLarge { triangles };
    }
    scene.width = plan.width;
    scene.height = plan.height;
    if let Err(e) = scene.validate() {
        return Loaded::Failed(format!("{e:#}"));
    }
    // As `coherent render` does by default: static instances at one transform, one object.
    let (scene, _) = scene.merge_static();
    Loaded::Scene(Box::new(scene))
}

/// [`load`] for an experiment that leaves out what it cannot render: the scene, or `None`
/// when the plan leaves it out as too large (quietly: not an error) or it failed to load
/// (noted as `experiment: scene NAME skipped: why`).
pub fn load_or_note(
    ctx: &mut crate::ctx::Ctx,
    experiment: &str,
    plan: &Plan,
    name: &str,
    spec: &str,
) -> Option<Box<RenderScene>> {
    match load(plan, spec) {
        Loaded::Scene(s) => Some(s),
        Loaded::TooLarge { .. } => None,
        Loaded::Failed(why) => {
            ctx.note(format!("{experiment}: scene {name} skipped: {why}"));
            None
        }
    }
}

/// The accelerators usable here, and a `(name, why)` for each that is not.
pub fn accels() -> (Vec<AccelKind>, Vec<(String, String)>) {
    let mut ok = Vec::new();
    let mut skipped = Vec::new();
    for k in AccelKind::compared() {
        match k.unavailable_reason() {
            None => ok.push(k),
            Some(why) => skipped.push((format!("accel {k}"), why)),
        }
    }
    (ok, skipped)
}

/// The backends usable here, and a `(name, why)` for each that is not.
pub fn backends() -> (Vec<Backend>, Vec<(String, String)>) {
    let mut skipped = Vec::new();
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            skipped.push((format!("backend {b}"), why));
        }
    }
    (Backend::available(), skipped)
}

/// Whether a results file's backend `name` is one of [`Backend::hand_written`].
pub fn is_hand_written(name: &str) -> bool {
    Backend::hand_written().any(|b| b.name() == name)
}

/// The widest hand-written backend usable here (the one `coherent render` picks by default).
pub fn widest() -> Backend {
    Backend::widest()
}

/// The renderer of `scene` with accelerator `kind`.
pub fn renderer(scene: &RenderScene, kind: AccelKind) -> anyhow::Result<Renderer<'_, AnyAccel>> {
    Ok(renderer_timed(scene, kind)?.0)
}

/// [`renderer`], with the seconds the accelerator took to build (from the scene's meshes and
/// instances, as `coherent render` times it).
pub fn renderer_timed(
    scene: &RenderScene,
    kind: AccelKind,
) -> anyhow::Result<(Renderer<'_, AnyAccel>, f64)> {
    let start = Instant::now();
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(kind))
        .with_context(|| format!("building the {kind} accelerator for {}", scene.name))?;
    let seconds = start.elapsed().as_secs_f64();
    let r = Renderer::new(scene, accel, scene.width, scene.height)
        .with_context(|| format!("the camera of {}", scene.name))?;
    Ok((r, seconds))
}

/// A rayon pool of `threads` threads.
pub fn pool(threads: usize) -> anyhow::Result<rayon::ThreadPool> {
    // 64 MiB reserved per worker, as `coherent render` does: unoptimised builds (this crate's
    // tests) keep the inlined pipeline's packet temporaries on the stack, and overflowed
    // rayon's default 2 MiB.
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .stack_size(64 << 20)
        .build()
        .context("starting the worker threads")
}

/// Renders one frame as `coherent render --spp N` does (film, Halton samples, all passes) in
/// `pool`; returns it and its seconds (the render only: no tone mapping, no file).
pub fn frame(
    pool: &rayon::ThreadPool,
    backend: Backend,
    renderer: &Renderer<'_, AnyAccel>,
    plan: &Plan,
) -> anyhow::Result<(Rendered<RenderStats>, f64)> {
    let opts = FilmOptions::new(plan.width, plan.height, Method::Uniform { spp: plan.spp });
    let start = Instant::now();
    let rendered = pool.install(|| render_frame(backend, renderer, &opts, &|_| {}))?;
    let seconds = start.elapsed().as_secs_f64();
    Ok((std::hint::black_box(rendered), seconds))
}
