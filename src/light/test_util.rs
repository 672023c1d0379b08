//! Helpers of the lights' unit tests: scalar (one-lane) evaluation of a light's irradiance.

use coherent_simd::scalar::Scalar;
use coherent_simd::{Lanes, SimdF32, SimdMask, Vec3s};
use glam::Vec3;

use super::Light;

/// Irradiance at `p` (normal `n`) on the scalar backend: the sum over the light's samples
/// of `cos(theta) li`, with `u` from a fixed sequence per sample.
pub fn irradiance1(light: &Light, p: Vec3, n: Vec3) -> [f32; 3] {
    let l = Scalar;
    let mut e = [0.0f64; 3];
    for k in 0..light.samples() {
        let u = [
            l.splat(((k as f32 + 0.5) * 0.618_034).fract()),
            l.splat(((k as f32 + 0.5) * 0.754_877_7).fract()),
        ];
        let s = light.sample(
            l,
            &Vec3s::splat(l, p),
            &Vec3s::splat(l, n),
            l.splat_mask(true),
            k,
            u,
        );
        if !s.active.lane(0) {
            continue;
        }
        let cos = n.dot(s.wi.lane(0)) as f64;
        let li = s.li.lane(0);
        for c in 0..3 {
            e[c] += cos * li[c] as f64;
        }
        let _ = s.dist.lane(0);
    }
    [e[0] as f32, e[1] as f32, e[2] as f32]
}

/// Points on the plane z = 0 around the origin.
pub fn plane_points() -> Vec<Vec3> {
    let mut v = Vec::new();
    for i in -3..=3 {
        for j in -3..=3 {
            v.push(Vec3::new(i as f32 * 0.7, j as f32 * 0.45, 0.0));
        }
    }
    v
}
