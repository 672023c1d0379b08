//! The `avx2` backend: 8 lanes of hand-written AVX2 + FMA intrinsics (`core::arch`), chosen at
//! run time (paper section 3's packets, at 8 rays).
//!
//! pulp supplies only the run-time detection (`V3::try_new`), the zero-sized proof token and
//! the `#[target_feature]` entry point (`V3::vectorize`) that [`crate::dispatch`] runs kernels
//! through; every operation below is written with `core::arch` intrinsics (the portable pulp
//! backends, `pulp8`/`pulp16` in [`crate::pulp`], use pulp's own operations instead). The lane
//! types can only be made through a [`Avx2`] token, which can only be made from a pulp token,
//! so a lane value is itself proof that the CPU has AVX2 and FMA: that is the safety argument of
//! every `unsafe` intrinsic call in this file. Every operation is `#[inline(always)]` so that
//! it is compiled inside the kernel's `#[target_feature]` function; a call that is not inlined
//! loses the features (and costs far more than the operation).

use core::arch::x86_64::*;
use core::fmt;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use pulp::x86::V3;

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};
use crate::x86::gather_check;

/// 8 lanes of hand-written AVX2 + FMA, on pulp's `V3` token.
#[derive(Clone, Copy, Debug)]
pub struct Avx2(V3);

impl Avx2 {
    /// The token, if this CPU has AVX2 and FMA.
    #[inline]
    pub fn try_new() -> Option<Avx2> {
        V3::try_new().map(Avx2)
    }
    /// The pulp token this backend runs on.
    #[inline(always)]
    pub fn simd(self) -> V3 {
        self.0
    }
}

/// Eight `f32` lanes (AVX).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x8(__m256);
/// Eight `i32` lanes (AVX2).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x8(__m256i);
/// Eight mask lanes (all-ones `f32` bit patterns).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M32x8(__m256);

impl F32x8 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [f32; 8] {
        let mut a = [0.0; 8];
        self.store(&mut a);
        a
    }
    #[inline(always)]
    fn has_fraction(self) -> __m256 {
        unsafe {
            _mm256_cmp_ps::<_CMP_LT_OQ>(
                _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0),
                _mm256_set1_ps(8388608.0),
            )
        }
    }
}
impl I32x8 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [i32; 8] {
        let mut a = [0; 8];
        self.store(&mut a);
        a
    }
}
impl fmt::Debug for F32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x8{:?}", self.to_array())
    }
}
impl fmt::Debug for I32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x8{:?}", self.to_array())
    }
}
impl fmt::Debug for M32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M32x8({:08b})", self.bitmask())
    }
}

impl Lanes for Avx2 {
    const N: usize = 8;
    type F32s = F32x8;
    type I32s = I32x8;
    type Mask = M32x8;

