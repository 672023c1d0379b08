//! The approximate transcendentals the shading code uses (paper sections 4.1, 4.2 and 6.1:
//! inverse trigonometry for BDF angles, `pow` for inverse tone mapping, `log2` for mip
//! levels from ray differentials), gathered in one place so every caller measures the
//! same maths on every backend: thin wrappers over [`coherent_simd::approx`] with the
//! bounds the callers' tests use.

use coherent_simd::approx as simd_approx;
use coherent_simd::{Lanes, SimdF32};

/// Largest absolute error (radians) of [`acos`] on `[-1, 1]`.
pub const ACOS_ABS_ERROR: f32 = simd_approx::ACOS_MAX_ABS_ERROR;
/// Largest absolute error (radians) of [`atan2`].
pub const ATAN2_ABS_ERROR: f32 = simd_approx::ATAN_MAX_ABS_ERROR;
/// Largest relative error of [`pow`] for exponents `|y| <= 3` (inverse tone mapping's
/// gamma) and results above `e^-14`.
pub const POW_REL_ERROR: f32 =
    simd_approx::EXP_MAX_REL_ERROR + 3.0 * simd_approx::LOG_MAX_ABS_ERROR;
/// Largest absolute error of [`log2`] for positive finite arguments.
pub const LOG2_ABS_ERROR: f32 = simd_approx::LOG_MAX_ABS_ERROR / core::f32::consts::LN_2 + 1e-6;

/// `acos(x)` per lane, `x` clamped to `[-1, 1]` first (rounding can push a dot product of
/// unit vectors just past 1).
#[inline(always)]
pub fn acos<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    simd_approx::acos(l, x.clamp(l.splat(-1.0), l.splat(1.0)))
}

/// `atan2(y, x)` per lane, in `(-pi, pi]`.
#[inline(always)]
pub fn atan2<L: Lanes>(l: L, y: L::F32s, x: L::F32s) -> L::F32s {
    simd_approx::atan2(l, y, x)
}

/// `x^y` per lane for `x >= 0` (`0^y = 0` for positive `y`).
#[inline(always)]
pub fn pow<L: Lanes>(l: L, x: L::F32s, y: L::F32s) -> L::F32s {
    simd_approx::pow(l, x, y)
}

/// `log2(x)` per lane for `x > 0`.
#[inline(always)]
pub fn log2<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    simd_approx::log(l, x) * core::f32::consts::LOG2_E
}
