//! Axis-aligned bounding boxes: the scene box every packet is tested against first
//! (paper section 3) and the instance boxes of the top-level tree.

use glam::{Affine3A, Vec3};

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The box that contains nothing; growing it by a point gives that point.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The smallest box holding all `points`.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// True when the box holds no point (some `min > max`, or NaN).
    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The common part of two boxes (may be empty).
    pub fn intersection(self, o: Aabb) -> Self {
        Self {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area (0 for an empty box).
    pub fn area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The box of the eight transformed corners (holds the transformed box).
    pub fn transformed(&self, m: &Affine3A) -> Self {
        if self.is_empty() {
            return *self;
        }
        let mut b = Self::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b = b.grow(m.transform_point3(c));
        }
        b
    }

    /// The parametric range `[t0, t1]` in which the ray `origin + t * dir` is inside the box,
    /// clipped to `[tmin, tmax]`; `None` when it misses. `inv_dir` is `1 / dir` per axis
    /// (infinite for zero components). A ray lying in a face plane counts as inside.
    #[inline(always)]
    pub fn clip1(&self, origin: Vec3, inv_dir: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32)> {
        let mut t0 = tmin;
        let mut t1 = tmax;
        for a in 0..3 {
            let (lo, hi) = slab1(origin[a], inv_dir[a], self.min[a], self.max[a]);
            t0 = if lo > t0 { lo } else { t0 };
            t1 = if hi < t1 { hi } else { t1 };
        }
        if t0 <= t1 { Some((t0, t1)) } else { None }
    }
}

/// The entry and exit `t` of one slab. `0 * inf` is NaN: it happens only for a ray with a
/// zero direction component lying exactly in a face plane, which then counts as inside the
/// slab (the slab does not limit it).
#[inline(always)]
pub fn slab1(o: f32, inv: f32, min: f32, max: f32) -> (f32, f32) {
    let a = (min - o) * inv;
    let b = (max - o) * inv;
    if a.is_nan() || b.is_nan() {
        return (f32::NEG_INFINITY, f32::INFINITY);
    }
    if a < b { (a, b) } else { (b, a) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_axis_parallel_ray_in_face_plane() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        // Ray along x lying in the face plane y = 0.
        let o = Vec3::new(-1.0, 0.0, 0.5);
        let d = Vec3::X;
        let r = b.clip1(o, d.recip(), 0.0, f32::INFINITY);
        assert_eq!(r, Some((1.0, 2.0)));
        // Outside the slab in y: a miss.
        let o = Vec3::new(-1.0, -0.1, 0.5);
        assert_eq!(b.clip1(o, d.recip(), 0.0, f32::INFINITY), None);
    }

    #[test]
    fn empty_and_union() {
        assert!(Aabb::EMPTY.is_empty());
        let b = Aabb::from_points([Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        assert!(!b.is_empty());
        assert_eq!(b.area(), 2.0 * (2.0 + 6.0 + 3.0));
        assert_eq!(Aabb::EMPTY.union(b), b);
    }
}
