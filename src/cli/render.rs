//! `coherent render` (paper section 7): load a scene, build the chosen accelerator, render
//! with the chosen lane backend on a pool of T threads through the progressive film, write
//! the image, and print one summary line (rays by kind, time, Mrays/s, active lanes per
//! packet per stage and per ray depth, material passes per packet). With `--indirect imap`
//! the illumination map is loaded or built (and saved) first, and its time reported apart
//! from the frame's.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{
    FilmOptions, Method, PassReport, scale_top, write_heatmap_png, write_map_exr,
};
use coherent::illum::{DEFAULT_CELLS, IllumMap, MapOptions, Mode};
use coherent::median::median;
use coherent::render::colour::{ColourForm, spectral_backends, spectral_refusal};
use coherent::render::indirect::DEFAULT_MAX_BOUNCES;
use coherent::render::{
    AovBuffer, AovKind, Indirect, IndirectMode, Packets, RayKind, RenderStats, Renderer,
    render_frame,
};
use coherent::scene::RenderScene;
use coherent::simd::Backend;
use indicatif::{ProgressBar, ProgressStyle};

use crate::RenderArgs;

/// Checks the cheap things before loading anything: the backend, the accelerator's name, the
/// output's type and folder, the thread count.
fn check_args(args: &RenderArgs) -> anyhow::Result<(Backend, AccelKind, ColourForm)> {
    let colour =
        ColourForm::from_flags(args.colour, args.bins, args.layout).map_err(anyhow::Error::msg)?;
    let backend = match (colour.is_spectral(), args.backend.as_deref()) {
        // The spectral renderer is compiled for a few backends alone.
        (true, None) => spectral_backends()
            .filter(|b| b.is_available())
            .last()
            .unwrap_or(Backend::Scalar),
        (_, name) => super::backend_arg(name)?,
    };
    if colour.is_spectral() {
        if let Some(why) = spectral_refusal(&colour, backend) {
            bail!("--backend {}: {why}", backend.name());
        }
        if args.regroup {
            bail!(
                "--regroup: spectral colour ({}) runs with the paper's packets; leave out --regroup",
                colour.label()
            );
        }
    }
    let kind: AccelKind = args.accel.parse()?;
    match args.out.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("png") => {}
        _ => bail!(
            "{}: the output must be an .exr or .png file",
            args.out.display()
        ),
    }
    super::threads_arg(args.threads)?;
    check_indirect(args)?;
    // Fail before rendering, not after, when the image cannot be written.
    if let Some(dir) = args.out.parent()
        && !dir.as_os_str().is_empty()
        && !dir.is_dir()
    {
        bail!(
            "{}: cannot write the image there: the folder {} does not exist",
            args.out.display(),
            dir.display()
        );
    }
    Ok((backend, kind, colour))
}

/// Particles of a new illumination map unless `--particles` says otherwise.
pub const DEFAULT_PARTICLES: u64 = 1_000_000;

/// Checks the indirect-light flags: each map flag only with `--indirect imap` (an error, not
/// a warning: a flag that would do nothing is a mistake in the command), `--max-bounces` only
/// with `--indirect path`, and counts of at least 1.
fn check_indirect(args: &RenderArgs) -> anyhow::Result<()> {
    let mode = args.indirect;
    let map_flags = [
        ("--particles", args.particles.is_some()),
        ("--imap-cells", args.imap_cells.is_some()),
        ("--imap-mode", args.imap_mode.is_some()),
        ("--imap", args.imap.is_some()),
    ];
    if mode != IndirectMode::Imap
        && let Some((flag, _)) = map_flags.iter().find(|f| f.1)
    {
        bail!("{flag} sets up the illumination map: it needs --indirect imap (not {mode})");
    }
    if mode != IndirectMode::Path && args.max_bounces.is_some() {
        bail!("--max-bounces limits path tracing: it needs --indirect path (not {mode})");
    }
    if args.particles == Some(0) {
        bail!("--particles 0: the illumination map needs at least 1 particle");
    }
    if args.imap_cells == Some(0) {
        bail!("--imap-cells 0: the illumination map needs at least 1 cell");
    }
    if args.max_bounces == Some(0) {
        bail!("--max-bounces 0: a path needs at least 1 bounce (--indirect none has none)");
    }
    Ok(())
}

