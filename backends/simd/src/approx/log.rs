//! The paper's natural logarithm (section 6.1): Padé above 0.17, a 1024-entry interpolated
//! table on (0, 0.17].

use super::tables::LN_MANTISSA;
use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};

/// Largest absolute error of [`log`] for positive finite x: the Padé part's, reached at
/// x = 0.17 (and 1/0.17), 3.8e-4; the table part stays below 2e-7 (plus f32 rounding of
/// the result).
pub const LOG_MAX_ABS_ERROR: f32 = 3.9e-4;

const PADE_MIN: f32 = 0.17;
const LN_2: f32 = core::f32::consts::LN_2;

/// `ln x`. On (0.17, 1] the [5/4] Padé approximant of `2 atanh(z)`, `z = (x - 1) / (x + 1)`;
/// on (0, 0.17] `e ln 2 + ln m` for `x = m 2^e`, with `ln m` interpolated in a 1024-interval
/// table over the mantissa m in [1, 2) (the paper's table, indexed by the mantissa so that
/// it keeps its accuracy down to the smallest denormal); above 1, `-ln(1/x)`.
///
/// Error: absolute error at most [`LOG_MAX_ABS_ERROR`] for every positive finite x.
/// Outside: `±0` gives `-inf`, `+inf` gives `+inf`, negative x and NaN give NaN.
#[inline(always)]
pub fn log<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let one = l.splat(1.0);
    let above_one = x.gt(one);
    // In [0, 1] for non-negative x (the division only where a lane needs it).
    let xr = if above_one.any() {
        above_one.select(one / x, x)
    } else {
        x
    };
    let in_pade = xr.gt(l.splat(PADE_MIN));
    let r = if in_pade.all() {
        pade(l, xr)
    } else if in_pade.none() {
        table(l, xr)
    } else {
        in_pade.select(pade(l, xr), table(l, xr))
    };
    let r = xr.eq(l.splat(0.0)).select(l.splat(f32::NEG_INFINITY), r);
    let r = above_one.select(-r, r);
    // NaN and negative x (not `x >= 0`) give NaN.
    x.ge(l.splat(0.0)).select(r, l.splat(f32::NAN))
}

#[inline(always)]
fn pade<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    // atanh(z) ~ z (945 - 735 z^2 + 64 z^4) / (945 - 1050 z^2 + 225 z^4)
    let z = (x - 1.0) / (x + 1.0);
    let z2 = z * z;
    let num = (z2 * 64.0 - 735.0).mul_add(z2, l.splat(945.0));
    let den = (z2 * 225.0 - 1050.0).mul_add(z2, l.splat(945.0));
    (z + z) * num / den
}

#[inline(always)]
fn table<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    // Scale denormals into the normal range first.
    let tiny = x.lt(l.splat(f32::MIN_POSITIVE));
    let xs = tiny.select(x * 8388608.0, x); // 2^23
    let bits = xs.to_bits();
    let e = (bits.shr_logical(23) - l.splat_i32(127)).to_f32()
        - tiny.select(l.splat(23.0), l.splat(0.0));
    let mantissa = bits & l.splat_i32(0x7f_ffff);
    let i = mantissa.shr_logical(13); // top 10 mantissa bits: the interval
    let f = (mantissa & l.splat_i32(0x1fff)).to_f32() * (1.0 / 8192.0);
    let (v0, v1) = l.gather2(&LN_MANTISSA, i);
    let ln_m = (v1 - v0).mul_add(f, v0);
    e.mul_add(l.splat(LN_2), ln_m)
}
