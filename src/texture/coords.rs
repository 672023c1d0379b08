//! Texture coordinates at the hits (paper section 4.1): the triangle's vertex coordinates
//! fetched per lane (each lane may hit another triangle) and interpolated with the hit's
//! barycentrics.

// Index loops, not iterator adapters, in the per-packet code: it must inline into the
// backends' `#[target_feature]` entry points (a non-inlined `array::from_fn` made the AVX2 backend 7x slower).
#![allow(clippy::needless_range_loop)]

use coherent_simd::{Lanes, SimdF32, SimdMask};

/// Per-vertex texture coordinates of a mesh and its triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct TexCoords {
    /// `s` of each vertex.
    pub s: Vec<f32>,
    /// `t` of each vertex.
    pub t: Vec<f32>,
    /// Three vertex indices per triangle.
    pub indices: Vec<u32>,
}

impl TexCoords {
    /// `(s, t)` at barycentrics `(b1, b2)` of triangle `prim` in each active lane
    /// (the vertex weights are `1 - b1 - b2`, `b1`, `b2`); inactive lanes read triangle 0
    /// and give its first vertex's coordinates. Panics if an active lane's triangle or a
    /// vertex index is outside the mesh.
    #[inline(always)]
    pub fn interpolate<L: Lanes>(
        &self,
        l: L,
        active: L::Mask,
        prim: L::I32s,
        b1: L::F32s,
        b2: L::F32s,
    ) -> (L::F32s, L::F32s) {
        let zero = l.splat(0.0);
        let first = active.select_i32(prim * l.splat_i32(3), l.splat_i32(0));
        let (b1, b2) = (active.select(b1, zero), active.select(b2, zero));
        let b0 = l.splat(1.0) - b1 - b2;
        let mut s = zero;
        let mut t = zero;
        let weights = [b0, b1, b2];
        for k in 0..3 {
            let w = weights[k];
            let v = l.gather_u32(&self.indices, first + l.splat_i32(k as i32));
            s = w.mul_add(l.gather(&self.s, v), s);
            t = w.mul_add(l.gather(&self.t, v), t);
        }
        (s, t)
    }
}
