//! Approximations over lanes, written once over the lane trait (paper sections 4.2, 5, 6.1):
//! the paper's hybrid Padé/table `exp` and `log` (and `exp_poly`, the range-reduced
//! polynomial the field uses today, for comparison), `pow` by range reduction, inverse
//! trigonometry for BDF and goniodiagram angles, and the spot-light cosine.
//!
//! Each function states its largest error against `std` (measured by the tests in this
//! module over dense sweeps and proptests, for every backend) and what it returns outside
//! its domain. Every backend runs the same code, so backend comparisons measure the same
//! maths; results differ between backends only where `mul_add` is fused.

mod exp;
mod func;
mod log;
mod pow;
mod tables;
mod trig;

pub use exp::{
    EXP_MAX_REL_ERROR, EXP_POLY_MAX, EXP_POLY_MAX_REL_ERROR, EXP_POLY_MIN, exp, exp_poly,
};
pub use func::{Approx, Bound, EvalSlices, POW_MAX, POW_Y};
pub use log::{LOG_MAX_ABS_ERROR, log};
pub use pow::{POW_MAX_REL_ERROR, PowRange, pow};
pub use trig::{
    ACOS_MAX_ABS_ERROR, ATAN_MAX_ABS_ERROR, acos, asin, atan, atan2, cos_spot,
    cos_spot_max_abs_error,
};

#[cfg(test)]
mod tests;
