//! The kernels the `kernels` experiment and the criterion benches time: the approximations
//! of `coherent_simd::approx` mapped over slices, one packet at a time, on any backend.
//!
//! Each packet's input goes through `std::hint::black_box`, on every backend alike, so that
//! LLVM cannot vectorise the scalar backend's loop across iterations: the scalar baseline
//! stays one value at a time, as the paper's non-SSE code was (checked in the assembly; see
//! docs/findings/scalar-baseline.md).

use std::hint::black_box;

use coherent_simd::approx::Approx;
use coherent_simd::{Kernel, Lanes, MAX_LANES, SimdF32};

/// `out[i] = f(a[i], b[i])` for an approximation `f`, packet by packet.
pub struct ApproxKernel<'a> {
    pub f: Approx,
    pub a: &'a [f32],
    pub b: &'a [f32],
    pub out: &'a mut [f32],
}

impl Kernel for ApproxKernel<'_> {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        // One `match` outside the loop: each arm is a loop of its own kernel.
        match self.f {
            Approx::Exp => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Exp.eval(l, x, y),
            ),
            Approx::ExpPoly => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::ExpPoly.eval(l, x, y),
            ),
            Approx::Log => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Log.eval(l, x, y),
            ),
            Approx::Pow => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Pow.eval(l, x, y),
            ),
            Approx::Acos => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Acos.eval(l, x, y),
            ),
            Approx::Asin => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Asin.eval(l, x, y),
            ),
            Approx::Atan => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Atan.eval(l, x, y),
            ),
            Approx::Atan2 => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::Atan2.eval(l, x, y),
            ),
            Approx::CosSpot => map_packets(
                l,
                self.a,
                self.b,
                self.out,
                #[inline(always)]
                |x, y| Approx::CosSpot.eval(l, x, y),
            ),
        }
    }
}

/// The timed loop: `a.len()` must be a multiple of [`MAX_LANES`] (inputs are made so).
#[inline(always)]
fn map_packets<L: Lanes>(
    l: L,
    a: &[f32],
    b: &[f32],
    out: &mut [f32],
    f: impl Fn(L::F32s, L::F32s) -> L::F32s,
) {
    assert!(a.len().is_multiple_of(MAX_LANES) && b.len() == a.len() && out.len() == a.len());
    let mut i = 0;
    while i < a.len() {
        let x = l.load(black_box(&a[i..]));
        let y = l.load(black_box(&b[i..]));
        f(x, y).store(&mut out[i..]);
        i += L::N;
    }
}

/// Inputs for timing `f`: `n` values (rounded up to a multiple of [`MAX_LANES`]) spread over
/// its domain in a fixed pseudo-random order (coherent neighbours, like pixels of an image:
/// a slowly varying base plus small noise), the same for every backend.
pub fn approx_inputs(f: Approx, n: usize) -> (Vec<f32>, Vec<f32>) {
    let n = n.div_ceil(MAX_LANES) * MAX_LANES;
    let (lo, hi) = match f {
        // Timed on the paper's domains: exp on [-14, 0], log on (0, 1] (after pow's range
        // reduction), the rest on their full domains.
        Approx::Exp => (-14.0, 0.0),
        Approx::Log => (1e-6, 1.0),
        _ => f.domain(),
    };
    let mut state = 0x9e37_79b9_7f4a_7c15_u64 ^ f.name().len() as u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut a = Vec::with_capacity(n);
    let mut b = Vec::with_capacity(n);
    for i in 0..n {
        // A smooth sweep over the domain (period 4096 values) with 1% noise.
        let t = ((i % 4096) as f32 / 4096.0 + 0.01 * next()).min(1.0);
        let u = (((i / 64) % 64) as f32 / 64.0 + 0.01 * next()).min(1.0);
        a.push(lo + (hi - lo) * t);
        b.push(lo + (hi - lo) * u);
    }
    (a, b)
}

/// The scalar backend's loops of the timed approximations, as standalone symbols so their
/// assembly can be checked for packed instructions (`scripts/check-scalar-asm.sh`): the
/// same generic code the experiment times, monomorphised for `Scalar`.
#[inline(never)]
pub fn scalar_baseline(f: Approx, a: &[f32], b: &[f32], out: &mut [f32]) {
    ApproxKernel { f, a, b, out }.run(coherent_simd::scalar::Scalar);
}
