//! Running a packet kernel over slices: full packets straight from the slice, the tail
//! through a padded packet (padding lanes repeat the last value and are not written back).

use crate::lanes::{Lanes, MAX_LANES, SimdF32};

/// `out[i] = f(xs[i])` packet by packet. Panics if `out` is shorter than `xs`.
#[inline(always)]
pub fn map<L: Lanes>(l: L, xs: &[f32], out: &mut [f32], mut f: impl FnMut(L::F32s) -> L::F32s) {
    let n = xs.len();
    assert!(out.len() >= n, "output of {} for {} inputs", out.len(), n);
    let full = n - n % L::N;
    let mut i = 0;
    while i < full {
        f(l.load(&xs[i..])).store(&mut out[i..]);
        i += L::N;
    }
    if i < n {
        let mut buf = [xs[n - 1]; MAX_LANES];
        buf[..n - i].copy_from_slice(&xs[i..]);
        let mut res = [0.0; MAX_LANES];
        f(l.load(&buf)).store(&mut res);
        out[i..n].copy_from_slice(&res[..n - i]);
    }
}

/// `out[i] = f(xs[i], ys[i])` packet by packet. Panics if the slices differ in length.
#[inline(always)]
pub fn map2<L: Lanes>(
    l: L,
    xs: &[f32],
    ys: &[f32],
    out: &mut [f32],
    mut f: impl FnMut(L::F32s, L::F32s) -> L::F32s,
) {
    let n = xs.len();
    assert!(
        ys.len() == n && out.len() >= n,
        "slices of {}, {} and {}",
        n,
        ys.len(),
        out.len()
    );
    let full = n - n % L::N;
    let mut i = 0;
    while i < full {
        f(l.load(&xs[i..]), l.load(&ys[i..])).store(&mut out[i..]);
        i += L::N;
    }
    if i < n {
        let mut bx = [xs[n - 1]; MAX_LANES];
        let mut by = [ys[n - 1]; MAX_LANES];
        bx[..n - i].copy_from_slice(&xs[i..]);
        by[..n - i].copy_from_slice(&ys[i..]);
        let mut res = [0.0; MAX_LANES];
        f(l.load(&bx), l.load(&by)).store(&mut res);
        out[i..n].copy_from_slice(&res[..n - i]);
    }
}
