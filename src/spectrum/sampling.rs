//! The wavelengths a spectral sample carries, and how its values become CIE XYZ.
//!
//! Two schemes: hero wavelengths (Wilkie et al. 2014, "Hero Wavelength Spectral
//! Sampling"), [`HERO`] wavelengths per sample drawn from one random number and spread
//! evenly over the range, so that a path traced once estimates four wavelengths and the
//! colour noise of single-wavelength sampling mostly cancels; and fixed bins (the paper's
//! "20 to 40 intensities measured for different wavelengths"), a deterministic spectrum of
//! `n` values per sample.

use coherent_simd::{Lanes, SimdF32, SimdMask};

use super::cie::{self, SAMPLES};
use super::{LAMBDA_MAX, LAMBDA_MIN, SpectrumError};

/// Wavelengths per hero sample.
pub const HERO: usize = 4;

/// The width of the module's range, in nm.
const RANGE: f32 = LAMBDA_MAX - LAMBDA_MIN;

/// The hero wavelengths of a sample with random number `u` in `[0, 1)`: the hero
/// `λ0 = LAMBDA_MIN + u · range` and the others a quarter of the range apart, wrapping
/// around past [`LAMBDA_MAX`]. Each is uniform over the range when `u` is (and lies in
/// [`LAMBDA_MIN`, `LAMBDA_MAX`]: rounding may give the upper end).
#[inline]
pub fn hero(u: f32) -> [f32; HERO] {
    std::array::from_fn(|j| {
        let mut t = u + j as f32 / HERO as f32;
        if t >= 1.0 {
            t -= 1.0;
        }
        LAMBDA_MIN + t * RANGE
    })
}

/// [`hero`] per lane, with the same bits.
#[inline(always)]
pub fn hero_lanes<L: Lanes>(l: L, u: L::F32s) -> [L::F32s; HERO] {
    let one = l.splat(1.0);
    let mut out = [l.splat(LAMBDA_MIN); HERO];
    for (j, lambda) in out.iter_mut().enumerate() {
        let t = u + j as f32 / HERO as f32;
        let t = t.ge(one).select(t - 1.0, t);
        *lambda = t * RANGE + LAMBDA_MIN;
    }
    out
}

/// The CIE XYZ estimate of one hero sample: `values[j]` is the spectrum at `lambdas[j]`,
/// each drawn with the uniform density `1 / range`, so the estimate of
/// `∫ S [x̄, ȳ, z̄] dλ` is `range / HERO · Σ values[j] · cmf(lambdas[j])`.
pub fn hero_xyz(lambdas: [f32; HERO], values: [f32; HERO]) -> [f32; 3] {
    let mut xyz = [0.0f32; 3];
    for (&lambda, &v) in lambdas.iter().zip(&values) {
        for (acc, c) in xyz.iter_mut().zip(cie::cmf(lambda)) {
            *acc += v * c;
        }
    }
    xyz.map(|s| s * (RANGE / HERO as f32))
}

/// `n` bins of equal width over [`LAMBDA_MIN`, `LAMBDA_MAX`], each with the observer
/// integrated over it: a spectrum that is constant over each bin, at its bin average (as
/// [`Bins::tabulate`] gives), has `XYZ = Σ value_i · weight_i` exactly, with the observer
/// interpolated linearly between its 1 nm samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Bins {
    centres: Vec<f32>,
    weights: Vec<[f32; 3]>,
    /// The range the bins cover, in nm.
    range: [f32; 2],
}

impl Bins {
    /// The most bins.
    pub const MAX: u32 = 1024;

    /// `n` bins, 1 to [`Bins::MAX`], else [`SpectrumError::BadBins`].
    pub fn new(n: u32) -> Result<Self, SpectrumError> {
        Self::over(n, [LAMBDA_MIN, LAMBDA_MAX])
    }