/// Where the illumination map lives: `--imap`, else beside the scene file as
/// `SCENE.imap.exr`, else (a built-in scene) beside the image as `IMAGE.imap.exr`.
pub fn imap_path(scene: &str, out: &Path, imap: Option<&Path>) -> PathBuf {
    if let Some(p) = imap {
        return p.to_path_buf();
    }
    let file = Path::new(scene);
    let beside = if file.is_file() { file } else { out };
    let stem = beside
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy());
    beside.with_file_name(format!("{stem}.imap.exr"))
}

/// The world bounds of every instance's triangles (where parallel and environment lights
/// emit from).
fn world_bounds(scene: &RenderScene) -> coherent::accel::Aabb {
    let mut b = coherent::accel::Aabb::from_points(std::iter::empty());
    for inst in &scene.instances {
        if let Some(m) = scene.meshes.get(inst.mesh) {
            b = b.union(m.mesh.bounds().transformed(&inst.world_from_object));
        }
    }
    b
}

/// The illumination map for `--indirect imap`: loaded from its file when it was made for this
/// scene and cells target, else built with a progress bar in `pool` and saved there. Says
/// which, with the time it took.
fn illumination_map(
    args: &RenderArgs,
    scene: &RenderScene,
    accel: &AnyAccel,
    backend: Backend,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<IllumMap> {
    let path = imap_path(&args.scene, &args.out, args.imap.as_deref());
    let cells = args.imap_cells.unwrap_or(DEFAULT_CELLS);
    let t = Instant::now();
    if path.exists() {
        let map = IllumMap::load(&path, scene, cells).map_err(|e| {
            anyhow::anyhow!(
                "{e}\n(delete {} to build the map again, or pass another --imap FILE)",
                path.display()
            )
        })?;
        println!(
            "illumination map: loaded {} ({} cells, {} particles) in {:.3} s",
            path.display(),
            map.cells(),
            map.particles(),
            t.elapsed().as_secs_f64()
        );
        if let Some(p) = args.particles
            && p != map.particles()
        {
            eprintln!(
                "coherent: warning: --particles {p}: the map loaded from {} was built from {} \
                 particles; delete it to build one from {p}",
                path.display(),
                map.particles()
            );
        }
        return Ok(map);
    }
    let opts = MapOptions {
        particles: args.particles.unwrap_or(DEFAULT_PARTICLES),
        cells,
        mode: args.imap_mode.unwrap_or(Mode::Sorted),
        ..MapOptions::default()
    };
    opts.check()?;
    let bar = progress_bar(args.quiet);
    bar.set_length(opts.particles);
    bar.set_message(format!("illumination map, {} particles", opts.particles));
    let built = pool.install(|| {
        coherent::illum::build_map(backend, scene, accel, &opts, &|done| bar.set_position(done))
    });
    bar.finish_and_clear();
    let (map, st) =
        built.with_context(|| format!("building the illumination map of {}", scene.name))?;
    let seconds = t.elapsed().as_secs_f64();
    map.save(&path)?;
    println!(
        "illumination map: built from {} particles ({} rays, {} packets, {:.1} Mrays/s) in \
         {:.3} s, {} cells -> {}",
        opts.particles,
        st.rays(),
        opts.mode,
        st.rays() as f64 / seconds.max(1e-9) * 1e-6,
        seconds,
        map.cells(),
        path.display()
    );
    Ok(map)
}

/// Loads the scene with the command line's overrides, validated, and merges its static
/// instances unless told not to: the scene, its objects before merging and those merged.
fn load_scene(args: &RenderArgs) -> anyhow::Result<(RenderScene, usize, usize)> {
    let mut scene = coherent::scene::load(&args.scene)?;
    if let Some((w, h)) = args.resolution {
        scene.width = w;
        scene.height = h;
    }
    if let Some(d) = args.depth {
        scene.depth = d;
    }
    scene
        .validate()
        .with_context(|| format!("scene {}", args.scene))?;
    let objects = scene.instances.len();
    let merged = if args.no_merge {
        0
    } else {
        let (s, report) = scene.merge_static();
        scene = s;
        report.merged
    };
    Ok((scene, objects, merged))
}

/// The film's sampling: `--spp`, else `--accuracy`, else the scene's own, else adaptive at
/// 5%.
fn film_method(args: &RenderArgs, scene: &RenderScene) -> Method {
    match (args.spp, args.accuracy, scene.spp, scene.accuracy) {
        (Some(spp), _, _, _) => Method::Uniform { spp },
        (None, Some(accuracy), _, _) | (None, None, _, Some(accuracy)) => Method::Adaptive {
            accuracy,
            max_samples_per_pixel: args.max_spp,
            time_budget: None,
        },
        (None, None, Some(spp), None) => Method::Uniform { spp },
        (None, None, None, None) => Method::Adaptive {
            accuracy: 0.05,
            max_samples_per_pixel: args.max_spp,
            time_budget: None,
        },
    }
}

/// Runs `coherent render`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let (backend, kind, colour) = check_args(args)?;
    let t_load = Instant::now();
    let (scene, objects, merged) = load_scene(args)?;
    let (w, h) = (scene.width, scene.height);
    let method = film_method(args, &scene);
    let mut opts = FilmOptions::new(w, h, method);
    opts.tonemap = match &args.tonemap {
        Some(op) => op.parse().map_err(|e| anyhow::anyhow!("--tonemap: {e}"))?,
        None => scene.tonemap,
    };
    opts.validate()?;
    if args.indirect == IndirectMode::Imap {
        // No light to trace particles from, before building anything.
        coherent::illum::Emitter::new(&scene, world_bounds(&scene))?;
        let path = imap_path(&args.scene, &args.out, args.imap.as_deref());
        if !path.exists()
            && let Some(dir) = path.parent()
            && !dir.as_os_str().is_empty()
            && !dir.is_dir()
        {
            bail!(
                "--imap {}: cannot write the illumination map there: the folder {} does not exist",
                path.display(),
                dir.display()
            );
        }
    }

    let t_build = Instant::now();
    let mut params = AnyParams::of(kind);
    params.bsp.object.build = args.bsp_build;
    let accel = AnyAccel::build(&scene.accel_scene(), &params)
        .with_context(|| format!("building the {kind} accelerator for {}", scene.name))?;
    let build = t_build.elapsed();
    let memory = accel.memory_bytes();
    if let Some(k) = args.aov.iter().find(|k| k.needs_counts())
        && !accel.counts_work()
    {
        bail!(
            "--aov {k}: the {kind} accelerator does not count its traversal's steps and tests \
             (only the BSP's traversal is ours to count); `lanes` and `time` work with any"
        );
    }
    let threads = args.threads.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    // Unoptimised (debug) builds keep every packet temporary of the inlined pipeline on the
    // stack: 16-lane packets overflowed rayon's default 2 MiB on the built-in `cornell` (and
    // ran with 64 MiB). The stack is reserved, not committed, so the margin costs nothing.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .stack_size(64 << 20)
        .build()
        .context("starting the worker threads")?;

    let indirect = match args.indirect {
        IndirectMode::None => Indirect::None,
        IndirectMode::Path => Indirect::Path {
            max_bounces: args.max_bounces.unwrap_or(DEFAULT_MAX_BOUNCES),
        },
        IndirectMode::Imap => Indirect::Map(Arc::new(illumination_map(
            args, &scene, &accel, backend, &pool,
        )?)),
    };
    let mut renderer = Renderer::new(&scene, accel, w, h).context("the scene's camera")?;
    renderer.indirect = indirect;
    renderer.light_samples = args.light_samples;
    renderer.regroup = args.regroup;
    renderer.packets = args.packets;
    renderer.time_stages = args.stages;
    renderer
        .set_colour(colour)
        .context("the colour form's spectra")?;
    let aov = (!args.aov.is_empty()).then(|| Arc::new(AovBuffer::new(w, h)));
    renderer.aov = aov.clone();

    let bar = progress_bar(args.quiet);
    let spp = match method {
        Method::Uniform { spp } => Some(spp),
        Method::Adaptive { .. } => None,
    };
    let progress = |p: &PassReport| {
        let r = &p.record;
        let done = match spp {
            Some(n) => f64::from(r.pass) / f64::from(n.max(1)),
            None => r.done,
        };
        bar.set_position((done.clamp(0.0, 1.0) * 1000.0) as u64);
        bar.set_message(format!(
            "pass {}, {:.1} Mrays",
            r.pass,
            r.rays as f64 * 1e-6
        ));
    };
    let mut frames = Vec::new();
    let mut rendered = None;
    for _ in 0..args.frames {
        // The last frame's film is dropped before the next frame starts, as in `reproduce`.
        drop(rendered.take());
        let t_render = Instant::now();
        rendered = Some(pool.install(|| render_frame(backend, &renderer, &opts, &progress))?);
        frames.push(t_render.elapsed().as_secs_f64());
    }
    let rendered = rendered.context("no frame rendered")?;
    let seconds = Duration::from_secs_f64(median(&frames));
    bar.finish_and_clear();
    rendered.write(&args.out)?;

    if let Some(buf) = &aov {
        write_maps(args, buf, backend)?;
    }

    let st = &rendered.stats;
    let rays = st.total_rays();
    println!(
        "{}: {}x{} {} ({} triangles, {}), {} + {}{}{}{}, {} thread(s), {}: {:.3} s ({:.1} Mrays/s); rays: {}; \
         active lanes per packet (of {}): {}; by depth: {}; material passes per packet {:.2}; \
         build {:.3} s, {:.1} MB; load {:.3} s -> {}",
        scene.name,
        w,
        h,
        method.name(),
        scene.triangles(),
        objects_text(objects, merged, scene.instances.len()),
        backend.name(),
        kind,
        packets_text(args),
        indirect_text(args),
        match colour {
            ColourForm::Rgb => String::new(),
            c => format!(", {} colour", c.label()),
        },
        threads,
        stop_text(&rendered),
        seconds.as_secs_f64(),
        rays as f64 / seconds.as_secs_f64().max(1e-9) * 1e-6,
        rays_text(st),
        backend.lanes(),
        lanes_text(st),
        st.depth_summary(),
        st.materials.passes_per_packet(),
        build.as_secs_f64(),
        memory as f64 / 1e6,
        (t_build - t_load).as_secs_f64(),
        args.out.display(),
    );
    if frames.len() > 1 {
        let each: Vec<String> = frames.iter().map(|s| format!("{s:.4}")).collect();
        println!(
            "{} frames: {} s; median {:.4} s (the time above)",
            frames.len(),
            each.join(", "),
            seconds.as_secs_f64()
        );
    }
    if args.stages {
        println!(
            "time by stage (the clock read around each stage, its own cost taken out): {}",
            st.stage_summary()
        );
    }
    warn_bad_samples(&rendered);
    Ok(())
}

