//! Tone mapping (paper section 6.1): one global operator per image, its parameters taken
//! from a low-resolution pre-render (the logarithmic average and maximum luminance), applied
//! to packets of pixels with the range-reduced power `x^y = Max^y e^(y ln(x / Max))` of
//! [`coherent_simd::approx::PowRange`].
//!
//! The paper uses the operator of its reference \[22\] (Barladian et al. 2004), whose formula
//! is not given. [`Operator::Tumblin`] stands in for it: Tumblin and Rushmeier's 1993
//! operator has exactly the ingredients the paper names (a log-average adaptation
//! luminance and one power per pixel with an exponent shared by the image). Reinhard et
//! al. 2002 (global, key 0.18, white point from the pre-render maximum) and Ward 1994 (a
//! contrast-based scale factor) are offered for comparison.
//!
//! Luminance is Rec. 709 luminance of the radiance, read as cd/m^2. Colours keep their
//! chromaticity: every channel is scaled by `L_display / L`.
//!
//! Every operator shows a uniform scene as a mid grey, whatever its scale: the log average
//! lands at `1/sqrt(C_max) - 1/C_max` (Tumblin, 0.139), [`MID_GREY`] (Reinhard, 0.18) or
//! 0.232 (Ward, world at 50 cd/m^2), all with the display defaults.
//!
//! Why the default operator showed lit scenes black: Tumblin and Rushmeier's cd/m^2 `alpha`
//! and `beta` take `x = log10 L_a + 0.84`, and `beta(x) + alpha(x) (x - 0.84) = -0.432` for
//! every `x`, so with the offset on both sides the curve is `L_da (L / L_avg)^y`: the
//! world's log average shows at the display adaptation `L_da`. The offset was on the world
//! side only, which showed the log average at `L_da / 10^0.84 = 1.93` cd/m^2, under the
//! display's black level `L_dmax / C_max = 2.22`: display value 0 at every world scale, for
//! everything up to 1.1 times the log average. Reinhard's white point (the pre-render
//! maximum) showed a uniform scene all white; Ward's display adaptation `L_dmax / 2` showed
//! the log average at 0.52 and clipped anything 1.9 times brighter.

// Per-packet code uses index loops over lanes (see docs/architecture.md#inlining).
#![allow(clippy::needless_range_loop)]

use core::fmt;
use core::str::FromStr;

use coherent_simd::approx::{EXP_MAX_REL_ERROR, LOG_MAX_ABS_ERROR, PowRange};
use coherent_simd::{Lanes, Rgbs, SimdF32, SimdMask};

/// A global tone-mapping operator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Operator {
    /// Tumblin and Rushmeier 1993 (standing in for the paper's reference \[22\]).
    #[default]
    Tumblin,
    /// Reinhard et al. 2002, global operator with white point.
    Reinhard,
    /// Ward 1994, contrast-based scale factor.
    Ward,
}

impl Operator {
    pub const ALL: [Operator; 3] = [Operator::Tumblin, Operator::Reinhard, Operator::Ward];
    /// The name on the command line and in results (`tonemap_<name>` in `kernels.csv`).
    pub fn name(self) -> &'static str {
        match self {
            Operator::Tumblin => "tumblin",
            Operator::Reinhard => "reinhard",
            Operator::Ward => "ward",
        }
    }
}

impl fmt::Display for Operator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown operator name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown tone-mapping operator `{0}`; operators: tumblin, reinhard, ward")]
pub struct UnknownOperator(pub String);

impl FromStr for Operator {
    type Err = UnknownOperator;
    fn from_str(s: &str) -> Result<Operator, UnknownOperator> {
        Operator::ALL
            .into_iter()
            .find(|o| o.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| UnknownOperator(s.to_string()))
    }
}

