//! The scalar backend with the SIMD backends' arithmetic: one lane, every operation the
//! scalar backend's except `rsqrt` and `recip`, which use the x86 estimate instructions
//! (`rsqrtss`, `rcpss`: 12 bits, the same tables as the `rsqrtps`/`rcpps` of sse, avx2 and
//! wide) instead of an exact division and square root.
//!
//! It exists to measure one factor of the paper's Table 3 on its own: how much of a SIMD
//! backend's speedup over the scalar one comes from cheaper arithmetic rather than from
//! lanes. It is not one of the swept backends ([`crate::Backend::ALL`]); the command line
//! and `table3` name it (`scalar-est`). x86-64 only: no other target's SIMD backends
//! estimate (pulp's are exact everywhere, and aarch64's estimates have 8 bits, outside the
//! lane trait's bound).

use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};
use crate::scalar::{I32x1, Scalar};

/// One lane with estimated `rsqrt`/`recip`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScalarEst;

/// One `f32` lane of [`ScalarEst`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(transparent)]
pub struct F32e(pub f32);

/// One `i32` lane of [`ScalarEst`] (wrapping, as [`I32x1`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct I32e(pub I32x1);

/// One mask lane of [`ScalarEst`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct Me(pub bool);

impl Lanes for ScalarEst {
    const N: usize = 1;
    type F32s = F32e;
    type I32s = I32e;
    type Mask = Me;

    #[inline(always)]
    fn splat(self, x: f32) -> F32e {
        F32e(x)
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> I32e {
        I32e(I32x1(x))
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> Me {
        Me(b)
    }
    #[inline(always)]
    fn lane_ids(self) -> I32e {
        I32e(I32x1(0))
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> F32e {
        F32e(s[0])
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> I32e {
        I32e(I32x1(s[0]))
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> Me {
        Me(bits & 1 == 1)
    }
    #[inline(always)]
    fn gather(self, table: &[f32], idx: I32e) -> F32e {
        F32e(Scalar.gather(table, idx.0))
    }
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: I32e) -> I32e {
        I32e(Scalar.gather_u32(table, idx.0))
    }
}

macro_rules! f32e_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident),*) => {$(
        impl $tr for F32e {
            type Output = F32e;
            #[inline(always)]
            fn $f(self, o: F32e) -> F32e {
                F32e($tr::$f(self.0, o.0))
            }
        }
        impl $tr<f32> for F32e {
            type Output = F32e;
            #[inline(always)]
            fn $f(self, o: f32) -> F32e {
                F32e($tr::$f(self.0, o))
            }
        }
        impl $atr for F32e {
            #[inline(always)]
            fn $af(&mut self, o: F32e) {
                $atr::$af(&mut self.0, o.0)
            }
        }
    )*};
}
f32e_ops!(Add add AddAssign add_assign, Sub sub SubAssign sub_assign,
    Mul mul MulAssign mul_assign, Div div DivAssign div_assign);

impl Neg for F32e {
    type Output = F32e;
    #[inline(always)]
    fn neg(self) -> F32e {
        F32e(-self.0)
    }
}

macro_rules! wrap_binops {
    ($ty:ident; $($tr:ident $f:ident),*) => {$(
        impl $tr for $ty {
            type Output = $ty;
            #[inline(always)]
            fn $f(self, o: $ty) -> $ty {
                $ty($tr::$f(self.0, o.0))
            }
        }
    )*};
}
wrap_binops!(I32e; Add add, Sub sub, Mul mul, BitAnd bitand, BitOr bitor, BitXor bitxor);
wrap_binops!(Me; BitAnd bitand, BitOr bitor, BitXor bitxor);

impl Not for I32e {
    type Output = I32e;
    #[inline(always)]
    fn not(self) -> I32e {
        I32e(!self.0)
    }
}
impl Shl<u32> for I32e {
    type Output = I32e;
    #[inline(always)]
    fn shl(self, n: u32) -> I32e {
        I32e(self.0 << n)
    }
}
impl Shr<u32> for I32e {
    type Output = I32e;
    #[inline(always)]
    fn shr(self, n: u32) -> I32e {
        I32e(self.0 >> n)
    }
}
impl Not for Me {
    type Output = Me;
    #[inline(always)]
    fn not(self) -> Me {
        Me(!self.0)
    }
}
impl BitAndAssign for Me {
    #[inline(always)]
    fn bitand_assign(&mut self, o: Me) {
        self.0 &= o.0
    }
}
impl BitOrAssign for Me {
    #[inline(always)]
    fn bitor_assign(&mut self, o: Me) {
        self.0 |= o.0
    }
}

impl SimdF32 for F32e {
    type Mask = Me;
    type I32s = I32e;

