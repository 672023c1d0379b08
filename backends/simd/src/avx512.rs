//! The `avx512` backend: 16 lanes of hand-written AVX-512 F/BW/CD/DQ/VL intrinsics (`core::arch`), chosen at
//! run time (paper section 3's packets, at 16 rays).
//!
//! pulp supplies only the run-time detection (`V4::try_new`), the zero-sized proof token and
//! the `#[target_feature]` entry point (`V4::vectorize`) that [`crate::dispatch`] runs kernels
//! through; every operation below is written with `core::arch` intrinsics (the portable pulp
//! backends, `pulp8`/`pulp16` in [`crate::pulp`], use pulp's own operations instead). The lane
//! types can only be made through a [`Avx512`] token, which can only be made from a pulp token,
//! so a lane value is itself proof that the CPU has AVX-512 F/BW/CD/DQ/VL: that is the safety argument of
//! every `unsafe` intrinsic call in this file. Every operation is `#[inline(always)]` so that
//! it is compiled inside the kernel's `#[target_feature]` function; a call that is not inlined
//! loses the features (and costs far more than the operation).

use core::arch::x86_64::*;
use core::fmt;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use pulp::x86::V4;

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};
use crate::x86::gather_check;

/// 16 lanes of hand-written AVX-512 (`__mmask16` masks), on pulp's `V4` token.
#[derive(Clone, Copy, Debug)]
pub struct Avx512(V4);

impl Avx512 {
    /// The token, if this CPU has AVX-512 F/BW/CD/DQ/VL.
    #[inline]
    pub fn try_new() -> Option<Avx512> {
        V4::try_new().map(Avx512)
    }
    /// The pulp token this backend runs on.
    #[inline(always)]
    pub fn simd(self) -> V4 {
        self.0
    }
}

/// Sixteen `f32` lanes (AVX-512F).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x16(__m512);
/// Sixteen `i32` lanes (AVX-512F).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x16(__m512i);
/// Sixteen mask lanes in an AVX-512 mask register.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M16(__mmask16);

impl F32x16 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [f32; 16] {
        let mut a = [0.0; 16];
        self.store(&mut a);
        a
    }
    #[inline(always)]
    fn has_fraction(self) -> __mmask16 {
        unsafe {
            _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(self.0), _mm512_set1_ps(8388608.0))
        }
    }
}
impl I32x16 {
    /// The lanes as an array.
    #[inline(always)]
    pub fn to_array(self) -> [i32; 16] {
        let mut a = [0; 16];
        self.store(&mut a);
        a
    }
}
impl fmt::Debug for F32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x16{:?}", self.to_array())
    }
}
impl fmt::Debug for I32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x16{:?}", self.to_array())
    }
}
impl fmt::Debug for M16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M16({:016b})", self.0)
    }
}

impl Lanes for Avx512 {
    const N: usize = 16;
    type F32s = F32x16;
    type I32s = I32x16;
    type Mask = M16;

