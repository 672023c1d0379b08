//! Shadow beams traced from the light: an occlusion query asks only whether a segment is
//! blocked, not where, so a beam's segments may be walked from either end. A tile's shadow
//! rays toward one point of a light start spread over the tile's surfaces and end together
//! at the light; walked from there, the group's rays share an origin, and the interval
//! bounds and frustum of the group (`group.rs`, `frustum.rs`) are as tight as a camera
//! beam's. The choice is made per group from the rays themselves: the end whose points
//! span the smaller box is the origin. Segments with no finite far end (lights at infinity)
//! keep their direction.
//!
//! A segment `o + t d`, `t` in `[tmin, tmax]`, is walked as `f - t' d` with `f = o + tmax d`
//! and `t'` in `[e, tmax - tmin]`: the same points up to the rounding of `f` (an ulp of the
//! scene's coordinates, far below the offsets shadow rays start with). `e`, 2^-20 of the
//! segment, keeps the far end itself out, as the forward walk does (its `tmax` is exclusive):
//! a segment ending exactly on a surface (a light on a wall) is not blocked by that surface.

use coherent_accel::Rays;
use coherent_simd::{Lanes, SimdF32, SimdMask};

/// Whether the segments of lanes `active` (valid rays) end closer together than they
/// start: the sum of the far ends' box extents below the near ends'. `false` when some
/// active segment has no finite far end or no lane is active.
#[inline(always)]
pub(crate) fn far_ends_closer<L: Lanes>(l: L, rays: &[Rays<L>], active: &[L::Mask]) -> bool {
    let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
    let mut near = [[inf; 3], [ninf; 3]];
    let mut far = [[inf; 3], [ninf; 3]];
    let mut finite = true;
    let mut any = false;
    for j in 0..rays.len() {
        let (r, m) = (&rays[j], active[j] & rays[j].valid(l));
        if m.none() {
            continue;
        }
        any = true;
        let (o, d) = (
            [r.origin.x, r.origin.y, r.origin.z],
            [r.dir.x, r.dir.y, r.dir.z],
        );
        for k in 0..3 {
            let n = d[k].mul_add(r.tmin, o[k]);
            let f = d[k].mul_add(r.tmax, o[k]);
            finite &= m.and_not(f.abs().lt(inf)).none();
            near[0][k] = near[0][k].min(m.select(n, inf));
            near[1][k] = near[1][k].max(m.select(n, ninf));
            far[0][k] = far[0][k].min(m.select(f, inf));
            far[1][k] = far[1][k].max(m.select(f, ninf));
        }
    }
    if !(any && finite) {
        return false;
    }
    let (mut near_span, mut far_span) = (0.0, 0.0);
    for k in 0..3 {
        near_span += near[1][k].reduce_max() - near[0][k].reduce_min();
        far_span += far[1][k].reduce_max() - far[0][k].reduce_min();
    }
    far_span < near_span
}

/// The segments of `r` walked from their far ends back (see the module's comment).
#[inline(always)]
pub(crate) fn reversed<L: Lanes>(l: L, r: &Rays<L>) -> Rays<L> {
    let far = r.dir.mul_add(r.tmax, r.origin);
    let len = r.tmax - r.tmin;
    Rays {
        origin: far,
        dir: -r.dir,
        tmin: len * l.splat(1.0 / (1u32 << 20) as f32),
        tmax: len,
    }
}
