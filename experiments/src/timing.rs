//! Wall-clock timing for the experiments (paper section 7 reports seconds per run and the
//! ratio non-SSE / SSE; so do we).
//!
//! Timings are only meant as ratios within one run of `reproduce` on one machine: the
//! `speedup` columns divide two medians taken minutes apart on the same CPU, with the same
//! build. Absolute seconds depend on the CPU, its clock and what else runs on it; compare them
//! across machines only with `machine.json` in hand.

use std::hint::black_box;
use std::time::Instant;

/// The spread of repeated runs of one measurement, in seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Median of the repeats: the figure the CSVs report.
    pub median: f64,
    pub min: f64,
    pub max: f64,
    /// How many timed runs it summarises.
    pub repeats: usize,
}

/// Runs `f` `warmup` times untimed (caches, page faults, CPU clock), then `repeats` times
/// timed (at least once), and returns the median, min and max seconds. The result of `f` goes
/// through [`black_box`] so the work is not optimised away.
pub fn time<R>(warmup: usize, repeats: usize, mut f: impl FnMut() -> R) -> Timing {
    for _ in 0..warmup {
        black_box(f());
    }
    let repeats = repeats.max(1);
    let mut seconds: Vec<f64> = (0..repeats)
        .map(|_| {
            let start = Instant::now();
            black_box(f());
            start.elapsed().as_secs_f64()
        })
        .collect();
    seconds.sort_by(f64::total_cmp);
    Timing {
        median: median(&seconds),
        min: seconds[0],
        max: seconds[repeats - 1],
        repeats,
    }
}

pub use coherent::median::median;

/// `baseline / seconds`: the contract's speedup (scalar seconds of the same group over this
/// row's seconds); `inf` when `seconds` is 0, `NaN` when either is not a positive time.
pub fn speedup(baseline: f64, seconds: f64) -> f64 {
    if baseline.is_nan() || seconds.is_nan() || baseline < 0.0 || seconds < 0.0 {
        f64::NAN
    } else {
        baseline / seconds
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn median_min_max_and_call_counts() {
        let mut calls = 0;
        let t = time(2, 3, || {
            calls += 1;
            std::thread::sleep(Duration::from_millis(2 * calls));
        });
        assert_eq!(calls, 5);
        assert_eq!(t.repeats, 3);
        // The timed calls slept 6, 8 and 10 ms, in that order.
        assert!(
            t.min >= 0.006 && t.median >= 0.008 && t.max >= 0.010,
            "{t:?}"
        );
        assert!(t.min <= t.median && t.median <= t.max);
    }

    #[test]
    fn zero_repeats_still_times_once() {
        let mut calls = 0;
        let t = time(0, 0, || calls += 1);
        assert_eq!((calls, t.repeats), (1, 1));
        assert_eq!(t.min, t.max);
    }

    #[test]
    fn speedup_is_the_ratio() {
        assert_eq!(speedup(1.0, 0.25), 4.0);
        assert_eq!(speedup(1.0, 0.0), f64::INFINITY);
        assert!(speedup(-1.0, 1.0).is_nan());
    }
}
