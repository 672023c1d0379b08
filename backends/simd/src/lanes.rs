//! The lane trait: one SIMD register's worth of values (a *packet*), written once and
//! monomorphised per backend. Masks are the paper's `QBool` (section 3): one all-ones or
//! all-zeros lane per ray, used to block rays that take another path.
//!
//! Semantics are fixed here, not by whatever instruction a backend happens to use, so that
//! every backend gives the scalar backend's answer bit for bit (checked by `backends/simd/tests/lanes.rs`):
//!
//! - `+ - * /`, `sqrt`, comparisons, conversions from `i32`: IEEE 754, round to nearest even.
//! - `min(a, b)` is `if a < b { a } else { b }` and `max(a, b)` is `if a > b { a } else { b }`:
//!   the x86 `minps`/`maxps` rule, so a NaN in either operand gives `b`, and `min(-0, +0)`
//!   gives `+0`.
//! - `abs` clears and `neg` flips the sign bit (NaN payloads kept).
//! - `floor` rounds toward minus infinity, `round` to nearest with ties to even; both keep
//!   the sign of zero, and return NaN/inf/integers above 2^23 unchanged.
//! - `to_i32` truncates toward zero; NaN and values outside the i32 range give `i32::MIN`
//!   (x86's "integer indefinite").
//! - `rsqrt` and `recip` are approximate where the hardware is: relative error at most
//!   [`RSQRT_REL_ERROR`] / [`RECIP_REL_ERROR`] (the scalar backend is exact) for normal
//!   inputs and results; the x86 estimates treat denormal inputs as zero (giving inf) and
//!   flush denormal results to zero.
//! - `mul_add(a, b, c)` is fused on backends with FMA and two roundings elsewhere: either
//!   result is accepted (`backends/simd/tests/lanes.rs` checks it is one of the two).
//! - Integer `+ - *` wrap; `>>` is arithmetic, [`SimdI32::shr_logical`] logical; shift counts
//!   must be below 32.
//! - `reduce_min`/`reduce_max` are exact for non-NaN lanes (the sign of a zero result is
//!   unspecified); with a NaN lane the result is unspecified.

use core::fmt::Debug;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

/// Largest relative error of [`SimdF32::rsqrt`] on any backend (x86 `rsqrtps`: 1.5 * 2^-12).
pub const RSQRT_REL_ERROR: f32 = 1.5 / 4096.0;
/// Largest relative error of [`SimdF32::recip`] on any backend (x86 `rcpps`: 1.5 * 2^-12).
pub const RECIP_REL_ERROR: f32 = 1.5 / 4096.0;

