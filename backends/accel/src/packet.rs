//! Packets of rays and hits, one ray per lane (paper section 3: rays are traced `N` at a time
//! under a mask of active lanes).

pub use coherent_simd::Vec3s;
use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask};
use glam::{Affine3A, Vec3};

use crate::{Hit1, Ray1};

/// Component `axis` (0, 1 or 2) of a packet vector.
#[inline(always)]
pub fn axis<L: Lanes>(v: &Vec3s<L>, axis: usize) -> L::F32s {
    match axis {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// A packet of rays: lane `i` is the ray `origin[i] + t * dir[i]`, `t` in `[tmin[i], tmax[i])`.
/// Invalid lanes (see [`Ray1`]) are misses.
#[derive(Debug, Clone, Copy)]
pub struct Rays<L: Lanes> {
    pub origin: Vec3s<L>,
    pub dir: Vec3s<L>,
    pub tmin: L::F32s,
    pub tmax: L::F32s,
}

impl<L: Lanes> Rays<L> {
    /// Packs one ray per lane.
    #[inline(always)]
    pub fn from_fn(l: L, mut f: impl FnMut(usize) -> Ray1) -> Self {
        let mut buf = [Ray1::infinite(Vec3::ZERO, Vec3::X); coherent_simd::MAX_LANES];
        for (i, r) in buf.iter_mut().enumerate().take(L::N) {
            *r = f(i);
        }
        Self {
            origin: Vec3s::from_fn(l, |i| buf[i].origin),
            dir: Vec3s::from_fn(l, |i| buf[i].dir),
            tmin: l.from_fn(|i| buf[i].tmin),
            tmax: l.from_fn(|i| buf[i].tmax),
        }
    }

    /// Lane `i` (slow: unpacking, tests).
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Ray1 {
        Ray1::new(
            self.origin.lane(i),
            self.dir.lane(i),
            self.tmin.lane(i),
            self.tmax.lane(i),
        )
    }

    /// Every lane as a single ray (the first `L::N` entries): one store per component, for
    /// the packet forms built on single-ray queries.
    #[inline(always)]
    pub fn unpack(&self) -> [Ray1; coherent_simd::MAX_LANES] {
        let mut c = [[0.0f32; coherent_simd::MAX_LANES]; 8];
        let v = [
            self.origin.x,
            self.origin.y,
            self.origin.z,
            self.dir.x,
            self.dir.y,
            self.dir.z,
            self.tmin,
            self.tmax,
        ];
        for (out, v) in c.iter_mut().zip(v) {
            v.store(out);
        }
        let mut rays = [Ray1::infinite(Vec3::ZERO, Vec3::X); coherent_simd::MAX_LANES];
        for (i, r) in rays.iter_mut().enumerate().take(L::N) {
            *r = Ray1::new(
                Vec3::new(c[0][i], c[1][i], c[2][i]),
                Vec3::new(c[3][i], c[4][i], c[5][i]),
                c[6][i],
                c[7][i],
            );
        }
        rays
    }

    /// Lanes holding a valid ray (the rule of [`Ray1::is_valid`], lane by lane).
    #[inline(always)]
    pub fn valid(&self, l: L) -> L::Mask {
        let zero = l.splat(0.0);
        let inf = l.splat(f32::INFINITY);
        // False for NaN and both infinities.
        let o = &self.origin;
        let d = &self.dir;
        o.x.abs().lt(inf)
            & o.y.abs().lt(inf)
            & o.z.abs().lt(inf)
            & d.x.abs().lt(inf)
            & d.y.abs().lt(inf)
            & d.z.abs().lt(inf)
            // Without FMA, as `Ray1::is_valid` computes it.
            & (d.x * d.x + d.y * d.y + d.z * d.z).gt(zero)
            & self.tmin.le(self.tmax)
    }

    /// The rays in the space `m` maps to, with the arithmetic of [`Ray1::transformed`].
    #[inline(always)]
    pub fn transformed(&self, l: L, m: &Affine3A) -> Self {
        let t = m.translation;
        let d = transform_vector(l, m, &self.dir);
        let o = transform_vector(l, m, &self.origin);
        Self {
            origin: Vec3s::new(o.x + t.x, o.y + t.y, o.z + t.z),
            dir: d,
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

#[inline(always)]
fn transform_vector<L: Lanes>(l: L, m: &Affine3A, v: &Vec3s<L>) -> Vec3s<L> {
    let (a, b, c) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis);
    // Written out, not through a closure: a closure here was not inlined into the
    // backends' `#[target_feature]` entry points, so every AVX-512 multiply and add of an
    // instance transform became a call (seen in `perf` of `coherent render car --backend
    // avx512`: `_mm512_mul_ps` and this function's closure as their own symbols).
    Vec3s::new(
        l.splat(a.x) * v.x + l.splat(b.x) * v.y + l.splat(c.x) * v.z,
        l.splat(a.y) * v.x + l.splat(b.y) * v.y + l.splat(c.y) * v.z,
        l.splat(a.z) * v.x + l.splat(b.z) * v.y + l.splat(c.z) * v.z,
    )
}

/// The first hits of a packet: per lane `t` (`+inf` on a miss), barycentrics `u`, `v`,
/// triangle `prim` and instance `inst` (both `-1` on a miss). See [`Hit1`].
#[derive(Debug, Clone, Copy)]
pub struct Hits<L: Lanes> {
    pub t: L::F32s,
    pub u: L::F32s,
    pub v: L::F32s,
    pub prim: L::I32s,
    pub inst: L::I32s,
}

impl<L: Lanes> Hits<L> {
    /// Every lane a miss.
    #[inline(always)]
    pub fn miss(l: L) -> Self {
        Self {
            t: l.splat(f32::INFINITY),
            u: l.splat(0.0),
            v: l.splat(0.0),
            prim: l.splat_i32(-1),
            inst: l.splat_i32(-1),
        }
    }

    /// Lanes that hit something.
    #[inline(always)]
    pub fn hit_mask(&self, l: L) -> L::Mask {
        self.prim.gt(l.splat_i32(-1))
    }

    /// Lane `i` (slow: unpacking, tests).
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Option<Hit1> {
        let prim = self.prim.lane(i);
        (prim >= 0).then(|| Hit1 {
            t: self.t.lane(i),
            u: self.u.lane(i),
            v: self.v.lane(i),
            prim: prim as u32,
            inst: self.inst.lane(i) as u32,
        })
    }

    /// Packs one optional hit per lane (packet forms built on single-ray queries).
    #[inline(always)]
    pub fn from_fn(l: L, mut f: impl FnMut(usize) -> Option<Hit1>) -> Self {
        let mut buf = [None; coherent_simd::MAX_LANES];
        for (i, h) in buf.iter_mut().enumerate().take(L::N) {
            *h = f(i);
        }
        Self {
            t: l.from_fn(|i| buf[i].map_or(f32::INFINITY, |h| h.t)),
            u: l.from_fn(|i| buf[i].map_or(0.0, |h| h.u)),
            v: l.from_fn(|i| buf[i].map_or(0.0, |h| h.v)),
            prim: l.from_fn_i32(|i| buf[i].map_or(-1, |h| h.prim as i32)),
            inst: l.from_fn_i32(|i| buf[i].map_or(-1, |h| h.inst as i32)),
        }
    }

    /// Takes `o`'s lanes where `m` is on.
    #[inline(always)]
    pub fn select(m: L::Mask, o: &Self, s: &Self) -> Self {
        Self {
            t: m.select(o.t, s.t),
            u: m.select(o.u, s.u),
            v: m.select(o.v, s.v),
            prim: m.select_i32(o.prim, s.prim),
            inst: m.select_i32(o.inst, s.inst),
        }
    }
}
