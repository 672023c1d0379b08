//! The spot light of section 5: a point light whose intensity falls off from the axis
//! between an inner and an outer cone angle. With `theta` the angle between the axis and
//! the direction to the lit point (approximate `acos`), `t = (theta - inner) / (outer -
//! inner)` clamped to `[0, 1]` and `x = t pi / 2`, the falloff is `cos x`: 1 inside the
//! inner cone, 0 at the outer one. The paper replaces `cos x` by `1 - x^2 / 2`
//! ([`SpotFalloff::Approx`], the default): that reaches 0 at `t = 2 sqrt(2) / pi ~ 0.90`
//! and is clamped there, a slightly narrower edge; [`SpotFalloff::Exact`] evaluates the
//! cosine by its Taylor series ([`super::sincos::cos_taylor`], within 4e-7 of `std`) for
//! comparison.

use coherent_simd::approx::cos_spot;
use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

use super::sincos::cos_taylor;
use super::{LightError, LightSample, check_colour, check_dir, check_point, finish_scaled, toward};
use crate::approx::acos;

/// How the spot's falloff cosine is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpotFalloff {
    /// The paper's `cos x ~ 1 - x^2 / 2`, clamped at 0.
    #[default]
    Approx,
    /// The cosine to f32 precision (Taylor series to `x^14`).
    Exact,
}

/// A spot light at `position` aimed along `axis`, with intensity `intensity` (W/sr) inside
/// the inner cone, falling off to 0 at the outer cone (half-angles in radians).
#[derive(Debug, Clone, PartialEq)]
pub struct Spot {
    position: Vec3,
    axis: Vec3,
    intensity: [f32; 3],
    inner: f32,
    outer: f32,
    falloff: SpotFalloff,
}

impl Spot {
    /// `inner` and `outer` are half-angles in radians, `0 <= inner < outer <= pi`.
    pub fn new(
        position: Vec3,
        axis: Vec3,
        intensity: [f32; 3],
        inner: f32,
        outer: f32,
        falloff: SpotFalloff,
    ) -> Result<Self, LightError> {
        if !(outer.is_finite() && outer > 0.0 && outer <= std::f32::consts::PI) {
            return Err(LightError::bad(
                "spot",
                "outer angle",
                outer,
                "not in (0, pi] radians",
            ));
        }
        if !(inner.is_finite() && inner >= 0.0 && inner < outer) {
            return Err(LightError::bad(
                "spot",
                "inner angle",
                inner,
                "not in [0, outer angle) radians",
            ));
        }
        Ok(Spot {
            position: check_point("spot", "position", position)?,
            axis: check_dir("spot", "axis", axis)?,
            intensity: check_colour("spot", "intensity", intensity)?,
            inner,
            outer,
            falloff,
        })
    }

    /// The same spot with another falloff.
    pub fn with_falloff(mut self, falloff: SpotFalloff) -> Self {
        self.falloff = falloff;
        self
    }

    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The unit axis the spot is aimed along.
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// Intensity inside the inner cone (W/sr per channel).
    pub fn intensity(&self) -> [f32; 3] {
        self.intensity
    }

    /// The inner and outer cone half-angles (radians).
    pub fn cone(&self) -> (f32, f32) {
        (self.inner, self.outer)
    }