    #[inline(always)]
    fn lt(self, o: F32e) -> Me {
        Me(self.0 < o.0)
    }
    #[inline(always)]
    fn le(self, o: F32e) -> Me {
        Me(self.0 <= o.0)
    }
    #[inline(always)]
    fn gt(self, o: F32e) -> Me {
        Me(self.0 > o.0)
    }
    #[inline(always)]
    fn ge(self, o: F32e) -> Me {
        Me(self.0 >= o.0)
    }
    #[inline(always)]
    fn eq(self, o: F32e) -> Me {
        Me(self.0 == o.0)
    }
    #[inline(always)]
    fn ne(self, o: F32e) -> Me {
        Me(self.0 != o.0)
    }
    #[inline(always)]
    fn min(self, o: F32e) -> F32e {
        F32e(SimdF32::min(self.0, o.0))
    }
    #[inline(always)]
    fn max(self, o: F32e) -> F32e {
        F32e(SimdF32::max(self.0, o.0))
    }
    #[inline(always)]
    fn abs(self) -> F32e {
        F32e(f32::abs(self.0))
    }
    #[inline(always)]
    fn sqrt(self) -> F32e {
        F32e(f32::sqrt(self.0))
    }
    #[inline(always)]
    fn rsqrt(self) -> F32e {
        F32e(estimate::rsqrt(self.0))
    }
    #[inline(always)]
    fn recip(self) -> F32e {
        F32e(estimate::recip(self.0))
    }
    #[inline(always)]
    fn floor(self) -> F32e {
        F32e(SimdF32::floor(self.0))
    }
    #[inline(always)]
    fn round(self) -> F32e {
        F32e(SimdF32::round(self.0))
    }
    #[inline(always)]
    fn mul_add(self, b: F32e, c: F32e) -> F32e {
        F32e(SimdF32::mul_add(self.0, b.0, c.0))
    }
    #[inline(always)]
    fn to_i32(self) -> I32e {
        I32e(SimdF32::to_i32(self.0))
    }
    #[inline(always)]
    fn to_bits(self) -> I32e {
        I32e(SimdF32::to_bits(self.0))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        out[0] = self.0;
    }
    #[inline(always)]
    fn store_masked(self, m: Me, out: &mut [f32]) {
        if m.0 {
            out[0] = self.0;
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        SimdF32::lane(self.0, i)
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        self.0
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        self.0
    }
    #[inline(always)]
    fn copysign(self, sign: F32e) -> F32e {
        F32e(f32::copysign(self.0, sign.0))
    }
}

impl SimdMask for Me {
    type F32s = F32e;
    type I32s = I32e;

    #[inline(always)]
    fn select(self, t: F32e, f: F32e) -> F32e {
        if self.0 { t } else { f }
    }
    #[inline(always)]
    fn select_i32(self, t: I32e, f: I32e) -> I32e {
        if self.0 { t } else { f }
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.0
    }
    #[inline(always)]
    fn none(self) -> bool {
        !self.0
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self.0 as u32
    }
    #[inline(always)]
    fn and_not(self, o: Me) -> Me {
        Me(self.0 & !o.0)
    }
}

impl SimdI32 for I32e {
    type Mask = Me;
    type F32s = F32e;

    #[inline(always)]
    fn splat_same(self, x: i32) -> I32e {
        I32e(I32x1(x))
    }
    #[inline(always)]
    fn eq(self, o: I32e) -> Me {
        Me(self.0.0 == o.0.0)
    }
    #[inline(always)]
    fn lt(self, o: I32e) -> Me {
        Me(self.0.0 < o.0.0)
    }
    #[inline(always)]
    fn gt(self, o: I32e) -> Me {
        Me(self.0.0 > o.0.0)
    }
    #[inline(always)]
    fn min(self, o: I32e) -> I32e {
        I32e(SimdI32::min(self.0, o.0))
    }
    #[inline(always)]
    fn max(self, o: I32e) -> I32e {
        I32e(SimdI32::max(self.0, o.0))
    }
    #[inline(always)]
    fn to_f32(self) -> F32e {
        F32e(self.0.0 as f32)
    }
    #[inline(always)]
    fn bits_to_f32(self) -> F32e {
        F32e(f32::from_bits(self.0.0 as u32))
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> I32e {
        I32e(self.0.shr_logical(n))
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        out[0] = self.0.0;
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.0.lane(i)
    }
}

/// The estimate instructions, one lane (`_ss`: the other three lanes are don't-care).
mod estimate {
    use core::arch::x86_64::{_mm_cvtss_f32, _mm_rcp_ss, _mm_rsqrt_ss, _mm_set_ss};

    #[inline(always)]
    pub(super) fn rsqrt(x: f32) -> f32 {
        // SAFETY: SSE is part of x86-64.
        unsafe { _mm_cvtss_f32(_mm_rsqrt_ss(_mm_set_ss(x))) }
    }
    #[inline(always)]
    pub(super) fn recip(x: f32) -> f32 {
        // SAFETY: SSE is part of x86-64.
        unsafe { _mm_cvtss_f32(_mm_rcp_ss(_mm_set_ss(x))) }
    }
}