/// Display parameters: maximum display luminance (cd/m^2) and maximum contrast, and how
/// radiance converts to world luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Display {
    pub l_dmax: f32,
    pub c_max: f32,
    /// `Some(t)`: radiance is scaled so that the pre-render's log average is `t` cd/m^2 (an
    /// exposure: renderers' radiance units are arbitrary, and Tumblin-Rushmeier and Ward
    /// are absolute operators: Ward shows a scene of 1 cd/m^2 at 0.06, and the level sets
    /// Tumblin-Rushmeier's contrast exponent). `None`: radiance is read as cd/m^2.
    pub world_log_average: Option<f32>,
}

impl Display {
    /// The luminance (cd/m^2) the viewer of the display is adapted to, `L_dmax / sqrt(C_max)`
    /// (Tumblin and Rushmeier's choice), for both absolute operators: Tumblin-Rushmeier
    /// shows the world's log average at this luminance.
    pub fn adaptation(&self) -> f64 {
        self.l_dmax as f64 / (self.c_max as f64).sqrt()
    }
}

impl Default for Display {
    /// A CRT-like display: 80 cd/m^2, contrast 36 (Tumblin and Rushmeier's defaults as
    /// commonly implemented), world scaled to a log average of 50 cd/m^2 (a lit interior).
    fn default() -> Display {
        Display {
            l_dmax: 80.0,
            c_max: 36.0,
            world_log_average: Some(50.0),
        }
    }
}

/// Reinhard's key: the display value of the log average, 18% grey (CIE lightness 49.5).
pub const MID_GREY: f32 = 0.18;

/// Tumblin and Rushmeier's adaptation offset: their `alpha` and `beta` take
/// `log10 L_a + 0.84` on the world and the display side alike.
const TR_OFFSET: f64 = 0.84;

/// What the operators need from the pre-render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptation {
    /// `exp(mean(ln(delta + L)))` over the pre-render's lit points (`L > 0`),
    /// `delta = DELTA * max`.
    pub log_average: f32,
    /// Largest luminance of the pre-render.
    pub max: f32,
}

impl Adaptation {
    /// `delta` of the log average relative to the maximum: bounds how far one near-black
    /// point pulls it down, and keeps the log average proportional to the radiance's scale
    /// (an absolute `delta` raised the log average of dim scenes, whatever their unit).
    pub const DELTA: f64 = 1e-6;

    /// From luminances (non-finite and negative values are skipped). Black points (rays
    /// that left the scene, unlit surfaces) are left out of the log average: with `delta`
    /// each pulled it down by up to `ln(1e-6)`, so a frame with much background showed its
    /// lit part too bright. An empty or black set gives `max = 0`, which
    /// maps everything to black.
    pub fn from_luminances(ls: impl IntoIterator<Item = f32>) -> Adaptation {
        let lit: Vec<f32> = ls
            .into_iter()
            .filter(|l| l.is_finite() && *l > 0.0)
            .collect();
        let max = lit.iter().fold(0.0f32, |m, &l| m.max(l));
        let delta = Self::DELTA * max as f64;
        let sum: f64 = lit.iter().map(|&l| (delta + l as f64).ln()).sum();
        let log_average = if lit.is_empty() {
            0.0
        } else {
            (sum / lit.len() as f64).exp() as f32
        };
        Adaptation { log_average, max }
    }
}

/// A tone-mapping operator with its per-image constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    op: Operator,
    /// Everything maps to black (a black pre-render).
    black: bool,
    /// Tumblin: `L_d = scale L^y - offset`; Reinhard: `L_s = scale L`, `offset = 1 / L_white^2`;
    /// Ward: `L_d = scale L`.
    scale: f32,
    offset: f32,
    /// Tumblin: the power with its range reduction.
    pow: Option<PowRange>,
    /// Tumblin: luminances are clamped here so that `y ln(L / Max) <= 13`.
    clamp_hi: f32,
}

/// Tumblin and Rushmeier's `alpha(x) = 0.4 x + 2.92` (x a log10 luminance).
fn tr_alpha(x: f64) -> f64 {
    0.4 * x + 2.92
}
/// Tumblin and Rushmeier's `beta(x) = -0.4 x^2 - 2.584 x + 2.0208`.
fn tr_beta(x: f64) -> f64 {
    -0.4 * x * x - 2.584 * x + 2.0208
}