    /// `n` bins over `range` (nm, a part of [`LAMBDA_MIN`, `LAMBDA_MAX`] with `lo < hi`): a
    /// narrow band renders one wavelength's image, as the prism's test does.
    pub fn over(n: u32, range: [f32; 2]) -> Result<Self, SpectrumError> {
        if !(1..=Self::MAX).contains(&n) {
            return Err(SpectrumError::BadBins { bins: n });
        }
        let [lo, hi] = range;
        if !(LAMBDA_MIN <= lo && lo < hi && hi <= LAMBDA_MAX) {
            return Err(SpectrumError::BadCoefficient {
                what: "the wavelength range of the bins".to_string(),
                value: if LAMBDA_MIN <= lo { hi } else { lo },
                expected: "lo < hi within 380-780 nm",
            });
        }
        let cumulative = CumulativeObserver::new();
        let width = f64::from(hi) - f64::from(lo);
        let edge = |i: u32| f64::from(lo) + width * f64::from(i) / f64::from(n);
        let mut centres = Vec::with_capacity(n as usize);
        let mut weights = Vec::with_capacity(n as usize);
        let mut below = cumulative.at(edge(0));
        for i in 0..n {
            let (lo, hi) = (edge(i), edge(i + 1));
            let above = cumulative.at(hi);
            centres.push(((lo + hi) / 2.0) as f32);
            weights.push([0, 1, 2].map(|c| (above[c] - below[c]) as f32));
            below = above;
        }
        Ok(Self {
            centres,
            weights,
            range,
        })
    }

    /// The number of bins.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Always false (there is at least one bin); here for clippy's `len` rule.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The width of each bin, in nm.
    pub fn width(&self) -> f32 {
        (self.range[1] - self.range[0]) / self.len() as f32
    }

    /// The range the bins cover, in nm.
    pub fn range(&self) -> [f32; 2] {
        self.range
    }

    /// The bins' centres, in nm.
    pub fn centres(&self) -> &[f32] {
        &self.centres
    }

    /// Per bin, `[∫ x̄, ∫ ȳ, ∫ z̄]` over the bin (nm).
    pub fn weights(&self) -> &[[f32; 3]] {
        &self.weights
    }

    /// The CIE XYZ of a spectrum given by its bin averages: `Σ values[i] · weights[i]`.
    ///
    /// # Panics
    ///
    /// If `values` does not hold one value per bin.
    pub fn xyz(&self, values: &[f32]) -> [f32; 3] {
        assert_eq!(values.len(), self.len(), "one value per spectral bin");
        let mut xyz = [0.0f64; 3];
        for (&v, w) in values.iter().zip(&self.weights) {
            for (acc, &wc) in xyz.iter_mut().zip(w) {
                *acc += f64::from(v) * f64::from(wc);
            }
        }
        xyz.map(|s| s as f32)
    }

    /// The bin averages of `f` (λ in nm): per bin the mean of `f` at the midpoints of
    /// equal steps of at most 1 nm (a bin narrower than 1 nm takes its centre).
    pub fn tabulate(&self, f: impl Fn(f32) -> f32) -> Vec<f32> {
        let width = (f64::from(self.range[1]) - f64::from(self.range[0])) / self.len() as f64;
        let steps = width.ceil() as usize;
        let step = width / steps as f64;
        (0..self.len())
            .map(|i| {
                let lo = f64::from(self.range[0]) + width * i as f64;
                let sum: f64 = (0..steps)
                    .map(|k| f64::from(f((lo + (k as f64 + 0.5) * step) as f32)))
                    .sum();
                (sum / steps as f64) as f32
            })
            .collect()
    }
}

/// `∫ [x̄, ȳ, z̄] dλ` from [`LAMBDA_MIN`] up to a wavelength, exact for the observer
/// interpolated linearly between its 1 nm samples.
struct CumulativeObserver {
    /// At each 1 nm sample.
    knots: Vec<[f64; 3]>,
}

impl CumulativeObserver {
    fn new() -> Self {
        let t = cie::cmf_table();
        let mut knots = Vec::with_capacity(SAMPLES);
        let mut acc = [0.0f64; 3];
        knots.push(acc);
        for i in 1..SAMPLES {
            for (c, a) in acc.iter_mut().enumerate() {
                *a += (t[c][i - 1] + t[c][i]) / 2.0;
            }
            knots.push(acc);
        }
        Self { knots }
    }

    /// The integral up to `lambda` (nm), clamped to the range.
    fn at(&self, lambda: f64) -> [f64; 3] {
        let x = (lambda - f64::from(LAMBDA_MIN)).clamp(0.0, (SAMPLES - 1) as f64);
        let k = (x.floor() as usize).min(SAMPLES - 2);
        let s = x - k as f64;
        let t = cie::cmf_table();
        // ∫_0^s (c_k + (c_{k+1} - c_k) σ) dσ.
        std::array::from_fn(|c| {
            let (a, b) = (t[c][k], t[c][k + 1]);
            self.knots[k][c] + a * s + (b - a) * s * s / 2.0
        })
    }
}

