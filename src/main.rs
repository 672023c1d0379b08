//! The `coherent` command line (the README says how to use it): `coherent render` renders a
//! scene with the packet renderer (paper section 7), `coherent view` renders it progressively
//! for a web page that moves the camera (the paper's interactive mode), `coherent scenes`
//! lists the built-in scenes, `coherent info` describes the CPU, the build and the lane
//! backends.

use clap::{Parser, Subcommand};
use coherent::accel_any::AccelKind;
use coherent::machine::Machine;
use coherent::simd::Backend;
use std::io::{self, Write};
use std::process::ExitCode;

mod cli;

/// Coherent (SIMD packet) physically accurate ray tracing after Adinetz et al., Graphicon 2005.
#[derive(Parser, Debug)]
#[command(name = "coherent", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to an EXR (linear radiance) or PNG (tone-mapped) image.
    ///
    /// SCENE is a scene file (.toml), a built-in scene's name (`coherent scenes`) or a bare
    /// mesh file (framed by a default camera and light). The image is the same for any
    /// thread count; backends and accelerators differ only in rounding.
    Render(Box<RenderArgs>),
    /// Render a scene progressively and show it on a local web page, where the mouse and
    /// keys move the camera and the settings change (every change restarts the render).
    ///
    /// Prints the page's address. Drag: orbit; shift-drag or right-drag: pan; wheel: dolly.
    /// `GET /frame.png` is the current image, `GET /state` the figures as JSON. The render
    /// pauses when no request came for 10 s. Ctrl-C ends it.
    View(Box<ViewArgs>),
    /// Write a scene for another renderer: `--mitsuba DIR` writes Mitsuba 3's scene
    /// description (DIR/scene.xml, with the meshes as PLY and the textures as EXR) of the part
    /// of the scene both renderers compute alike, and lists every feature it left out, with
    /// the reason.
    Export(Box<ExportArgs>),
    /// List the built-in scenes and the scene files of the repository's `scenes/` folder
    /// (or `$COHERENT_SCENES`).
    Scenes,
    /// Show the CPU and its SIMD features, how this binary was built, and which lane backends
    /// are compiled in and usable here.
    Info {
        /// Print the machine description as JSON (the `machine.json` of `reproduce`).
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info { json } => info(json),
        Command::Render(args) => cli::render::run(&args),
        Command::View(args) => cli::view::run(&args),
        Command::Export(args) => cli::export::run(&args),
        Command::Scenes => scenes(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`coherent info | head`) is not an error of ours.
        Err(e)
            if e.downcast_ref::<io::Error>().map(io::Error::kind)
                == Some(io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("coherent: error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message
/// already holds: most of our errors print their source in their own text as well, so
/// anyhow's `{:#}` said "No such file or directory (os error 2)" twice.
fn message(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if text.contains(&c) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&c);
    }
    text
}

/// What `coherent export` takes.
#[derive(clap::Args, Debug)]
struct ExportArgs {
    /// A scene file (.toml), a built-in scene's name, or a bare mesh file.
    scene: String,
    /// The folder to write Mitsuba 3's scene into (created if needed).
    #[arg(long)]
    mitsuba: std::path::PathBuf,
    /// Image size WxH (default: the scene's).
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
}

/// What `coherent render` takes.
#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// A scene file (.toml), a built-in scene's name, or a bare mesh file.
    scene: String,
    #[arg(long, help = backend_help())]
    backend: Option<String>,
    #[arg(long, default_value = "bsp", help = accel_help())]
    accel: String,
    /// How the BSP builds its object trees: `binned` (binned SAH at every level, in
    /// parallel: the shortest time to a first image), `exact` (the O(N log N) sweep over every
    /// plane at every node: the fastest trees, for a longer build) or `fast` (binned SAH above
    /// 256 references, the sweep below). Other accelerators ignore it.
    #[arg(long, default_value_t = coherent::bsp::BuildPreset::default(), value_parser = parse_bsp_build())]
    bsp_build: coherent::bsp::BuildPreset,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
    /// Uniform supersampling with N samples per pixel (instead of the adaptive method).
    #[arg(long, conflicts_with = "accuracy")]
    spp: Option<u32>,
    /// Adaptive anti-aliasing to this relative accuracy (the paper's method; default 0.05
    /// unless the scene sets spp or accuracy).
    #[arg(long)]
    accuracy: Option<f32>,
    /// Largest number of samples per pixel of the adaptive method.
    #[arg(long, default_value_t = 64)]
    max_spp: u32,
    /// Image size WxH (default: the scene's).
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Reflection/refraction depth (default: the scene's; 0 = camera rays only).
    #[arg(long)]
    depth: Option<u32>,
    /// Tone-mapping operator for PNG output: tumblin, reinhard, ward (default: the scene
    /// file's `tonemap`, else tumblin).
    #[arg(long)]
    tonemap: Option<String>,
    /// Light sample points and environment directions: `pixel` (each sample draws its own)
    /// or `tile` (the samples of a 4x4 pixel tile share them, as the paper's fixed points on
    /// surface lights: coherent shadow packets, noise correlated within a tile).
    #[arg(long, default_value = "pixel")]
    light_samples: coherent::render::LightSamples,
    /// Regroup reflection and refraction rays: the active lanes of a tile's secondary packets
    /// are compacted into full packets (the same image up to rounding; fewer, fuller packets).
    #[arg(long)]
    regroup: bool,
    /// Camera rays: `lanes` (packet by packet, the paper's way) or `beam` (a film tile's
    /// packets together through the accelerator's beam query: the BSP walks them as one
    /// beam; the others answer packet by packet). The same image up to edge hits.
    #[arg(long, default_value = "lanes")]
    packets: coherent::render::Packets,
    /// Per-pixel maps of where coherence breaks, written beside the image as
    /// `IMAGE.KIND.png` (a heat map with a colour bar) and `IMAGE.KIND.exr` (the values):
    /// `steps` (inner nodes visited per sample, by the packets its rays were in), `tests`
    /// (triangle tests per sample), `lanes` (active lanes of those packets), `time` (ns per
    /// sample). Comma-separated. `steps` and `tests` need `--accel bsp` (the others'
    /// traversal is not ours to count). The maps' bookkeeping slows the frame.
    #[arg(long, value_delimiter = ',')]
    aov: Vec<coherent::render::AovKind>,
    /// Keep every instance its own object under the top tree, as the scene places it (the
    /// paper's two levels). By default the instances that never move and share a transform
    /// are merged into one object first: a scene of thousands of static objects then builds
    /// and traces as one tree (the image is the same up to edge hits).
    #[arg(long)]
    no_merge: bool,
    /// Time each stage of the packet pipeline (traversal, shadows, lights, shading, other)
    /// and print the split. The clock is read around every stage of every packet, which
    /// slows the frame; the split is for comparing stages, not for frame times.
    #[arg(long)]
    stages: bool,
    /// Indirect light: `none` (direct light, mirror and refraction rays only), `imap` (an
    /// illumination map of particles traced from the lights adds `albedo / pi * E` at every
    /// hit) or `path` (path tracing's diffuse bounces: the unbiased reference, slow to
    /// converge). The Phong specular lobe's share of indirect light is left out by both.
    #[arg(long, default_value = "none")]
    indirect: coherent::render::IndirectMode,
    /// Particles traced to build the illumination map (`--indirect imap` only; default
    /// 1000000). A map file that is loaded keeps the particles it was built with.
    #[arg(long)]
    particles: Option<u64>,
    /// Cells the illumination map aims at over the scene's surfaces (`--indirect imap` only;
    /// default 65536).
    #[arg(long)]
    imap_cells: Option<u64>,
    /// How the map's particle rays are grouped into packets: single, packets, sorted
    /// (by direction octant and origin) or octant (`--indirect imap` only; default sorted).
    /// The map is the same whichever.
    #[arg(long)]
    imap_mode: Option<coherent::illum::Mode>,
    /// The illumination map's file (`--indirect imap` only): loaded when it was made for this
    /// scene and cells target, else built and written there. Default: beside the scene file
    /// as `SCENE.imap.exr`, for a built-in scene beside the image as `IMAGE.imap.exr`.
    #[arg(long)]
    imap: Option<std::path::PathBuf>,
    /// Diffuse bounces per path at most (`--indirect path` only; default 64; Russian
    /// roulette ends most paths long before).
    #[arg(long)]
    max_bounces: Option<u32>,
    /// Colour: `rgb` (three channels, the paper's), `hero` (four wavelengths per ray, the
    /// first drawn per sample, the others spaced evenly) or `bins` (fixed bins over 380-780
    /// nm). The spectral forms upsample the scene's RGB colours to smooth spectra, show a
    /// dispersive glass's colours and run on the hand-written backends (scalar, sse, avx2,
    /// avx512).
    #[arg(long, default_value = "rgb")]
    colour: coherent::render::colour::ColourKind,
    /// Spectral bins, 1 to 1024 (`--colour bins` only; default 32).
    #[arg(long)]
    bins: Option<u32>,
    /// Where a packet's lanes go with `--colour bins`: `rays` (each lane a ray with all of
    /// its bins) or `wavelengths` (one ray's bins across the lanes). Default rays.
    #[arg(long)]
    layout: Option<coherent::render::colour::Layout>,
    /// Render the frame N times in a row and report each frame's seconds and their median
    /// (as `reproduce` times frames; the image and statistics are the last frame's). The
    /// first frame of a run also pays for fresh memory.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Output image: .exr (HDR radiance) or .png (tone-mapped).
    #[arg(long, short)]
    out: std::path::PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// What `coherent view` takes.
#[derive(clap::Args, Debug)]
struct ViewArgs {
    /// A scene file (.toml), a built-in scene's name, or a bare mesh file.
    scene: String,
    /// The address to serve on (only this machine can reach the default).
    #[arg(long, default_value = "127.0.0.1")]
    bind: std::net::IpAddr,
    /// The port to serve on (0: any free port; the address printed says which).
    #[arg(long, default_value_t = 8000)]
    port: u16,
    #[arg(long, help = backend_help())]
    backend: Option<String>,
    #[arg(long, default_value = "bsp", help = accel_help())]
    accel: String,
    /// Image size WxH.
    #[arg(long, default_value = "512x384", value_parser = parse_resolution)]
    resolution: (u32, u32),
    /// Adaptive anti-aliasing to this relative accuracy (default: the scene's, else 0.05).
    #[arg(long)]
    accuracy: Option<f32>,
    /// Uniform supersampling with N samples per pixel (instead of the adaptive method).
    #[arg(long, conflicts_with = "accuracy")]
    spp: Option<u32>,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
}

/// `--bsp-build`: clap lists the names and refuses others.
fn parse_bsp_build() -> impl clap::builder::TypedValueParser<Value = coherent::bsp::BuildPreset> {
    use clap::builder::TypedValueParser;
    let names = coherent::bsp::BuildPreset::ALL.map(|b| b.name());
    clap::builder::PossibleValuesParser::new(names).map(|s| {
        s.parse::<coherent::bsp::BuildPreset>()
            .expect("a listed name")
    })
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("resolution `{s}`: expected WxH, e.g. 1024x768"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|e| format!("resolution `{s}`: `{v}` is not a size ({e})"))
    };
    Ok((p(w)?, p(h)?))
}

/// `coherent scenes`.
fn scenes() -> anyhow::Result<()> {
    let mut out = io::stdout().lock();
    writeln!(out, "Built in (`coherent render NAME`):")?;
    for (name, about) in coherent::scene::builtin_names() {
        writeln!(out, "  {name:<12} {about}")?;
    }
    // The scene files of the repository this binary was built from (real scenes: their
    // assets come from `python3 scripts/native.py`).
    let dir = coherent::scene::scenes_dir();
    let mut files: Vec<_> = match std::fs::read_dir(&dir) {
        Ok(d) => d.filter_map(|e| e.ok().map(|e| e.path())).collect(),
        Err(e) => {
            writeln!(
                out,
                "No scene files: {} cannot be read ({e})",
                dir.display()
            )?;
            Vec::new()
        }
    };
    files.retain(|p| p.extension().is_some_and(|e| e == "toml"));
    files.sort();
    if !files.is_empty() {
        writeln!(
            out,
            "Scene files in {} (`coherent render FILE`):",
            dir.display()
        )?;
        for f in files {
            let about = std::fs::read_to_string(&f)
                .map(|t| first_sentence(&t))
                .unwrap_or_default();
            let name = f.file_name().unwrap_or_default().to_string_lossy();
            writeln!(out, "  {name:<16} {about}")?;
        }
    }
    out.flush()?;
    Ok(())
}

/// What a scene file is: the first sentence of its leading comment lines, joined.
fn first_sentence(text: &str) -> String {
    let comment = text
        .lines()
        .map_while(|l| l.trim_start().strip_prefix('#'))
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(" ");
    match comment.find(". ") {
        Some(i) => comment[..=i].to_owned(),
        None => comment,
    }
}

/// `coherent info`.
fn info(json: bool) -> anyhow::Result<()> {
    let machine = Machine::detect();
    let mut out = io::stdout().lock();
    if json {
        writeln!(out, "{}", machine.to_json())?;
        return Ok(());
    }
    let list = |items: &[String]| {
        if items.is_empty() {
            "(none)".to_owned()
        } else {
            items.join(" ")
        }
    };
    let rustflags = if machine.rustflags.is_empty() {
        "(none)"
    } else {
        &machine.rustflags
    };
    writeln!(out, "coherent {}", env!("CARGO_PKG_VERSION"))?;
    writeln!(out, "cpu:               {}", machine.cpu)?;
    writeln!(
        out,
        "cores / threads:   {} / {}",
        machine.cores, machine.threads
    )?;
    writeln!(out, "os:                {}", machine.os)?;
    writeln!(out, "cpu features:      {}", list(&machine.cpu_features))?;
    writeln!(out, "build:")?;
    writeln!(out, "  rustc:           {}", machine.rustc)?;
    writeln!(out, "  profile:         {}", machine.profile)?;
    writeln!(out, "  RUSTFLAGS:       {rustflags}")?;
    writeln!(out, "  target features: {}", list(&machine.target_features))?;
    writeln!(out, "  git:             {}", machine.git_rev)?;
    writeln!(out, "backends:")?;
    for backend in Backend::every() {
        let lanes = match backend.lanes() {
            1 => "1 lane".to_owned(),
            n => format!("{n} lanes"),
        };
        let state = match (backend.compiled(), backend.unavailable_reason()) {
            (_, None) => "compiled in, usable here".to_owned(),
            (true, Some(reason)) => format!("compiled in, not usable here: {reason}"),
            (false, Some(reason)) => reason,
        };
        writeln!(out, "  {:<10} {lanes:<9} {state}", backend.name())?;
    }
    let skipped: Vec<String> = Backend::skipped()
        .into_iter()
        .map(|(b, _)| b.name().to_owned())
        .collect();
    writeln!(
        out,
        "  skipped here: {}",
        if skipped.is_empty() {
            "(none)".to_owned()
        } else {
            skipped.join(", ")
        }
    )?;
    writeln!(
        out,
        "  wide4/8/16 use the build's target features (above): build with\n  \
         RUSTFLAGS=\"-C target-cpu=native\" to let them use this CPU's AVX/AVX-512;\n  \
         avx2/avx512 (hand-written intrinsics) and pulp8/16 (pulp's portable\n  \
         operations) choose AVX2/AVX-512 at run time."
    )?;
    writeln!(out, "accelerators:")?;
    for k in AccelKind::ALL {
        writeln!(out, "  {:<7} {}", k.name(), k.describe())?;
    }
    out.flush()?;
    Ok(())
}

/// `--backend`'s help: every backend the dispatch module has, by family.
fn backend_help() -> String {
    let mut families = Backend::families();
    families.extend(Backend::FACTORS.map(Backend::family));
    let list: Vec<String> = families
        .iter()
        .map(|f| {
            let names: Vec<&str> = Backend::every()
                .filter(|b| b.family() == *f)
                .map(Backend::name)
                .collect();
            names.join(", ")
        })
        .collect();
    format!(
        "Lane backend: {} (`coherent info` says which run here; default: the widest \
         hand-written one usable here, else the widest `wide`)",
        list.join("; ")
    )
}

/// `--accel`'s help: every accelerator of `AccelKind`.
fn accel_help() -> String {
    let names: Vec<&str> = AccelKind::ALL.iter().map(|k| k.name()).collect();
    format!("Accelerator: {}", names.join(", "))
}
