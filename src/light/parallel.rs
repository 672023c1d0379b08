//! The parallel (directional) light of section 5: light travelling in one direction from
//! infinitely far, with irradiance `E` on a surface facing it; `li = E`, the distance is
//! infinite.

use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

use super::{LightError, LightSample, check_colour, check_dir, finish};

/// Light travelling along `direction` with `irradiance` (W/m^2 per channel) on a surface
/// perpendicular to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Parallel {
    /// Unit direction the light travels in.
    direction: Vec3,
    irradiance: [f32; 3],
}

impl Parallel {
    pub fn new(direction: Vec3, irradiance: [f32; 3]) -> Result<Self, LightError> {
        Ok(Parallel {
            direction: check_dir("parallel", "direction", direction)?,
            irradiance: check_colour("parallel", "irradiance", irradiance)?,
        })
    }

    /// The unit direction the light travels in.
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// Irradiance on a surface facing the light (W/m^2 per channel).
    pub fn irradiance(&self) -> [f32; 3] {
        self.irradiance
    }

    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        _p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
    ) -> LightSample<L> {
        let wi = Vec3s::splat(l, -self.direction);
        let active = active & n.dot(wi).gt(l.splat(0.0));
        let li = coherent_simd::Rgbs::splat(l, self.irradiance);
        finish(l, n, active, wi, l.splat(f32::INFINITY), li)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::{irradiance1, plane_points};

    #[test]
    fn irradiance_on_a_plane_is_e_cos_theta() {
        let dir = Vec3::new(0.3, -0.2, -1.0).normalize();
        let light = Light::Parallel(Parallel::new(dir * 5.0, [2.0, 1.0, 0.5]).unwrap());
        let cos = -dir.z;
        for p in plane_points() {
            let e = irradiance1(&light, p, Vec3::Z);
            for c in 0..3 {
                let want = [2.0, 1.0, 0.5][c] * cos;
                assert!((e[c] - want).abs() <= 1e-6 * want, "{e:?}");
            }
        }
        // Lit from behind: nothing.
        assert_eq!(irradiance1(&light, Vec3::ZERO, -Vec3::Z), [0.0; 3]);
    }

    #[test]
    fn a_zero_direction_is_an_error() {
        let e = Parallel::new(Vec3::ZERO, [1.0; 3]).unwrap_err();
        assert!(e.to_string().contains("direction"), "{e}");
    }
}