#[cfg(test)]
mod tests {
    use coherent_simd::scalar::Scalar;
    use coherent_simd::{Backend, Kernel};

    use super::*;
    use crate::spectrum::illuminant::{Emission, EmissionTable, Illuminant, white};

    fn assert_rgb_one(rgb: [f32; 3], tol: f32, what: &str) {
        for c in rgb {
            assert!((c - 1.0).abs() < tol, "{what}: {rgb:?}");
        }
    }

    fn assert_xy(got: [f64; 2], want: [f64; 2], tol: f64, what: &str) {
        assert!(
            (got[0] - want[0]).abs() < tol && (got[1] - want[1]).abs() < tol,
            "{what}: {got:?}, expected {want:?} within {tol}"
        );
    }

    fn table_a() -> EmissionTable {
        Emission::from(Illuminant::A).table()
    }

    #[test]
    fn hero_wavelengths_are_a_quarter_range_apart_and_wrap() {
        assert_eq!(hero(0.0), [380.0, 480.0, 580.0, 680.0]);
        let h = hero(0.9);
        for (got, want) in h.iter().zip([740.0, 440.0, 540.0, 640.0]) {
            assert!((got - want).abs() < 1e-3, "{h:?}");
        }
        for k in 0..1000 {
            let u = k as f32 / 1000.0;
            let mut h = hero(u);
            assert!((h[0] - (LAMBDA_MIN + u * RANGE)).abs() < 1e-3, "{u}");
            assert!(
                h.iter().all(|l| (LAMBDA_MIN..=LAMBDA_MAX).contains(l)),
                "{u}: {h:?}"
            );
            h.sort_by(f32::total_cmp);
            for w in h.windows(2) {
                assert!((w[1] - w[0] - RANGE / 4.0).abs() < 1e-3, "{u}: {h:?}");
            }
        }
        let below_one = 1.0f32.next_down();
        assert!(
            hero(below_one)
                .iter()
                .all(|l| (LAMBDA_MIN..=LAMBDA_MAX).contains(l))
        );
    }

    /// `u`s over `[0, 1)`, the ends and rounding-prone values, padded to whole packets.
    fn probe_us() -> Vec<f32> {
        let mut us: Vec<f32> = (0..997).map(|k| k as f32 / 997.0).collect();
        us.extend([
            0.25,
            0.5,
            0.75,
            0.25f32.next_down(),
            0.75f32.next_up(),
            1.0f32.next_down(),
        ]);
        us.resize(us.len().next_multiple_of(16), 0.3);
        us
    }

