//! The projection ("Wald") ray-triangle test of paper section 3 (after Wald et al. 2001):
//! each triangle is precomputed into a 48-byte record; a ray meets the triangle's plane, the
//! hit point is projected onto the axis plane where the triangle is largest, and two
//! precomputed edge equations give its barycentric coordinates.
//!
//! Two changes from Wald's record make the test more exact, and both are measured by the
//! watertightness test (`backends/bsp/tests/watertight.rs`):
//! - the plane distance and the projected hit point are computed relative to the triangle's
//!   first vertex `a` (so the rounding error scales with the ray's distance to the triangle,
//!   not with the coordinates' magnitude);
//! - the barycentric tests accept `u, v >= -EDGE_EPS` and `u + v <= 1 + EDGE_EPS`, so two
//!   triangles sharing an edge overlap by a sliver instead of leaving a crack. A record says
//!   per edge whether it takes that band ([`TriAccel::with_shared_edges`]): a mesh's records
//!   built by [`crate::edges::mesh_records`] take it on shared edges only, so the outline of
//!   an open mesh is tested exactly and its silhouette is not widened.
//!
//! Every accelerator of this crate family uses this record, so their answers can be compared
//! bit for bit with [`crate::BruteForce`].

use coherent_simd::{Lanes, SimdF32, SimdMask};
use glam::{DVec3, Vec3};

use crate::Vec3s;

/// Edge tolerance of the barycentric test, in barycentric units (a fraction of the triangle's
/// size): points with `u, v, 1 - u - v >= -EDGE_EPS` are hits.
///
/// Measured with `backends/bsp/tests/watertight.rs` (`million_rays`: 7 closed meshes, 10^6
/// rays each from inside, aimed exactly at shared vertices and edge points): with 0, 557,830
/// of 7 * 10^6 rays leaked (7.5% on the icosphere: each triangle's own rounding puts an
/// edge point outside it about half the time); with 2^-13, 1 ray leaked (a grazing ray in
/// the torus), on the scalar, sse and avx512 backends alike.
pub const EDGE_EPS: f32 = 1.0 / 8192.0;

/// Triangles whose height is below this fraction of their longest edge count as degenerate
/// and are dropped (2^-20). Their plane is not held by f32 coordinates: the test's
/// barycentrics then reached points 4e-7 outside a needle of width 1e-7 (found by the BSP's
/// equivalence tests), which no accelerator could be asked to find.
pub const MIN_THINNESS: f64 = 1.0 / (1u64 << 20) as f64;

/// A triangle prepared for the projection test (48 bytes, 16-byte aligned).
///
/// With `(u, v)` the axes after `k` (`(k + 1) % 3`, `(k + 2) % 3`) and `n` the normal scaled
/// so that `n[k] = 1`: the plane is `n . (p - a) = 0`, and a point `p` of the plane has
/// barycentrics `beta = b_nu * (p_u - a_u) + b_nv * (p_v - a_v)` and
/// `gamma = c_nu * (p_u - a_u) + c_nv * (p_v - a_v)`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
pub struct TriAccel {
    pub n_u: f32,
    pub n_v: f32,
    /// Projection axis (0, 1, 2): the axis of the normal's largest component.
    pub k: u32,
    /// Triangle index in its mesh.
    pub prim: u32,
    /// The first vertex, components in the order `k`, `u`, `v`.
    pub a_k: f32,
    pub a_u: f32,
    pub a_v: f32,
    pub b_nu: f32,
    pub b_nv: f32,
    pub c_nu: f32,
    pub c_nv: f32,
    /// Which edges take the [`EDGE_EPS`] band: bit 0 the edge `a-c` (where `u = 0`), bit 1
    /// the edge `a-b` (`v = 0`), bit 2 the edge `b-c` (`u + v = 1`). [`TriAccel::new`] sets
    /// all three ([`ALL_EDGES`]).
    pub edges: u32,
}

/// [`TriAccel::edges`] with the band on every edge.
pub const ALL_EDGES: u32 = 0b111;