    #[inline(always)]
    fn splat(self, x: f32) -> F32x8 {
        F32x8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> I32x8 {
        I32x8(unsafe { _mm256_set1_epi32(x) })
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> M32x8 {
        M32x8(unsafe { _mm256_castsi256_ps(_mm256_set1_epi32(-(b as i32))) })
    }
    #[inline(always)]
    fn apart<R>(self, f: impl FnOnce(Self) -> R) -> R {
        // Out of line, then inside the token's `#[target_feature]` entry point.
        #[inline(never)]
        fn go<R, F: FnOnce(Avx2) -> R>(l: Avx2, f: F) -> R {
            l.simd().vectorize(
                #[inline(always)]
                move || f(l),
            )
        }
        go(self, f)
    }

    #[inline(always)]
    fn lane_ids(self) -> I32x8 {
        I32x8(unsafe { _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7) })
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> F32x8 {
        let s = &s[..8];
        F32x8(unsafe { _mm256_loadu_ps(s.as_ptr()) })
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> I32x8 {
        let s = &s[..8];
        I32x8(unsafe { _mm256_loadu_si256(s.as_ptr().cast()) })
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> M32x8 {
        unsafe {
            let lanes = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let b = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lanes);
            M32x8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(b, lanes)))
        }
    }
    #[inline(always)]
    fn gather(self, table: &[f32], idx: I32x8) -> F32x8 {
        let ok = in_range8(idx, table.len());
        if !ok {
            gather_check(ok, &idx.to_array(), table.len());
        }
        // SAFETY: every index was checked to lie in `0..table.len()`.
        F32x8(unsafe { _mm256_i32gather_ps::<4>(table.as_ptr(), idx.0) })
    }
    #[inline(always)]
    fn pick8(self, table: &[f32; 8], first: M32x8, second: M32x8, third: M32x8) -> F32x8 {
        // Each lane's even index `4 first + 2 second` and its odd neighbour, permuted from
        // the table in a register; only the blend waits for `third`.
        // SAFETY: the token proves AVX2; `vpermps` reads no memory (each index's low three
        // bits pick a lane of the loaded table).
        unsafe {
            let t = _mm256_loadu_ps(table.as_ptr());
            let even = _mm256_or_si256(
                _mm256_and_si256(_mm256_castps_si256(first.0), _mm256_set1_epi32(4)),
                _mm256_and_si256(_mm256_castps_si256(second.0), _mm256_set1_epi32(2)),
            );
            let odd = _mm256_or_si256(even, _mm256_set1_epi32(1));
            let down = _mm256_permutevar8x32_ps(t, even);
            let up = _mm256_permutevar8x32_ps(t, odd);
            F32x8(_mm256_blendv_ps(down, up, third.0))
        }
    }
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: I32x8) -> I32x8 {
        let ok = in_range8(idx, table.len());
        if !ok {
            gather_check(ok, &idx.to_array(), table.len());
        }
        // SAFETY: every index was checked to lie in `0..table.len()`.
        I32x8(unsafe { _mm256_i32gather_epi32::<4>(table.as_ptr().cast(), idx.0) })
    }
    #[inline(always)]
    fn gather2(self, table: &[f32], idx: I32x8) -> (F32x8, F32x8) {
        let n = table.len().saturating_sub(1);
        let ok = in_range8(idx, n);
        if !ok {
            gather_check(ok, &idx.to_array(), n);
        }
        // SAFETY: every `idx + 1` was checked to lie inside `table`; each 64-bit element is
        // the pair (table[i], table[i + 1]), read unaligned at 4-byte scale.
        unsafe {
            let base = table.as_ptr() as *const i64;
            let q0 = _mm256_castsi256_ps(_mm256_i32gather_epi64::<4>(
                base,
                _mm256_castsi256_si128(idx.0),
            ));
            let q1 = _mm256_castsi256_ps(_mm256_i32gather_epi64::<4>(
                base,
                _mm256_extracti128_si256::<1>(idx.0),
            ));
            // Per 128-bit half: evens (odds) of q0 then q1; then put the 64-bit chunks in order.
            let lo = _mm256_shuffle_ps::<0b10_00_10_00>(q0, q1);
            let hi = _mm256_shuffle_ps::<0b11_01_11_01>(q0, q1);
            let order = |v: __m256| {
                _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)))
            };
            (F32x8(order(lo)), F32x8(order(hi)))
        }
    }
}

#[inline(always)]
fn in_range8(idx: I32x8, len: usize) -> bool {
    let len = len.min(i32::MAX as usize) as i32;
    unsafe {
        let ge0 = _mm256_cmpgt_epi32(idx.0, _mm256_set1_epi32(-1));
        let ltn = _mm256_cmpgt_epi32(_mm256_set1_epi32(len), idx.0);
        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(ge0, ltn))) == 0xff
    }
}

