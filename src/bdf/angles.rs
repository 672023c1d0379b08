//! BDF angles for a packet (paper section 4.2, first step): directions into the hit's local
//! frame (tangent, bitangent, normal), then polar and azimuthal angles with the
//! approximate inverse trigonometry of [`crate::approx`].

use coherent_simd::{Lanes, SimdF32, SimdMask, Vec3s};

use crate::approx;

/// Per-lane local frames: orthonormal tangent, bitangent and normal in world space.
#[derive(Debug, Clone, Copy)]
pub struct Frames<L: Lanes> {
    pub tangent: Vec3s<L>,
    pub bitangent: Vec3s<L>,
    pub normal: Vec3s<L>,
}

impl<L: Lanes> Frames<L> {
    /// A world direction in each lane's frame: (along tangent, along bitangent, along normal).
    #[inline(always)]
    pub fn to_local(&self, w: Vec3s<L>) -> Vec3s<L> {
        Vec3s::new(
            w.dot(self.tangent),
            w.dot(self.bitangent),
            w.dot(self.normal),
        )
    }
}

/// Polar angle `theta = acos(z)` of a unit local direction.
#[inline(always)]
pub fn theta<L: Lanes>(l: L, w: &Vec3s<L>) -> L::F32s {
    approx::acos(l, w.z)
}

/// Azimuth `phi = atan2(y, x)` of a local direction, in `[-pi, pi]`.
#[inline(always)]
pub fn phi<L: Lanes>(l: L, w: &Vec3s<L>) -> L::F32s {
    approx::atan2(l, w.y, w.x)
}

/// Azimuth difference `|phi_o - phi_i|` folded into `[0, pi]`, from the cosine of the
/// angle between the directions' projections on the tangent plane (0 where either
/// projection vanishes).
#[inline(always)]
pub fn delta_phi<L: Lanes>(l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> L::F32s {
    let across = wi.x.mul_add(wo.x, wi.y * wo.y);
    let ri = wi.x.mul_add(wi.x, wi.y * wi.y);
    let ro = wo.x.mul_add(wo.x, wo.y * wo.y);
    let len = (ri * ro).sqrt();
    let tiny = l.splat(1e-20);
    let cos = len.gt(tiny).select(across / len.max(tiny), l.splat(1.0));
    approx::acos(l, cos)
}

/// Mirrors both directions so that `wi` lies in the first quadrant of the tangent plane
/// (`x, y >= 0`): valid for BDFs symmetric about the tangent and the bitangent planes.
#[inline(always)]
pub fn fold_quadrant<L: Lanes>(l: L, wi: &mut Vec3s<L>, wo: &mut Vec3s<L>) {
    let zero = l.splat(0.0);
    let flip = wi.x.lt(zero);
    wi.x = wi.x.abs();
    wo.x = flip.select(-wo.x, wo.x);
    let flip = wi.y.lt(zero);
    wi.y = wi.y.abs();
    wo.y = flip.select(-wo.y, wo.y);
}
