//! The portable `pulp` backends: one implementation of the lane trait, generic over
//! `S: pulp::Simd`, written only with pulp's portable operations (`add_f32s`, `less_than_f32s`,
//! `select_f32s`, ...; no `core::arch`). [`crate::dispatch`] runs it as `pulp8` on pulp's `V3`
//! (AVX2 + FMA, 8 lanes) and `pulp16` on its `V4` (AVX-512, 16 lanes), and on aarch64 as
//! `pulp4` on its `Neon` (4 lanes), through
//! `Simd::vectorize` and [`pulp::WithSimd`], the entry point `pulp::Arch::dispatch` uses; the
//! same code compiles for any other `Simd` pulp has. Paper section 3's packets at
//! the width the token's registers hold.
//!
//! This is the testbed's answer to "what does portability cost": the hand-written
//! `avx2`/`avx512` backends do the same work with intrinsics.
//!
//! pulp 0.22 has no operation for some of the lane trait; these are written here on top of
//! pulp, portably, and keep the trait's semantics bit for bit (checked by `backends/simd/tests/lanes.rs`).
//! Most go lane by lane through an array with plain Rust (`f32::floor`, `as f32`, `if a < b`):
//! inside the `#[target_feature]` function LLVM compiles such a loop into the one vector
//! instruction the target has (`vroundps`, `vcvtdq2ps`, `vminps`, ...), and on a target without
//! one it is still correct. The hand-built versions of these on pulp's integer operations,
//! used before, made pulp 1.3-2.0x slower than the hand-written backend of its width on exp,
//! log and the BDF; through arrays it is 0.95-1.45x (the `kernels` experiment on Zen 4).
//! - gathers: lane by lane through an array after one vector bounds check (pulp has no
//!   gather). At 8 lanes LLVM keeps the loop as loads and inserts, so this is what
//!   portability costs there (LLVM forms no gather for an AVX2-only target). At 16 lanes
//!   `gather2` reads each pair as one 8-byte word and splits the words, a loop LLVM makes a
//!   64-bit hardware gather of on AVX-512; `gather`/`gather_u32` read their values as halves
//!   of such words too (a loop of 4-byte loads LLVM keeps as sixteen loads and inserts). At 8
//!   lanes the words cost more than the loads they saved;
//! - `floor`/`round`: `f32::floor` / `f32::round_ties_even` through an array, lanes without a
//!   fraction kept as they are;
//! - `i32 -> f32`: `as f32` through an array;
//! - `f32 -> i32` (truncating, out of range to `i32::MIN`): `to_int_unchecked` under the
//!   check `|x| < 2^31` through an array (one compare where a range needs two);
//! - arithmetic `>>`: the logical shift of `x ^ sign` xor `sign`;
//! - `min`/`max`: `if a < b { a } else { b }` through arrays (pulp's `min_f32s` follows the
//!   target's NaN rule, not the trait's);
//! - `rsqrt`/`recip`: exact (`1 / sqrt`, `1 /`; pulp has no estimate instructions);
//! - mask `any`/`all`/`bitmask`: the bits of pulp's mask type where it is a bit per lane
//!   (AVX-512); else (pulp has no movemask) `all` is an and over the mask's 64-bit words,
//!   which LLVM makes one `vptest`, `any` is "not all lanes off" (an or over the lanes became
//!   a chain of lane extractions), and `bitmask` goes lane by lane through an array;
//! - `store_masked`: load, select, store; `reduce_min`/`reduce_max`: lane by lane.
//!
//! Every method is `#[inline(always)]` so that it compiles inside the `#[target_feature]`
//! function `vectorize` runs the kernel in.

use core::fmt;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use pulp::Simd;

use crate::lanes::{Lanes, MAX_LANES, SimdF32, SimdI32, SimdMask};

/// The lane backend on pulp's portable operations for the token `S` (zero-sized: the token
/// proves the CPU has `S`'s instructions).
#[derive(Clone, Copy, Debug)]
pub struct PulpLanes<S: Simd>(S);

