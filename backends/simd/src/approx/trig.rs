//! Approximate inverse trigonometry for BDF and goniodiagram angles (sections 4.2 and 5) and
//! the spot-light cosine (section 5).

// The coefficients are quoted as Abramowitz & Stegun print them.
#![allow(clippy::excessive_precision)]

use core::f32::consts::{FRAC_PI_2, PI};

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};

/// Largest absolute error (radians) of [`acos`] and [`asin`] on [-1, 1]: the polynomial's
/// 6.8e-5 (Abramowitz & Stegun 4.4.45) plus f32 rounding.
pub const ACOS_MAX_ABS_ERROR: f32 = 7.0e-5;
/// Largest absolute error (radians) of [`atan`] and [`atan2`]: the polynomial's 1e-5
/// (Abramowitz & Stegun 4.4.49) plus f32 rounding.
pub const ATAN_MAX_ABS_ERROR: f32 = 1.2e-5;

/// `acos x`: `sqrt(1 - |x|) (a0 + a1|x| + a2|x|^2 + a3|x|^3)` (A&S 4.4.45), mirrored
/// (`pi - acos(-x)`) for negative x.
/// Error: at most [`ACOS_MAX_ABS_ERROR`] radians on [-1, 1].
/// Outside: `|x| > 1` and NaN give NaN (as `std`): clamp dot products first.
#[inline(always)]
pub fn acos<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let a = x.abs();
    let p = (a * -0.0187293 + 0.0742610).mul_add(a, l.splat(-0.2121144));
    let p = p.mul_add(a, l.splat(1.5707288));
    let r = (l.splat(1.0) - a).sqrt() * p;
    x.lt(l.splat(0.0)).select(l.splat(PI) - r, r)
}

/// `asin x = pi/2 - acos x`. Error: at most [`ACOS_MAX_ABS_ERROR`] radians on [-1, 1].
/// Outside: `|x| > 1` and NaN give NaN.
#[inline(always)]
pub fn asin<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    l.splat(FRAC_PI_2) - acos(l, x)
}

/// The odd polynomial of A&S 4.4.49 for `atan` on [-1, 1].
#[inline(always)]
fn atan_unit<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let x2 = x * x;
    let p = (x2 * 0.0208351 - 0.0851330).mul_add(x2, l.splat(0.1801410));
    let p = p.mul_add(x2, l.splat(-0.3302995));
    let p = p.mul_add(x2, l.splat(0.9998660));
    p * x
}

/// `atan x`, reduced to [-1, 1] by `atan x = ±pi/2 - atan(1/x)`.
/// Error: at most [`ATAN_MAX_ABS_ERROR`] radians for every finite x; `±inf` gives `±pi/2`;
/// NaN gives NaN.
#[inline(always)]
pub fn atan<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let big = x.abs().gt(l.splat(1.0));
    let t = big.select(l.splat(-1.0) / x, x);
    let r = atan_unit(l, t);
    big.select(l.splat(FRAC_PI_2).copysign(x) + r, r)
}

/// `atan2(y, x)` in (-pi, pi], by octant reduction to `atan` on [0, 1].
/// Error: at most [`ATAN_MAX_ABS_ERROR`] radians for finite arguments. Signed zeros follow
/// `std` (`atan2(±0, +0) = ±0`, `atan2(±0, -0) = ±pi`). Outside: both arguments infinite gives
/// NaN (`std` gives `±pi/4` or `±3pi/4`); any NaN gives NaN.
#[inline(always)]
pub fn atan2<L: Lanes>(l: L, y: L::F32s, x: L::F32s) -> L::F32s {
    let ax = x.abs();
    let ay = y.abs();
    let hi = ax.max(ay);
    let lo = ax.min(ay);
    let zero = l.splat(0.0);
    // 0/0 at the origin: the angle's magnitude is 0 there.
    let q = hi.eq(zero).select(zero, lo / hi);
    let r = atan_unit(l, q);
    let r = ay.gt(ax).select(l.splat(FRAC_PI_2) - r, r);
    let r = x.to_bits().lt(l.splat_i32(0)).select(l.splat(PI) - r, r); // sign bit: -0 too
    let r = r.copysign(y);
    (x.is_nan() | y.is_nan()).select(x + y, r)
}

/// The spot-light falloff cosine of section 5: `cos x ~ 1 - x^2/2`. The error is at most
/// `x^4 / 24` (the next term of the alternating series): see [`cos_spot_max_abs_error`].
/// Any x is accepted; NaN gives NaN.
#[inline(always)]
pub fn cos_spot<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    l.splat(1.0) - x * x * 0.5
}

/// The largest absolute error of [`cos_spot`] on `[-x, x]`: `x^4 / 24` (plus f32 rounding).
pub fn cos_spot_max_abs_error(x: f32) -> f32 {
    x.powi(4) / 24.0 + 2.0 * f32::EPSILON
}
