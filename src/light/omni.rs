//! The omnidirectional point light (paper section 5): radiant intensity `I` in every
//! direction, so `li = I / d^2`.

use coherent_simd::{Lanes, Vec3s};
use glam::Vec3;

use super::{LightError, LightSample, check_colour, check_point, finish_scaled, toward};

/// A point light radiating `intensity` (W/sr per channel) in every direction.
#[derive(Debug, Clone, PartialEq)]
pub struct Omni {
    position: Vec3,
    intensity: [f32; 3],
}

impl Omni {
    pub fn new(position: Vec3, intensity: [f32; 3]) -> Result<Self, LightError> {
        Ok(Omni {
            position: check_point("omni", "position", position)?,
            intensity: check_colour("omni", "intensity", intensity)?,
        })
    }

    pub fn position(&self) -> Vec3 {
        self.position
    }

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
        finish_scaled(l, n, t.active, t.wi, t.dist, self.intensity, t.inv_d2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::test_util::{irradiance1, plane_points};

    #[test]
    fn irradiance_on_a_plane_is_the_inverse_square_cosine_law() {
        // A light at height h above the plane z = 0: E(x) = I h / (h^2 + r^2)^(3/2).
        let h = 2.0;
        let light = super::super::Light::Omni(
            Omni::new(Vec3::new(0.5, -0.25, h), [3.0, 2.0, 1.0]).unwrap(),
        );
        for p in plane_points() {
            let e = irradiance1(&light, p, Vec3::Z);
            let r2 = (p - Vec3::new(0.5, -0.25, 0.0)).length_squared();
            let want = h / (h * h + r2).powf(1.5);
            for c in 0..3 {
                let i = [3.0, 2.0, 1.0][c];
                assert!(
                    (e[c] - i * want).abs() <= 1e-5 * i * want,
                    "{p}: {e:?} vs {}",
                    i * want
                );
            }
        }
    }

    #[test]
    fn points_behind_the_light_get_nothing() {
        let light =
            super::super::Light::Omni(Omni::new(Vec3::new(0.0, 0.0, 1.0), [1.0; 3]).unwrap());
        assert_eq!(irradiance1(&light, Vec3::ZERO, -Vec3::Z), [0.0; 3]);
        // The shading point at the light itself is masked, not NaN.
        assert_eq!(irradiance1(&light, Vec3::Z, Vec3::Z), [0.0; 3]);
    }

    #[test]
    fn bad_parameters_are_errors_naming_the_field() {
        let e = Omni::new(Vec3::new(f32::NAN, 0.0, 0.0), [1.0; 3]).unwrap_err();
        assert!(e.to_string().contains("position"), "{e}");
        let e = Omni::new(Vec3::ZERO, [1.0, -1.0, 0.0]).unwrap_err();
        assert!(e.to_string().contains("intensity"), "{e}");
    }
}
