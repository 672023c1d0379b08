//! The SSE backend: 4 lanes in hand-written `core::arch::x86_64` SSE/SSE2 intrinsics, as the
//! paper's packets were (section 3). Masks are `__m128` with all-ones lanes and selects are
//! `and`/`andnot`/`or`, as in the paper. SSE2 is part of x86-64, so this backend is always
//! usable where it compiles. Only SSE2 is assumed: `floor`/`round` and integer
//! `mul`/`min`/`max`, which need SSE4.1 instructions, are built from SSE2 ones.
//!
//! `round` and `floor` assume the default MXCSR rounding mode (to nearest).

use core::arch::x86_64::*;
use core::fmt;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};
use crate::scalar::gather_index;

// SAFETY (for every `unsafe` block below): the intrinsics need only SSE and SSE2, which
// every x86-64 CPU has; loads and stores go through slices whose length is checked first.

/// The 4-lane SSE token (zero-sized; SSE2 is always present on x86-64).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sse;

/// Four `f32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x4(__m128);
/// Four `i32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x4(__m128i);
/// Four mask lanes (all-ones or all-zeros `f32` bit patterns): the paper's `QBool`.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M32x4(__m128);

impl Lanes for Sse {
    const N: usize = 4;
    type F32s = F32x4;
    type I32s = I32x4;
    type Mask = M32x4;

    #[inline(always)]
    fn splat(self, x: f32) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_set1_ps(x)) }
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_set1_epi32(x)) }
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_castsi128_ps(_mm_set1_epi32(-(b as i32)))) }
    }
    #[inline(always)]
    fn lane_ids(self) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_setr_epi32(0, 1, 2, 3)) }
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let s = &s[..4];
            F32x4(_mm_loadu_ps(s.as_ptr()))
        }
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let s = &s[..4];
            I32x4(_mm_loadu_si128(s.as_ptr().cast()))
        }
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let lanes = _mm_setr_epi32(1, 2, 4, 8);
            let b = _mm_and_si128(_mm_set1_epi32(bits as i32), lanes);
            M32x4(_mm_castsi128_ps(_mm_cmpeq_epi32(b, lanes)))
        }
    }
    #[inline(always)]
    fn gather(self, table: &[f32], idx: I32x4) -> F32x4 {
        let i = idx.to_array();
        let v = [
            table[gather_index(i[0], table.len())],
            table[gather_index(i[1], table.len())],
            table[gather_index(i[2], table.len())],
            table[gather_index(i[3], table.len())],
        ];
        self.load(&v)
    }
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: I32x4) -> I32x4 {
        let i = idx.to_array();
        let v = [
            table[gather_index(i[0], table.len())] as i32,
            table[gather_index(i[1], table.len())] as i32,
            table[gather_index(i[2], table.len())] as i32,
            table[gather_index(i[3], table.len())] as i32,
        ];
        self.load_i32(&v)
    }
    #[inline(always)]
    fn gather2(self, table: &[f32], idx: I32x4) -> (F32x4, F32x4) {
        // One 64-bit load per lane: (table[i], table[i + 1]).
        let i = idx.to_array();
        let n = table.len().saturating_sub(1);
        let pair = |k: i32| {
            let k = gather_index(k, n);
            // SAFETY: reads the two floats of a checked subslice.
            unsafe { _mm_castpd_ps(_mm_load_sd(table[k..k + 2].as_ptr().cast())) }
        };
        unsafe {
            let ab = _mm_movelh_ps(pair(i[0]), pair(i[1])); // a0 a1 b0 b1
            let cd = _mm_movelh_ps(pair(i[2]), pair(i[3])); // c0 c1 d0 d1
            (
                F32x4(_mm_shuffle_ps::<0b10_00_10_00>(ab, cd)),
                F32x4(_mm_shuffle_ps::<0b11_01_11_01>(ab, cd)),
            )
        }
    }
}

impl F32x4 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [f32; 4] {
        let mut a = [0.0; 4];
        self.store(&mut a);
        a
    }
    #[inline(always)]
    fn sign_bit() -> __m128 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_set1_ps(-0.0) }
    }
    /// True where `|x| < 2^23`: values with a fractional part (false for NaN and inf).
    #[inline(always)]
    fn has_fraction(self) -> __m128 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            _mm_cmplt_ps(
                _mm_andnot_ps(Self::sign_bit(), self.0),
                _mm_set1_ps(8388608.0),
            )
        }
    }
    #[inline(always)]
    fn copysign_of(r: __m128, x: __m128) -> __m128 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let s = Self::sign_bit();
            _mm_or_ps(_mm_andnot_ps(s, r), _mm_and_ps(s, x))
        }
    }
    #[inline(always)]
    fn blend(m: __m128, t: __m128, f: __m128) -> __m128 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_or_ps(_mm_and_ps(m, t), _mm_andnot_ps(m, f)) }
    }
}

impl I32x4 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [i32; 4] {
        let mut a = [0; 4];
        self.store(&mut a);
        a
    }
}