/// The scene's objects for the summary line: before merging, merged and left.
fn objects_text(objects: usize, merged: usize, left: usize) -> String {
    if merged > 0 {
        format!("{objects} objects, {merged} static ones merged: {left} left")
    } else {
        format!("{objects} objects")
    }
}

/// How the packets travelled, for the summary line.
fn packets_text(args: &RenderArgs) -> &'static str {
    match (args.regroup, args.packets) {
        (false, Packets::Lanes) => "",
        (true, Packets::Lanes) => ", regrouped",
        (false, Packets::Beam) => ", camera beams",
        (true, Packets::Beam) => ", camera beams, regrouped",
    }
}

/// The indirect light, for the summary line (nothing without).
fn indirect_text(args: &RenderArgs) -> String {
    match args.indirect {
        IndirectMode::None => String::new(),
        IndirectMode::Imap => ", indirect light from the map".into(),
        IndirectMode::Path => format!(
            ", indirect light path traced (at most {} bounces)",
            args.max_bounces.unwrap_or(DEFAULT_MAX_BOUNCES)
        ),
    }
}

/// Rays traced per kind (diffuse bounces only when there were some).
fn rays_text(st: &RenderStats) -> String {
    let kinds: Vec<String> = RayKind::ALL
        .iter()
        .filter(|&&k| k.always_listed() || st.rays(k) > 0)
        .map(|&k| format!("{} {}", k.name(), st.rays(k)))
        .collect();
    kinds.join(", ")
}