impl<S: Simd> PulpLanes<S> {
    /// The backend on a pulp token (which proves the CPU can run `S`).
    #[inline(always)]
    pub fn new(simd: S) -> Self {
        PulpLanes(simd)
    }
    /// The pulp token this backend runs on.
    #[inline(always)]
    pub fn simd(self) -> S {
        self.0
    }
    /// `table[idx[i]]` per lane (the indices already checked, `table.len() >= 2`) as the
    /// upper value of the pair at `idx - 1` (the lower of the pair at 0 where `idx` is 0),
    /// read by [`PulpLanes::words`]. LLVM makes a 64-bit hardware gather of that loop at 16
    /// lanes on AVX-512, while a loop of 4-byte loads stays sixteen loads and inserts: 2.2x
    /// the time of `vgatherdps` on an Intel Xeon host (a scratch program, 2^20 random lookups
    /// in a 256 KiB table: 0.95 -> 0.45-0.46 ms; `avx512` 0.39-0.44 ms).
    #[inline(always)]
    fn gather_by_pairs(self, table: &[f32], idx: PI32<S>) -> PF32<S> {
        let s = self.0;
        let one = s.splat_i32s(1);
        // `idx < table.len()` was checked, so `below + 1 <= max(idx, 1) < table.len()`.
        let below = PI32(s.sub_i32s(s.max_i32s(idx.0, one), one), s).to_array();
        let (lo, hi) = self.split_words(&self.words(table, &below));
        PM32(s.equal_i32s(idx.0, s.splat_i32s(0)), s).select(lo, hi)
    }
    /// The 8-byte words `table[ix[i]..ix[i] + 2]` per lane, unaligned. The caller has checked
    /// that every `ix[i] + 1` lies inside `table`.
    #[inline(always)]
    fn words(self, table: &[f32], ix: &[i32; MAX_LANES]) -> [u64; MAX_LANES] {
        let mut words = [0u64; MAX_LANES];
        for (w, &j) in words.iter_mut().zip(ix).take(Self::N) {
            debug_assert!(j >= 0 && (j as usize) + 1 < table.len());
            // SAFETY: the caller checked `0 <= j` and `j + 1 < table.len()`: both floats of
            // the pair lie in `table`, read as one unaligned 8-byte word.
            *w = unsafe { (table.as_ptr().add(j as usize) as *const u64).read_unaligned() };
        }
        words
    }
    /// Each word's float at the lower address and the one above it.
    #[inline(always)]
    fn split_words(self, words: &[u64; MAX_LANES]) -> (PF32<S>, PF32<S>) {
        let mut lo = [0.0f32; MAX_LANES];
        let mut hi = [0.0f32; MAX_LANES];
        for i in 0..Self::N {
            // the float at the lower address is the word's low half on little-endian targets
            let (a, b) = (words[i] as u32, (words[i] >> 32) as u32);
            let (a, b) = if cfg!(target_endian = "little") {
                (a, b)
            } else {
                (b, a)
            };
            lo[i] = f32::from_bits(a);
            hi[i] = f32::from_bits(b);
        }
        (self.load(&lo), self.load(&hi))
    }
}

/// `pulp8`: the portable backend on `V3` (AVX2 + FMA, 8 lanes).
#[cfg(target_arch = "x86_64")]
pub type Pulp8 = PulpLanes<pulp::x86::V3>;
/// `pulp16`: the portable backend on `V4` (AVX-512, 16 lanes).
#[cfg(target_arch = "x86_64")]
pub type Pulp16 = PulpLanes<pulp::x86::V4>;
/// `pulp4`: the portable backend on `Neon` (aarch64, 4 lanes).
#[cfg(target_arch = "aarch64")]
pub type Pulp4 = PulpLanes<pulp::aarch64::Neon>;

/// Runs a [`crate::Kernel`] with the lanes of whatever token pulp calls it with: the
/// [`pulp::WithSimd`] that `vectorize`/`Arch::dispatch` take.
pub struct WithKernel<K>(pub K);

impl<K: crate::Kernel> pulp::WithSimd for WithKernel<K> {
    type Output = K::Output;
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> K::Output {
        self.0.run(PulpLanes(simd))
    }
}

