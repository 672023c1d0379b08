//! A group's frustum: four planes every ray of a beam's group lies within, so that a leaf's
//! triangle outside one of them is skipped for every packet of the group at once (Reshetov,
//! Soupikov & Hurley 2005 cull a leaf's triangles against the beam's frustum before any
//! packet tests them).
//!
//! The planes bound the slopes of the rays' directions about a dominant axis `k`: with
//! `u = d_a / d_k` for each other axis `a`, every ray's points `o + t d` (`t >= 0`) satisfy
//! `u_min <= (p_a - o_a) / (p_k - o_k) <= u_max`, four half-spaces through the ray's origin.
//! The origins range over a box (one point for camera rays, the far ends of reversed shadow
//! rays): each plane's offset is taken over that box, so the planes hold for every ray.
//! A triangle is outside when its box (grown by the projection test's edge band, see
//! [`cull_box`]) lies beyond one plane by more than a relative margin of `1e-5` (many times
//! the rounding of the slopes and products; a miss costs only a test, a wrong cull a hit).

use coherent_accel::{Aabb, EDGE_EPS};
use coherent_simd::{Lanes, SimdF32, SimdMask};
use glam::{BVec4A, Vec3, Vec4};

use crate::walk::RaysX;

/// Relative margin a box must clear a plane by to be culled.
const MARGIN: f32 = 1e-5;

/// Four planes `n . p <= c` holding every ray of a group.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frustum {
    n: [Vec3; 4],
    c: [f32; 4],
    /// Per plane, `sum |n_i| * max |o_i|` over the origins' box: the scale of `c`.
    c_scale: [f32; 4],
}

impl Frustum {
    /// The test for the triangles of a mesh whose boxes lie in `bounds`: the four planes
    /// side by side, each offset by its margin at the scale of `bounds`' coordinates.
    #[inline(always)]
    pub fn culler(&self, bounds: &Aabb) -> Culler {
        let m = bounds.min.abs().max(bounds.max.abs());
        let mut thr = [0.0; 4];
        let mut n = [Vec4::ZERO; 3];
        for p in 0..4 {
            let np = self.n[p];
            thr[p] = self.c[p] + MARGIN * ((np.abs() * m).element_sum() + self.c_scale[p]);
            for a in 0..3 {
                n[a][p] = np[a];
            }
        }
        let z = Vec4::ZERO;
        Culler {
            n,
            pos: [n[0].cmpge(z), n[1].cmpge(z), n[2].cmpge(z)],
            thr: Vec4::from_array(thr),
        }
    }
}

/// A group's frustum against one mesh's triangle boxes (see [`Frustum::culler`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Culler {
    /// Per axis, the four planes' normal components, and which are not negative.
    n: [Vec4; 3],
    pos: [BVec4A; 3],
    /// Per plane, the offset a box must lie beyond.
    thr: Vec4,
}

impl Culler {
    /// Whether box `b` lies outside some plane (conservatively: `false` when unsure).
    #[inline(always)]
    pub fn outside(&self, b: &Aabb) -> bool {
        // Per plane, the box's lowest `n . x`: per axis the corner against the normal.
        let mut lo = Vec4::ZERO;
        for a in 0..3 {
            let x = Vec4::select(self.pos[a], Vec4::splat(b.min[a]), Vec4::splat(b.max[a]));
            lo += self.n[a] * x;
        }
        lo.cmpgt(self.thr).any()
    }
}

/// Accumulates a group's rays, slot by slot, into its [`Frustum`].
pub(crate) struct FrustumBuilder<L: Lanes> {
    /// The dominant axis and the other two.
    k: usize,
    ab: (usize, usize),
    u_lo: [L::F32s; 2],
    u_hi: [L::F32s; 2],
    o_lo: [L::F32s; 3],
    o_hi: [L::F32s; 3],
    /// Lowest `tmin`: the planes hold for `t >= 0` only.
    tmin: L::F32s,
    any: bool,
}