macro_rules! f32x8_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident $intr:ident),*) => {$(
        impl $tr for F32x8 {
            type Output = F32x8;
            #[inline(always)]
            fn $f(self, o: F32x8) -> F32x8 {
                F32x8(unsafe { $intr(self.0, o.0) })
            }
        }
        impl $tr<f32> for F32x8 {
            type Output = F32x8;
            #[inline(always)]
            fn $f(self, o: f32) -> F32x8 {
                F32x8(unsafe { $intr(self.0, _mm256_set1_ps(o)) })
            }
        }
        impl $atr for F32x8 {
            #[inline(always)]
            fn $af(&mut self, o: F32x8) {
                self.0 = unsafe { $intr(self.0, o.0) };
            }
        }
    )*};
}
f32x8_ops!(
    Add add AddAssign add_assign _mm256_add_ps,
    Sub sub SubAssign sub_assign _mm256_sub_ps,
    Mul mul MulAssign mul_assign _mm256_mul_ps,
    Div div DivAssign div_assign _mm256_div_ps
);
impl Neg for F32x8 {
    type Output = F32x8;
    #[inline(always)]
    fn neg(self) -> F32x8 {
        F32x8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

macro_rules! cmp8 {
    ($a:expr, $b:expr, $imm:ident) => {
        M32x8(unsafe { _mm256_cmp_ps::<$imm>($a, $b) })
    };
}

impl SimdF32 for F32x8 {
    type Mask = M32x8;
    type I32s = I32x8;

    #[inline(always)]
    fn lt(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_LT_OQ)
    }
    #[inline(always)]
    fn le(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_LE_OQ)
    }
    #[inline(always)]
    fn gt(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_GT_OQ)
    }
    #[inline(always)]
    fn ge(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_GE_OQ)
    }
    #[inline(always)]
    fn eq(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_EQ_OQ)
    }
    #[inline(always)]
    fn ne(self, o: F32x8) -> M32x8 {
        cmp8!(self.0, o.0, _CMP_NEQ_UQ)
    }
    #[inline(always)]
    fn min(self, o: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn abs(self) -> F32x8 {
        F32x8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn sqrt(self) -> F32x8 {
        F32x8(unsafe { _mm256_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn rsqrt(self) -> F32x8 {
        F32x8(unsafe { _mm256_rsqrt_ps(self.0) })
    }
    #[inline(always)]
    fn recip(self) -> F32x8 {
        F32x8(unsafe { _mm256_rcp_ps(self.0) })
    }
    #[inline(always)]
    fn floor(self) -> F32x8 {
        // roundps would quiet a signalling NaN; keep non-fractional lanes as they are.
        unsafe {
            let r = _mm256_round_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(self.0);
            F32x8(_mm256_blendv_ps(self.0, r, self.has_fraction()))
        }
    }
    #[inline(always)]
    fn round(self) -> F32x8 {
        unsafe {
            let r = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(self.0);
            F32x8(_mm256_blendv_ps(self.0, r, self.has_fraction()))
        }
    }
    #[inline(always)]
    fn mul_add(self, b: F32x8, c: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_fmadd_ps(self.0, b.0, c.0) })
    }
    #[inline(always)]
    fn to_i32(self) -> I32x8 {
        I32x8(unsafe { _mm256_cvttps_epi32(self.0) })
    }
    #[inline(always)]
    fn to_bits(self) -> I32x8 {
        I32x8(unsafe { _mm256_castps_si256(self.0) })
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        let out = &mut out[..8];
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn store_masked(self, m: M32x8, out: &mut [f32]) {
        let out = &mut out[..8];
        unsafe { _mm256_maskstore_ps(out.as_mut_ptr(), _mm256_castps_si256(m.0), self.0) }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        let a = self.to_array();
        a[1..].iter().fold(a[0], |m, &x| if m < x { m } else { x })
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        let a = self.to_array();
        a[1..].iter().fold(a[0], |m, &x| if m > x { m } else { x })
    }
}

impl SimdMask for M32x8 {
    type F32s = F32x8;
    type I32s = I32x8;

    #[inline(always)]
    fn select(self, t: F32x8, f: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_blendv_ps(f.0, t.0, self.0) })
    }
    #[inline(always)]
    fn select_i32(self, t: I32x8, f: I32x8) -> I32x8 {
        unsafe {
            I32x8(_mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(f.0),
                _mm256_castsi256_ps(t.0),
                self.0,
            )))
        }
    }
    #[inline(always)]
    fn any(self) -> bool {
        unsafe { _mm256_movemask_ps(self.0) != 0 }
    }
    #[inline(always)]
    fn all(self) -> bool {
        unsafe { _mm256_movemask_ps(self.0) == 0xff }
    }
    #[inline(always)]
    fn none(self) -> bool {
        unsafe { _mm256_movemask_ps(self.0) == 0 }
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
    #[inline(always)]
    fn and_not(self, o: M32x8) -> M32x8 {
        M32x8(unsafe { _mm256_andnot_ps(o.0, self.0) })
    }
}