impl fmt::Debug for F32x4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x4{:?}", self.to_array())
    }
}
impl fmt::Debug for I32x4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x4{:?}", self.to_array())
    }
}
impl fmt::Debug for M32x4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M32x4({:04b})", self.bitmask())
    }
}

macro_rules! f32_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident $intr:ident),*) => {$(
        impl $tr for F32x4 {
            type Output = F32x4;
            #[inline(always)]
            fn $f(self, o: F32x4) -> F32x4 {
                F32x4(unsafe { $intr(self.0, o.0) })
            }
        }
        impl $tr<f32> for F32x4 {
            type Output = F32x4;
            #[inline(always)]
            fn $f(self, o: f32) -> F32x4 {
                F32x4(unsafe { $intr(self.0, _mm_set1_ps(o)) })
            }
        }
        impl $atr for F32x4 {
            #[inline(always)]
            fn $af(&mut self, o: F32x4) {
                self.0 = unsafe { $intr(self.0, o.0) };
            }
        }
    )*};
}
f32_ops!(
    Add add AddAssign add_assign _mm_add_ps,
    Sub sub SubAssign sub_assign _mm_sub_ps,
    Mul mul MulAssign mul_assign _mm_mul_ps,
    Div div DivAssign div_assign _mm_div_ps
);

impl Neg for F32x4 {
    type Output = F32x4;
    #[inline(always)]
    fn neg(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_xor_ps(self.0, Self::sign_bit())) }
    }
}

impl SimdF32 for F32x4 {
    type Mask = M32x4;
    type I32s = I32x4;

    #[inline(always)]
    fn lt(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmplt_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn le(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmple_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn gt(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmpgt_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn ge(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmpge_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn eq(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmpeq_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn ne(self, o: F32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_cmpneq_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn min(self, o: F32x4) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            // minps is exactly `a < b ? a : b`.
            F32x4(_mm_min_ps(self.0, o.0))
        }
    }
    #[inline(always)]
    fn max(self, o: F32x4) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn abs(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_andnot_ps(Self::sign_bit(), self.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn rsqrt(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_rsqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn recip(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_rcp_ps(self.0)) }
    }
    #[inline(always)]
    fn floor(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            // Truncate through i32, step down where that went up, restore the sign of zero.
            let t = _mm_cvtepi32_ps(_mm_cvttps_epi32(self.0));
            let up = _mm_and_ps(_mm_cmpgt_ps(t, self.0), _mm_set1_ps(1.0));
            let r = Self::copysign_of(_mm_sub_ps(t, up), self.0);
            F32x4(Self::blend(self.has_fraction(), r, self.0))
        }
    }
    #[inline(always)]
    fn round(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            // cvtps2dq rounds to nearest even under the default MXCSR.
            let r = Self::copysign_of(_mm_cvtepi32_ps(_mm_cvtps_epi32(self.0)), self.0);
            F32x4(Self::blend(self.has_fraction(), r, self.0))
        }
    }
    #[inline(always)]
    fn mul_add(self, b: F32x4, c: F32x4) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            // SSE has no FMA: two roundings.
            F32x4(_mm_add_ps(_mm_mul_ps(self.0, b.0), c.0))
        }
    }
    #[inline(always)]
    fn to_i32(self) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_cvttps_epi32(self.0)) }
    }
    #[inline(always)]
    fn to_bits(self) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_castps_si128(self.0)) }
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let out = &mut out[..4];
            _mm_storeu_ps(out.as_mut_ptr(), self.0)
        }
    }
    #[inline(always)]
    fn store_masked(self, m: M32x4, out: &mut [f32]) {
        let old = Sse.load(out);
        m.select(self, old).store(out);
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let m = _mm_min_ps(self.0, _mm_shuffle_ps::<0b01_00_11_10>(self.0, self.0));
            let m = _mm_min_ps(m, _mm_shuffle_ps::<0b10_11_00_01>(m, m));
            _mm_cvtss_f32(m)
        }
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let m = _mm_max_ps(self.0, _mm_shuffle_ps::<0b01_00_11_10>(self.0, self.0));
            let m = _mm_max_ps(m, _mm_shuffle_ps::<0b10_11_00_01>(m, m));
            _mm_cvtss_f32(m)
        }
    }
    #[inline(always)]
    fn copysign(self, sign: F32x4) -> F32x4 {
        F32x4(Self::copysign_of(self.0, sign.0))
    }
}

impl SimdMask for M32x4 {
    type F32s = F32x4;
    type I32s = I32x4;

    #[inline(always)]
    fn select(self, t: F32x4, f: F32x4) -> F32x4 {
        F32x4(F32x4::blend(self.0, t.0, f.0))
    }
    #[inline(always)]
    fn select_i32(self, t: I32x4, f: I32x4) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let m = _mm_castps_si128(self.0);
            I32x4(_mm_or_si128(
                _mm_and_si128(m, t.0),
                _mm_andnot_si128(m, f.0),
            ))
        }
    }
    #[inline(always)]
    fn any(self) -> bool {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_movemask_ps(self.0) != 0 }
    }
    #[inline(always)]
    fn all(self) -> bool {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_movemask_ps(self.0) == 0xf }
    }
    #[inline(always)]
    fn none(self) -> bool {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_movemask_ps(self.0) == 0 }
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { _mm_movemask_ps(self.0) as u32 }
    }
    #[inline(always)]
    fn and_not(self, o: M32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_andnot_ps(o.0, self.0)) }
    }
}

