//! Realistic BDF calls for timing (paper Table 1, section 4.2): the inputs a renderer
//! hands the BDF when it shades a brushed-metal sphere seen through a pinhole camera and
//! lit by a point light. Pixels come in 4 x 4 tiles of neighbours, so a packet of 1, 4, 8
//! or 16 consecutive calls is a coherent group of neighbouring pixels, as the renderer's
//! packets are; only tiles whose 16 pixels all hit the sphere are kept.

use std::hint::black_box;

use coherent_simd::{Kernel, Lanes, Rgbs, SimdF32, Vec3s};
use glam::Vec3;

use super::angles::Frames;
use super::table::AnisotropicBdf;

/// Per call, structure of arrays: world-space frame (tangent, bitangent, normal), the
/// direction to the light `wi` and to the viewer `wo`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BdfInputs {
    /// `[tangent, bitangent, normal, wi, wo]`, each `[x, y, z]`, each one value per call.
    pub v: [[Vec<f32>; 3]; 5],
}

impl BdfInputs {
    /// Calls held (a multiple of 16).
    pub fn len(&self) -> usize {
        self.v[0][0].len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn push(&mut self, vs: [Vec3; 5]) {
        for (k, v) in vs.iter().enumerate() {
            self.v[k][0].push(v.x);
            self.v[k][1].push(v.y);
            self.v[k][2].push(v.z);
        }
    }

    /// The calls for a `size` x `size` image of a unit sphere filling most of the view
    /// (about `0.6 size^2` calls), lit from the upper left.
    pub fn sphere(size: usize) -> Self {
        let size = size.div_ceil(4) * 4;
        let eye = Vec3::new(0.0, 0.0, 3.0);
        let light = Vec3::new(-4.0, 5.0, 6.0);
        // The brushing direction: tangents follow circles around this axis.
        let axis = Vec3::new(0.3, 1.0, 0.2).normalize();
        let half_fov = 0.36f32; // tan of half the field of view: the sphere fills ~80%
        let pixel = |px: usize, py: usize| -> Option<[Vec3; 5]> {
            let x = ((px as f32 + 0.5) / size as f32 * 2.0 - 1.0) * half_fov;
            let y = (1.0 - (py as f32 + 0.5) / size as f32 * 2.0) * half_fov;
            let d = Vec3::new(x, y, -1.0).normalize();
            // Ray against the unit sphere at the origin.
            let b = eye.dot(d);
            let disc = b * b - (eye.length_squared() - 1.0);
            if disc <= 0.0 {
                return None;
            }
            let p = eye + d * (-b - disc.sqrt());
            let n = p.normalize();
            let tangent = axis.cross(n).normalize_or(n.any_orthonormal_vector());
            let bitangent = n.cross(tangent);
            Some([tangent, bitangent, n, (light - p).normalize(), -d])
        };
        let mut out = Self::default();
        for ty in (0..size).step_by(4) {
            for tx in (0..size).step_by(4) {
                let tile: Option<Vec<_>> = (0..16).map(|i| pixel(tx + i % 4, ty + i / 4)).collect();
                for vs in tile.into_iter().flatten() {
                    out.push(vs);
                }
            }
        }
        out
    }
}

/// The packet of vectors starting at call `i`.
#[inline(always)]
fn load3<L: Lanes>(l: L, v: &[Vec<f32>; 3], i: usize) -> Vec3s<L> {
    Vec3s::new(l.load(&v[0][i..]), l.load(&v[1][i..]), l.load(&v[2][i..]))
}

/// `calls` evaluations of `bdf` over `inputs` (cycled), a packet at a time; returns the
/// sum of the values (so nothing is optimised away). `calls` is rounded up to whole
/// 16-call tiles.
#[derive(Debug, Clone, Copy)]
pub struct BdfCalls<'a> {
    pub bdf: &'a AnisotropicBdf,
    pub inputs: &'a BdfInputs,
    pub calls: usize,
}

impl Kernel for BdfCalls<'_> {
    type Output = f32;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f32 {
        let n = self.inputs.len();
        assert!(
            n > 0 && n.is_multiple_of(16),
            "BDF inputs must be whole 16-call tiles"
        );
        let v = &self.inputs.v;
        let mut sum = Rgbs::zero(l);
        let mut done = 0;
        let mut i = 0;
        while done < self.calls {
            // Each packet's inputs through `black_box`, on every backend alike (as the
            // approximation kernels do): the scalar loop stays one call at a time.
            let v = black_box(v);
            let frames = Frames {
                tangent: load3(l, &v[0], i),
                bitangent: load3(l, &v[1], i),
                normal: load3(l, &v[2], i),
            };
            let wi = frames.to_local(load3(l, &v[3], i));
            let wo = frames.to_local(load3(l, &v[4], i));
            sum += self.bdf.eval(l, &wi, &wo);
            done += L::N;
            i += L::N;
            if i == n {
                i = 0;
            }
        }
        let total = sum.r + sum.g + sum.b;
        (0..L::N).map(|k| total.lane(k)).sum()
    }
}

/// The scalar backend's loop of [`BdfCalls`], as a standalone symbol so that its assembly
/// can be inspected (as `scripts/check-scalar-asm.sh` does for the approximation kernels):
/// the same generic code `table1` times, monomorphised for `Scalar`.
#[inline(never)]
pub fn scalar_baseline_bdf(bdf: &AnisotropicBdf, inputs: &BdfInputs, calls: usize) -> f32 {
    BdfCalls { bdf, inputs, calls }.run(coherent_simd::scalar::Scalar)
}