    #[inline(always)]
    fn splat(self, x: f32) -> F32x16 {
        F32x16(unsafe { _mm512_set1_ps(x) })
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> I32x16 {
        I32x16(unsafe { _mm512_set1_epi32(x) })
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> M16 {
        M16(if b { 0xffff } else { 0 })
    }
    #[inline(always)]
    fn apart<R>(self, f: impl FnOnce(Self) -> R) -> R {
        // Out of line, then inside the token's `#[target_feature]` entry point.
        #[inline(never)]
        fn go<R, F: FnOnce(Avx512) -> R>(l: Avx512, f: F) -> R {
            l.simd().vectorize(
                #[inline(always)]
                move || f(l),
            )
        }
        go(self, f)
    }

    #[inline(always)]
    fn lane_ids(self) -> I32x16 {
        I32x16(unsafe { _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) })
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> F32x16 {
        let s = &s[..16];
        F32x16(unsafe { _mm512_loadu_ps(s.as_ptr()) })
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> I32x16 {
        let s = &s[..16];
        I32x16(unsafe { _mm512_loadu_si512(s.as_ptr().cast()) })
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> M16 {
        M16(bits as u16)
    }
    #[inline(always)]
    fn gather(self, table: &[f32], idx: I32x16) -> F32x16 {
        let ok = in_range16(idx, table.len());
        if !ok {
            gather_check(ok, &idx.to_array(), table.len());
        }
        // SAFETY: every index was checked to lie in `0..table.len()`.
        F32x16(unsafe { _mm512_i32gather_ps::<4>(idx.0, table.as_ptr()) })
    }
    #[inline(always)]
    fn pick8(self, table: &[f32; 8], first: M16, second: M16, third: M16) -> F32x16 {
        // Each lane's even index `4 first + 2 second` and its odd neighbour, permuted from
        // the table in both halves of a register; only the blend waits for `third`.
        // SAFETY: the token proves AVX-512 F/DQ; `vpermps` reads no memory (each index's
        // low four bits pick a lane, and both halves hold the table).
        unsafe {
            let t = _mm512_broadcast_f32x8(_mm256_loadu_ps(table.as_ptr()));
            let even = _mm512_or_si512(
                _mm512_maskz_set1_epi32(first.0, 4),
                _mm512_maskz_set1_epi32(second.0, 2),
            );
            let odd = _mm512_or_si512(even, _mm512_set1_epi32(1));
            let down = _mm512_permutexvar_ps(even, t);
            let up = _mm512_permutexvar_ps(odd, t);
            F32x16(_mm512_mask_blend_ps(third.0, down, up))
        }
    }
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: I32x16) -> I32x16 {
        let ok = in_range16(idx, table.len());
        if !ok {
            gather_check(ok, &idx.to_array(), table.len());
        }
        // SAFETY: every index was checked to lie in `0..table.len()`.
        I32x16(unsafe { _mm512_i32gather_epi32::<4>(idx.0, table.as_ptr().cast()) })
    }
    #[inline(always)]
    fn gather2(self, table: &[f32], idx: I32x16) -> (F32x16, F32x16) {
        let n = table.len().saturating_sub(1);
        let ok = in_range16(idx, n);
        if !ok {
            gather_check(ok, &idx.to_array(), n);
        }
        // SAFETY: every `idx + 1` was checked to lie inside `table`; each 64-bit element is
        // the pair (table[i], table[i + 1]), read unaligned at 4-byte scale.
        unsafe {
            let base = table.as_ptr() as *const i64;
            let q0 = _mm512_castsi512_ps(_mm512_i32gather_epi64::<4>(
                _mm512_castsi512_si256(idx.0),
                base,
            ));
            let q1 = _mm512_castsi512_ps(_mm512_i32gather_epi64::<4>(
                _mm512_extracti64x4_epi64::<1>(idx.0),
                base,
            ));
            let evens =
                _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
            let odds = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
            (
                F32x16(_mm512_permutex2var_ps(q0, evens, q1)),
                F32x16(_mm512_permutex2var_ps(q0, odds, q1)),
            )
        }
    }
    #[inline(always)]
    fn gather_near(self, table: &[f32], idx: I32x16) -> F32x16 {
        match window16(idx, table.len(), 1) {
            // SAFETY: `window16` checked that the window's values from `at` it reads lie in
            // `table` and that every offset lies among them.
            Some((at, d)) => unsafe {
                let p = table.as_ptr().add(at);
                F32x16(lookup32(p, table.len() - at, d))
            },
            None => self.gather(table, idx),
        }
    }
    #[inline(always)]
    fn gather2_near(self, table: &[f32], idx: I32x16) -> (F32x16, F32x16) {
        match window16(idx, table.len(), 2) {
            // SAFETY: `window16` checked that the window's values from `at` it reads lie in
            // `table` and that every offset + 1 lies among them.
            Some((at, d)) => unsafe {
                let p = table.as_ptr().add(at);
                let len = table.len() - at;
                let d1 = _mm512_add_epi32(d, _mm512_set1_epi32(1));
                (F32x16(lookup32(p, len, d)), F32x16(lookup32(p, len, d1)))
            },
            None => self.gather2(table, idx),
        }
    }
}

/// Values `gather2_near` reads at once: two registers, picked from by `vpermt2ps`.
const WINDOW16: usize = 32;

/// The test of [`Lanes::gather2_near`]: whether the lanes' pairs lie in a window of
/// [`WINDOW16`] values (or in the whole table, when it is shorter), which two loads and one
/// two-register permute read, where the hardware gather reads lane by lane. In a
/// micro-benchmark on the Zen 4 of our results (a table of 1,025 values, in L1), a 16-lane
/// `gather2` (a `vpgatherdq` pair) took 4-7 ns and the window 1 ns; in the `kernels`
/// experiment the paper's exp went from 5.1-6.6x to 7.2-7.4x over scalar (three interleaved
/// runs of each build). Taken for every gather, the test's cost where the window misses
/// (log's table indexed by the mantissa, textures, the BDF's corners) made those kernels
/// 6-20% slower, so only lookups that expect close lanes or short tables ask for it. The
/// `avx2` backend keeps the hardware gather: its 8-lane gathers are cheap, and the same
/// window there (four permutes and three blends per lookup, in AVX2's 16 registers) made the
/// exp kernel 1.6-1.9x slower.
///
/// The window starts at the smallest index, moved back to end at the table's end (at 0 in a
/// table shorter than the window). Returns its start and every lane's offset into it when
/// every lane's `span` values (1: the offset; 2: the pair offset, offset + 1) lie inside both
/// the window and the table; `None` sends the lookup to the hardware gather (with its range
/// check), so the result is the same either way. [`Lanes::gather_near`] asks for the same
/// window with `span` 1.
#[inline(always)]
fn window16(idx: I32x16, len: usize, span: usize) -> Option<(usize, __m512i)> {
    // The largest offset whose `span` values are inside the window, or the table.
    let (at, reach) = if len >= WINDOW16 {
        let end = (len - WINDOW16).min(i32::MAX as usize) as i32;
        // SAFETY: the lane type proves AVX-512 F.
        (
            unsafe { _mm512_reduce_min_epi32(idx.0) }.min(end),
            WINDOW16 - span,
        )
    } else if len >= span {
        (0, len - span)
    } else {
        return None;
    };
    unsafe {
        let d = _mm512_sub_epi32(idx.0, _mm512_set1_epi32(at));
        // Unsigned: an index below the window's start gives a huge offset.
        let all = _mm512_cmple_epu32_mask(d, _mm512_set1_epi32(reach as i32)) == 0xffff;
        (all && at >= 0).then_some((at as usize, d))
    }
}

/// `p[d[i]]` per lane for offsets `d` in `0..32` and below `len`: the first 32 values from
/// `p` (fewer when `len` is smaller: the loads are masked to the first `len`, and masked-off
/// elements are never read) picked by `vpermt2ps`.
///
/// # Safety
/// `p` must be valid for reading `len.min(32)` values.
#[inline(always)]
unsafe fn lookup32(p: *const f32, len: usize, d: __m512i) -> __m512 {
    unsafe {
        if len >= WINDOW16 {
            _mm512_permutex2var_ps(_mm512_loadu_ps(p), d, _mm512_loadu_ps(p.add(16)))
        } else {
            let bits = |n: usize| ((1u32 << n.min(16)) - 1) as __mmask16;
            let lo = _mm512_maskz_loadu_ps(bits(len), p);
            let hi = _mm512_maskz_loadu_ps(bits(len.saturating_sub(16)), p.add(16));
            _mm512_permutex2var_ps(lo, d, hi)
        }
    }
}

#[inline(always)]
fn in_range16(idx: I32x16, len: usize) -> bool {
    let len = len.min(i32::MAX as usize) as u32;
    // Unsigned compare: negative indices become huge.
    unsafe { _mm512_cmplt_epu32_mask(idx.0, _mm512_set1_epi32(len as i32)) == 0xffff }
}

macro_rules! f32x16_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident $intr:ident),*) => {$(
        impl $tr for F32x16 {
            type Output = F32x16;
            #[inline(always)]
            fn $f(self, o: F32x16) -> F32x16 {
                F32x16(unsafe { $intr(self.0, o.0) })
            }
        }
        impl $tr<f32> for F32x16 {
            type Output = F32x16;
            #[inline(always)]
            fn $f(self, o: f32) -> F32x16 {
                F32x16(unsafe { $intr(self.0, _mm512_set1_ps(o)) })
            }
        }
        impl $atr for F32x16 {
            #[inline(always)]
            fn $af(&mut self, o: F32x16) {
                self.0 = unsafe { $intr(self.0, o.0) };
            }
        }
    )*};
}
f32x16_ops!(
    Add add AddAssign add_assign _mm512_add_ps,
    Sub sub SubAssign sub_assign _mm512_sub_ps,
    Mul mul MulAssign mul_assign _mm512_mul_ps,
    Div div DivAssign div_assign _mm512_div_ps
);
impl Neg for F32x16 {
    type Output = F32x16;
    #[inline(always)]
    fn neg(self) -> F32x16 {
        unsafe {
            F32x16(_mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(self.0),
                _mm512_set1_epi32(i32::MIN),
            )))
        }
    }
}