    struct HeroAll<'a> {
        us: &'a [f32],
    }

    impl Kernel for HeroAll<'_> {
        type Output = Vec<[f32; HERO]>;
        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> Vec<[f32; HERO]> {
            let mut out = Vec::with_capacity(self.us.len());
            for chunk in self.us.chunks_exact(L::N) {
                let h = hero_lanes(l, l.load(chunk));
                out.extend((0..L::N).map(|k| h.map(|v| v.lane(k))));
            }
            out
        }
    }

    #[test]
    fn hero_lanes_is_hero_on_every_backend() {
        let us = probe_us();
        let bits = |h: [f32; HERO]| h.map(f32::to_bits);
        let want: Vec<[f32; HERO]> = us.iter().map(|&u| hero(u)).collect();
        for (&u, &w) in us.iter().zip(&want) {
            assert_eq!(bits(hero_lanes(Scalar, u)), bits(w), "scalar, u {u}");
        }
        for b in Backend::usable() {
            let got = b.run(HeroAll { us: &us }).unwrap();
            for ((&u, &w), &g) in us.iter().zip(&want).zip(&got) {
                assert_eq!(bits(g), bits(w), "{b}, u {u}");
            }
        }
    }

    /// The mean of the estimator over stratified `u`.
    fn hero_estimate(table: &EmissionTable, n: usize) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        for k in 0..n {
            let lambdas = hero((k as f32 + 0.5) / n as f32);
            let xyz = hero_xyz(lambdas, lambdas.map(|l| table.eval(l)));
            for (s, v) in sum.iter_mut().zip(xyz) {
                *s += f64::from(v);
            }
        }
        sum.map(|s| s / n as f64)
    }

    #[test]
    fn the_hero_estimator_is_unbiased() {
        let w = hero_estimate(white(), 4096);
        assert_rgb_one(cie::xyz_to_rgb(w.map(|v| v as f32)), 5e-3, "white");
        let a = table_a();
        let got = cie::chromaticity(hero_estimate(&a, 4096));
        assert_xy(got, cie::chromaticity(a.xyz()), 1e-3, "A");
        // One sample of a constant spectrum: range / 4 times the sum of cmf.
        let one = hero_xyz([500.0; 4], [1.0; 4]);
        assert!(
            (one[1] - RANGE * cie::cmf(500.0)[1]).abs() < 1e-4,
            "{one:?}"
        );
    }

    #[test]
    fn bin_counts_outside_1_to_1024_are_refused() {
        for n in [0, 1025, u32::MAX] {
            assert_eq!(Bins::new(n), Err(SpectrumError::BadBins { bins: n }));
        }
        for n in [1, 2, 31, 401, 1024] {
            let b = Bins::new(n).unwrap();
            assert_eq!(b.len(), n as usize);
            assert_eq!(b.weights().len(), n as usize);
            assert!(!b.is_empty());
        }
    }

    #[test]
    fn bins_tile_the_range_and_share_the_observer_out() {
        let b = Bins::new(4).unwrap();
        assert_eq!(b.centres(), [430.0, 530.0, 630.0, 730.0]);
        assert_eq!(b.width(), 100.0);
        let total = cie::xyz_of(|_| 1.0);
        for n in [1, 3, 32, 401, 1024] {
            let b = Bins::new(n).unwrap();
            let sums = [0, 1, 2].map(|c| b.weights().iter().map(|w| f64::from(w[c])).sum::<f64>());
            for (sum, whole) in sums.iter().zip(total) {
                // The sum of the samples differs from the integral of their interpolation
                // by half the (tiny) end values.
                assert!((sum / whole - 1.0).abs() < 1e-4, "{n} bins: {sums:?}");
            }
            let c = b.centres();
            assert!((c[0] - (LAMBDA_MIN + b.width() / 2.0)).abs() < 1e-3, "{n}");
            assert!(
                (c[c.len() - 1] - (LAMBDA_MAX - b.width() / 2.0)).abs() < 1e-3,
                "{n}"
            );
            // A constant spectrum is tabulated exactly.
            assert!(b.tabulate(|_| 2.5).iter().all(|&v| v == 2.5));
        }
    }

    #[test]
    fn thirty_two_bins_integrate_the_white_and_a() {
        let b = Bins::new(32).unwrap();
        let w = white();
        let xyz = b.xyz(&b.tabulate(|l| w.eval(l)));
        assert_rgb_one(cie::xyz_to_rgb(xyz), 1e-2, "white in 32 bins");
        let a = table_a();
        let xyz = b.xyz(&b.tabulate(|l| a.eval(l))).map(f64::from);
        assert_xy(
            cie::chromaticity(xyz),
            [0.44758, 0.40745],
            2e-3,
            "A in 32 bins",
        );
    }

    #[test]
    fn one_bin_and_401_bins_work() {
        let w = white();
        let one = Bins::new(1).unwrap();
        assert_eq!(one.centres(), [580.0]);
        let avg = one.tabulate(|l| w.eval(l));
        assert_eq!(avg.len(), 1);
        // The mean of the white over the range, times the observer's integral.
        let mean = w.values().iter().map(|&v| f64::from(v)).sum::<f64>() / SAMPLES as f64;
        assert!(
            (f64::from(avg[0]) / mean - 1.0).abs() < 1e-2,
            "{avg:?} vs {mean}"
        );
        let xyz = one.xyz(&avg);
        assert!((f64::from(xyz[1]) / (mean * cie::xyz_of(|_| 1.0)[1]) - 1.0).abs() < 1e-2);

        let fine = Bins::new(401).unwrap();
        let values = fine.tabulate(|l| w.eval(l));
        assert_eq!(values.len(), 401);
        assert_rgb_one(
            cie::xyz_to_rgb(fine.xyz(&values)),
            2e-3,
            "white in 401 bins",
        );
    }
}
