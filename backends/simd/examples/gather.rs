//! Random gathers on every backend this CPU has: 2^20 lookups at random indices into a
//! 256 KiB table of `f32` (64 Ki values, larger than L1, inside L2), through `Lanes::gather`,
//! the operation a texture, a tabulated BDF and the paper's `exp` table read with.
//!
//! ```text
//! cargo run --release -p coherent-simd --example gather
//! ```
//!
//! It prints the median time of 15 rounds per backend (the backends interleaved in each
//! round) and the ratio to the hand-written backend of the same width. It is what
//! `docs/findings/backends.md` cites for pulp16's gathers by pairs of 64-bit words against
//! avx512's `vgatherdps`. Every backend's sum is checked against the scalar backend's.

use std::hint::black_box;
use std::time::Instant;

use coherent_simd::{Backend, Kernel, Lanes, SimdF32};

const TABLE: usize = 1 << 16;
const LOOKUPS: usize = 1 << 20;
const ROUNDS: usize = 15;

/// Sums `table[idx[i]]` over all indices, one packet at a time.
struct Gathers<'a> {
    table: &'a [f32],
    idx: &'a [i32],
}

impl Kernel for Gathers<'_> {
    type Output = f64;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f64 {
        let mut acc = l.splat(0.0);
        for chunk in self.idx.chunks_exact(L::N) {
            acc += l.gather(self.table, l.load_i32(chunk));
        }
        (0..L::N).map(|i| f64::from(acc.lane(i))).sum()
    }
}

fn main() {
    // Values with exact sums in f32 (small integers), so every backend's sum is the same.
    let table: Vec<f32> = (0..TABLE).map(|i| (i % 7) as f32).collect();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let idx: Vec<i32> = (0..LOOKUPS)
        .map(|_| {
            // xorshift64: the rays' lookups are what matters, not the generator's quality.
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % TABLE as u64) as i32
        })
        .collect();
    let expected = (idx.iter().map(|&i| f64::from(table[i as usize]))).sum::<f64>();

    let backends = Backend::available();
    let mut ms = vec![Vec::with_capacity(ROUNDS); backends.len()];
    for _ in 0..ROUNDS {
        for (b, times) in backends.iter().zip(&mut ms) {
            let start = Instant::now();
            let sum = b
                .run(Gathers {
                    table: black_box(&table),
                    idx: black_box(&idx),
                })
                .expect("usable backends run");
            times.push(start.elapsed().as_secs_f64() * 1e3);
            assert_eq!(sum, expected, "{b}: the gathered sum differs from scalar's");
        }
    }
    let medians: Vec<f64> = ms
        .iter_mut()
        .map(|t| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        })
        .collect();
    println!(
        "{LOOKUPS} random lookups in a {} KiB table, median of {ROUNDS} rounds",
        TABLE * 4 / 1024
    );
    for (b, median) in backends.iter().zip(&medians) {
        // The hand-written backend of this width, when this CPU runs it.
        let reference = Backend::preferred_for_lanes(b.lanes())
            .and_then(|p| backends.iter().position(|&u| u == p))
            .map(|i| medians[i]);
        let ratio = reference.map_or(String::new(), |r| {
            format!(", {:.2}x its width's hand-written backend", median / r)
        });
        println!(
            "{:>8} ({:>2} lanes): {median:6.3} ms{ratio}",
            b.name(),
            b.lanes()
        );
    }
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            println!("{:>8}: skipped, {why}", b.name());
        }
    }
}
