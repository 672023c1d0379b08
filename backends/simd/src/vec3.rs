//! Packet vectors and colours: `Vec3s<L>` and `Rgbs<L>`, structs of lanes (one ray per lane),
//! with the vector algebra of sections 3-5 (dot, cross, normalize, per-lane select).
//! Scalar geometry uses `glam`; [`Vec3s::splat`] and [`Vec3s::lane`] convert.

use core::ops::{Add, AddAssign, Mul, Neg, Sub};

use glam::Vec3;

use crate::lanes::{Lanes, SimdF32, SimdMask};

/// One 3-vector per lane.
pub struct Vec3s<L: Lanes> {
    pub x: L::F32s,
    pub y: L::F32s,
    pub z: L::F32s,
}

impl<L: Lanes> Clone for Vec3s<L> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lanes> Copy for Vec3s<L> {}

impl<L: Lanes> core::fmt::Debug for Vec3s<L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list()
            .entries((0..L::N).map(|i| self.lane(i)))
            .finish()
    }
}

impl<L: Lanes> Vec3s<L> {
    #[inline(always)]
    pub fn new(x: L::F32s, y: L::F32s, z: L::F32s) -> Self {
        Vec3s { x, y, z }
    }
    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(l: L, v: Vec3) -> Self {
        Vec3s {
            x: l.splat(v.x),
            y: l.splat(v.y),
            z: l.splat(v.z),
        }
    }
    /// Lane `i` of `vs`, for each lane (packing; not for hot loops).
    #[inline(always)]
    pub fn from_fn(l: L, mut f: impl FnMut(usize) -> Vec3) -> Self {
        let mut v = [Vec3::ZERO; crate::MAX_LANES];
        for (i, vi) in v.iter_mut().enumerate().take(L::N) {
            *vi = f(i);
        }
        Vec3s {
            x: l.from_fn(|i| v[i].x),
            y: l.from_fn(|i| v[i].y),
            z: l.from_fn(|i| v[i].z),
        }
    }
    /// Lane `i` as a glam vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x.lane(i), self.y.lane(i), self.z.lane(i))
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> L::F32s {
        self.x.mul_add(o.x, self.y.mul_add(o.y, self.z * o.z))
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Vec3s {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }
    #[inline(always)]
    pub fn length_squared(self) -> L::F32s {
        self.dot(self)
    }
    #[inline(always)]
    pub fn length(self) -> L::F32s {
        self.length_squared().sqrt()
    }
    /// `self / |self|` with an exact square root and division (zero vectors give NaN lanes,
    /// like glam's `normalize`).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        let len = self.length();
        Vec3s {
            x: self.x / len,
            y: self.y / len,
            z: self.z / len,
        }
    }
    /// Per lane `if m { t } else { f }`.
    #[inline(always)]
    pub fn select(m: L::Mask, t: Self, f: Self) -> Self {
        Vec3s {
            x: m.select(t.x, f.x),
            y: m.select(t.y, f.y),
            z: m.select(t.z, f.z),
        }
    }
    /// Componentwise product.
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        Vec3s {
            x: self.x * o.x,
            y: self.y * o.y,
            z: self.z * o.z,
        }
    }
    /// `self * s + o`, per component.
    #[inline(always)]
    pub fn mul_add(self, s: L::F32s, o: Self) -> Self {
        Vec3s {
            x: self.x.mul_add(s, o.x),
            y: self.y.mul_add(s, o.y),
            z: self.z.mul_add(s, o.z),
        }
    }
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        Vec3s {
            x: self.x.min(o.x),
            y: self.y.min(o.y),
            z: self.z.min(o.z),
        }
    }
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        Vec3s {
            x: self.x.max(o.x),
            y: self.y.max(o.y),
            z: self.z.max(o.z),
        }
    }
}

impl<L: Lanes> Add for Vec3s<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Vec3s {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}
impl<L: Lanes> AddAssign for Vec3s<L> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl<L: Lanes> Sub for Vec3s<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Vec3s {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}
impl<L: Lanes> Neg for Vec3s<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Vec3s {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}
/// Scale by one value per lane.
impl<L: Lanes> Mul<L::F32s> for Vec3s<L> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: L::F32s) -> Self {
        Vec3s {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

/// One RGB colour per lane (the paper renders RGB; section 8).
pub struct Rgbs<L: Lanes> {
    pub r: L::F32s,
    pub g: L::F32s,
    pub b: L::F32s,
}

impl<L: Lanes> Clone for Rgbs<L> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lanes> Copy for Rgbs<L> {}

impl<L: Lanes> core::fmt::Debug for Rgbs<L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list()
            .entries((0..L::N).map(|i| self.lane(i)))
            .finish()
    }
}

impl<L: Lanes> Rgbs<L> {
    #[inline(always)]
    pub fn new(r: L::F32s, g: L::F32s, b: L::F32s) -> Self {
        Rgbs { r, g, b }
    }
    /// `c` (linear RGB) in every lane.
    #[inline(always)]
    pub fn splat(l: L, c: [f32; 3]) -> Self {
        Rgbs {
            r: l.splat(c[0]),
            g: l.splat(c[1]),
            b: l.splat(c[2]),
        }
    }
    /// Black in every lane.
    #[inline(always)]
    pub fn zero(l: L) -> Self {
        Rgbs::splat(l, [0.0; 3])
    }
    /// Lane `i` as `[r, g, b]`.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> [f32; 3] {
        [self.r.lane(i), self.g.lane(i), self.b.lane(i)]
    }
    /// Rec. 709 luminance.
    #[inline(always)]
    pub fn luminance(self) -> L::F32s {
        self.r * 0.2126 + self.g * 0.7152 + self.b * 0.0722
    }
    /// Per lane `if m { t } else { f }`.
    #[inline(always)]
    pub fn select(m: L::Mask, t: Self, f: Self) -> Self {
        Rgbs {
            r: m.select(t.r, f.r),
            g: m.select(t.g, f.g),
            b: m.select(t.b, f.b),
        }
    }
    /// Scale by one value per lane.
    #[inline(always)]
    pub fn scale(self, s: L::F32s) -> Self {
        Rgbs {
            r: self.r * s,
            g: self.g * s,
            b: self.b * s,
        }
    }
    /// `self * s + o`, per channel.
    #[inline(always)]
    pub fn mul_add(self, s: L::F32s, o: Self) -> Self {
        Rgbs {
            r: self.r.mul_add(s, o.r),
            g: self.g.mul_add(s, o.g),
            b: self.b.mul_add(s, o.b),
        }
    }
}

impl<L: Lanes> Add for Rgbs<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Rgbs {
            r: self.r + o.r,
            g: self.g + o.g,
            b: self.b + o.b,
        }
    }
}
impl<L: Lanes> AddAssign for Rgbs<L> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
/// Channelwise product (filtering one colour by another).
impl<L: Lanes> Mul for Rgbs<L> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Rgbs {
            r: self.r * o.r,
            g: self.g * o.g,
            b: self.b * o.b,
        }
    }
}
