//! `x^y` by the paper's range reduction (section 6.1): `x^y = Max^y * e^(y ln(x / Max))`,
//! so that the logarithm works on (0, 1] and the exponential on (-inf, 0].

use super::exp::{EXP_MAX_REL_ERROR, exp};
use super::log::{LOG_MAX_ABS_ERROR, log};
use crate::lanes::Lanes;

/// Largest relative error of [`PowRange::pow`] for `|y| <= 1` where the result is at least
/// `Max^y e^-14`: `EXP_MAX_REL_ERROR + |y| LOG_MAX_ABS_ERROR` (first order), 1.02e-2. For
/// other `y` the bound is `EXP_MAX_REL_ERROR + |y| * LOG_MAX_ABS_ERROR`.
pub const POW_MAX_REL_ERROR: f32 = EXP_MAX_REL_ERROR + LOG_MAX_ABS_ERROR + 1e-5;

/// The range reduction of a power with a fixed exponent `y` over values in `[0, Max]`, as
/// tone mapping uses it: `Max` comes from a low-resolution pre-render (section 6.1) and
/// `Max^y` is computed once, exactly, with `std`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowRange {
    y: f32,
    inv_max: f32,
    max_pow_y: f32,
}

impl PowRange {
    /// The reduction for exponent `y` and largest value `max`; `None` unless `max` is
    /// positive and finite and `y` finite.
    pub fn new(y: f32, max: f32) -> Option<PowRange> {
        (max > 0.0 && max.is_finite() && y.is_finite()).then(|| PowRange {
            y,
            inv_max: 1.0 / max,
            max_pow_y: max.powf(y),
        })
    }

    /// The exponent.
    pub fn y(&self) -> f32 {
        self.y
    }

    /// `x^y`. Error: relative error at most `EXP_MAX_REL_ERROR + |y| LOG_MAX_ABS_ERROR`
    /// (see [`POW_MAX_REL_ERROR`]) while `x / Max >= e^(-14 / |y|)`; below that (results under
    /// `Max^y e^-14`) the result is 0 for positive y, with absolute error under
    /// `Max^y * 8.4e-7`. Values above `Max` work while `y ln(x / Max) <= 14`.
    /// Outside: `x = 0` gives 0 for positive y; negative x and NaN give NaN.
    #[inline(always)]
    pub fn pow<L: Lanes>(&self, l: L, x: L::F32s) -> L::F32s {
        let lnx = log(l, x * self.inv_max);
        exp(l, lnx * self.y) * self.max_pow_y
    }
}

/// `x^y` per lane without range reduction: `e^(y ln x)`. Relative error at most
/// `EXP_MAX_REL_ERROR + |y| LOG_MAX_ABS_ERROR` while `|y ln x| <= 14`; outside that range
/// the result is 0 or `+inf` as [`exp`] documents. Negative x and NaN give NaN; `0^y` is 0
/// for positive y.
#[inline(always)]
pub fn pow<L: Lanes>(l: L, x: L::F32s, y: L::F32s) -> L::F32s {
    exp(l, y * log(l, x))
}