/// The barycentric bounds `(lowest u, lowest v, highest u + v, unused)` per
/// [`TriAccel::edges`] value, read by index so that the tests stay free of branches.
const BOUNDS: [[f32; 4]; 8] = {
    let mut b = [[0.0; 4]; 8];
    let mut e = 0;
    while e < 8 {
        let lo_u = if e & 1 == 1 { -EDGE_EPS } else { 0.0 };
        let lo_v = if e & 2 == 2 { -EDGE_EPS } else { 0.0 };
        let hi = if e & 4 == 4 { 1.0 + EDGE_EPS } else { 1.0 };
        b[e] = [lo_u, lo_v, hi, 0.0];
        e += 1;
    }
    b
};

/// The axes `u`, `v` that follow `k`.
#[inline(always)]
pub const fn uv_axes(k: u32) -> (usize, usize) {
    (NEXT_U[(k & 3) as usize], NEXT_V[(k & 3) as usize])
}

/// `(k + 1) % 3` and `(k + 2) % 3` by table (4 entries: indexing with `k & 3` needs no bounds
/// check and no branch).
const NEXT_U: [usize; 4] = [1, 2, 0, 1];
const NEXT_V: [usize; 4] = [2, 0, 1, 2];

/// A vector as `[x, y, z, z]`, indexable by `k & 3` without bounds checks or branches.
#[inline(always)]
pub fn xyzz(v: Vec3) -> [f32; 4] {
    [v.x, v.y, v.z, v.z]
}

/// A packet vector as `[x, y, z, z]` (see [`xyzz`]).
#[inline(always)]
pub fn xyzz_s<L: Lanes>(v: &Vec3s<L>) -> [L::F32s; 4] {
    [v.x, v.y, v.z, v.z]
}

impl TriAccel {
    /// The record of triangle `prim` with vertices `p`; `None` when it is degenerate: its
    /// height is below [`MIN_THINNESS`] of its longest edge (zero area included), or its
    /// coefficients overflow f32. Coefficients are computed in f64.
    pub fn new(p: [Vec3; 3], prim: u32) -> Option<Self> {
        let [a, b, c] = p.map(|v| v.as_dvec3());
        let e1: DVec3 = b - a;
        let e2: DVec3 = c - a;
        let n = e1.cross(e2);
        // |n| is twice the area: the height over the longest edge L is |n| / L.
        let longest2 = e1
            .length_squared()
            .max(e2.length_squared())
            .max((c - b).length_squared());
        // Written so that NaN counts as degenerate.
        let thick = n.length() > MIN_THINNESS * longest2;
        if !thick {
            return None;
        }
        let k = n.abs().max_position();
        let (u, v) = uv_axes(k as u32);
        let nk = n[k];
        if nk == 0.0 || !nk.is_finite() {
            return None;
        }
        // n[k] = e1[u] * e2[v] - e1[v] * e2[u]: the projected triangle's doubled signed area.
        let rec = Self {
            n_u: (n[u] / nk) as f32,
            n_v: (n[v] / nk) as f32,
            k: k as u32,
            prim,
            a_k: a[k] as f32,
            a_u: a[u] as f32,
            a_v: a[v] as f32,
            b_nu: (e2[v] / nk) as f32,
            b_nv: (-e2[u] / nk) as f32,
            c_nu: (-e1[v] / nk) as f32,
            c_nv: (e1[u] / nk) as f32,
            edges: ALL_EDGES,
        };
        let coeffs = [rec.n_u, rec.n_v, rec.b_nu, rec.b_nv, rec.c_nu, rec.c_nv];
        coeffs.iter().all(|x| x.is_finite()).then_some(rec)
    }

    /// This record with the [`EDGE_EPS`] band on the edges `shared` says are shared (edges
    /// `p0-p1`, `p1-p2`, `p2-p0` of the vertices given to [`TriAccel::new`], as
    /// [`crate::edges::shared_edges`] lists them) and none on the others.
    pub fn with_shared_edges(mut self, shared: [bool; 3]) -> Self {
        let [ab, bc, ca] = shared;
        self.edges = ca as u32 | (ab as u32) << 1 | (bc as u32) << 2;
        self
    }

    /// The barycentric bounds of a hit: `(lowest u, lowest v, highest u + v)`.
    #[inline(always)]
    pub fn bounds(&self) -> (f32, f32, f32) {
        let [lo_u, lo_v, hi, _] = BOUNDS[(self.edges & ALL_EDGES) as usize];
        (lo_u, lo_v, hi)
    }

