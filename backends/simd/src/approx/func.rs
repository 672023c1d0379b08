//! The approximations by name, with their `std` references, domains and error bounds: one
//! table that the tests sweep and the `kernels` experiment times, so both see the same set.

use super::{
    ACOS_MAX_ABS_ERROR, ATAN_MAX_ABS_ERROR, EXP_MAX_REL_ERROR, EXP_POLY_MAX,
    EXP_POLY_MAX_REL_ERROR, EXP_POLY_MIN, LOG_MAX_ABS_ERROR, POW_MAX_REL_ERROR, PowRange, acos,
    asin, atan, atan2, cos_spot, cos_spot_max_abs_error, exp, exp_poly, log,
};
use crate::lanes::Lanes;

/// An approximation, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Approx {
    Exp,
    /// `e^x` by range reduction and a polynomial ([`super::exp_poly`]), beside the paper's.
    ExpPoly,
    Log,
    /// `x^(1/2.2)` over [0, 64] through [`PowRange`]: the display transform of tone mapping.
    Pow,
    Acos,
    Asin,
    Atan,
    Atan2,
    CosSpot,
}

/// How an approximation's error is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// `|approx - exact| <= bound * |exact|`.
    Relative(f32),
    /// `|approx - exact| <= bound`.
    Absolute(f32),
}

/// The exponent and range of [`Approx::Pow`].
pub const POW_Y: f32 = 1.0 / 2.2;
/// The range of [`Approx::Pow`].
pub const POW_MAX: f32 = 64.0;

impl Approx {
    /// Every approximation.
    pub const ALL: [Approx; 9] = [
        Approx::Exp,
        Approx::ExpPoly,
        Approx::Log,
        Approx::Pow,
        Approx::Acos,
        Approx::Asin,
        Approx::Atan,
        Approx::Atan2,
        Approx::CosSpot,
    ];
    /// The kernels the `kernels` experiment times: the paper's exp, log, pow, acos, atan2,
    /// and the polynomial exp beside its exp.
    pub const TIMED: [Approx; 6] = [
        Approx::Exp,
        Approx::ExpPoly,
        Approx::Log,
        Approx::Pow,
        Approx::Acos,
        Approx::Atan2,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Approx::Exp => "exp",
            Approx::ExpPoly => "exp_poly",
            Approx::Log => "log",
            Approx::Pow => "pow",
            Approx::Acos => "acos",
            Approx::Asin => "asin",
            Approx::Atan => "atan",
            Approx::Atan2 => "atan2",
            Approx::CosSpot => "cos_spot",
        }
    }

    /// Whether the second argument is used (only `atan2(y, x)`, which takes `y` first).
    pub fn binary(self) -> bool {
        self == Approx::Atan2
    }

    /// The domain the bound holds on (`(lo, hi)` for each argument), as sampled by tests and
    /// the experiment.
    pub fn domain(self) -> (f32, f32) {
        match self {
            Approx::Exp => (-14.0, 14.0),
            Approx::ExpPoly => (EXP_POLY_MIN, EXP_POLY_MAX),
            Approx::Log => (1e-30, 1e30),
            Approx::Pow => (0.0, POW_MAX),
            Approx::Acos | Approx::Asin => (-1.0, 1.0),
            Approx::Atan => (-1e4, 1e4),
            Approx::Atan2 => (-1.0, 1.0),
            Approx::CosSpot => (-0.5, 0.5),
        }
    }

    /// The stated error bound at argument `x`.
    pub fn bound(self, x: f32) -> Bound {
        match self {
            Approx::Exp => Bound::Relative(EXP_MAX_REL_ERROR),
            Approx::ExpPoly => Bound::Relative(EXP_POLY_MAX_REL_ERROR),
            Approx::Log => Bound::Absolute(LOG_MAX_ABS_ERROR),
            Approx::Pow => Bound::Relative(POW_MAX_REL_ERROR),
            Approx::Acos | Approx::Asin => Bound::Absolute(ACOS_MAX_ABS_ERROR),
            Approx::Atan | Approx::Atan2 => Bound::Absolute(ATAN_MAX_ABS_ERROR),
            Approx::CosSpot => Bound::Absolute(cos_spot_max_abs_error(x)),
        }
    }

    /// The `std` value, in `f64`.
    pub fn reference(self, a: f32, b: f32) -> f64 {
        let (a, b) = (a as f64, b as f64);
        match self {
            Approx::Exp | Approx::ExpPoly => a.exp(),
            Approx::Log => a.ln(),
            Approx::Pow => a.powf(POW_Y as f64),
            Approx::Acos => a.acos(),
            Approx::Asin => a.asin(),
            Approx::Atan => a.atan(),
            Approx::Atan2 => a.atan2(b),
            Approx::CosSpot => a.cos(),
        }
    }

    /// The approximation on a packet (`b` is used by `atan2` only).
    #[inline(always)]
    pub fn eval<L: Lanes>(self, l: L, a: L::F32s, b: L::F32s) -> L::F32s {
        match self {
            Approx::Exp => exp(l, a),
            Approx::ExpPoly => exp_poly(l, a),
            Approx::Log => log(l, a),
            Approx::Pow => PowRange::new(POW_Y, POW_MAX)
                .expect("constant range")
                .pow(l, a),
            Approx::Acos => acos(l, a),
            Approx::Asin => asin(l, a),
            Approx::Atan => atan(l, a),
            Approx::Atan2 => atan2(l, a, b),
            Approx::CosSpot => cos_spot(l, a),
        }
    }
}

impl core::fmt::Display for Approx {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

impl core::str::FromStr for Approx {
    type Err = String;
    fn from_str(s: &str) -> Result<Approx, String> {
        Approx::ALL
            .into_iter()
            .find(|a| a.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Approx::ALL.iter().map(|a| a.name()).collect();
                format!("unknown approximation `{s}`; known: {}", names.join(", "))
            })
    }
}

/// `out[i] = f(a[i], b[i])` for an approximation over slices (tail padded), on any backend:
/// `Backend::run(EvalSlices { .. })`. Used by the accuracy sweeps of the tests and of the
/// `kernels` experiment.
pub struct EvalSlices<'a> {
    pub f: Approx,
    pub a: &'a [f32],
    pub b: &'a [f32],
}

impl crate::dispatch::Kernel for EvalSlices<'_> {
    type Output = Vec<f32>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<f32> {
        let mut out = vec![0.0; self.a.len()];
        let f = self.f;
        crate::slices::map2(
            l,
            self.a,
            self.b,
            &mut out,
            #[inline(always)]
            |x, y| f.eval(l, x, y),
        );
        out
    }
}
