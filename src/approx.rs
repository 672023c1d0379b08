//! The approximate transcendentals the shading code uses (paper sections 4.1, 4.2 and 6.1:
//! inverse trigonometry for BDF angles, `pow` for inverse tone mapping, `log2` for mip
//! levels from ray differentials), gathered in one place so every caller measures the
//! same maths on every backend.
//!
//! TEMPORARY: until `coherent_simd::approx` lands on main these call `std` lane by lane;
//! then each body becomes a call to the foundation's approximation (and its stated error
//! bound replaces [`ANGLE_ABS_ERROR`] / [`POW_REL_ERROR`]).

use coherent_simd::{Lanes, SimdF32};

/// Largest absolute error (radians) of [`acos`] and [`atan2`]; the tests of every module
/// that turns directions into angles use it as their tolerance.
pub const ANGLE_ABS_ERROR: f32 = 1e-6;
/// Largest relative error of [`pow`] and [`exp2`] for arguments in the ranges used here.
pub const POW_REL_ERROR: f32 = 1e-6;
/// Largest absolute error of [`log2`] for positive normal arguments.
pub const LOG2_ABS_ERROR: f32 = 1e-6;

/// `acos(x)` per lane, `x` clamped to `[-1, 1]`.
#[inline(always)]
pub fn acos<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    let x = x.clamp(l.splat(-1.0), l.splat(1.0));
    l.from_fn(|i| x.lane(i).acos())
}

/// `atan2(y, x)` per lane, in `[-pi, pi]`.
#[inline(always)]
pub fn atan2<L: Lanes>(l: L, y: L::F32s, x: L::F32s) -> L::F32s {
    l.from_fn(|i| y.lane(i).atan2(x.lane(i)))
}

/// `x^y` per lane for `x >= 0`.
#[inline(always)]
pub fn pow<L: Lanes>(l: L, x: L::F32s, y: L::F32s) -> L::F32s {
    l.from_fn(|i| x.lane(i).powf(y.lane(i)))
}

/// `log2(x)` per lane for `x > 0`.
#[inline(always)]
pub fn log2<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    l.from_fn(|i| x.lane(i).log2())
}