impl ToneMap {
    pub fn new(op: Operator, a: Adaptation, d: Display) -> ToneMap {
        let black = !(a.max > 0.0 && a.max.is_finite() && a.log_average > 0.0);
        let mut t = ToneMap {
            op,
            black,
            scale: 0.0,
            offset: 0.0,
            pow: None,
            clamp_hi: f32::MAX,
        };
        if black {
            return t;
        }
        // World luminance = k * radiance luminance.
        let k = match d.world_log_average {
            Some(t) if t > 0.0 && t.is_finite() => t as f64 / a.log_average as f64,
            _ => 1.0,
        };
        let lavg = a.log_average as f64 * k;
        let max = a.max as f64;
        let l_da = d.adaptation();
        match op {
            Operator::Tumblin => {
                // The offset on both sides, as in tizian/tonemapper's TumblinRushmeierOperator
                // (same alpha, beta, formula and defaults 80, 36): then the curve is
                // `L_da (L / L_avg)^y`, the log average shown at L_da (see the module docs).
                let x_rw = lavg.log10() + TR_OFFSET;
                let x_d = l_da.log10() + TR_OFFSET;
                let (a_rw, b_rw) = (tr_alpha(x_rw), tr_beta(x_rw));
                let (a_d, b_d) = (tr_alpha(x_d), tr_beta(x_d));
                let y = a_rw / a_d;
                // (k L)^y = k^y L^y: the power runs on the radiance luminance.
                t.scale = (k.powf(y) * 10f64.powf((b_rw - b_d) / a_d) / d.l_dmax as f64) as f32;
                t.offset = 1.0 / d.c_max;
                t.pow = PowRange::new(y as f32, a.max);
                t.clamp_hi = (max * (13.0 / y.abs().max(1e-3)).exp()).min(f32::MAX as f64) as f32;
                if t.pow.is_none() {
                    t.black = true;
                }
            }
            Operator::Reinhard => {
                // Relative: the world scale k cancels. The white point is the scaled maximum,
                // but at least 1: a white point below 1 shows every luminance brighter than
                // linear exposure does (a uniform image all white), at 1 the curve is linear
                // (`s (1 + s) / (1 + s) = s`), so an image that fits under the key's linear
                // exposure is shown linearly, its log average at the key.
                let key = MID_GREY as f64;
                let lavg = a.log_average as f64;
                t.scale = (key / lavg) as f32;
                let white = (key / lavg * max).max(1.0);
                t.offset = (1.0 / (white * white)) as f32;
            }
            Operator::Ward => {
                // Ward's L_dmax / 2 for the display adaptation (a viewer adapted to a half-white
                // screen) showed the log average at 0.52 and clipped everything 1.9 times
                // brighter; the display's own adaptation puts it near mid grey.
                let num = 1.219 + l_da.powf(0.4);
                let den = 1.219 + lavg.powf(0.4);
                t.scale = (k * (num / den).powf(2.5) / d.l_dmax as f64) as f32;
            }
        }
        t
    }

    pub fn operator(&self) -> Operator {
        self.op
    }

    /// Whether everything maps to black (a black or empty pre-render).
    pub fn is_black(&self) -> bool {
        self.black
    }

    /// Largest absolute error of [`ToneMap::apply`]'s display luminance (in `[0, 1]`)
    /// against [`ToneMap::apply_exact`]: zero for Reinhard and Ward (no approximation);
    /// for Tumblin, the power's relative error `EXP_MAX_REL_ERROR + |y| LOG_MAX_ABS_ERROR`
    /// times the largest unclamped `scale L^y = L_d + offset <= 1 + 1/C_max`, plus `f32`
    /// rounding (1e-5). Channels are the display luminance times `c / L`, so their error is
    /// this bound times `c / L`.
    pub fn max_abs_error(&self) -> f32 {
        match (self.op, self.pow) {
            (Operator::Tumblin, Some(p)) if !self.black => {
                (EXP_MAX_REL_ERROR + p.y().abs() * LOG_MAX_ABS_ERROR) * (1.0 + self.offset) + 1e-5
            }
            _ => 1e-5,
        }
    }