    /// The hit `(t, u, v)` of the ray `o + t d` with `tmin <= t < tmax`, if any.
    #[inline(always)]
    pub fn intersect1(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        self.intersect1x(&xyzz(o), &xyzz(d), tmin, tmax)
    }

    /// [`Self::intersect1`] with the ray as [`xyzz`] arrays (the traversal's form).
    #[inline(always)]
    pub fn intersect1x(
        &self,
        o: &[f32; 4],
        d: &[f32; 4],
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        let k = (self.k & 3) as usize;
        let (ku, kv) = uv_axes(self.k);
        let (wk, wu, wv) = (o[k] - self.a_k, o[ku] - self.a_u, o[kv] - self.a_v);
        let (dk, du, dv) = (d[k], d[ku], d[kv]);
        let denom = dk + self.n_u * du + self.n_v * dv;
        let t = -(wk + self.n_u * wu + self.n_v * wv) / denom;
        // Also rejects NaN (a ray parallel to the plane).
        let in_range = t >= tmin && t < tmax;
        if !in_range {
            return None;
        }
        let hu = wu + t * du;
        let hv = wv + t * dv;
        let (lo_u, lo_v, hi) = self.bounds();
        let beta = self.b_nu * hu + self.b_nv * hv;
        if beta < lo_u {
            return None;
        }
        let gamma = self.c_nu * hu + self.c_nv * hv;
        // Written so that NaN barycentrics are rejected.
        let inside = gamma >= lo_v && beta + gamma <= hi;
        inside.then_some((t, beta, gamma))
    }