macro_rules! m8_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident $intr:ident),*) => {$(
        impl $tr for M32x8 {
            type Output = M32x8;
            #[inline(always)]
            fn $f(self, o: M32x8) -> M32x8 {
                M32x8(unsafe { $intr(self.0, o.0) })
            }
        }
        impl $atr for M32x8 {
            #[inline(always)]
            fn $af(&mut self, o: M32x8) {
                self.0 = unsafe { $intr(self.0, o.0) };
            }
        }
    )*};
}
m8_ops!(BitAnd bitand BitAndAssign bitand_assign _mm256_and_ps,
    BitOr bitor BitOrAssign bitor_assign _mm256_or_ps);
impl BitXor for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn bitxor(self, o: M32x8) -> M32x8 {
        M32x8(unsafe { _mm256_xor_ps(self.0, o.0) })
    }
}
impl Not for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn not(self) -> M32x8 {
        M32x8(unsafe { _mm256_xor_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) })
    }
}

macro_rules! i32x8_ops {
    ($($tr:ident $f:ident $intr:ident),*) => {$(
        impl $tr for I32x8 {
            type Output = I32x8;
            #[inline(always)]
            fn $f(self, o: I32x8) -> I32x8 {
                I32x8(unsafe { $intr(self.0, o.0) })
            }
        }
    )*};
}
i32x8_ops!(Add add _mm256_add_epi32, Sub sub _mm256_sub_epi32, Mul mul _mm256_mullo_epi32,
    BitAnd bitand _mm256_and_si256, BitOr bitor _mm256_or_si256, BitXor bitxor _mm256_xor_si256);
impl Not for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn not(self) -> I32x8 {
        I32x8(unsafe { _mm256_xor_si256(self.0, _mm256_set1_epi32(-1)) })
    }
}
impl Shl<u32> for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn shl(self, n: u32) -> I32x8 {
        I32x8(unsafe { _mm256_sll_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
}
impl Shr<u32> for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn shr(self, n: u32) -> I32x8 {
        I32x8(unsafe { _mm256_sra_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
}

impl SimdI32 for I32x8 {
    type Mask = M32x8;
    type F32s = F32x8;

    #[inline(always)]
    fn splat_same(self, x: i32) -> I32x8 {
        I32x8(unsafe { _mm256_set1_epi32(x) })
    }
    #[inline(always)]
    fn eq(self, o: I32x8) -> M32x8 {
        M32x8(unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, o.0)) })
    }
    #[inline(always)]
    fn lt(self, o: I32x8) -> M32x8 {
        M32x8(unsafe { _mm256_castsi256_ps(_mm256_cmpgt_epi32(o.0, self.0)) })
    }
    #[inline(always)]
    fn gt(self, o: I32x8) -> M32x8 {
        M32x8(unsafe { _mm256_castsi256_ps(_mm256_cmpgt_epi32(self.0, o.0)) })
    }
    #[inline(always)]
    fn min(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_min_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_max_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn to_f32(self) -> F32x8 {
        F32x8(unsafe { _mm256_cvtepi32_ps(self.0) })
    }
    #[inline(always)]
    fn bits_to_f32(self) -> F32x8 {
        F32x8(unsafe { _mm256_castsi256_ps(self.0) })
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> I32x8 {
        I32x8(unsafe { _mm256_srl_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        let out = &mut out[..8];
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), self.0) }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.to_array()[i]
    }
}
