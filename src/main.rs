//! The `coherent` command line (DESIGN.md, "The CLI"): `coherent info` describes the CPU, the
//! build and the lane backends; `render` and `scenes` come with the renderer.

use clap::{Parser, Subcommand};
use coherent::machine::Machine;
use coherent::simd::Backend;
use std::io::{self, Write};
use std::process::ExitCode;

/// Coherent (SIMD packet) physically accurate ray tracing after Adinetz et al., Graphicon 2005.
#[derive(Parser, Debug)]
#[command(name = "coherent", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
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
            eprintln!("coherent: error: {e:#}");
            ExitCode::FAILURE
        }
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
    for backend in Backend::ALL {
        let lanes = match backend.lanes() {
            1 => "1 lane".to_owned(),
            n => format!("{n} lanes"),
        };
        let state = match (backend.compiled(), backend.unavailable_reason()) {
            (_, None) => "compiled in, usable here".to_owned(),
            (true, Some(reason)) => format!("compiled in, not usable here: {reason}"),
            (false, Some(reason)) => reason,
        };
        writeln!(out, "  {:<7} {lanes:<9} {state}", backend.name())?;
    }
    writeln!(
        out,
        "  wide4/8/16 use the build's target features (above): build with\n  \
         RUSTFLAGS=\"-C target-cpu=native\" to let them use this CPU's AVX/AVX-512;\n  \
         pulp8/16 choose AVX2/AVX-512 at run time."
    )?;
    writeln!(out, "accelerators:")?;
    writeln!(
        out,
        "  bsp     the paper's two-level BSP, packets of every backend's width"
    )?;
    writeln!(out, "  embree  {}", embree_state())?;
    writeln!(out, "  obvhs   {}", obvhs_state())?;
    out.flush()?;
    Ok(())
}

/// Whether Embree is compiled in and loadable here, with its version or the reason.
fn embree_state() -> String {
    #[cfg(feature = "embree")]
    {
        match coherent::embree::version() {
            Ok(v) => format!(
                "Embree {}.{}.{} (rtcGetDeviceProperty VERSION {v}), packets of 1, 4, 8, 16",
                v / 10000,
                v / 100 % 100,
                v % 100
            ),
            Err(e) => format!("compiled in, not usable here: {e}"),
        }
    }
    #[cfg(not(feature = "embree"))]
    {
        "not compiled in (cargo feature `embree`)".to_owned()
    }
}

/// Whether obvhs is compiled in.
fn obvhs_state() -> String {
    if cfg!(feature = "obvhs") {
        "obvhs BVH2 / CWBVH, single rays (packets served lane by lane)".to_owned()
    } else {
        "not compiled in (cargo feature `obvhs`)".to_owned()
    }
}
