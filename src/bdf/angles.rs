//! BDF angles for a packet (paper section 4.2, first step): directions into the hit's local
//! frame (tangent, bitangent, normal), then polar and azimuthal angles with the
//! approximate inverse trigonometry of [`crate::approx`].

use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::approx;

/// Three lanes-wide components (x, y, z).
pub type Vec3Lanes<L> = [<L as Lanes>::F32s; 3];

/// Per-lane local frames: orthonormal tangent, bitangent and normal in world space.
#[derive(Debug, Clone, Copy)]
pub struct Frames<L: Lanes> {
    pub tangent: Vec3Lanes<L>,
    pub bitangent: Vec3Lanes<L>,
    pub normal: Vec3Lanes<L>,
}

#[inline(always)]
fn dot<L: Lanes>(a: &Vec3Lanes<L>, b: &Vec3Lanes<L>) -> L::F32s {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

impl<L: Lanes> Frames<L> {
    /// A world direction in each lane's frame: (along tangent, along bitangent, along normal).
    #[inline(always)]
    pub fn to_local(&self, w: &Vec3Lanes<L>) -> Vec3Lanes<L> {
        [
            dot::<L>(w, &self.tangent),
            dot::<L>(w, &self.bitangent),
            dot::<L>(w, &self.normal),
        ]
    }
}

/// Polar angle `theta = acos(z)` of a unit local direction.
#[inline(always)]
pub fn theta<L: Lanes>(l: L, w: &Vec3Lanes<L>) -> L::F32s {
    approx::acos(l, w[2])
}

/// Azimuth `phi = atan2(y, x)` of a local direction, in `[-pi, pi]`.
#[inline(always)]
pub fn phi<L: Lanes>(l: L, w: &Vec3Lanes<L>) -> L::F32s {
    approx::atan2(l, w[1], w[0])
}

/// Azimuth difference `|phi_o - phi_i|` folded into `[0, pi]`, from the cosine of the
/// angle between the directions' projections on the tangent plane (0 where either
/// projection vanishes).
#[inline(always)]
pub fn delta_phi<L: Lanes>(l: L, wi: &Vec3Lanes<L>, wo: &Vec3Lanes<L>) -> L::F32s {
    let across = wi[0].mul_add(wo[0], wi[1] * wo[1]);
    let ri = wi[0].mul_add(wi[0], wi[1] * wi[1]);
    let ro = wo[0].mul_add(wo[0], wo[1] * wo[1]);
    let len = (ri * ro).sqrt();
    let tiny = l.splat(1e-20);
    let cos = len.gt(tiny).select(across / len.max(tiny), l.splat(1.0));
    approx::acos(l, cos)
}

/// Mirrors both directions so that `wi` lies in the first quadrant of the tangent plane
/// (`x, y >= 0`): valid for BDFs symmetric about the tangent and the bitangent planes.
#[inline(always)]
pub fn fold_quadrant<L: Lanes>(l: L, wi: &mut Vec3Lanes<L>, wo: &mut Vec3Lanes<L>) {
    let zero = l.splat(0.0);
    for k in 0..2 {
        let flip = wi[k].lt(zero);
        wi[k] = wi[k].abs();
        wo[k] = flip.select(-wo[k], wo[k]);
    }
}