    /// The display luminance in `[0, 1]` of world luminance `l`, with `std` maths.
    pub fn display_exact(&self, l: f32) -> f32 {
        if self.black || l.is_nan() || l <= 0.0 {
            return 0.0;
        }
        let d = match self.op {
            Operator::Tumblin => {
                let p = self.pow.expect("set unless black");
                self.scale * l.min(self.clamp_hi).powf(p.y()) - self.offset
            }
            Operator::Reinhard => {
                let s = self.scale * l;
                s * (1.0 + s * self.offset) / (1.0 + s)
            }
            Operator::Ward => self.scale * l,
        };
        d.clamp(0.0, 1.0)
    }

    /// One pixel, with `std` maths: the reference [`ToneMap::apply`] is checked against.
    pub fn apply_exact(&self, c: [f32; 3]) -> [f32; 3] {
        let c = [c[0].max(0.0), c[1].max(0.0), c[2].max(0.0)];
        let l = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        if l.is_nan() || l <= 0.0 {
            return [0.0; 3];
        }
        let k = self.display_exact(l) / l;
        [c[0] * k, c[1] * k, c[2] * k]
    }

    /// A packet of pixels (negative and NaN channels count as 0; black stays black).
    #[inline(always)]
    pub fn apply<L: Lanes>(&self, l: L, c: Rgbs<L>) -> Rgbs<L> {
        let zero = l.splat(0.0);
        let c = Rgbs::new(c.r.max(zero), c.g.max(zero), c.b.max(zero));
        if self.black {
            return Rgbs::zero(l);
        }
        let lum: L::F32s = c.luminance();
        let lit = lum.gt(zero);
        let d = match self.op {
            Operator::Tumblin => {
                let p = self.pow.expect("set unless black");
                let x = lum.min(l.splat(self.clamp_hi));
                p.pow(l, x) * self.scale - self.offset
            }
            Operator::Reinhard => {
                let s = lum * self.scale;
                s * (s * self.offset + 1.0) / (s + 1.0)
            }
            Operator::Ward => lum * self.scale,
        };
        let d = d.clamp(zero, l.splat(1.0));
        // Lanes with L = 0 divide 0 by 0: the select below discards them.
        let k = lit.select(d / lum, zero);
        c.scale(k)
    }
}

/// sRGB encoding of a display value in `[0, 1]` to 8 bits (exact `std` maths: done once
/// per output pixel, not per sample).
pub fn srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests;

/// Tone-maps an image in packets of the backend's width.
pub fn apply_image(
    backend: coherent_simd::Backend,
    t: &ToneMap,
    px: &[[f32; 3]],
) -> Result<Vec<[f32; 3]>, coherent_simd::BackendError> {
    let mut out = vec![[0.0f32; 3]; px.len()];
    apply_into(backend, t, px, &mut out)?;
    Ok(out)
}

/// Tone-maps `px` into `out` (the same length) in packets of the backend's width.
pub fn apply_into(
    backend: coherent_simd::Backend,
    t: &ToneMap,
    px: &[[f32; 3]],
    out: &mut [[f32; 3]],
) -> Result<(), coherent_simd::BackendError> {
    assert_eq!(px.len(), out.len(), "tone mapping: output length");
    backend.run(ImageKernel { t, px, out })
}

struct ImageKernel<'a> {
    t: &'a ToneMap,
    px: &'a [[f32; 3]],
    out: &'a mut [[f32; 3]],
}

