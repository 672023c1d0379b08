//! The paper's exponential (section 6.1): Padé [4/4] on [-3.8, 0], linear interpolation in a
//! 1024-entry uniform table on [-14, -3.8].

use super::tables::EXP;
use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};

/// Largest relative error of [`exp`] on [-14, 14]: the Padé part's, reached at x = -3.8
/// (9.79e-3, "about 1%" in the paper); the table part stays below 1.3e-5.
pub const EXP_MAX_REL_ERROR: f32 = 9.8e-3;

const PADE_MIN: f32 = -3.8;
const TABLE_MIN: f32 = -14.0;
const TABLE_SCALE: f32 = 1024.0 / (PADE_MIN - TABLE_MIN);

/// `e^x`, the paper's hybrid: `P(x) / P(-x)` with `P(x) = x^4 + 20x^3 + 180x^2 + 840x + 1680`
/// on [-3.8, 0], a 1024-interval table with linear interpolation on [-14, -3.8), and
/// `1 / e^-x` for positive x.
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
    let (v0, v1) = l.gather2(&EXP, i);
    (v1 - v0).mul_add(f, v0)
}
