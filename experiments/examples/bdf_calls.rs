//! Times Table 1's BDF workload on one backend, for `perf stat` (task-clock) comparisons:
//! `bdf_calls <backend> <calls> [image size, 512]`; prints the backend, calls and seconds per call.

use std::time::Instant;

use coherent::bdf::workload::{BdfCalls, BdfInputs};
use coherent::bdf::{Analytic, PAPER_ANISOTROPIC_SHAPE, Symmetry};
use coherent::simd::Backend;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("scalar");
    let calls: usize = args
        .get(2)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(8_000_000);
    let backend = Backend::ALL
        .into_iter()
        .find(|b| b.name() == name)
        .ok_or_else(|| anyhow::anyhow!("no backend {name}"))?;
    let bdf = coherent::bdf::tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )?;
    let size: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(512);
    let inputs = BdfInputs::sphere(size);
    let start = Instant::now();
    let sum = backend.run(BdfCalls {
        bdf: &bdf,
        inputs: &inputs,
        calls,
    })?;
    let s = start.elapsed().as_secs_f64();
    println!(
        "{name} {calls} {:.2} ns/call (sum {sum})",
        s * 1e9 / calls as f64
    );
    Ok(())
}