    /// The packet form of [`Self::intersect1`], with the same arithmetic per lane: the lanes of
    /// `active` with a hit in `[tmin, tmax)`, and their `t`, `u`, `v` (other lanes undefined).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn intersect<L: Lanes>(
        &self,
        l: L,
        o: &Vec3s<L>,
        d: &Vec3s<L>,
        tmin: L::F32s,
        tmax: L::F32s,
        active: L::Mask,
    ) -> (L::Mask, L::F32s, L::F32s, L::F32s) {
        self.intersectx(l, &xyzz_s(o), &xyzz_s(d), tmin, tmax, active)
    }

    /// [`Self::intersect`] with the rays as [`xyzz_s`] arrays (the traversal's form).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn intersectx<L: Lanes>(
        &self,
        l: L,
        o: &[L::F32s; 4],
        d: &[L::F32s; 4],
        tmin: L::F32s,
        tmax: L::F32s,
        active: L::Mask,
    ) -> (L::Mask, L::F32s, L::F32s, L::F32s) {
        let k = (self.k & 3) as usize;
        let (ku, kv) = uv_axes(self.k);
        let wk = o[k] - l.splat(self.a_k);
        let wu = o[ku] - l.splat(self.a_u);
        let wv = o[kv] - l.splat(self.a_v);
        let (dk, du, dv) = (d[k], d[ku], d[kv]);
        let n_u = l.splat(self.n_u);
        let n_v = l.splat(self.n_v);
        let denom = dk + n_u * du + n_v * dv;
        let t = -(wk + n_u * wu + n_v * wv) / denom;
        let mut m = active & t.ge(tmin) & t.lt(tmax);
        if m.none() {
            return (m, t, t, t);
        }
        let hu = wu + t * du;
        let hv = wv + t * dv;
        let beta = l.splat(self.b_nu) * hu + l.splat(self.b_nv) * hv;
        let gamma = l.splat(self.c_nu) * hu + l.splat(self.c_nv) * hv;
        let (lo_u, lo_v, hi) = self.bounds();
        m = m & beta.ge(l.splat(lo_u)) & gamma.ge(l.splat(lo_v)) & (beta + gamma).le(l.splat(hi));
        (m, t, beta, gamma)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;

    #[test]
    fn record_is_48_bytes() {
        assert_eq!(core::mem::size_of::<TriAccel>(), 48);
    }

    #[test]
    fn hits_centre_with_barycentrics() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let r = TriAccel::new(p, 7).unwrap();
        let o = Vec3::new(0.25, 0.5, 2.0);
        let (t, u, v) = r.intersect1(o, -Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert_eq!((t, u, v), (2.0, 0.25, 0.5));
        let hit = (1.0 - u - v) * p[0] + u * p[1] + v * p[2];
        assert!(hit.distance(o - 2.0 * Vec3::Z) < 1e-6);
        // Outside, behind, beyond tmax.
        assert!(
            r.intersect1(Vec3::new(0.8, 0.8, 2.0), -Vec3::Z, 0.0, 9.0)
                .is_none()
        );
        assert!(r.intersect1(o, Vec3::Z, 0.0, 9.0).is_none());
        assert!(r.intersect1(o, -Vec3::Z, 0.0, 2.0).is_none());
        // Parallel to the plane.
        assert!(r.intersect1(o, Vec3::X, 0.0, 9.0).is_none());
    }

    #[test]
    fn degenerate_triangles_have_no_record() {
        assert!(TriAccel::new([Vec3::ZERO, Vec3::X, 2.0 * Vec3::X], 0).is_none());
        assert!(TriAccel::new([Vec3::ONE; 3], 0).is_none());
        let tiny = Vec3::splat(1e-42); // coefficients ~1e42 overflow f32
        assert!(TriAccel::new([Vec3::ZERO, tiny * Vec3::X, tiny * Vec3::Y], 0).is_none());
    }

    #[test]
    fn packet_matches_single_bitwise() {
        let p = [
            Vec3::new(-1.0, -0.5, 3.0),
            Vec3::new(2.0, 0.1, 2.5),
            Vec3::new(0.3, 1.7, 4.0),
        ];
        let r = TriAccel::new(p, 0).unwrap();
        for i in 0..200 {
            let f = i as f32 * 0.37;
            let o = Vec3::new(f.sin(), f.cos(), -1.0);
            let d = Vec3::new((f * 1.3).sin() * 0.5, (f * 0.7).cos() * 0.5, 1.0);
            let one = r.intersect1(o, d, 0.0, f32::INFINITY);
            let l = Scalar;
            let (m, t, u, v) = r.intersect(
                l,
                &Vec3s::splat(l, o),
                &Vec3s::splat(l, d),
                0.0,
                f32::INFINITY,
                true,
            );
            assert_eq!(one, m.then_some((t, u, v)));
        }
    }

    #[test]
    fn the_band_lies_beyond_shared_edges_only() {
        // The unit right triangle in z = 0; rays straight down just outside each edge, by half
        // the band (in barycentric units): hits while the edge takes the band, misses once it
        // does not.
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let out = 0.5 * EDGE_EPS;
        let beyond = [
            Vec3::new(0.5, -out, 1.0),                        // edge p0-p1 (v < 0)
            Vec3::new(0.5 + out / 2.0, 0.5 + out / 2.0, 1.0), // edge p1-p2 (u + v > 1)
            Vec3::new(-out, 0.5, 1.0),                        // edge p2-p0 (u < 0)
        ];
        let all = TriAccel::new(p, 0).unwrap();
        assert_eq!(all.edges, ALL_EDGES);
        assert_eq!(all, all.with_shared_edges([true; 3]));
        for (e, &o) in beyond.iter().enumerate() {
            assert!(
                all.intersect1(o, -Vec3::Z, 0.0, f32::INFINITY).is_some(),
                "edge {e}"
            );
            let mut shared = [true; 3];
            shared[e] = false;
            let one = all.with_shared_edges(shared);
            assert_eq!(
                one.intersect1(o, -Vec3::Z, 0.0, f32::INFINITY),
                None,
                "edge {e}"
            );
            // Only that edge is exact: the others still take the band.
            for (f, &o2) in beyond.iter().enumerate().filter(|&(f, _)| f != e) {
                assert!(
                    one.intersect1(o2, -Vec3::Z, 0.0, f32::INFINITY).is_some(),
                    "{e} {f}"
                );
            }
            // The packet form agrees.
            let l = Scalar;
            let (m, ..) = one.intersect(
                l,
                &Vec3s::splat(l, o),
                &Vec3s::splat(l, -Vec3::Z),
                0.0,
                f32::INFINITY,
                true,
            );
            assert!(!m, "edge {e}");
            // Inside the exact edge by as little still hits.
            let inside = [
                Vec3::new(0.5, out, 1.0),
                Vec3::new(0.5 - out / 2.0, 0.5 - out / 2.0, 1.0),
                Vec3::new(out, 0.5, 1.0),
            ][e];
            assert!(
                one.intersect1(inside, -Vec3::Z, 0.0, f32::INFINITY)
                    .is_some()
            );
        }
    }
}