impl<L: Lanes> FrustumBuilder<L> {
    /// A builder about the axis along which the lanes `m` of `first` (the group's first
    /// packet) travel fastest. Every ray added must have a direction of the same sign along
    /// it (a sign group) and finite inverse directions.
    #[inline(always)]
    pub fn new(l: L, first: &RaysX<L>, m: L::Mask) -> Self {
        let zero = l.splat(0.0);
        let mut k = 0;
        let mut best = -1.0;
        for a in 0..3 {
            let v = m.select(first.d[a].abs(), zero).reduce_max();
            if v > best {
                (k, best) = (a, v);
            }
        }
        let ab = if k == 0 {
            (1, 2)
        } else if k == 1 {
            (2, 0)
        } else {
            (0, 1)
        };
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        Self {
            k,
            ab,
            u_lo: [inf; 2],
            u_hi: [ninf; 2],
            o_lo: [inf; 3],
            o_hi: [ninf; 3],
            tmin: inf,
            any: false,
        }
    }

    /// Adds lanes `m` of `r`.
    #[inline(always)]
    pub fn add(&mut self, l: L, r: &RaysX<L>, m: L::Mask) {
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        let inv_k = r.inv[self.k];
        // Index loops, not iterator adaptors: those may stay out of line, outside the
        // kernel's target features.
        for i in 0..2 {
            let a = if i == 0 { self.ab.0 } else { self.ab.1 };
            let u = r.d[a] * inv_k;
            self.u_lo[i] = self.u_lo[i].min(m.select(u, inf));
            self.u_hi[i] = self.u_hi[i].max(m.select(u, ninf));
        }
        for a in 0..3 {
            self.o_lo[a] = self.o_lo[a].min(m.select(r.o[a], inf));
            self.o_hi[a] = self.o_hi[a].max(m.select(r.o[a], ninf));
        }
        self.tmin = self.tmin.min(m.select(r.tmin, inf));
        self.any |= m.any();
    }

    /// The frustum (`neg`: the group's direction sign bits), or `None` when the rays give
    /// no finite one.
    #[inline(always)]
    pub fn finish(&self, neg: u32) -> Option<Frustum> {
        let tmin = self.tmin.reduce_min();
        if !self.any || tmin.is_nan() || tmin < 0.0 {
            return None;
        }
        let s = if neg >> self.k & 1 != 0 { -1.0 } else { 1.0 };
        let (mut o_lo, mut o_hi) = (Vec3::ZERO, Vec3::ZERO);
        for a in 0..3 {
            o_lo[a] = self.o_lo[a].reduce_min();
            o_hi[a] = self.o_hi[a].reduce_max();
        }
        let mut f = Frustum {
            n: [Vec3::ZERO; 4],
            c: [0.0; 4],
            c_scale: [0.0; 4],
        };
        for i in 0..2 {
            let a = if i == 0 { self.ab.0 } else { self.ab.1 };
            let (u_lo, u_hi) = (self.u_lo[i].reduce_min(), self.u_hi[i].reduce_max());
            if !(u_lo.is_finite() && u_hi.is_finite()) {
                return None;
            }
            // `u <= u_hi`: s (p_a - u_hi p_k) <= s (o_a - u_hi o_k); `u >= u_lo` mirrored.
            let mut hi = Vec3::ZERO;
            hi[a] = s;
            hi[self.k] = -s * u_hi;
            let mut lo = Vec3::ZERO;
            lo[a] = -s;
            lo[self.k] = s * u_lo;
            f.n[2 * i] = hi;
            f.n[2 * i + 1] = lo;
        }
        for p in 0..4 {
            let n = f.n[p];
            // The origins' highest `n . o`.
            f.c[p] = (n * Vec3::select(n.cmpge(Vec3::ZERO), o_hi, o_lo)).element_sum();
            f.c_scale[p] = (n.abs() * o_lo.abs().max(o_hi.abs())).element_sum();
            if !(f.c[p].is_finite() && f.c_scale[p].is_finite()) {
                return None;
            }
        }
        Some(f)
    }
}

/// The box a triangle's projection test can hit: the triangle's own box grown per axis by
/// `4 EDGE_EPS` of its extent (the test accepts barycentrics down to `-EDGE_EPS`; a corner
/// of that band lies `2 EDGE_EPS (|e1| + |e2|)` from the triangle per axis, at most
/// `4 EDGE_EPS` of the extent).
pub(crate) fn cull_box(v: &[Vec3; 3]) -> Aabb {
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let g = (hi - lo) * (4.0 * EDGE_EPS) + (lo.abs().max(hi.abs())) * 1e-6;
    Aabb::new(lo - g, hi + g)
}