    /// The falloff factor for the cosine of the angle to the axis, per lane.
    #[inline(always)]
    pub fn falloff<L: Lanes>(&self, l: L, cos_axis: L::F32s) -> L::F32s {
        let theta = acos(l, cos_axis);
        let scale = std::f32::consts::FRAC_PI_2 / (self.outer - self.inner);
        let x = ((theta - self.inner) * scale)
            .clamp(l.splat(0.0), l.splat(std::f32::consts::FRAC_PI_2));
        let f = match self.falloff {
            SpotFalloff::Approx => cos_spot(l, x),
            SpotFalloff::Exact => cos_taylor(l, x),
        };
        f.clamp(l.splat(0.0), l.splat(1.0))
    }

    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
    ) -> LightSample<L> {
        let t = toward(l, p, n, active, &Vec3s::splat(l, self.position));
        let cos_axis = -Vec3s::splat(l, self.axis).dot(t.wi);
        let f = self.falloff(l, cos_axis);
        let active = t.active & f.gt(l.splat(0.0));
        finish_scaled(l, n, active, t.wi, t.dist, self.intensity, f * t.inv_d2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;
    use coherent_simd::scalar::Scalar;

    fn spot(falloff: SpotFalloff) -> Spot {
        Spot::new(
            Vec3::new(0.0, 0.0, 2.0),
            -Vec3::Z,
            [1.0; 3],
            0.2,
            0.5,
            falloff,
        )
        .unwrap()
    }

    #[test]
    fn falloff_is_monotone_one_inside_and_zero_outside_the_cone() {
        for mode in [SpotFalloff::Approx, SpotFalloff::Exact] {
            let s = spot(mode);
            let mut prev = f32::INFINITY;
            for i in 0..=2000 {
                let theta = i as f32 * (std::f32::consts::PI / 2000.0);
                let f = s.falloff(Scalar, theta.cos());
                assert!(f <= prev, "{mode:?}: not monotone at {theta}: {f} > {prev}");
                prev = f;
                // acos is approximate to 7e-5 rad: stay that far from the cone edges.
                if theta < 0.2 - 1e-4 {
                    assert_eq!(f, 1.0, "{mode:?} at {theta}");
                }
                if theta > 0.5 + 1e-4 {
                    assert_eq!(f, 0.0, "{mode:?} at {theta}");
                }
                if mode == SpotFalloff::Exact && theta > 0.2 && theta < 0.5 {
                    let want = ((theta - 0.2) / 0.3 * std::f32::consts::FRAC_PI_2).cos();
                    // acos error 7e-5 rad times the slope pi/2 / 0.3.
                    assert!((f - want).abs() <= 4e-4, "{theta}: {f} vs {want}");
                }
            }
        }
    }

    #[test]
    fn approx_and_exact_falloff_differ_by_the_series_bound() {
        let (a, e) = (spot(SpotFalloff::Approx), spot(SpotFalloff::Exact));
        for i in 0..=1000 {
            let theta = 0.2 + 0.3 * i as f32 / 1000.0;
            let x = (theta - 0.2) / 0.3 * std::f32::consts::FRAC_PI_2;
            let (fa, fe) = (
                a.falloff(Scalar, theta.cos()),
                e.falloff(Scalar, theta.cos()),
            );
            // Where 1 - x^2/2 is not clamped, the two differ by at most x^4 / 24 (plus the
            // acos error times the slopes).
            if 1.0 - x * x / 2.0 > 0.0 {
                assert!(
                    (fa - fe).abs() <= x.powi(4) / 24.0 + 1e-3,
                    "{theta}: {fa} vs {fe}"
                );
            }
        }
    }

    #[test]
    fn on_axis_the_spot_is_an_omni_light() {
        let light = Light::Spot(spot(SpotFalloff::Approx));
        let e = irradiance1(&light, Vec3::ZERO, Vec3::Z);
        assert!((e[0] - 0.25).abs() < 1e-6, "{e:?}");
        // Outside the outer cone: dark (tan 0.5 * 2 = 1.09).
        assert_eq!(
            irradiance1(&light, Vec3::new(1.2, 0.0, 0.0), Vec3::Z),
            [0.0; 3]
        );
    }

    #[test]
    fn bad_cone_angles_are_errors() {
        let e =
            Spot::new(Vec3::ZERO, Vec3::Z, [1.0; 3], 0.5, 0.4, SpotFalloff::Approx).unwrap_err();
        assert!(e.to_string().contains("inner angle"), "{e}");
    }
}