/// A lane backend. The value is a token: for run-time dispatched backends its existence
/// proves that the CPU has the instructions, and every packet value made through it
/// carries that proof. Zero-sized for every backend.
pub trait Lanes: Copy + Debug + Send + Sync + 'static {
    /// Lanes per packet.
    const N: usize;
    /// One `f32` per lane.
    type F32s: SimdF32<Mask = Self::Mask, I32s = Self::I32s>;
    /// One `i32` (or `u32`, by bits) per lane.
    type I32s: SimdI32<Mask = Self::Mask, F32s = Self::F32s>;
    /// One boolean per lane (the paper's `QBool`).
    type Mask: SimdMask<F32s = Self::F32s, I32s = Self::I32s>;

    /// Every lane `x`.
    fn splat(self, x: f32) -> Self::F32s;
    /// Every lane `x`.
    fn splat_i32(self, x: i32) -> Self::I32s;
    /// Every lane `b`.
    fn splat_mask(self, b: bool) -> Self::Mask;
    /// Lane `i` holds `i`.
    fn lane_ids(self) -> Self::I32s;
    /// Lanes from the first `N` values of `s`. Panics if `s` is shorter.
    fn load(self, s: &[f32]) -> Self::F32s;
    /// Lanes from the first `N` values of `s`. Panics if `s` is shorter.
    fn load_i32(self, s: &[i32]) -> Self::I32s;
    /// Lane `i` is on when bit `i` of `bits` is set.
    fn mask_from_bits(self, bits: u32) -> Self::Mask;
    /// `table[idx[i]]` per lane. Panics if any lane's index is outside `table` (clamp first).
    fn gather(self, table: &[f32], idx: Self::I32s) -> Self::F32s;
    /// `table[idx[i]]` per lane, as bits. Panics if any lane's index is outside `table`.
    fn gather_u32(self, table: &[u32], idx: Self::I32s) -> Self::I32s;
    /// `(table[idx[i]], table[idx[i] + 1])` per lane: the two ends of an interpolation
    /// interval. Backends with 64-bit gathers load each pair at once (half the gathered
    /// elements). Panics unless every `idx[i] + 1` lies inside `table`.
    #[inline(always)]
    fn gather2(self, table: &[f32], idx: Self::I32s) -> (Self::F32s, Self::F32s) {
        let lo = self.gather(&table[..table.len().saturating_sub(1)], idx);
        (lo, self.gather(&table[1..], idx))
    }
    /// [`Lanes::gather`] for lookups whose lanes are expected to lie close together or in a
    /// short table, as [`Lanes::gather2_near`]: the same values and the same panics.
    #[inline(always)]
    fn gather_near(self, table: &[f32], idx: Self::I32s) -> Self::F32s {
        self.gather(table, idx)
    }
    /// [`Lanes::gather2`] for lookups whose lanes are expected to lie close together (a
    /// coherent packet's lookups in the table of a smooth function, such as the paper's
    /// `exp`) or in a short table (a tabulated BDF's axis): the same values and the same
    /// panics. Backends whose gathers are slow may read a window of the table around the
    /// lanes' indices when they all fall in it, and gather otherwise (`avx512`: 32 values);
    /// the rest gather.
    #[inline(always)]
    fn gather2_near(self, table: &[f32], idx: Self::I32s) -> (Self::F32s, Self::F32s) {
        self.gather2(table, idx)
    }

    /// `table[i]` per lane, where bit 2 of `i` is `first`, bit 1 is `second` and bit 0 is
    /// `third` (a lane on = 1): one of eight values by three masks, as a step of a binary
    /// search picks the node it probes from the outcomes of the three steps before. Here
    /// by selects, both halves picked by `first` and `second` so that only the last select
    /// waits for `third`; backends with a lane permute (`avx2`, `avx512`) permute instead.
    #[inline(always)]
    fn pick8(
        self,
        table: &[f32; 8],
        first: Self::Mask,
        second: Self::Mask,
        third: Self::Mask,
    ) -> Self::F32s {
        // Written out, no closure: it must inline into the backends' entry points.
        let up = first.select(
            second.select(self.splat(table[7]), self.splat(table[5])),
            second.select(self.splat(table[3]), self.splat(table[1])),
        );
        let down = first.select(
            second.select(self.splat(table[6]), self.splat(table[4])),
            second.select(self.splat(table[2]), self.splat(table[0])),
        );
        third.select(up, down)
    }

    /// `f(self)` in a function of its own, compiled for this backend's instruction set
    /// (inside its `#[target_feature]` entry point, as [`crate::Backend::run`] runs kernels).
    /// For code a kernel runs rarely (per-pixel diagnostics) that must neither be inlined into
    /// the kernel (a kernel is one function, and LLVM optimises a function in time
    /// superlinear in its size) nor be compiled without the backend's instructions (each
    /// vector operation would become a call). The default: a function without target
    /// features, for backends whose instructions are the target's baseline.
    #[inline(always)]
    fn apart<R>(self, f: impl FnOnce(Self) -> R) -> R {
        apart_plain(self, f)
    }

    /// Lanes from a function of the lane index (packing, tests; not for hot loops).
    #[inline(always)]
    #[allow(clippy::wrong_self_convention)] // a token method: the token proves the backend
    fn from_fn(self, mut f: impl FnMut(usize) -> f32) -> Self::F32s {
        let mut buf = [0.0f32; MAX_LANES];
        for (i, v) in buf.iter_mut().enumerate().take(Self::N) {
            *v = f(i);
        }
        self.load(&buf)
    }
    /// Lanes from a function of the lane index (packing, tests; not for hot loops).
    #[inline(always)]
    #[allow(clippy::wrong_self_convention)]
    fn from_fn_i32(self, mut f: impl FnMut(usize) -> i32) -> Self::I32s {
        let mut buf = [0i32; MAX_LANES];
        for (i, v) in buf.iter_mut().enumerate().take(Self::N) {
            *v = f(i);
        }
        self.load_i32(&buf)
    }
    /// Mask from a function of the lane index.
    #[inline(always)]
    fn mask_from_fn(self, mut f: impl FnMut(usize) -> bool) -> Self::Mask {
        let mut bits = 0u32;
        for i in 0..Self::N {
            bits |= (f(i) as u32) << i;
        }
        self.mask_from_bits(bits)
    }
}

/// The widest packet any backend has.
pub const MAX_LANES: usize = 16;

