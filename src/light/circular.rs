//! The circular light of section 5: a one-sided disk of uniform radiance `L`, sampled as
//! point lights, one per stratum of a polar grid (`rings` x `sectors` cells of equal
//! area: radius `R sqrt((i + a) / rings)`, angle `2 pi (j + b) / sectors`). A point stands
//! for its cell's area `A / n`, so `li = L (A / n) cos(theta_light) / d^2`.

use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

use super::sincos::sincos;
use super::{
    LightError, LightSample, Strata, check_colour, check_dir, check_point, check_positive,
    check_samples, finish_scaled, toward,
};

/// Default polar grid (rings, sectors): 21 points, as many as the paper's rectangle.
pub const DEFAULT_GRID: (u32, u32) = (3, 7);

/// A disk at `center`, emitting towards `normal`, of `radius` and `radiance` (W/(m^2 sr)).
#[derive(Debug, Clone, PartialEq)]
pub struct Circular {
    center: Vec3,
    normal: Vec3,
    /// Two unit vectors spanning the disk's plane.
    tangent: Vec3,
    bitangent: Vec3,
    radius: f32,
    radiance: [f32; 3],
    rings: u32,
    sectors: u32,
    strata: Strata,
}

impl Circular {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        center: Vec3,
        normal: Vec3,
        radius: f32,
        radiance: [f32; 3],
        (rings, sectors): (u32, u32),
        seed: u64,
        jitter: bool,
    ) -> Result<Self, LightError> {
        check_samples(
            "circular",
            "points (rings, sectors)",
            u64::from(rings) * u64::from(sectors),
            (rings, sectors),
        )?;
        let normal = check_dir("circular", "normal", normal)?;
        let (tangent, bitangent) = normal.any_orthonormal_pair();
        Ok(Circular {
            center: check_point("circular", "center", center)?,
            normal,
            tangent,
            bitangent,
            radius: check_positive("circular", "radius", radius)?,
            radiance: check_colour("circular", "radiance", radiance)?,
            rings,
            sectors,
            strata: Strata::new(rings * sectors, seed, jitter),
        })
    }

    pub fn samples(&self) -> u32 {
        self.strata.count()
    }

    /// Whether the points are jittered by the caller's numbers (else fixed).
    pub fn jittered(&self) -> bool {
        self.strata.jitter()
    }

    /// Centre, unit normal (the side it emits to) and radius.
    pub fn disk(&self) -> (Vec3, Vec3, f32) {
        (self.center, self.normal, self.radius)
    }

    /// Radiance (W/(m^2 sr) per channel).
    pub fn radiance(&self) -> [f32; 3] {
        self.radiance
    }

    /// The two unit vectors spanning the disk's plane (angle 0 along the first).
    pub fn tangents(&self) -> (Vec3, Vec3) {
        (self.tangent, self.bitangent)
    }

    /// The polar grid of points: (rings, sectors).
    pub fn grid(&self) -> (u32, u32) {
        (self.rings, self.sectors)
    }

    /// The points' strata.
    pub fn strata(&self) -> &Strata {
        &self.strata
    }

    /// The same disk with its points jittered (`true`) or fixed.
    pub fn with_jitter(&self, jitter: bool) -> Self {
        let mut c = self.clone();
        c.strata = Strata::new(self.strata.count(), self.strata.seed(), jitter);
        c
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
        let k = k % self.strata.count();
        let (ring, sector) = (k / self.sectors, k % self.sectors);
        let o = self.strata.offset(l, k, u);
        let r = ((o[0] + ring as f32) * (1.0 / self.rings as f32)).sqrt() * self.radius;
        // Angle in [-pi, pi): the sector's cell, shifted by -pi.
        let phi = (o[1] + sector as f32) * (std::f32::consts::TAU / self.sectors as f32)
            - std::f32::consts::PI;
        let (s, c) = sincos(l, phi);
        let q = Vec3s::splat(l, self.tangent).mul_add(
            r * c,
            Vec3s::splat(l, self.bitangent).mul_add(r * s, Vec3s::splat(l, self.center)),
        );
        let t = toward(l, p, n, active, &q);
        let cos_light = -Vec3s::splat(l, self.normal).dot(t.wi);
        let active = t.active & cos_light.gt(l.splat(0.0));
        let area = std::f32::consts::PI * self.radius * self.radius / self.strata.count() as f32;
        finish_scaled(
            l,
            n,
            active,
            t.wi,
            t.dist,
            self.radiance,
            cos_light * t.inv_d2 * area,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;

    #[test]
    fn sampled_irradiance_on_the_axis_converges_to_pi_l_r2_over_h2_plus_r2() {
        let (r, h) = (0.8, 1.1);
        let want = std::f32::consts::PI * r * r / (h * h + r * r);
        let mut errors = Vec::new();
        for grid in [(3, 7), (10, 20), (40, 60)] {
            for jitter in [false, true] {
                let light = Light::Circular(
                    Circular::new(
                        Vec3::new(0.0, 0.0, h),
                        -Vec3::Z,
                        r,
                        [1.0; 3],
                        grid,
                        5,
                        jitter,
                    )
                    .unwrap(),
                );
                let e = irradiance1(&light, Vec3::ZERO, Vec3::Z)[0];
                errors.push((e - want).abs() / want);
            }
        }
        assert!(errors[4] < 2e-3 && errors[5] < 2e-3, "{errors:?}");
        assert!(errors[0] < 0.05, "{errors:?}");
        // The back of the disk gives nothing.
        let back = Light::Circular(
            Circular::new(
                Vec3::new(0.0, 0.0, h),
                Vec3::Z,
                r,
                [1.0; 3],
                (3, 7),
                5,
                false,
            )
            .unwrap(),
        );
        assert_eq!(irradiance1(&back, Vec3::ZERO, Vec3::Z), [0.0; 3]);
    }
}
