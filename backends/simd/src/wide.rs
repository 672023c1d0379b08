//! The `wide` backends: 4, 8 and 16 lanes on the `wide` crate's `f32x4/8/16` (section 3's
//! packets, wider). `wide` picks its instructions at compile time from the build's target
//! features: without AVX in RUSTFLAGS an `f32x8` is two SSE registers and an `f32x16` four,
//! so record RUSTFLAGS beside every timing (`reproduce` does, in `machine.json`).
//!
//! Where `wide`'s own operation has other semantics than [`crate::lanes`] fixes (its `min`
//! ignores NaN; its `floor` falls back to a scalar loop without SSE4.1) the operation is
//! composed here from `wide` primitives instead.

use core::fmt;
use core::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Mul,
    MulAssign, Neg, Not, Shl, Shr, Sub, SubAssign,
};

use bytemuck::cast;
use wide::{f32x4, f32x8, f32x16, i32x4, i32x8, i32x16};

use crate::lanes::{Lanes, SimdF32, SimdI32, SimdMask};
use crate::scalar::gather_index;

macro_rules! wide_backend {
    ($(#[$doc:meta])* $token:ident, $f:ident, $i:ident, $m:ident, $wf:ident, $wi:ident, $n:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default)]
        pub struct $token;

        #[doc = concat!(stringify!($n), " `f32` lanes on `wide::", stringify!($wf), "`.")]
        #[derive(Clone, Copy)]
        #[repr(transparent)]
        pub struct $f($wf);
        #[doc = concat!(stringify!($n), " `i32` lanes on `wide::", stringify!($wi), "`.")]
        #[derive(Clone, Copy)]
        #[repr(transparent)]
        pub struct $i($wi);
        #[doc = concat!(stringify!($n), " mask lanes (all-ones `f32` bit patterns).")]
        #[derive(Clone, Copy)]
        #[repr(transparent)]
        pub struct $m($wf);

        impl $f {
            /// The lanes as an array.
            #[inline(always)]
            pub fn to_array(self) -> [f32; $n] {
                cast(self.0)
            }
            #[inline(always)]
            fn has_fraction(self) -> $wf {
                self.0.abs().simd_lt($wf::splat(8388608.0))
            }
            #[inline(always)]
            fn copysign_of(r: $wf, x: $wf) -> $wf {
                let s = $wf::splat(-0.0);
                (r & !s) | (x & s)
            }
        }
        impl $i {
            /// The lanes as an array.
            #[inline(always)]
            pub fn to_array(self) -> [i32; $n] {
                cast(self.0)
            }
        }
        impl fmt::Debug for $f {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}{:?}", stringify!($f), self.to_array())
            }
        }
        impl fmt::Debug for $i {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}{:?}", stringify!($i), self.to_array())
            }
        }
        impl fmt::Debug for $m {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}({:0w$b})", stringify!($m), self.bitmask(), w = $n)
            }
        }

        impl Lanes for $token {
            const N: usize = $n;
            type F32s = $f;
            type I32s = $i;
            type Mask = $m;

            #[inline(always)]
            fn splat(self, x: f32) -> $f {
                $f($wf::splat(x))
            }
            #[inline(always)]
            fn splat_i32(self, x: i32) -> $i {
                $i($wi::splat(x))
            }
            #[inline(always)]
            fn splat_mask(self, b: bool) -> $m {
                $m(cast($wi::splat(-(b as i32))))
            }
            #[inline(always)]
            fn lane_ids(self) -> $i {
                let mut a = [0i32; $n];
                for (k, v) in a.iter_mut().enumerate() {
                    *v = k as i32;
                }
                $i(cast(a))
            }
            #[inline(always)]
            fn load(self, s: &[f32]) -> $f {
                let a: [f32; $n] = s[..$n].try_into().unwrap();
                $f(cast(a))
            }
            #[inline(always)]
            fn load_i32(self, s: &[i32]) -> $i {
                let a: [i32; $n] = s[..$n].try_into().unwrap();
                $i(cast(a))
            }
            #[inline(always)]
            fn mask_from_bits(self, bits: u32) -> $m {
                let mut lanes = [0i32; $n];
                for (k, v) in lanes.iter_mut().enumerate() {
                    *v = 1 << k;
                }
                let lanes = $wi::from(lanes);
                $m(cast(($wi::splat(bits as i32) & lanes).simd_eq(lanes)))
            }
            #[inline(always)]
            fn gather(self, table: &[f32], idx: $i) -> $f {
                let i = idx.to_array();
                let mut v = [0.0f32; $n];
                for k in 0..$n {
                    v[k] = table[gather_index(i[k], table.len())];
                }
                $f(cast(v))
            }
            #[inline(always)]
            fn gather_u32(self, table: &[u32], idx: $i) -> $i {
                let i = idx.to_array();
                let mut v = [0i32; $n];
                for k in 0..$n {
                    v[k] = table[gather_index(i[k], table.len())] as i32;
                }
                $i(cast(v))
            }
        }

        impl Add for $f { type Output = $f; #[inline(always)] fn add(self, o: $f) -> $f { $f(self.0 + o.0) } }
        impl Sub for $f { type Output = $f; #[inline(always)] fn sub(self, o: $f) -> $f { $f(self.0 - o.0) } }
        impl Mul for $f { type Output = $f; #[inline(always)] fn mul(self, o: $f) -> $f { $f(self.0 * o.0) } }
        impl Div for $f { type Output = $f; #[inline(always)] fn div(self, o: $f) -> $f { $f(self.0 / o.0) } }
        impl Add<f32> for $f { type Output = $f; #[inline(always)] fn add(self, o: f32) -> $f { $f(self.0 + $wf::splat(o)) } }
        impl Sub<f32> for $f { type Output = $f; #[inline(always)] fn sub(self, o: f32) -> $f { $f(self.0 - $wf::splat(o)) } }
        impl Mul<f32> for $f { type Output = $f; #[inline(always)] fn mul(self, o: f32) -> $f { $f(self.0 * $wf::splat(o)) } }
        impl Div<f32> for $f { type Output = $f; #[inline(always)] fn div(self, o: f32) -> $f { $f(self.0 / $wf::splat(o)) } }
        impl AddAssign for $f { #[inline(always)] fn add_assign(&mut self, o: $f) { self.0 = self.0 + o.0; } }
        impl SubAssign for $f { #[inline(always)] fn sub_assign(&mut self, o: $f) { self.0 = self.0 - o.0; } }
        impl MulAssign for $f { #[inline(always)] fn mul_assign(&mut self, o: $f) { self.0 = self.0 * o.0; } }
        impl DivAssign for $f { #[inline(always)] fn div_assign(&mut self, o: $f) { self.0 = self.0 / o.0; } }
        impl Neg for $f { type Output = $f; #[inline(always)] fn neg(self) -> $f { $f(self.0 ^ $wf::splat(-0.0)) } }

        impl SimdF32 for $f {
            type Mask = $m;
            type I32s = $i;

            #[inline(always)]
            fn lt(self, o: $f) -> $m { $m(self.0.simd_lt(o.0)) }
            #[inline(always)]
            fn le(self, o: $f) -> $m { $m(self.0.simd_le(o.0)) }
            #[inline(always)]
            fn gt(self, o: $f) -> $m { $m(self.0.simd_gt(o.0)) }
            #[inline(always)]
            fn ge(self, o: $f) -> $m { $m(self.0.simd_ge(o.0)) }
            #[inline(always)]
            fn eq(self, o: $f) -> $m { $m(self.0.simd_eq(o.0)) }
            #[inline(always)]
            fn ne(self, o: $f) -> $m { $m(self.0.simd_ne(o.0)) }
            #[inline(always)]
            fn min(self, o: $f) -> $f {
                // `fast_min` is minps (`a < b ? a : b`) on x86; `min` would ignore NaN, and on
                // NEON `fast_min` is fmin, which passes NaN through: the trait's rule by select.
                #[cfg(target_arch = "x86_64")]
                { $f(self.0.fast_min(o.0)) }
                #[cfg(not(target_arch = "x86_64"))]
                { $f(self.0.simd_lt(o.0).bitselect(self.0, o.0)) }
            }
            #[inline(always)]
            fn max(self, o: $f) -> $f {
                #[cfg(target_arch = "x86_64")]
                { $f(self.0.fast_max(o.0)) }
                #[cfg(not(target_arch = "x86_64"))]
                { $f(self.0.simd_gt(o.0).bitselect(self.0, o.0)) }
            }
            #[inline(always)]
            fn abs(self) -> $f { $f(self.0 & !$wf::splat(-0.0)) }
            #[inline(always)]
            fn sqrt(self) -> $f { $f(self.0.sqrt()) }
            #[inline(always)]
            fn rsqrt(self) -> $f { $f(self.0.recip_sqrt()) }
            #[inline(always)]
            fn recip(self) -> $f { $f(self.0.recip()) }
            #[inline(always)]
            fn floor(self) -> $f {
                let t = $wi::round_float(self.0.fast_trunc_int());
                let up = t.simd_gt(self.0) & $wf::splat(1.0);
                let r = Self::copysign_of(t - up, self.0);
                $f(self.has_fraction().bitselect(r, self.0))
            }
            #[inline(always)]
            fn round(self) -> $f {
                let r = Self::copysign_of($wi::round_float(self.0.fast_round_int()), self.0);
                $f(self.has_fraction().bitselect(r, self.0))
            }
            #[inline(always)]
            fn mul_add(self, b: $f, c: $f) -> $f { $f(self.0.mul_add(b.0, c.0)) }
            #[inline(always)]
            fn to_i32(self) -> $i {
                // x86's cvttps gives i32::MIN (integer indefinite) out of range and for NaN;
                // NEON's fcvtzs saturates and gives 0 for NaN: the trait's rule by select.
                #[cfg(target_arch = "x86_64")]
                { $i(self.0.fast_trunc_int()) }
                #[cfg(not(target_arch = "x86_64"))]
                {
                    let inside: $wi = cast(self.abs().0.simd_lt($wf::splat(2_147_483_648.0)));
                    $i(inside.bitselect(self.0.fast_trunc_int(), $wi::splat(i32::MIN)))
                }
            }
            #[inline(always)]
            fn to_bits(self) -> $i { $i(cast(self.0)) }
            #[inline(always)]
            fn store(self, out: &mut [f32]) {
                out[..$n].copy_from_slice(&self.to_array());
            }
            #[inline(always)]
            fn store_masked(self, m: $m, out: &mut [f32]) {
                let old = $token.load(out);
                m.select(self, old).store(out);
            }
            #[inline(always)]
            fn lane(self, i: usize) -> f32 { self.to_array()[i] }
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
            #[inline(always)]
            fn copysign(self, sign: $f) -> $f { $f(Self::copysign_of(self.0, sign.0)) }
        }

        impl SimdMask for $m {
            type F32s = $f;
            type I32s = $i;

            #[inline(always)]
            fn select(self, t: $f, f: $f) -> $f { $f(self.0.bitselect(t.0, f.0)) }
            #[inline(always)]
            fn select_i32(self, t: $i, f: $i) -> $i {
                let m: $wi = cast(self.0);
                $i(m.bitselect(t.0, f.0))
            }
            #[inline(always)]
            fn any(self) -> bool { self.0.any() }
            #[inline(always)]
            fn all(self) -> bool { self.0.all() }
            #[inline(always)]
            fn none(self) -> bool { self.0.none() }
            #[inline(always)]
            fn bitmask(self) -> u32 { self.0.to_bitmask() as u32 }
            #[inline(always)]
            fn and_not(self, o: $m) -> $m { $m(self.0 & !o.0) }
        }
        impl BitAnd for $m { type Output = $m; #[inline(always)] fn bitand(self, o: $m) -> $m { $m(self.0 & o.0) } }
        impl BitOr for $m { type Output = $m; #[inline(always)] fn bitor(self, o: $m) -> $m { $m(self.0 | o.0) } }
        impl BitXor for $m { type Output = $m; #[inline(always)] fn bitxor(self, o: $m) -> $m { $m(self.0 ^ o.0) } }
        impl Not for $m { type Output = $m; #[inline(always)] fn not(self) -> $m { $m(!self.0) } }
        impl BitAndAssign for $m { #[inline(always)] fn bitand_assign(&mut self, o: $m) { self.0 = self.0 & o.0; } }
        impl BitOrAssign for $m { #[inline(always)] fn bitor_assign(&mut self, o: $m) { self.0 = self.0 | o.0; } }

        impl Add for $i { type Output = $i; #[inline(always)] fn add(self, o: $i) -> $i { $i(self.0 + o.0) } }
        impl Sub for $i { type Output = $i; #[inline(always)] fn sub(self, o: $i) -> $i { $i(self.0 - o.0) } }
        impl Mul for $i { type Output = $i; #[inline(always)] fn mul(self, o: $i) -> $i { $i(self.0 * o.0) } }
        impl BitAnd for $i { type Output = $i; #[inline(always)] fn bitand(self, o: $i) -> $i { $i(self.0 & o.0) } }
        impl BitOr for $i { type Output = $i; #[inline(always)] fn bitor(self, o: $i) -> $i { $i(self.0 | o.0) } }
        impl BitXor for $i { type Output = $i; #[inline(always)] fn bitxor(self, o: $i) -> $i { $i(self.0 ^ o.0) } }
        impl Not for $i { type Output = $i; #[inline(always)] fn not(self) -> $i { $i(!self.0) } }
        impl Shl<u32> for $i { type Output = $i; #[inline(always)] fn shl(self, n: u32) -> $i { $i(self.0 << n) } }
        impl Shr<u32> for $i { type Output = $i; #[inline(always)] fn shr(self, n: u32) -> $i { $i(self.0 >> n) } }

        impl SimdI32 for $i {
            type Mask = $m;
            type F32s = $f;

            #[inline(always)]
            fn splat_same(self, x: i32) -> $i { $i($wi::splat(x)) }
            #[inline(always)]
            fn eq(self, o: $i) -> $m { $m(cast(self.0.simd_eq(o.0))) }
            #[inline(always)]
            fn lt(self, o: $i) -> $m { $m(cast(self.0.simd_lt(o.0))) }
            #[inline(always)]
            fn gt(self, o: $i) -> $m { $m(cast(self.0.simd_gt(o.0))) }
            #[inline(always)]
            fn min(self, o: $i) -> $i { $i(self.0.min(o.0)) }
            #[inline(always)]
            fn max(self, o: $i) -> $i { $i(self.0.max(o.0)) }
            #[inline(always)]
            fn to_f32(self) -> $f { $f(self.0.round_float()) }
            #[inline(always)]
            fn bits_to_f32(self) -> $f { $f(cast(self.0)) }
            #[inline(always)]
            fn shr_logical(self, n: u32) -> $i {
                let u: [u32; $n] = cast(self.0);
                $i(cast(u.map(|x| x >> n)))
            }
            #[inline(always)]
            fn store(self, out: &mut [i32]) {
                out[..$n].copy_from_slice(&self.to_array());
            }
            #[inline(always)]
            fn lane(self, i: usize) -> i32 { self.to_array()[i] }
        }
    };
}

wide_backend!(
    /// 4 lanes on `wide::f32x4`.
    Wide4, F32xW4, I32xW4, MxW4, f32x4, i32x4, 4
);
wide_backend!(
    /// 8 lanes on `wide::f32x8` (two SSE registers unless AVX is in the build's target features).
    Wide8, F32xW8, I32xW8, MxW8, f32x8, i32x8, 8
);
wide_backend!(
    /// 16 lanes on `wide::f32x16` (four SSE registers unless AVX/AVX-512 is in the build's target features).
    Wide16, F32xW16, I32xW16, MxW16, f32x16, i32x16, 16
);
