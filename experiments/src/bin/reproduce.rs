//! `reproduce [--quick] [--only NAME,...] [--out DIR]`: regenerates the results (paper
//! section 7) into DIR (default: the workspace's `results/`). See `coherent_experiments::cli`.

use std::process::ExitCode;

fn main() -> ExitCode {
    coherent_experiments::cli::main(std::env::args_os(), coherent_experiments::EXPERIMENTS)
}