/// Runs a closure on given lanes inside pulp's entry point ([`Lanes::apart`]).
struct Apart<L, F>(L, F);

impl<S: Simd, R, F: FnOnce(PulpLanes<S>) -> R> pulp::WithSimd for Apart<PulpLanes<S>, F> {
    type Output = R;
    #[inline(always)]
    fn with_simd<S2: Simd>(self, _simd: S2) -> R {
        (self.1)(self.0)
    }
}

/// `f32` lanes.
#[derive(Clone, Copy)]
pub struct PF32<S: Simd>(S::f32s, S);
/// `i32` lanes.
#[derive(Clone, Copy)]
pub struct PI32<S: Simd>(S::i32s, S);
/// Mask lanes.
#[derive(Clone, Copy)]
pub struct PM32<S: Simd>(S::m32s, S);

/// 2^23: at and above it every `f32` is an integer.
const TWO23: f32 = 8_388_608.0;

/// Lane `i` holds `i`.
const IOTA: [i32; MAX_LANES] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];
/// Lane `i` holds `1 << i`.
const LANE_BITS: [i32; MAX_LANES] = [
    1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768,
];

impl<S: Simd> PF32<S> {
    #[inline(always)]
    fn w(&self, v: S::f32s) -> Self {
        PF32(v, self.1)
    }
    #[inline(always)]
    fn splat(&self, x: f32) -> S::f32s {
        self.1.splat_f32s(x)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; MAX_LANES] {
        let mut a = [0.0; MAX_LANES];
        self.store(&mut a);
        a
    }
    /// `f` applied lane by lane through an array.
    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> Self {
        let mut a = self.to_array();
        for x in a.iter_mut().take(S::F32_LANES) {
            *x = f(*x);
        }
        self.w(S::as_simd_f32s(&a[..S::F32_LANES]).0[0])
    }
    /// `f` applied lane by lane to two vectors through arrays.
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        let mut a = self.to_array();
        let b = o.to_array();
        for (x, &y) in a.iter_mut().zip(&b).take(S::F32_LANES) {
            *x = f(*x, y);
        }
        self.w(S::as_simd_f32s(&a[..S::F32_LANES]).0[0])
    }
    /// Lanes below 2^23 in magnitude (not NaN): the ones with a fraction to round.
    #[inline(always)]
    fn has_fraction(self) -> S::m32s {
        let s = self.1;
        s.less_than_f32s(SimdF32::abs(self).0, s.splat_f32s(TWO23))
    }
}
impl<S: Simd> PI32<S> {
    #[inline(always)]
    fn u(self) -> S::u32s {
        self.1.transmute_u32s_i32s(self.0)
    }
    #[inline(always)]
    fn from_u(s: S, v: S::u32s) -> Self {
        PI32(s.transmute_i32s_u32s(v), s)
    }
    #[inline(always)]
    fn to_array(self) -> [i32; MAX_LANES] {
        let mut a = [0; MAX_LANES];
        self.store(&mut a);
        a
    }
    /// The lanes as an array, after checking (one vector compare) that every one lies in
    /// `0..len`; panics naming the first index outside it.
    #[inline(always)]
    fn checked(self, len: usize) -> [i32; MAX_LANES] {
        let s = self.1;
        let len = len.min(i32::MAX as usize) as u32;
        // as u32, a negative index is above every `len`.
        let inside = PM32(s.less_than_u32s(self.u(), s.splat_u32s(len)), s);
        let ix = self.to_array();
        if !inside.all() {
            let bad = ix[..S::I32_LANES]
                .iter()
                .find(|&&i| i < 0 || i as u32 >= len)
                .copied()
                .unwrap_or(-1);
            panic!("gather index {bad} outside a table of {len}");
        }
        ix
    }
    /// Logical right shift by a per-lane amount (below 32).
    #[inline(always)]
    fn shr_dyn(self, n: S::u32s) -> Self {
        Self::from_u(self.1, self.1.wrapping_dyn_shr_u32s(self.u(), n))
    }
}
impl<S: Simd> PM32<S> {
    /// The mask's bits, where pulp's mask type is a bit per lane (AVX-512's `V4`: a `u16`;
    /// its scalar `bool`); `None` where it is a vector of all-ones/zero lanes (`V3`). The
    /// size is known at compile time, so only one arm is compiled.
    #[inline(always)]
    fn bits(self) -> Option<u32> {
        let bytes = bytemuck::bytes_of(&self.0);
        match bytes.len() {
            1 => Some(u32::from(bytes[0])),
            2 => Some(u32::from(u16::from_le_bytes([bytes[0], bytes[1]]))),
            _ => None,
        }
    }
    /// The mask's bytes as 64-bit words (two lanes each), where it is a vector of lanes.
    /// Reductions over these are what LLVM recognises as a vector test; the same fold over
    /// the 32-bit lanes through an array became 15-30 lane extractions and shuffles (`exp`:
    /// pulp8 0.64 and 2.0 ns per value against 0.47).
    #[inline(always)]
    fn words(self) -> impl Iterator<Item = u64> {
        let bytes = bytemuck::bytes_of(&self.0);
        let mut w = [0u64; MAX_LANES / 2];
        for (o, c) in w.iter_mut().zip(bytes.chunks_exact(8)) {
            *o = u64::from_le_bytes(c.try_into().expect("8 bytes"));
        }
        w.into_iter().take(bytes.len() / 8)
    }
    /// The mask as an array of `u32` lanes: all ones where on, 0 where off.
    #[inline(always)]
    fn lanes(self) -> [u32; MAX_LANES] {
        let s = self.1;
        let v = s.select_u32s(self.0, s.splat_u32s(!0), s.splat_u32s(0));
        let mut a = [0u32; MAX_LANES];
        S::as_mut_simd_u32s(&mut a[..S::U32_LANES]).0[0] = v;
        a
    }
}

