//! The linear light of section 5: a segment sampled as point lights ("the linear light
//! source has been subdivided into 7 point light sources"), one per stratum of the
//! segment. The segment radiates a total intensity `I` (W/sr) evenly along its length and
//! equally in every direction, so each of the `n` points is an omni light of `I / n`.

use coherent_simd::{Lanes, Vec3s};
use glam::Vec3;

use super::{
    LightError, LightSample, Strata, check_colour, check_point, check_samples, finish_scaled,
    toward,
};

/// The paper's point count for linear lights.
pub const DEFAULT_POINTS: u32 = 7;

/// A segment from `a` to `b` radiating `intensity` (W/sr, the whole segment) isotropically.
#[derive(Debug, Clone, PartialEq)]
pub struct Linear {
    a: Vec3,
    b: Vec3,
    intensity: [f32; 3],
    strata: Strata,
}

impl Linear {
    /// `points` strata along the segment, offsets from `seed`, jittered by the caller's
    /// numbers when `jitter`.
    pub fn new(
        a: Vec3,
        b: Vec3,
        intensity: [f32; 3],
        points: u32,
        seed: u64,
        jitter: bool,
    ) -> Result<Self, LightError> {
        check_samples("linear", "points", u64::from(points), points)?;
        Ok(Linear {
            a: check_point("linear", "a", a)?,
            b: check_point("linear", "b", b)?,
            intensity: check_colour("linear", "intensity", intensity)?,
            strata: Strata::new(points, seed, jitter),
        })
    }

    pub fn samples(&self) -> u32 {
        self.strata.count()
    }

    /// Whether the points are jittered by the caller's numbers (else fixed).
    pub fn jittered(&self) -> bool {
        self.strata.jitter()
    }

    /// The segment's ends.
    pub fn ends(&self) -> (Vec3, Vec3) {
        (self.a, self.b)
    }

    /// Intensity of the whole segment (W/sr per channel).
    pub fn intensity(&self) -> [f32; 3] {
        self.intensity
    }

    /// The points' strata.
    pub fn strata(&self) -> &Strata {
        &self.strata
    }

    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
        k: u32,
        u: [L::F32s; 2],
    ) -> LightSample<L> {
        let count = self.strata.count();
        let k = k % count;
        let o = self.strata.offset(l, k, u);
        let s = (o[0] + k as f32) * (1.0 / count as f32);
        let q = Vec3s::splat(l, self.b - self.a).mul_add(s, Vec3s::splat(l, self.a));
        let t = toward(l, p, n, active, &q);
        finish_scaled(
            l,
            n,
            t.active,
            t.wi,
            t.dist,
            self.intensity,
            t.inv_d2 * (1.0 / count as f32),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;

    /// Irradiance at distance h from the middle of a segment of length `len` (total
    /// intensity I), on a surface facing it: `I / (h sqrt(h^2 + len^2 / 4))`.
    fn analytic(i: f32, len: f32, h: f32) -> f32 {
        i / (h * (h * h + len * len / 4.0).sqrt())
    }

    #[test]
    fn sampled_irradiance_converges_to_the_analytic_value() {
        let (len, h) = (2.0, 0.7);
        let want = analytic(1.0, len, h);
        let mut errors = Vec::new();
        for points in [7, 70, 700] {
            let light = Light::Linear(
                Linear::new(
                    Vec3::new(-1.0, 0.0, h),
                    Vec3::new(1.0, 0.0, h),
                    [1.0; 3],
                    points,
                    9,
                    false,
                )
                .unwrap(),
            );
            let e = irradiance1(&light, Vec3::ZERO, Vec3::Z)[0];
            errors.push((e - want).abs() / want);
        }
        assert!(errors[2] < 2e-3, "{errors:?}");
        assert!(errors[2] < errors[0], "{errors:?}");
    }

    #[test]
    fn zero_points_is_an_error() {
        assert!(Linear::new(Vec3::ZERO, Vec3::X, [1.0; 3], 0, 0, false).is_err());
    }

    #[test]
    fn sample_counts_past_the_limit_are_errors_before_any_memory_is_taken() {
        let max = crate::light::MAX_SAMPLES as u32;
        assert!(Linear::new(Vec3::ZERO, Vec3::X, [1.0; 3], max, 0, false).is_ok());
        let e = Linear::new(Vec3::ZERO, Vec3::X, [1.0; 3], 4_000_000_000, 0, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("points") && e.contains("65536"), "{e}");
        // Area lights count the product of their grid.
        let grid = crate::light::Rectangular::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            [1.0; 3],
            (100_000, 100_000),
            0,
            false,
        );
        assert!(grid.unwrap_err().to_string().contains("65536"));
    }
}
