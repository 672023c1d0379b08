//! The paper's `exp` timed by part: its Padé approximant (inputs in [-3.8, 0]), its table
//! (inputs in [-14, -3.8)), and both together as the `kernels` experiment times it (a sweep
//! of [-14, 0], 73% in the table part), on every backend this CPU has.
//!
//! ```text
//! cargo run --release -p coherent-simd --example exp_parts
//! ```
//!
//! `approx::exp` takes one path for a packet whose lanes all lie in one part, so a sweep of a
//! part times that part alone. Each set is 2^20 inputs in sweep order (coherent, as the
//! `kernels` experiment's), timed as the median of 15 rounds with the backends interleaved;
//! the speedups are over the scalar backend on the same set. `docs/findings/backends.md`
//! cites it for why exp misses 10x at 16 lanes.

use std::hint::black_box;
use std::time::Instant;

use coherent_simd::{Backend, Kernel, Lanes, SimdF32, approx};

const N: usize = 1 << 20;
const ROUNDS: usize = 15;

/// `exp` over `x` into `out`.
struct Exp<'a> {
    x: &'a [f32],
    out: &'a mut [f32],
}

impl Kernel for Exp<'_> {
    type Output = ();

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        for (x, out) in self
            .x
            .chunks_exact(L::N)
            .zip(self.out.chunks_exact_mut(L::N))
        {
            approx::exp(l, l.load(x)).store(out);
        }
    }
}

fn main() {
    let sweep = |lo: f32, hi: f32| -> Vec<f32> {
        (0..N)
            .map(|i| lo + (hi - lo) * (i as f32 / N as f32))
            .collect()
    };
    let sets = [
        ("Padé, [-3.8, 0]", sweep(-3.8, 0.0)),
        ("table, [-14, -3.8)", sweep(-14.0, -3.8)),
        ("both, [-14, 0]", sweep(-14.0, 0.0)),
    ];
    let backends = Backend::available();
    for (name, x) in &sets {
        let mut out = vec![0.0; N];
        let mut ms = vec![Vec::with_capacity(ROUNDS); backends.len()];
        for _ in 0..ROUNDS {
            for (b, times) in backends.iter().zip(&mut ms) {
                let start = Instant::now();
                b.run(Exp {
                    x: black_box(x),
                    out: black_box(&mut out),
                })
                .expect("usable backends run");
                times.push(start.elapsed().as_secs_f64() * 1e3);
            }
        }
        let medians: Vec<f64> = ms
            .iter_mut()
            .map(|t| {
                t.sort_by(f64::total_cmp);
                t[t.len() / 2]
            })
            .collect();
        let scalar = medians[0];
        println!("{name}: median of {ROUNDS} rounds of {N} values");
        for (b, median) in backends.iter().zip(&medians) {
            println!(
                "{:>8} ({:>2} lanes): {median:6.3} ms, {:5.2}x scalar",
                b.name(),
                b.lanes(),
                scalar / median
            );
        }
    }
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            println!("{:>8}: skipped, {why}", b.name());
        }
    }
}
