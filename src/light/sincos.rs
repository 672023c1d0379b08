//! Sine and cosine over lanes for the lights (section 5): surface lights place jittered
//! points on disks and the environment light turns map coordinates into directions. Taylor
//! series on `[-pi/2, pi/2]` after reflecting the argument there; errors against `std`
//! are bounded below.

use coherent_simd::{Lanes, SimdF32, SimdMask};

/// Largest absolute error of [`sincos`] and [`cos_taylor`] on their domains (f32
/// rounding; the series remainders are below 1e-9).
pub const SINCOS_ABS_ERROR: f32 = 4e-7;

/// `cos x` for `x` in `[-pi/2, pi/2]` by its Taylor series to `x^14` (Horner in `x^2`).
#[inline(always)]
pub fn cos_taylor<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let x2 = x * x;
    let mut c = l.splat(-1.0 / 87_178_291_200.0);
    c = c.mul_add(x2, l.splat(1.0 / 479_001_600.0));
    c = c.mul_add(x2, l.splat(-1.0 / 3_628_800.0));
    c = c.mul_add(x2, l.splat(1.0 / 40_320.0));
    c = c.mul_add(x2, l.splat(-1.0 / 720.0));
    c = c.mul_add(x2, l.splat(1.0 / 24.0));
    c = c.mul_add(x2, l.splat(-0.5));
    c.mul_add(x2, l.splat(1.0))
}

/// `sin x` for `x` in `[-pi/2, pi/2]` by its Taylor series to `x^15`.
#[inline(always)]
pub fn sin_taylor<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let x2 = x * x;
    let mut s = l.splat(-1.0 / 1_307_674_368_000.0);
    s = s.mul_add(x2, l.splat(1.0 / 6_227_020_800.0));
    s = s.mul_add(x2, l.splat(-1.0 / 39_916_800.0));
    s = s.mul_add(x2, l.splat(1.0 / 362_880.0));
    s = s.mul_add(x2, l.splat(-1.0 / 5040.0));
    s = s.mul_add(x2, l.splat(1.0 / 120.0));
    s = s.mul_add(x2, l.splat(-1.0 / 6.0));
    s.mul_add(x2, l.splat(1.0)) * x
}

/// `(sin x, cos x)` for `x` in `[-pi, pi]`: outside `[-pi/2, pi/2]`, `x` is reflected to
/// `+-pi - x` (same sine, opposite cosine).
#[inline(always)]
pub fn sincos<L: Lanes>(l: L, x: L::F32s) -> (L::F32s, L::F32s) {
    let half = l.splat(std::f32::consts::FRAC_PI_2);
    let far = x.abs().gt(half);
    let reflected = l.splat(std::f32::consts::PI).copysign(x) - x;
    let y = far.select(reflected, x);
    let c = cos_taylor(l, y);
    (sin_taylor(l, y), far.select(-c, c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;

    #[test]
    fn sincos_matches_std_on_minus_pi_to_pi() {
        for i in -20_000..=20_000 {
            let x = i as f32 * (std::f32::consts::PI / 20_000.0);
            let (s, c) = sincos(Scalar, x);
            let (es, ec) = (
                (s as f64 - (x as f64).sin()).abs(),
                (c as f64 - (x as f64).cos()).abs(),
            );
            assert!(
                es <= SINCOS_ABS_ERROR as f64 && ec <= SINCOS_ABS_ERROR as f64,
                "{x}: {es} {ec}"
            );
        }
    }
}