impl coherent_simd::Kernel for ImageKernel<'_> {
    type Output = ();
    const BACKENDS: u32 = coherent_simd::Backend::WITH_FACTORS;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        let mut r = [0.0f32; coherent_simd::MAX_LANES];
        let mut g = [0.0f32; coherent_simd::MAX_LANES];
        let mut b = [0.0f32; coherent_simd::MAX_LANES];
        let mut i = 0;
        while i < self.px.len() {
            let n = (self.px.len() - i).min(L::N);
            for m in 0..L::N {
                let c = if m < n { self.px[i + m] } else { [0.0; 3] };
                r[m] = c[0];
                g[m] = c[1];
                b[m] = c[2];
            }
            let c = self
                .t
                .apply(l, Rgbs::new(l.load(&r), l.load(&g), l.load(&b)));
            c.r.store(&mut r);
            c.g.store(&mut g);
            c.b.store(&mut b);
            for m in 0..n {
                self.out[i + m] = [r[m], g[m], b[m]];
            }
            i += n;
        }
    }
}

/// Planar (structure-of-arrays) colour channels, as packets hold them.
pub struct Planar<'a> {
    pub r: &'a [f32],
    pub g: &'a [f32],
    pub b: &'a [f32],
}

/// Planar output channels.
pub struct PlanarMut<'a> {
    pub r: &'a mut [f32],
    pub g: &'a mut [f32],
    pub b: &'a mut [f32],
}

/// Tone-maps planar channels (all the same length) in packets of the backend's width,
/// loading and storing whole packets: the layout of a packet renderer's radiance, and the
/// form the `kernels` experiment times.
pub fn apply_planar(
    backend: coherent_simd::Backend,
    t: &ToneMap,
    px: Planar<'_>,
    out: PlanarMut<'_>,
) -> Result<(), coherent_simd::BackendError> {
    let n = px.r.len();
    assert!(
        px.g.len() == n
            && px.b.len() == n
            && out.r.len() == n
            && out.g.len() == n
            && out.b.len() == n,
        "tone mapping: channel lengths differ"
    );
    backend.run(PlanarKernel { t, px, out })
}

struct PlanarKernel<'a> {
    t: &'a ToneMap,
    px: Planar<'a>,
    out: PlanarMut<'a>,
}

impl coherent_simd::Kernel for PlanarKernel<'_> {
    type Output = ();
    const BACKENDS: u32 = coherent_simd::Backend::WITH_FACTORS;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        let n = self.px.r.len();
        let full = n - n % L::N;
        let mut i = 0;
        while i < full {
            let c = self.t.apply(
                l,
                Rgbs::new(
                    l.load(&self.px.r[i..]),
                    l.load(&self.px.g[i..]),
                    l.load(&self.px.b[i..]),
                ),
            );
            c.r.store(&mut self.out.r[i..]);
            c.g.store(&mut self.out.g[i..]);
            c.b.store(&mut self.out.b[i..]);
            i += L::N;
        }
        // The tail, through a padded packet.
        if full < n {
            let mut buf = [[0.0f32; coherent_simd::MAX_LANES]; 3];
            for m in 0..n - full {
                buf[0][m] = self.px.r[full + m];
                buf[1][m] = self.px.g[full + m];
                buf[2][m] = self.px.b[full + m];
            }
            let c = self.t.apply(
                l,
                Rgbs::new(l.load(&buf[0]), l.load(&buf[1]), l.load(&buf[2])),
            );
            c.r.store(&mut buf[0]);
            c.g.store(&mut buf[1]);
            c.b.store(&mut buf[2]);
            for m in 0..n - full {
                self.out.r[full + m] = buf[0][m];
                self.out.g[full + m] = buf[1][m];
                self.out.b[full + m] = buf[2][m];
            }
        }
    }
}

/// A coherent HDR test image for timing and accuracy (the `kernels` experiment): a smooth
/// coloured gradient over four decades of luminance, like neighbouring rendered pixels.
pub fn workload_image(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            let t = i as f32 / n.max(1) as f32;
            let l = 10f32.powf(-2.0 + 4.0 * t);
            [l * (1.0 + 0.3 * (t * 40.0).sin()), l, l * (0.6 + 0.4 * t)]
        })
        .collect()
}
