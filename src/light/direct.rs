//! The direct light of section 5. The paper names it without defining it; we read it as a
//! point light that radiates only into the half-space its axis points to, with an
//! intensity following the cosine of the angle to the axis: `I(theta) = I0 max(0, cos
//! theta)`, the far field of a small Lambertian emitter facing along the axis (a ceiling
//! downlight). So `li = I0 cos(theta) / d^2`, zero behind the light.

use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

use super::{LightError, LightSample, check_colour, check_dir, check_point, finish_scaled, toward};

/// A point light at `position` with intensity `intensity * max(0, cos theta)` (W/sr),
/// `theta` the angle between `axis` and the direction to the lit point.
#[derive(Debug, Clone, PartialEq)]
pub struct Direct {
    position: Vec3,
    axis: Vec3,
    intensity: [f32; 3],
}

impl Direct {
    pub fn new(position: Vec3, axis: Vec3, intensity: [f32; 3]) -> Result<Self, LightError> {
        Ok(Direct {
            position: check_point("direct", "position", position)?,
            axis: check_dir("direct", "axis", axis)?,
            intensity: check_colour("direct", "intensity", intensity)?,
        })
    }

    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The unit axis of the half-space the light radiates into.
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// Intensity along the axis (W/sr per channel).
    pub fn intensity(&self) -> [f32; 3] {
        self.intensity
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
        // cos(theta) = axis . (-wi)
        let cos = -Vec3s::splat(l, self.axis).dot(t.wi);
        let active = t.active & cos.gt(l.splat(0.0));
        finish_scaled(l, n, active, t.wi, t.dist, self.intensity, cos * t.inv_d2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::{irradiance1, plane_points};

    #[test]
    fn irradiance_below_a_downlight_is_i0_h2_over_d4() {
        // Axis straight down, height h: cos(theta) at the light = cos at the surface = h/d,
        // so E = I0 (h/d) (h/d) / d^2.
        let h = 1.5;
        let light = Light::Direct(Direct::new(Vec3::new(0.0, 0.0, h), -Vec3::Z, [4.0; 3]).unwrap());
        for p in plane_points() {
            let d2 = p.length_squared() + h * h;
            let want = 4.0 * h * h / (d2 * d2);
            let e = irradiance1(&light, p, Vec3::Z);
            assert!((e[0] - want).abs() <= 1e-5 * want, "{p}: {e:?} vs {want}");
        }
        // A light pointing up lights nothing below it.
        let up = Light::Direct(Direct::new(Vec3::new(0.0, 0.0, h), Vec3::Z, [4.0; 3]).unwrap());
        assert_eq!(irradiance1(&up, Vec3::ZERO, Vec3::Z), [0.0; 3]);
    }
}