impl<S: Simd> fmt::Debug for PF32<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PF32{:?}", &self.to_array()[..S::F32_LANES])
    }
}
impl<S: Simd> fmt::Debug for PI32<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PI32{:?}", &self.to_array()[..S::I32_LANES])
    }
}
impl<S: Simd> fmt::Debug for PM32<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PM32({:b})", self.bitmask())
    }
}

impl<S: Simd> Lanes for PulpLanes<S> {
    const N: usize = S::F32_LANES;
    type F32s = PF32<S>;
    type I32s = PI32<S>;
    type Mask = PM32<S>;

    #[inline(always)]
    fn splat(self, x: f32) -> PF32<S> {
        PF32(self.0.splat_f32s(x), self.0)
    }
    #[inline(always)]
    fn splat_i32(self, x: i32) -> PI32<S> {
        PI32(self.0.splat_i32s(x), self.0)
    }
    #[inline(always)]
    fn splat_mask(self, b: bool) -> PM32<S> {
        // A compare, not a transmute: pulp's V4 masks are bit masks (`b16`), not lanes.
        let s = self.0;
        PM32(s.equal_u32s(s.splat_u32s(0), s.splat_u32s(!b as u32)), s)
    }
    #[inline(always)]
    fn apart<R>(self, f: impl FnOnce(Self) -> R) -> R {
        // Out of line, then inside the token's `#[target_feature]` entry point.
        #[inline(never)]
        fn go<S: Simd, R, F: FnOnce(PulpLanes<S>) -> R>(l: PulpLanes<S>, f: F) -> R {
            pulp::Simd::vectorize(l.0, Apart(l, f))
        }
        go(self, f)
    }