/// Active lanes per packet per kind of rays traced in packets.
fn lanes_text(st: &RenderStats) -> String {
    let lanes: Vec<String> = RayKind::ALL
        .iter()
        .filter(|k| st.kinds[**k as usize].packets > 0)
        .map(|k| format!("{} {:.2}", k.name(), st.kinds[*k as usize].average()))
        .collect();
    lanes.join(", ")
}

/// The render's progress bar (hidden with `--quiet`).
fn progress_bar(quiet: bool) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1000)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
            .expect("a valid template"),
    );
    bar
}

/// Warns about samples that were set to 0: infinite or NaN image samples, NaN radiance.
fn warn_bad_samples(rendered: &coherent::film::Rendered<RenderStats>) {
    let st = &rendered.stats;
    let fixed = rendered.fixups;
    if fixed.non_finite > 0 {
        eprintln!(
            "coherent: warning: {} image samples were infinite or NaN (a light or material far \
             out of range?); they were counted and set to 0, so those pixels are darker than \
             the scene",
            fixed.non_finite
        );
    }
    if st.nan > 0 {
        eprintln!(
            "coherent: warning: {} radiance samples were NaN (a bad material or light?); they were \
             counted and set to 0",
            st.nan
        );
    }
}

fn stop_text<S>(r: &coherent::film::Rendered<S>) -> String {
    let n = r.passes.len();
    format!(
        "{n} pass{}, {}",
        if n == 1 { "" } else { "es" },
        r.stop.describe()
    )
}

