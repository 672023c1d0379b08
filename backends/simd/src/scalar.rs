//! The scalar backend: one lane, plain `f32` and `bool`. This is the paper's "non-SSE"
//! baseline (section 7): the same algorithms, one ray at a time. It also defines the
//! reference semantics every other backend is tested against (see [`crate::lanes`]).

use core::ops::{Add, BitAnd, BitOr, BitXor, Mul, Not, Shl, Shr, Sub};

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};

/// One lane. `F32s = f32`, `Mask = bool`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scalar;

/// One `i32` lane with wrapping arithmetic (as SIMD integer lanes wrap).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct I32x1(pub i32);

impl Lanes for Scalar {
    const N: usize = 1;
    type F32s = f32;
    type I32s = I32x1;
    type Mask = bool;

    #[inline(always)]
    fn splat(self, x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> I32x1 {
        I32x1(x)
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn lane_ids(self) -> I32x1 {
        I32x1(0)
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> f32 {
        s[0]
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> I32x1 {
        I32x1(s[0])
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> bool {
        bits & 1 == 1
    }
    #[inline(always)]
    fn gather(self, table: &[f32], idx: I32x1) -> f32 {
        table[gather_index(idx.0, table.len())]
    }
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: I32x1) -> I32x1 {
        I32x1(table[gather_index(idx.0, table.len())] as i32)
    }
}

/// Checks a gather index and turns it into a `usize` (shared by the backends without a
/// hardware gather).
#[inline(always)]
pub(crate) fn gather_index(i: i32, len: usize) -> usize {
    let u = i as u32 as usize;
    assert!(
        i >= 0 && u < len,
        "gather index {i} outside a table of {len}"
    );
    u
}

/// The reference `to_i32`: truncation, with NaN and out-of-range values giving `i32::MIN`.
#[inline(always)]
pub(crate) fn f32_to_i32_x86(x: f32) -> i32 {
    // 2^31 is exactly representable; anything at or above it (or NaN) is out of range.
    if !(-2147483648.0..2147483648.0).contains(&x) {
        i32::MIN
    } else {
        x as i32
    }
}

/// The reference `floor`/`round` rule for values that are already integers, inf or NaN.
#[inline(always)]
fn integral_or_special(x: f32) -> bool {
    // 2^23; also true for NaN.
    x.abs().partial_cmp(&8388608.0) != Some(core::cmp::Ordering::Less)
}

impl SimdF32 for f32 {
    type Mask = bool;
    type I32s = I32x1;

    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn min(self, o: f32) -> f32 {
        if self < o { self } else { o }
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        if self > o { self } else { o }
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn rsqrt(self) -> f32 {
        1.0 / f32::sqrt(self)
    }
    #[inline(always)]
    fn recip(self) -> f32 {
        1.0 / self
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        // Inline, never a libm `floorf` call (which a build without SSE4.1 would make while
        // the SIMD backends inline theirs): truncate through i32 (`cvttss2si`; |x| < 2^23
        // here), step down where that went up, keep the sign of zero.
        if integral_or_special(self) {
            self
        } else {
            let t = (self as i32) as f32;
            let r = if t > self { t - 1.0 } else { t };
            r.copysign(self)
        }
    }
    #[inline(always)]
    fn round(self) -> f32 {
        // Inline, never a libm call: |x| + 2^23 - 2^23 rounds |x| < 2^23 to nearest even
        // (the add-magic-number trick, scalar); the sign is copied back (keeps -0).
        if integral_or_special(self) {
            self
        } else {
            let r = (self.abs() + 8_388_608.0) - 8_388_608.0;
            r.copysign(self)
        }
    }
    #[inline(always)]
    fn mul_add(self, b: f32, c: f32) -> f32 {
        // Two roundings: a scalar CPU without FMA (the baseline) computes it so, and
        // `f32::mul_add` would call a slow soft-float routine there.
        self * b + c
    }
    #[inline(always)]
    fn to_i32(self) -> I32x1 {
        I32x1(f32_to_i32_x86(self))
    }
    #[inline(always)]
    fn to_bits(self) -> I32x1 {
        I32x1(f32::to_bits(self) as i32)
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        out[0] = self;
    }
    #[inline(always)]
    fn store_masked(self, m: bool, out: &mut [f32]) {
        if m {
            out[0] = self;
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        assert!(i == 0, "lane {i} of a 1-lane packet");
        self
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        self
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        self
    }
    #[inline(always)]
    fn copysign(self, sign: f32) -> f32 {
        f32::copysign(self, sign)
    }
}

impl SimdMask for bool {
    type F32s = f32;
    type I32s = I32x1;

    #[inline(always)]
    fn select(self, t: f32, f: f32) -> f32 {
        if self { t } else { f }
    }
    #[inline(always)]
    fn select_i32(self, t: I32x1, f: I32x1) -> I32x1 {
        if self { t } else { f }
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
    #[inline(always)]
    fn none(self) -> bool {
        !self
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self as u32
    }
    #[inline(always)]
    fn and_not(self, o: bool) -> bool {
        self & !o
    }
}

macro_rules! i32x1_binop {
    ($($tr:ident $f:ident $op:ident),*) => {$(
        impl $tr for I32x1 {
            type Output = I32x1;
            #[inline(always)]
            fn $f(self, o: I32x1) -> I32x1 {
                I32x1(self.0.$op(o.0))
            }
        }
    )*};
}
i32x1_binop!(Add add wrapping_add, Sub sub wrapping_sub, Mul mul wrapping_mul,
    BitAnd bitand bitand, BitOr bitor bitor, BitXor bitxor bitxor);

impl Not for I32x1 {
    type Output = I32x1;
    #[inline(always)]
    fn not(self) -> I32x1 {
        I32x1(!self.0)
    }
}
impl Shl<u32> for I32x1 {
    type Output = I32x1;
    #[inline(always)]
    fn shl(self, n: u32) -> I32x1 {
        I32x1(self.0.wrapping_shl(n))
    }
}
impl Shr<u32> for I32x1 {
    type Output = I32x1;
    #[inline(always)]
    fn shr(self, n: u32) -> I32x1 {
        I32x1(self.0.wrapping_shr(n))
    }
}

impl SimdI32 for I32x1 {
    type Mask = bool;
    type F32s = f32;

    #[inline(always)]
    fn splat_same(self, x: i32) -> I32x1 {
        I32x1(x)
    }
    #[inline(always)]
    fn eq(self, o: I32x1) -> bool {
        self.0 == o.0
    }
    #[inline(always)]
    fn lt(self, o: I32x1) -> bool {
        self.0 < o.0
    }
    #[inline(always)]
    fn gt(self, o: I32x1) -> bool {
        self.0 > o.0
    }
    #[inline(always)]
    fn min(self, o: I32x1) -> I32x1 {
        I32x1(self.0.min(o.0))
    }
    #[inline(always)]
    fn max(self, o: I32x1) -> I32x1 {
        I32x1(self.0.max(o.0))
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self.0 as f32
    }
    #[inline(always)]
    fn bits_to_f32(self) -> f32 {
        f32::from_bits(self.0 as u32)
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> I32x1 {
        I32x1(((self.0 as u32) >> n) as i32)
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        out[0] = self.0;
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        assert!(i == 0, "lane {i} of a 1-lane packet");
        self.0
    }
}