    #[inline(always)]
    fn lane_ids(self) -> PI32<S> {
        self.load_i32(&IOTA)
    }
    #[inline(always)]
    fn load(self, s: &[f32]) -> PF32<S> {
        let (v, _) = S::as_simd_f32s(&s[..Self::N]);
        PF32(v[0], self.0)
    }
    #[inline(always)]
    fn load_i32(self, s: &[i32]) -> PI32<S> {
        let (v, _) = S::as_simd_i32s(&s[..Self::N]);
        PI32(v[0], self.0)
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> PM32<S> {
        let s = self.0;
        let lanes = self.load_i32(&LANE_BITS).0;
        let b = s.and_i32s(s.splat_i32s(bits as i32), lanes);
        PM32(s.equal_i32s(b, lanes), s)
    }
    /// Lane by lane through an array (pulp has no gather), after one vector bounds check; at
    /// 16 lanes as halves of 8-byte words (see `PulpLanes::gather_by_pairs`).
    #[inline(always)]
    fn gather(self, table: &[f32], idx: PI32<S>) -> PF32<S> {
        let ix = idx.checked(table.len());
        if Self::N == 16 && table.len() >= 2 {
            return self.gather_by_pairs(table, idx);
        }
        let mut out = [0.0f32; MAX_LANES];
        for (o, &i) in out.iter_mut().zip(&ix).take(Self::N) {
            // SAFETY: `checked` proved every index to lie in `0..table.len()`.
            *o = unsafe { *table.get_unchecked(i as usize) };
        }
        self.load(&out)
    }
    /// As [`Lanes::gather`], by bits (the same words, read as `f32` and moved, never computed
    /// on, so every bit pattern comes back as it was).
    #[inline(always)]
    fn gather_u32(self, table: &[u32], idx: PI32<S>) -> PI32<S> {
        let ix = idx.checked(table.len());
        if Self::N == 16 && table.len() >= 2 {
            let words: &[f32] = bytemuck::cast_slice(table);
            return self.gather_by_pairs(words, idx).to_bits();
        }
        let mut out = [0i32; MAX_LANES];
        for (o, &i) in out.iter_mut().zip(&ix).take(Self::N) {
            // SAFETY: `checked` proved every index to lie in `0..table.len()`.
            *o = unsafe { *table.get_unchecked(i as usize) } as i32;
        }
        self.load_i32(&out)
    }
    /// Lane by lane: both ends of each interval as two loads (fewer than 16 lanes) or as one
    /// 8-byte load split into the two (16 lanes: `exp` 0.43 -> 0.32 ns per value on Zen 4).
    /// Either way the result is the table's values, bit for bit.
    #[inline(always)]
    fn gather2(self, table: &[f32], idx: PI32<S>) -> (PF32<S>, PF32<S>) {
        let ix = idx.checked(table.len().saturating_sub(1));
        if Self::N == 16 {
            // `checked` proved `0 <= idx <= table.len() - 2`. Clamping to that range changes
            // no lane, but it tells LLVM the range, and only then does its SLP vectoriser
            // make the word loop two whole 64-bit hardware gathers wherever the indices come
            // from. Without it, where it could not bound them (log's mantissa-indexed
            // table), it read four of the sixteen words with scalar loads and assembled the
            // vector with some thirty extractions, broadcasts and permutes: pulp16's log on
            // table-part arguments took 2.1x the avx512 time (a scratch program, 2^16
            // arguments in (1e-6, 0.15), median of 31: 48-50 us against 23 us), 1.1x with
            // the clamp (25.5-26.9 us). `gather`'s words are not clamped: there it cost the
            // texture 8% and gained nothing.
            let s = self.0;
            let top = s.splat_i32s((table.len() - 2).min(i32::MAX as usize) as i32);
            let clamped = s.min_i32s(s.max_i32s(idx.0, s.splat_i32s(0)), top);
            return self.split_words(&self.words(table, &PI32(clamped, s).to_array()));
        }
        let mut lo = [0.0f32; MAX_LANES];
        let mut hi = [0.0f32; MAX_LANES];
        for i in 0..Self::N {
            let j = ix[i] as usize;
            // SAFETY: `checked` proved `j + 1 < table.len()`.
            unsafe {
                lo[i] = *table.get_unchecked(j);
                hi[i] = *table.get_unchecked(j + 1);
            }
        }
        (self.load(&lo), self.load(&hi))
    }
}

macro_rules! f32_ops {
    ($($tr:ident $f:ident $atr:ident $af:ident $op:ident),*) => {$(
        impl<S: Simd> $tr for PF32<S> {
            type Output = PF32<S>;
            #[inline(always)]
            fn $f(self, o: PF32<S>) -> PF32<S> {
                self.w(self.1.$op(self.0, o.0))
            }
        }
        impl<S: Simd> $tr<f32> for PF32<S> {
            type Output = PF32<S>;
            #[inline(always)]
            fn $f(self, o: f32) -> PF32<S> {
                self.w(self.1.$op(self.0, self.splat(o)))
            }
        }
        impl<S: Simd> $atr for PF32<S> {
            #[inline(always)]
            fn $af(&mut self, o: PF32<S>) {
                self.0 = self.1.$op(self.0, o.0);
            }
        }
    )*};
}
f32_ops!(
    Add add AddAssign add_assign add_f32s,
    Sub sub SubAssign sub_assign sub_f32s,
    Mul mul MulAssign mul_assign mul_f32s,
    Div div DivAssign div_assign div_f32s
);
impl<S: Simd> Neg for PF32<S> {
    type Output = PF32<S>;
    #[inline(always)]
    fn neg(self) -> PF32<S> {
        self.w(self.1.xor_f32s(self.0, self.splat(-0.0)))
    }
}

impl<S: Simd> SimdF32 for PF32<S> {
    type Mask = PM32<S>;
    type I32s = PI32<S>;