/// `IMAGE.KIND.EXT` beside the image `out`.
fn map_path(out: &Path, kind: AovKind, ext: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "image".into(), |s| s.to_string_lossy());
    out.with_file_name(format!("{stem}.{}.{ext}", kind.name()))
}

/// Writes each asked-for map beside the image and says where, with its mean.
fn write_maps(args: &RenderArgs, buf: &AovBuffer, backend: Backend) -> anyhow::Result<()> {
    let (w, h) = (buf.width(), buf.height());
    for &kind in &args.aov {
        let map = buf.map(kind);
        // Lanes on the packet's own scale, so that widths compare.
        let top = match kind {
            AovKind::Lanes => backend.lanes() as f32,
            _ => scale_top(&map),
        };
        let (png, exr) = (
            map_path(&args.out, kind, "png"),
            map_path(&args.out, kind, "exr"),
        );
        write_heatmap_png(&png, &map, w, h, top, kind.label())?;
        write_map_exr(&exr, &map, w, h, kind.name())?;
        let mean = map.iter().map(|&v| f64::from(v)).sum::<f64>() / map.len().max(1) as f64;
        println!(
            "map {kind}: mean {mean:.2} {} -> {} and {}",
            kind.label(),
            png.display(),
            exr.display()
        );
    }
    Ok(())
}
