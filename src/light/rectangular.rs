//! The rectangular light of section 5: a one-sided rectangle of uniform radiance `L`
//! sampled as point lights on a `nu` x `nv` grid of strata ("subdivided into 7 x 3 = 21
//! light sources"). A point stands for its cell's area `A / n`, so
//! `li = L (A / n) cos(theta_light) / d^2`.

use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

use super::{
    LightError, LightSample, Strata, check_colour, check_point, check_samples, finish_scaled,
    toward,
};

/// The paper's grid for rectangular lights.
pub const DEFAULT_GRID: (u32, u32) = (7, 3);

/// The rectangle `corner + s edge_u + t edge_v` (`s, t` in `[0, 1]`), emitting towards
/// `edge_u x edge_v`, with `radiance` (W/(m^2 sr)).
#[derive(Debug, Clone, PartialEq)]
pub struct Rectangular {
    corner: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    normal: Vec3,
    area: f32,
    radiance: [f32; 3],
    nu: u32,
    strata: Strata,
}

impl Rectangular {
    pub fn new(
        corner: Vec3,
        edge_u: Vec3,
        edge_v: Vec3,
        radiance: [f32; 3],
        (nu, nv): (u32, u32),
        seed: u64,
        jitter: bool,
    ) -> Result<Self, LightError> {
        check_samples(
            "rectangular",
            "points (nu, nv)",
            u64::from(nu) * u64::from(nv),
            (nu, nv),
        )?;
        let edge_u = check_point("rectangular", "edge_u", edge_u)?;
        let edge_v = check_point("rectangular", "edge_v", edge_v)?;
        let cross = edge_u.cross(edge_v);
        let area = cross.length();
        if !(area.is_finite() && area > 0.0) {
            return Err(LightError::bad(
                "rectangular",
                "edges",
                (edge_u, edge_v),
                "parallel or zero: the rectangle has no area",
            ));
        }
        Ok(Rectangular {
            corner: check_point("rectangular", "corner", corner)?,
            edge_u,
            edge_v,
            normal: cross / area,
            area,
            radiance: check_colour("rectangular", "radiance", radiance)?,
            nu,
            strata: Strata::new(nu * nv, seed, jitter),
        })
    }

    pub fn samples(&self) -> u32 {
        self.strata.count()
    }

    /// Whether the points are jittered by the caller's numbers (else fixed).
    pub fn jittered(&self) -> bool {
        self.strata.jitter()
    }

    /// The corner and the two edges: the rectangle is `corner + s edge_u + t edge_v`.
    pub fn frame(&self) -> (Vec3, Vec3, Vec3) {
        (self.corner, self.edge_u, self.edge_v)
    }

    /// Radiance (W/(m^2 sr) per channel).
    pub fn radiance(&self) -> [f32; 3] {
        self.radiance
    }

    /// The grid of points: (nu, nv) along `edge_u` and `edge_v`.
    pub fn grid(&self) -> (u32, u32) {
        (self.nu, self.strata.count() / self.nu)
    }

    /// Unit normal (the side it emits to) and area.
    pub fn normal_area(&self) -> (Vec3, f32) {
        (self.normal, self.area)
    }

    /// The points' strata.
    pub fn strata(&self) -> &Strata {
        &self.strata
    }

    /// The same rectangle with its points jittered (`true`) or fixed.
    pub fn with_jitter(&self, jitter: bool) -> Self {
        let mut r = self.clone();
        r.strata = Strata::new(self.strata.count(), self.strata.seed(), jitter);
        r
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
        let nv = count / self.nu;
        let (i, j) = (k % self.nu, k / self.nu);
        let o = self.strata.offset(l, k, u);
        let s = (o[0] + i as f32) * (1.0 / self.nu as f32);
        let t = (o[1] + j as f32) * (1.0 / nv as f32);
        let q = Vec3s::splat(l, self.edge_u).mul_add(
            s,
            Vec3s::splat(l, self.edge_v).mul_add(t, Vec3s::splat(l, self.corner)),
        );
        let to = toward(l, p, n, active, &q);
        let cos_light = -Vec3s::splat(l, self.normal).dot(to.wi);
        let active = to.active & cos_light.gt(l.splat(0.0));
        finish_scaled(
            l,
            n,
            active,
            to.wi,
            to.dist,
            self.radiance,
            cos_light * to.inv_d2 * (self.area / count as f32),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;

    /// Irradiance from a uniform polygon of radiance 1 (Lambert's formula):
    /// `E = 1/2 sum_i angle(v_i, v_i+1) (n . unit(v_i x v_i+1))`, `v_i` the corners seen
    /// from the point, with the polygon wound clockwise as seen from the point.
    fn lambert(p: Vec3, n: Vec3, corners: &[Vec3]) -> f64 {
        let mut e = 0.0f64;
        for i in 0..corners.len() {
            let a = (corners[i] - p).as_dvec3().normalize();
            let b = (corners[(i + 1) % corners.len()] - p)
                .as_dvec3()
                .normalize();
            let angle = a.dot(b).clamp(-1.0, 1.0).acos();
            e += angle * n.as_dvec3().dot(a.cross(b).normalize());
        }
        (e / 2.0).abs()
    }

    #[test]
    fn sampled_irradiance_converges_to_lamberts_polygon_formula() {
        let corner = Vec3::new(-0.6, -0.3, 1.0);
        let (eu, ev) = (Vec3::new(1.5, 0.0, 0.0), Vec3::new(0.0, -0.8, 0.0));
        // edge_u x edge_v = -z: facing the plane z = 0.
        let corners = [corner, corner + eu, corner + eu + ev, corner + ev];
        for p in [
            Vec3::ZERO,
            Vec3::new(0.7, 0.4, 0.0),
            Vec3::new(-1.5, 0.2, 0.0),
        ] {
            let want = lambert(p, Vec3::Z, &corners) as f32;
            let mut errors = Vec::new();
            for grid in [(7, 3), (70, 30), (210, 90)] {
                let light = Light::Rectangular(
                    Rectangular::new(corner, eu, ev, [1.0; 3], grid, 3, true).unwrap(),
                );
                let e = irradiance1(&light, p, Vec3::Z)[0];
                errors.push((e - want).abs() / want);
            }
            assert!(errors[2] < 1e-3, "{p}: {errors:?}");
            assert!(errors[0] < 0.1, "{p}: {errors:?}");
        }
    }

    #[test]
    fn degenerate_rectangles_are_errors() {
        let e = Rectangular::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::X * 2.0,
            [1.0; 3],
            (7, 3),
            0,
            false,
        )
        .unwrap_err();
        assert!(e.to_string().contains("no area"), "{e}");
    }
}
