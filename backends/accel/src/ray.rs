//! Single rays and their hits: the scalar path of the ray tracer (paper section 3, the
//! non-SSE baseline), and the lane values packets are made of.

use glam::{Affine3A, Vec3};

/// A ray `origin + t * dir` for `t` in `[tmin, tmax)`. `dir` need not be normalised; `t` is in
/// units of `dir`, the same in world and object space.
///
/// A ray with a non-finite origin or direction, a zero direction (squared length 0 in f32),
/// a NaN bound or `tmin > tmax` is *invalid*: every query treats it as a miss.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray1 {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray1 {
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self {
            origin,
            dir,
            tmin,
            tmax,
        }
    }

    /// `[0, inf)`.
    pub fn infinite(origin: Vec3, dir: Vec3) -> Self {
        Self::new(origin, dir, 0.0, f32::INFINITY)
    }

    /// See the type's documentation.
    #[inline(always)]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.dir.dot(self.dir) > 0.0
            && self.tmin <= self.tmax
    }

    /// The point at `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// The ray in the space `m` maps to (origin as a point, direction as a vector, `t` range
    /// unchanged). Every accelerator moves rays into object space with this arithmetic
    /// (and its packet twin in [`crate::Rays::transformed`]), so `t` values agree bit for bit.
    #[inline(always)]
    pub fn transformed(&self, m: &Affine3A) -> Self {
        Self {
            origin: transform_point1(m, self.origin),
            dir: transform_vector1(m, self.dir),
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

/// `m * p` for a point, in a fixed order of operations (no FMA).
#[inline(always)]
pub fn transform_point1(m: &Affine3A, p: Vec3) -> Vec3 {
    let t = m.translation;
    transform_vector1(m, p) + Vec3::new(t.x, t.y, t.z)
}

/// `m * v` for a vector, in a fixed order of operations (no FMA).
#[inline(always)]
pub fn transform_vector1(m: &Affine3A, v: Vec3) -> Vec3 {
    let (a, b, c) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis);
    Vec3::new(
        a.x * v.x + b.x * v.y + c.x * v.z,
        a.y * v.x + b.y * v.y + c.y * v.z,
        a.z * v.x + b.z * v.y + c.z * v.z,
    )
}

/// A ray's hit: distance `t`, barycentrics `(u, v)` (the point is
/// `(1 - u - v) * p0 + u * p1 + v * p2` of triangle `prim`'s vertices in index order),
/// triangle `prim` of the mesh of instance `inst`.
///
/// `u` and `v` may fall outside `[0, 1]` by the intersection test's edge tolerance
/// ([`crate::EDGE_EPS`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit1 {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub prim: u32,
    pub inst: u32,
}

impl Ray1 {
    /// For structures that search `t >= 0` only (Embree, obvhs): the same ray with `tmin >= 0`
    /// and the shift `s` to add to its hits' `t`. A ray with `tmin < 0` is clipped to
    /// `bounds` (which must hold everything it can hit) and its origin moved to the clipped
    /// start when that lies behind it. `None` when such a ray misses `bounds`.
    #[inline]
    pub fn forward(&self, bounds: &crate::Aabb) -> Option<(Ray1, f32)> {
        if self.tmin >= 0.0 {
            return Some((*self, 0.0));
        }
        let (t0, _) = bounds.clip1(self.origin, self.dir.recip(), self.tmin, self.tmax)?;
        if t0 >= 0.0 {
            return Some((Ray1 { tmin: 0.0, ..*self }, 0.0));
        }
        let moved = Ray1::new(self.at(t0), self.dir, 0.0, self.tmax - t0);
        Some((moved, t0))
    }
}