/// One `f32` per lane.
pub trait SimdF32:
    Copy
    + Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
    + Div<f32, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    type Mask: SimdMask<F32s = Self, I32s = Self::I32s>;
    type I32s: SimdI32<Mask = Self::Mask, F32s = Self>;

    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    /// Ordered equality (NaN is never equal).
    fn eq(self, o: Self) -> Self::Mask;
    /// Unordered inequality (NaN is unequal to everything).
    fn ne(self, o: Self) -> Self::Mask;
    /// `if self < o { self } else { o }`.
    fn min(self, o: Self) -> Self;
    /// `if self > o { self } else { o }`.
    fn max(self, o: Self) -> Self;
    fn abs(self) -> Self;
    fn sqrt(self) -> Self;
    /// Approximate `1 / sqrt(self)`, relative error at most [`RSQRT_REL_ERROR`].
    fn rsqrt(self) -> Self;
    /// Approximate `1 / self`, relative error at most [`RECIP_REL_ERROR`].
    fn recip(self) -> Self;
    fn floor(self) -> Self;
    /// To nearest, ties to even.
    fn round(self) -> Self;
    /// `self * b + c`, fused where the backend has FMA.
    fn mul_add(self, b: Self, c: Self) -> Self;
    /// Truncating conversion (NaN and out-of-range give `i32::MIN`).
    fn to_i32(self) -> Self::I32s;
    /// The bits of each lane.
    fn to_bits(self) -> Self::I32s;
    /// Writes the lanes to the first `N` values of `out`. Panics if `out` is shorter.
    fn store(self, out: &mut [f32]);
    /// Writes the lanes whose mask is on; the others keep their value.
    fn store_masked(self, m: Self::Mask, out: &mut [f32]);
    /// Lane `i` (slow: packing and tests).
    fn lane(self, i: usize) -> f32;
    /// Smallest lane.
    fn reduce_min(self) -> f32;
    /// Largest lane.
    fn reduce_max(self) -> f32;

    /// The magnitude of `self` with the sign of `sign`.
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        let m = 0x7fff_ffff_u32 as i32;
        ((self.to_bits() & splat_like(self.to_bits(), m))
            | (sign.to_bits() & splat_like(self.to_bits(), !m)))
        .bits_to_f32()
    }
    /// `self * (1 - t) + o * t`.
    #[inline(always)]
    fn lerp(self, o: Self, t: Self) -> Self {
        (o - self).mul_add(t, self)
    }
    /// Clamp to `[lo, hi]`; NaN gives `lo` (by the `max` rule, `max(NaN, lo) = lo`).
    #[inline(always)]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
    /// NaN lanes.
    #[inline(always)]
    fn is_nan(self) -> Self::Mask {
        self.ne(self)
    }
}

/// A vector of `x` in every lane, shaped like `like` (used by default methods, which have
/// no token at hand; the value `like` proves the backend is usable).
#[inline(always)]
fn splat_like<I: SimdI32>(like: I, x: i32) -> I {
    like.splat_same(x)
}

/// One `i32` per lane; `u32` views by bits.
pub trait SimdI32:
    Copy
    + Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
    + Shl<u32, Output = Self>
    + Shr<u32, Output = Self>
{
    type Mask: SimdMask<F32s = Self::F32s, I32s = Self>;
    type F32s: SimdF32<Mask = Self::Mask, I32s = Self>;

    /// `x` in every lane (of the same backend as `self`).
    fn splat_same(self, x: i32) -> Self;
    fn eq(self, o: Self) -> Self::Mask;
    /// Signed.
    fn lt(self, o: Self) -> Self::Mask;
    /// Signed.
    fn gt(self, o: Self) -> Self::Mask;
    /// Signed.
    fn min(self, o: Self) -> Self;
    /// Signed.
    fn max(self, o: Self) -> Self;
    /// Conversion to the nearest float (ties to even).
    fn to_f32(self) -> Self::F32s;
    /// Reinterprets the bits as `f32`.
    fn bits_to_f32(self) -> Self::F32s;
    /// Logical (unsigned) right shift.
    fn shr_logical(self, n: u32) -> Self;
    /// Writes the lanes to the first `N` values of `out`. Panics if `out` is shorter.
    fn store(self, out: &mut [i32]);
    /// Lane `i` (slow: packing and tests).
    fn lane(self, i: usize) -> i32;
}

/// One boolean per lane: the paper's `QBool`.
pub trait SimdMask:
    Copy
    + Debug
    + Send
    + Sync
    + 'static
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
    + BitAndAssign
    + BitOrAssign
{
    type F32s: SimdF32<Mask = Self, I32s = Self::I32s>;
    type I32s: SimdI32<Mask = Self, F32s = Self::F32s>;

    /// Per lane `if self { t } else { f }`.
    fn select(self, t: Self::F32s, f: Self::F32s) -> Self::F32s;
    /// Per lane `if self { t } else { f }`.
    fn select_i32(self, t: Self::I32s, f: Self::I32s) -> Self::I32s;
    fn any(self) -> bool;
    fn all(self) -> bool;
    fn none(self) -> bool;
    /// Bit `i` set when lane `i` is on.
    fn bitmask(self) -> u32;
    /// Lanes on.
    #[inline(always)]
    fn count(self) -> u32 {
        self.bitmask().count_ones()
    }
    /// Lane `i` (slow: packing and tests).
    #[inline(always)]
    fn lane(self, i: usize) -> bool {
        self.bitmask() >> i & 1 == 1
    }
    /// `self & !o`.
    fn and_not(self, o: Self) -> Self;
}

/// [`Lanes::apart`] for the backends of the target's baseline instructions.
#[inline(never)]
fn apart_plain<L: Lanes, R, F: FnOnce(L) -> R>(l: L, f: F) -> R {
    f(l)
}