macro_rules! cmp16 {
    ($a:expr, $b:expr, $imm:ident) => {
        M16(unsafe { _mm512_cmp_ps_mask::<$imm>($a, $b) })
    };
}

impl SimdF32 for F32x16 {
    type Mask = M16;
    type I32s = I32x16;

    #[inline(always)]
    fn lt(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_LT_OQ)
    }
    #[inline(always)]
    fn le(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_LE_OQ)
    }
    #[inline(always)]
    fn gt(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_GT_OQ)
    }
    #[inline(always)]
    fn ge(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_GE_OQ)
    }
    #[inline(always)]
    fn eq(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_EQ_OQ)
    }
    #[inline(always)]
    fn ne(self, o: F32x16) -> M16 {
        cmp16!(self.0, o.0, _CMP_NEQ_UQ)
    }
    #[inline(always)]
    fn min(self, o: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn abs(self) -> F32x16 {
        F32x16(unsafe { _mm512_abs_ps(self.0) })
    }
    #[inline(always)]
    fn sqrt(self) -> F32x16 {
        F32x16(unsafe { _mm512_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn rsqrt(self) -> F32x16 {
        F32x16(unsafe { _mm512_rsqrt14_ps(self.0) })
    }
    #[inline(always)]
    fn recip(self) -> F32x16 {
        F32x16(unsafe { _mm512_rcp14_ps(self.0) })
    }
    #[inline(always)]
    fn floor(self) -> F32x16 {
        unsafe {
            let r = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(self.0);
            F32x16(_mm512_mask_blend_ps(self.has_fraction(), self.0, r))
        }
    }
    #[inline(always)]
    fn round(self) -> F32x16 {
        unsafe {
            let r =
                _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(self.0);
            F32x16(_mm512_mask_blend_ps(self.has_fraction(), self.0, r))
        }
    }
    #[inline(always)]
    fn mul_add(self, b: F32x16, c: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_fmadd_ps(self.0, b.0, c.0) })
    }
    #[inline(always)]
    fn to_i32(self) -> I32x16 {
        I32x16(unsafe { _mm512_cvttps_epi32(self.0) })
    }
    #[inline(always)]
    fn to_bits(self) -> I32x16 {
        I32x16(unsafe { _mm512_castps_si512(self.0) })
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        let out = &mut out[..16];
        unsafe { _mm512_storeu_ps(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn store_masked(self, m: M16, out: &mut [f32]) {
        let out = &mut out[..16];
        unsafe { _mm512_mask_storeu_ps(out.as_mut_ptr(), m.0, self.0) }
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

impl SimdMask for M16 {
    type F32s = F32x16;
    type I32s = I32x16;

    #[inline(always)]
    fn select(self, t: F32x16, f: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_mask_blend_ps(self.0, f.0, t.0) })
    }
    #[inline(always)]
    fn select_i32(self, t: I32x16, f: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_mask_blend_epi32(self.0, f.0, t.0) })
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.0 != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.0 == 0xffff
    }
    #[inline(always)]
    fn none(self) -> bool {
        self.0 == 0
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self.0 as u32
    }
    #[inline(always)]
    fn and_not(self, o: M16) -> M16 {
        M16(self.0 & !o.0)
    }
}
impl BitAnd for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitand(self, o: M16) -> M16 {
        M16(self.0 & o.0)
    }
}
impl BitOr for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitor(self, o: M16) -> M16 {
        M16(self.0 | o.0)
    }
}
impl BitXor for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitxor(self, o: M16) -> M16 {
        M16(self.0 ^ o.0)
    }
}
impl Not for M16 {
    type Output = M16;
    #[inline(always)]
    fn not(self) -> M16 {
        M16(!self.0)
    }
}
impl BitAndAssign for M16 {
    #[inline(always)]
    fn bitand_assign(&mut self, o: M16) {
        self.0 &= o.0;
    }
}
impl BitOrAssign for M16 {
    #[inline(always)]
    fn bitor_assign(&mut self, o: M16) {
        self.0 |= o.0;
    }
}

