//! The paper's exponential (section 6.1): Padé [4/4] on [-3.8, 0], linear interpolation in a
//! 1024-entry uniform table on [-14, -3.8].

use super::tables::EXP;
use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};

/// Largest relative error of [`exp`] on [-14, 14]: the Padé part's, reached at x = -3.8
/// (9.79e-3, "about 1%" in the paper); the table part stays below 1.4e-5 (1.34e-5 measured
/// over 4 million points of [-14, -3.8), as before the one-read interpolation below).
pub const EXP_MAX_REL_ERROR: f32 = 9.8e-3;

const PADE_MIN: f32 = -3.8;
const TABLE_MIN: f32 = -14.0;
const TABLE_SCALE: f32 = 1024.0 / (PADE_MIN - TABLE_MIN);
/// `e^h - 1` for the table's step `h` (`(PADE_MIN - TABLE_MIN) / 1024`): the nodes grow
/// geometrically, so the right node of an interval is the left one times `e^h` (the tests
/// check the value against `f64::exp_m1`).
pub(super) const STEP_GROWTH: f32 = 0.010_010_713;

/// `e^x`, the paper's hybrid: `P(x) / P(-x)` with `P(x) = x^4 + 20x^3 + 180x^2 + 840x + 1680`
/// on [-3.8, 0], a 1024-interval table with linear interpolation on [-14, -3.8), and
/// `1 / e^-x` for positive x.
///
/// The interpolation reads one node per lane, not two: the nodes are `e^(x0 + k h)`, so an
/// interval's right node is its left node `v` times `e^h`, and the interpolant
/// `v + (v e^h - v) f` is `v + v (e^h - 1) f`. On the 8-lane backends that is one
/// `vgatherdps` instead of two 64-bit gathers and their shuffles; the error is unchanged.
///
/// Error: relative error at most [`EXP_MAX_REL_ERROR`] on [-14, 14].
/// Outside: `x < -14` gives 0 (the true value is below 8.4e-7, also the absolute error);
/// `x > 14` gives `+inf` (callers range-reduce first, as [`super::pow`] does); `-inf` gives 0,
/// `+inf` gives `+inf`, NaN gives NaN.
#[inline(always)]
pub fn exp<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let xn = -x.abs(); // e^x = 1 / e^-|x| for positive x
    let in_pade = xn.ge(l.splat(PADE_MIN));
    let r = if in_pade.all() {
        pade(l, xn)
    } else if in_pade.none() {
        table(l, xn)
    } else {
        in_pade.select(pade(l, xn), table(l, xn))
    };
    let r = xn.lt(l.splat(TABLE_MIN)).select(l.splat(0.0), r);
    let positive = x.gt(l.splat(0.0));
    let r = if positive.any() {
        positive.select(l.splat(1.0) / r, r)
    } else {
        r
    };
    x.is_nan().select(x, r)
}

#[inline(always)]
fn pade<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    // P(x) and P(-x) from the even and odd parts of P.
    let x2 = x * x;
    let even = (x2 + 180.0).mul_add(x2, l.splat(1680.0));
    let odd = (x2 + 42.0) * x * 20.0; // 20x^3 + 840x
    (even + odd) / (even - odd)
}

#[inline(always)]
fn table<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let t = (x - TABLE_MIN) * TABLE_SCALE;
    let i = t.to_i32().max(l.splat_i32(0)).min(l.splat_i32(1023));
    let f = t - i.to_f32();
    // Coherent packets (neighbouring pixels' exposures, a sweep) read neighbouring entries.
    let v0 = l.gather_near(&EXP, i);
    (v0 * STEP_GROWTH).mul_add(f, v0)
}

/// Largest relative error of [`exp_poly`] on its domain [-87, 88], measured by the tests'
/// sweep against `f64::exp` (`print_measured_errors`, 10^6 points): 2.5e-7 on the backends
/// without FMA, 2.3e-7 with it, a few ulp; the degree-6 Taylor remainder alone is below
/// 1.7e-7 on |r| <= ln 2 / 2.
pub const EXP_POLY_MAX_REL_ERROR: f32 = 4e-7;
/// The domain of [`exp_poly`]: `e^x` is a normal `f32` there and `2^k` needs no splitting.
pub const EXP_POLY_MIN: f32 = -87.0;
/// See [`EXP_POLY_MIN`].
pub const EXP_POLY_MAX: f32 = 88.0;

/// `ln 2` in two parts (Cody and Waite): `LN2_HI` (0.693145751953125) has 15 significant
/// bits, so `k * LN2_HI` is exact for the `|k| <= 127` used here.
const LN2_HI: f32 = f32::from_bits(0x3f31_7200);
const LN2_LO: f32 = (core::f64::consts::LN_2 - 0.693_145_751_953_125) as f32;

/// `e^x` as the field computes it today (Cephes, SLEEF, the SIMD libraries): the range
/// reduction `x = k ln 2 + r` with `k = round(x / ln 2)` and `|r| <= ln 2 / 2`, `e^r` by its
/// degree-6 Taylor polynomial (Horner), and `2^k` built in the exponent bits. No table, so
/// no gather: the comparison row for the paper's [`exp`] in the `kernels` experiment.
///
/// Error: relative error at most [`EXP_POLY_MAX_REL_ERROR`] on [[`EXP_POLY_MIN`],
/// [`EXP_POLY_MAX`]]. Outside: below gives 0 (the true value is below 1.7e-38, also the
/// absolute error), above gives `+inf`; `-inf` gives 0, `+inf` gives `+inf`, NaN gives NaN.
#[inline(always)]
pub fn exp_poly<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let lo = l.splat(EXP_POLY_MIN);
    let hi = l.splat(EXP_POLY_MAX);
    let xc = x.max(lo).min(hi);
    let k = (xc * core::f32::consts::LOG2_E).round();
    // Exact: k has at most 8 significant bits and LN2_HI 15.
    let r = xc - k * LN2_HI;
    let r = r - k * LN2_LO;
    let p = r.mul_add(l.splat(1.0 / 720.0), l.splat(1.0 / 120.0));
    let p = p.mul_add(r, l.splat(1.0 / 24.0));
    let p = p.mul_add(r, l.splat(1.0 / 6.0));
    let p = p.mul_add(r, l.splat(0.5));
    let p = p.mul_add(r, l.splat(1.0));
    let p = p.mul_add(r, l.splat(1.0));
    let two_k = ((k.to_i32() + l.splat_i32(127)) << 23).bits_to_f32();
    let y = p * two_k;
    let y = x.lt(lo).select(l.splat(0.0), y);
    let y = x.gt(hi).select(l.splat(f32::INFINITY), y);
    x.is_nan().select(x, y)
}