macro_rules! mask_ops {
    ($($tr:ident $f:ident $intr:ident),*) => {$(
        impl $tr for M32x4 {
            type Output = M32x4;
            #[inline(always)]
            fn $f(self, o: M32x4) -> M32x4 {
                M32x4(unsafe { $intr(self.0, o.0) })
            }
        }
    )*};
}
mask_ops!(BitAnd bitand _mm_and_ps, BitOr bitor _mm_or_ps, BitXor bitxor _mm_xor_ps);
impl Not for M32x4 {
    type Output = M32x4;
    #[inline(always)]
    fn not(self) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_xor_ps(self.0, _mm_castsi128_ps(_mm_set1_epi32(-1)))) }
    }
}
impl BitAndAssign for M32x4 {
    #[inline(always)]
    fn bitand_assign(&mut self, o: M32x4) {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            self.0 = _mm_and_ps(self.0, o.0);
        }
    }
}
impl BitOrAssign for M32x4 {
    #[inline(always)]
    fn bitor_assign(&mut self, o: M32x4) {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            self.0 = _mm_or_ps(self.0, o.0);
        }
    }
}

macro_rules! i32_ops {
    ($($tr:ident $f:ident $intr:ident),*) => {$(
        impl $tr for I32x4 {
            type Output = I32x4;
            #[inline(always)]
            fn $f(self, o: I32x4) -> I32x4 {
                I32x4(unsafe { $intr(self.0, o.0) })
            }
        }
    )*};
}
i32_ops!(Add add _mm_add_epi32, Sub sub _mm_sub_epi32, BitAnd bitand _mm_and_si128,
    BitOr bitor _mm_or_si128, BitXor bitxor _mm_xor_si128);

impl Mul for I32x4 {
    type Output = I32x4;
    #[inline(always)]
    fn mul(self, o: I32x4) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            // SSE2 has no 32-bit low multiply: multiply even and odd lanes as 64-bit products
            // and interleave their low halves.
            let even = _mm_mul_epu32(self.0, o.0);
            let odd = _mm_mul_epu32(
                _mm_shuffle_epi32::<0b11_11_01_01>(self.0),
                _mm_shuffle_epi32::<0b11_11_01_01>(o.0),
            );
            I32x4(_mm_unpacklo_epi32(
                _mm_shuffle_epi32::<0b00_00_10_00>(even),
                _mm_shuffle_epi32::<0b00_00_10_00>(odd),
            ))
        }
    }
}
impl Not for I32x4 {
    type Output = I32x4;
    #[inline(always)]
    fn not(self) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_xor_si128(self.0, _mm_set1_epi32(-1))) }
    }
}
impl Shl<u32> for I32x4 {
    type Output = I32x4;
    #[inline(always)]
    fn shl(self, n: u32) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_sll_epi32(self.0, _mm_cvtsi32_si128(n as i32))) }
    }
}
impl Shr<u32> for I32x4 {
    type Output = I32x4;
    #[inline(always)]
    fn shr(self, n: u32) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_sra_epi32(self.0, _mm_cvtsi32_si128(n as i32))) }
    }
}

impl SimdI32 for I32x4 {
    type Mask = M32x4;
    type F32s = F32x4;

    #[inline(always)]
    fn splat_same(self, x: i32) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_set1_epi32(x)) }
    }
    #[inline(always)]
    fn eq(self, o: I32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_castsi128_ps(_mm_cmpeq_epi32(self.0, o.0))) }
    }
    #[inline(always)]
    fn lt(self, o: I32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_castsi128_ps(_mm_cmplt_epi32(self.0, o.0))) }
    }
    #[inline(always)]
    fn gt(self, o: I32x4) -> M32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { M32x4(_mm_castsi128_ps(_mm_cmpgt_epi32(self.0, o.0))) }
    }
    #[inline(always)]
    fn min(self, o: I32x4) -> I32x4 {
        self.lt(o).select_i32(self, o)
    }
    #[inline(always)]
    fn max(self, o: I32x4) -> I32x4 {
        self.gt(o).select_i32(self, o)
    }
    #[inline(always)]
    fn to_f32(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_cvtepi32_ps(self.0)) }
    }
    #[inline(always)]
    fn bits_to_f32(self) -> F32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { F32x4(_mm_castsi128_ps(self.0)) }
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> I32x4 {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe { I32x4(_mm_srl_epi32(self.0, _mm_cvtsi32_si128(n as i32))) }
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        // SAFETY: SSE and SSE2 are part of x86-64; pointers are checked above.
        unsafe {
            let out = &mut out[..4];
            _mm_storeu_si128(out.as_mut_ptr().cast(), self.0)
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.to_array()[i]
    }
}