macro_rules! i32x16_ops {
    ($($tr:ident $f:ident $intr:ident),*) => {$(
        impl $tr for I32x16 {
            type Output = I32x16;
            #[inline(always)]
            fn $f(self, o: I32x16) -> I32x16 {
                I32x16(unsafe { $intr(self.0, o.0) })
            }
        }
    )*};
}
i32x16_ops!(Add add _mm512_add_epi32, Sub sub _mm512_sub_epi32, Mul mul _mm512_mullo_epi32,
    BitAnd bitand _mm512_and_si512, BitOr bitor _mm512_or_si512, BitXor bitxor _mm512_xor_si512);
impl Not for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn not(self) -> I32x16 {
        I32x16(unsafe { _mm512_xor_si512(self.0, _mm512_set1_epi32(-1)) })
    }
}
impl Shl<u32> for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn shl(self, n: u32) -> I32x16 {
        I32x16(unsafe { _mm512_sll_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
}
impl Shr<u32> for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn shr(self, n: u32) -> I32x16 {
        I32x16(unsafe { _mm512_sra_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
}

impl SimdI32 for I32x16 {
    type Mask = M16;
    type F32s = F32x16;

    #[inline(always)]
    fn splat_same(self, x: i32) -> I32x16 {
        I32x16(unsafe { _mm512_set1_epi32(x) })
    }
    #[inline(always)]
    fn eq(self, o: I32x16) -> M16 {
        M16(unsafe { _mm512_cmpeq_epi32_mask(self.0, o.0) })
    }
    #[inline(always)]
    fn lt(self, o: I32x16) -> M16 {
        M16(unsafe { _mm512_cmplt_epi32_mask(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: I32x16) -> M16 {
        M16(unsafe { _mm512_cmpgt_epi32_mask(self.0, o.0) })
    }
    #[inline(always)]
    fn min(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_min_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_max_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn to_f32(self) -> F32x16 {
        F32x16(unsafe { _mm512_cvtepi32_ps(self.0) })
    }
    #[inline(always)]
    fn bits_to_f32(self) -> F32x16 {
        F32x16(unsafe { _mm512_castsi512_ps(self.0) })
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> I32x16 {
        I32x16(unsafe { _mm512_srl_epi32(self.0, _mm_cvtsi32_si128(n as i32)) })
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        let out = &mut out[..16];
        unsafe { _mm512_storeu_si512(out.as_mut_ptr().cast(), self.0) }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.to_array()[i]
    }
}
