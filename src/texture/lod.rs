//! Choosing the mip level per lane (paper section 4.1). The paper's way: the level is the
//! logarithm of the hit distance, found by successive halving rather than a logarithm
//! ("multiplication by 0.5 ... the loop is likely to terminate in the same number of
//! iterations for all the rays of the quadruple"). The option: the level from ray
//! differentials (the texture-space footprint of a pixel), with the approximate `log2`.

use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::approx;

/// The mip level for hits at distance `t`, by successive halving.
///
/// `spread` is the size, in finest-level texels, of a pixel's footprint at unit distance
/// (the pixel's angle times the texture's texels per world unit, a constant of the camera
/// and the textured surface). The footprint `t * spread` is halved until it is below 2:
/// the number of halvings is the integer level and the remainder `f` in `[1, 2)` gives the
/// fraction `f - 1` (`log2` made linear inside each octave, so the level is continuous in
/// `t`). The loop stops when no lane halves any more, and after `max_level` halvings.
#[inline(always)]
pub fn lod_by_halving<L: Lanes>(l: L, t: L::F32s, spread: f32, max_level: usize) -> L::F32s {
    let two = l.splat(2.0);
    let mut f = t * spread;
    let mut level = l.splat(0.0);
    for _ in 0..max_level {
        let more = f.ge(two);
        if more.none() {
            break;
        }
        level = more.select(level + 1.0, level);
        f = more.select(f * 0.5, f);
    }
    let frac = (f - 1.0).clamp(l.splat(0.0), l.splat(1.0));
    (level + frac).min(l.splat(max_level as f32))
}

/// The mip level from ray differentials: the derivatives of the texture coordinates with
/// respect to the screen (`ds/dx`, `dt/dx`, `ds/dy`, `dt/dy`) on a `width` x `height`
/// finest level; `log2` of the longer side of the footprint in texels, at least 0.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn lod_from_differentials<L: Lanes>(
    l: L,
    ds_dx: L::F32s,
    dt_dx: L::F32s,
    ds_dy: L::F32s,
    dt_dy: L::F32s,
    width: usize,
    height: usize,
    max_level: usize,
) -> L::F32s {
    let (w, h) = (width as f32, height as f32);
    // Written out, not a closure called twice: LLVM may leave such a closure out of line,
    // and outside the kernel's `#[target_feature]` function every intrinsic becomes a call
    // (`scripts/check-inlining.sh` found this one once the renderer's batch driver changed
    // the inlining around it).
    let (ax, bx) = (ds_dx * w, dt_dx * h);
    let (ay, by) = (ds_dy * w, dt_dy * h);
    let longest2 = ax
        .mul_add(ax, bx * bx)
        .max(ay.mul_add(ay, by * by))
        .max(l.splat(1.0));
    // log2(sqrt(x)) = log2(x) / 2
    (approx::log2(l, longest2) * 0.5).clamp(l.splat(0.0), l.splat(max_level as f32))
}