    #[inline(always)]
    fn lt(self, o: Self) -> PM32<S> {
        PM32(self.1.less_than_f32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn le(self, o: Self) -> PM32<S> {
        PM32(self.1.less_than_or_equal_f32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> PM32<S> {
        PM32(self.1.greater_than_f32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> PM32<S> {
        PM32(self.1.greater_than_or_equal_f32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> PM32<S> {
        PM32(self.1.equal_f32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> PM32<S> {
        !self.eq(o)
    }
    /// Lane by lane through arrays: LLVM compiles `if a < b { a } else { b }` into one vector
    /// `min` where the target's has this NaN rule (x86); pulp's compare and select stay two.
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, |a, b| if a < b { a } else { b })
    }
    /// As `min`.
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // Not pulp's `abs_f32s`: a provided trait method marked only `#[inline]`, which
        // LLVM left out of line in the BSP traversal, where (outside the `#[target_feature]`
        // function) each of its operations became a call.
        let magnitude = self.1.splat_u32s(0x7fff_ffff);
        let bits = self.1.transmute_u32s_f32s(self.0);
        self.w(self.1.transmute_f32s_u32s(self.1.and_u32s(bits, magnitude)))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.w(self.1.sqrt_f32s(self.0))
    }
    /// Exact `1 / sqrt` (pulp has no estimate).
    #[inline(always)]
    fn rsqrt(self) -> Self {
        self.w(self.1.div_f32s(self.splat(1.0), self.1.sqrt_f32s(self.0)))
    }
    /// Exact `1 /` (pulp has no estimate).
    #[inline(always)]
    fn recip(self) -> Self {
        self.w(self.1.div_f32s(self.splat(1.0), self.0))
    }
    /// Lane by lane through an array with `f32::floor` (pulp has no rounding); LLVM compiles
    /// the loop into one vector rounding inside the `#[target_feature]` kernel. Lanes without
    /// a fraction (and NaN) are kept as they are, bit for bit.
    #[inline(always)]
    fn floor(self) -> Self {
        let r = self.map(f32::floor);
        self.w(self.1.select_f32s(self.has_fraction(), r.0, self.0))
    }
    /// Lane by lane through an array with `f32::round_ties_even` (as `floor`).
    #[inline(always)]
    fn round(self) -> Self {
        let r = self.map(f32::round_ties_even);
        self.w(self.1.select_f32s(self.has_fraction(), r.0, self.0))
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        self.w(self.1.mul_add_f32s(self.0, b.0, c.0))
    }
    /// Lane by lane through an array (pulp has no conversion): truncation where the value is
    /// in `i32`'s range, `i32::MIN` elsewhere (NaN, infinities), as x86's `cvttps2dq`; LLVM
    /// compiles the loop into the vector conversion and one select. The test is `|x| < 2^31`:
    /// `-2^31`, the one value in range it leaves out, truncates to `i32::MIN` anyway, and one
    /// compare replaces the two of a range (pulp8 / avx2 on `exp_poly`, which reads no table:
    /// 1.24-1.26 -> 1.10-1.14, Intel host). Not the scalar backend's `f32_to_i32_x86`: its
    /// `as i32` keeps LLVM's saturation code in the vector loop, which made pulp8's exp 2.8x
    /// the avx2 time instead of 1.4x.
    #[inline(always)]
    fn to_i32(self) -> PI32<S> {
        let a = self.to_array();
        let mut out = [0i32; MAX_LANES];
        for (o, &x) in out.iter_mut().zip(&a).take(S::F32_LANES) {
            *o = if x.abs() < 2_147_483_648.0 {
                // SAFETY: `x` is finite and truncates to a value inside `i32`'s range.
                unsafe { x.to_int_unchecked::<i32>() }
            } else {
                i32::MIN
            };
        }
        PI32(S::as_simd_i32s(&out[..S::I32_LANES]).0[0], self.1)
    }
    #[inline(always)]
    fn to_bits(self) -> PI32<S> {
        PI32(self.1.transmute_i32s_f32s(self.0), self.1)
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        let (v, _) = S::as_mut_simd_f32s(&mut out[..S::F32_LANES]);
        v[0] = self.0;
    }
    #[inline(always)]
    fn store_masked(self, m: PM32<S>, out: &mut [f32]) {
        let (v, _) = S::as_mut_simd_f32s(&mut out[..S::F32_LANES]);
        v[0] = self.1.select_f32s(m.0, self.0, v[0]);
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        assert!(i < S::F32_LANES, "lane {i} of {}", S::F32_LANES);
        self.to_array()[i]
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        let a = self.to_array();
        let mut m = a[0];
        for &x in &a[1..S::F32_LANES] {
            m = if m < x { m } else { x };
        }
        m
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        let a = self.to_array();
        let mut m = a[0];
        for &x in &a[1..S::F32_LANES] {
            m = if m > x { m } else { x };
        }
        m
    }
}

impl<S: Simd> SimdMask for PM32<S> {
    type F32s = PF32<S>;
    type I32s = PI32<S>;

    #[inline(always)]
    fn select(self, t: PF32<S>, f: PF32<S>) -> PF32<S> {
        PF32(self.1.select_f32s(self.0, t.0, f.0), self.1)
    }
    #[inline(always)]
    fn select_i32(self, t: PI32<S>, f: PI32<S>) -> PI32<S> {
        PI32(self.1.select_i32s(self.0, t.0, f.0), self.1)
    }
    #[inline(always)]
    fn any(self) -> bool {
        match self.bits() {
            Some(bits) => bits != 0,
            // "not every lane off", through `all`: LLVM turns an or over the words back
            // into scalar extractions, an and into one `vptest`
            None => {
                let s = self.1;
                let lanes = s.select_u32s(self.0, s.splat_u32s(!0), s.splat_u32s(0));
                !PM32(s.equal_u32s(lanes, s.splat_u32s(0)), s).all()
            }
        }
    }
    #[inline(always)]
    fn all(self) -> bool {
        match self.bits() {
            Some(bits) => bits == u32::MAX >> (32 - S::F32_LANES),
            // an and over the mask's 64-bit words, which LLVM compiles into one `vptest`
            None => self.words().fold(!0, |a, x| a & x) == !0,
        }
    }
    #[inline(always)]
    fn none(self) -> bool {
        !self.any()
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        match self.bits() {
            Some(bits) => bits,
            None => {
                // each lane's sign shifted to its place: LLVM makes a shift/or reduction of
                // about ten instructions, not one move-mask (the hand-written backends' cost: 1)
                let m = self.lanes();
                let mut bits = 0;
                for (i, &x) in m.iter().enumerate().take(S::F32_LANES) {
                    bits |= u32::from((x as i32) < 0) << i;
                }
                bits
            }
        }
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        self & !o
    }
}

macro_rules! mask_ops {
    ($($tr:ident $f:ident $op:ident),*) => {$(
        impl<S: Simd> $tr for PM32<S> {
            type Output = PM32<S>;
            #[inline(always)]
            fn $f(self, o: PM32<S>) -> PM32<S> {
                PM32(self.1.$op(self.0, o.0), self.1)
            }
        }
    )*};
}
mask_ops!(BitAnd bitand and_m32s, BitOr bitor or_m32s, BitXor bitxor xor_m32s);
impl<S: Simd> Not for PM32<S> {
    type Output = PM32<S>;
    #[inline(always)]
    fn not(self) -> PM32<S> {
        PM32(self.1.not_m32s(self.0), self.1)
    }
}
impl<S: Simd> BitAndAssign for PM32<S> {
    #[inline(always)]
    fn bitand_assign(&mut self, o: PM32<S>) {
        *self = *self & o;
    }
}
impl<S: Simd> BitOrAssign for PM32<S> {
    #[inline(always)]
    fn bitor_assign(&mut self, o: PM32<S>) {
        *self = *self | o;
    }
}

macro_rules! i32_ops {
    ($($tr:ident $f:ident $op:ident),*) => {$(
        impl<S: Simd> $tr for PI32<S> {
            type Output = PI32<S>;
            #[inline(always)]
            fn $f(self, o: PI32<S>) -> PI32<S> {
                PI32(self.1.$op(self.0, o.0), self.1)
            }
        }
    )*};
}
i32_ops!(Add add add_i32s, Sub sub sub_i32s, Mul mul mul_i32s,
    BitAnd bitand and_i32s, BitOr bitor or_i32s, BitXor bitxor xor_i32s);
impl<S: Simd> Not for PI32<S> {
    type Output = PI32<S>;
    #[inline(always)]
    fn not(self) -> PI32<S> {
        PI32(self.1.not_i32s(self.0), self.1)
    }
}
impl<S: Simd> Shl<u32> for PI32<S> {
    type Output = PI32<S>;
    #[inline(always)]
    fn shl(self, n: u32) -> PI32<S> {
        let s = self.1;
        PI32::from_u(s, s.wrapping_dyn_shl_u32s(self.u(), s.splat_u32s(n)))
    }
}
impl<S: Simd> Shr<u32> for PI32<S> {
    type Output = PI32<S>;
    /// Arithmetic: `((x ^ sign) >> n) ^ sign` with logical shifts (pulp has no `sra`).
    #[inline(always)]
    fn shr(self, n: u32) -> PI32<S> {
        let sgn = self.splat_same(0) - self.shr_logical(31);
        ((self ^ sgn).shr_logical(n)) ^ sgn
    }
}

impl<S: Simd> SimdI32 for PI32<S> {
    type Mask = PM32<S>;
    type F32s = PF32<S>;

    #[inline(always)]
    fn splat_same(self, x: i32) -> Self {
        PI32(self.1.splat_i32s(x), self.1)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> PM32<S> {
        PM32(self.1.equal_i32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> PM32<S> {
        PM32(self.1.less_than_i32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> PM32<S> {
        PM32(self.1.greater_than_i32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        PI32(self.1.min_i32s(self.0, o.0), self.1)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        PI32(self.1.max_i32s(self.0, o.0), self.1)
    }
    /// Lane by lane through an array with `as f32` (pulp has no conversion; rounds to nearest
    /// even); LLVM compiles the loop into the vector conversion.
    #[inline(always)]
    fn to_f32(self) -> PF32<S> {
        let a = self.to_array();
        let mut out = [0.0f32; MAX_LANES];
        for (o, &x) in out.iter_mut().zip(&a).take(S::I32_LANES) {
            *o = x as f32;
        }
        PF32(S::as_simd_f32s(&out[..S::F32_LANES]).0[0], self.1)
    }
    #[inline(always)]
    fn bits_to_f32(self) -> PF32<S> {
        PF32(self.1.transmute_f32s_i32s(self.0), self.1)
    }
    #[inline(always)]
    fn shr_logical(self, n: u32) -> Self {
        self.shr_dyn(self.1.splat_u32s(n))
    }
    #[inline(always)]
    fn store(self, out: &mut [i32]) {
        let (v, _) = S::as_mut_simd_i32s(&mut out[..S::I32_LANES]);
        v[0] = self.0;
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        assert!(i < S::I32_LANES, "lane {i} of {}", S::I32_LANES);
        self.to_array()[i]
    }
}
