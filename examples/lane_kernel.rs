//! A kernel written once over the lane trait and run on every backend this CPU has: the
//! length of 2-D vectors, `sqrt(x^2 + y^2)`, checked against the scalar backend.
//!
//! `cargo run --release --example lane_kernel`
//!
//! A kernel is a struct holding its inputs; its `run` is generic over `Lanes` and is compiled
//! once per backend, inside that backend's `#[target_feature]` entry point
//! (`Backend::run`). Arithmetic goes through the lane type (`mul_add`, `sqrt`, ...); loads and
//! stores take slices of the lane count.

use std::time::Instant;

use coherent::simd::{Backend, Kernel, Lanes, SimdF32};

struct Lengths<'a> {
    x: &'a [f32],
    y: &'a [f32],
    out: &'a mut [f32],
}

impl Kernel for Lengths<'_> {
    type Output = ();

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        let n = self.x.len() / L::N * L::N;
        for i in (0..n).step_by(L::N) {
            let x = l.load(&self.x[i..i + L::N]);
            let y = l.load(&self.y[i..i + L::N]);
            x.mul_add(x, y * y).sqrt().store(&mut self.out[i..i + L::N]);
        }
        // The tail, one value at a time.
        for i in n..self.x.len() {
            self.out[i] = self.x[i].hypot(self.y[i]);
        }
    }
}

fn main() -> anyhow::Result<()> {
    let n = 1 << 20;
    let x: Vec<f32> = (0..n).map(|i| (i % 1000) as f32 * 0.01).collect();
    let y: Vec<f32> = (0..n).map(|i| (i % 777) as f32 * 0.02).collect();
    let mut reference = vec![0.0; n];
    Backend::Scalar.run(Lengths {
        x: &x,
        y: &y,
        out: &mut reference,
    })?;
    for b in Backend::usable() {
        let mut out = vec![0.0; n];
        let start = Instant::now();
        b.run(Lengths {
            x: &x,
            y: &y,
            out: &mut out,
        })?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let worst = out
            .iter()
            .zip(&reference)
            .map(|(a, r)| ((a - r) / r.max(1e-30)).abs())
            .fold(0.0f32, f32::max);
        println!(
            "{:>8} ({:>2} lanes): {ms:7.3} ms, largest relative difference from scalar {worst:.1e}",
            b.name(),
            b.lanes()
        );
    }
    for (name, why) in Backend::ALL
        .iter()
        .filter_map(|b| b.unavailable_reason().map(|r| (b.name(), r)))
    {
        println!("{name:>8}: skipped, {why}");
    }
    Ok(())
}
