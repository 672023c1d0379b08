//! Trilinear texture filtering over lanes (paper section 4.1): each lane's texel position
//! on two neighbouring mip levels, wrapped or clamped, then eight weighted texels gathered
//! per channel. As in the paper, texel coordinates are kept in floating point and turned
//! into integers only to fetch.
//!
//! Texel centres are at half-integer positions: coordinate `s` on a level `w` texels wide
//! falls between texels `floor(s w - 1/2)` and the next one.

// Index loops, not iterator adapters, in the per-packet code: it must inline into the
// backends' `#[target_feature]` entry points (a non-inlined `array::from_fn` made the AVX2 backend 7x slower).
#![allow(clippy::needless_range_loop)]

use coherent_simd::{Lanes, Rgbs, SimdF32, SimdMask};

use super::pyramid::Texture;

/// How texture coordinates outside `[0, 1]` are mapped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// Tiled: `s` and `s + 1` sample the same place.
    Repeat,
    /// The edge texels extend outward.
    Clamp,
}

/// The eight texels of a trilinear lookup and their weights (which sum to one).
#[derive(Debug, Clone, Copy)]
pub struct Footprint<L: Lanes> {
    /// Index of each texel in the texture's planes.
    pub index: [L::I32s; 8],
    pub weight: [L::F32s; 8],
}

/// A texel column or row number (an integer held in `f32`) mapped into `[0, n - 1]`.
#[inline(always)]
fn wrap_coord<L: Lanes>(l: L, wrap: Wrap, x: L::F32s, n: L::F32s) -> L::F32s {
    let zero = l.splat(0.0);
    let last = n - 1.0;
    match wrap {
        Wrap::Repeat => {
            let r = x - n * (x / n).floor();
            // Rounding of `x / n` can leave `r` one period off for huge `x`.
            let r = r.lt(zero).select(r + n, r);
            let r = r.ge(n).select(r - n, r);
            r.clamp(zero, last)
        }
        Wrap::Clamp => x.clamp(zero, last),
    }
}

impl Texture {
    /// The texels and weights of a trilinear lookup at `(s, t)` and mip level `lod`
    /// (fractional; clamped to the pyramid).
    #[inline(always)]
    pub fn footprint<L: Lanes>(&self, l: L, s: L::F32s, t: L::F32s, lod: L::F32s) -> Footprint<L> {
        let top = l.splat((self.levels.len() - 1) as f32);
        let lod = lod.clamp(l.splat(0.0), top);
        let lower = lod.floor();
        let frac = lod - lower;
        let upper = (lower + 1.0).min(top);
        let one = l.splat(1.0);
        let mut index = [l.splat_i32(0); 8];
        let mut weight = [l.splat(0.0); 8];
        // Plain loops: everything here must inline into the backend's entry point.
        let levels = [(lower, one - frac), (upper, frac)];
        for k in 0..2 {
            let (level, level_weight) = levels[k];
            let level = level.to_i32();
            let w = l.gather(&self.level_width, level);
            let h = l.gather(&self.level_height, level);
            let offset = l.gather_u32(&self.level_offset, level);
            let x = s.mul_add(w, l.splat(-0.5));
            let y = t.mul_add(h, l.splat(-0.5));
            // Texel numbers as floats; NaN coordinates end up on texel 0 by the clamps.
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let fx = fx.clamp(l.splat(0.0), one);
            let fy = fy.clamp(l.splat(0.0), one);
            let xs = [
                wrap_coord(l, self.wrap, x0, w),
                wrap_coord(l, self.wrap, x0 + 1.0, w),
            ];
            let ys = [
                wrap_coord(l, self.wrap, y0, h),
                wrap_coord(l, self.wrap, y0 + 1.0, h),
            ];
            let wx = [one - fx, fx];
            let wy = [(one - fy) * level_weight, fy * level_weight];
            let width_i = w.to_i32();
            for j in 0..2 {
                let row = offset + ys[j].to_i32() * width_i;
                for i in 0..2 {
                    index[4 * k + 2 * j + i] = row + xs[i].to_i32();
                    weight[4 * k + 2 * j + i] = wx[i] * wy[j];
                }
            }
        }
        Footprint { index, weight }
    }

    /// Trilinear filtering at `(s, t)` and mip level `lod`: linear RGB per lane.
    #[inline(always)]
    pub fn sample<L: Lanes>(&self, l: L, s: L::F32s, t: L::F32s, lod: L::F32s) -> Rgbs<L> {
        let f = self.footprint(l, s, t, lod);
        let mut rgb = [l.splat(0.0); 3];
        for c in 0..3 {
            let plane = &self.planes[c];
            let mut sum = f.weight[0] * l.gather(plane, f.index[0]);
            for k in 1..8 {
                sum = f.weight[k].mul_add(l.gather(plane, f.index[k]), sum);
            }
            rgb[c] = sum;
        }
        Rgbs::new(rgb[0], rgb[1], rgb[2])
    }

    /// The scalar reference of [`Texture::sample`], written directly with integer texel
    /// arithmetic, for tests.
    pub fn sample1(&self, s: f32, t: f32, lod: f32) -> [f32; 3] {
        let top = (self.levels.len() - 1) as f32;
        let lod = if lod.is_nan() {
            0.0
        } else {
            lod.clamp(0.0, top)
        };
        let lower = lod.floor();
        let frac = lod - lower;
        let wrap = |v: i64, n: usize| -> usize {
            match self.wrap {
                Wrap::Repeat => v.rem_euclid(n as i64) as usize,
                Wrap::Clamp => v.clamp(0, n as i64 - 1) as usize,
            }
        };
        let mut out = [0.0f64; 3];
        for (level, lw) in [
            (lower as usize, 1.0 - frac),
            ((lower as usize + 1).min(top as usize), frac),
        ] {
            let info = self.levels[level];
            let x = s as f64 * info.width as f64 - 0.5;
            let y = t as f64 * info.height as f64 - 0.5;
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                    let tx = wrap(x0 as i64 + dx, info.width);
                    let ty = wrap(y0 as i64 + dy, info.height);
                    let texel = self.texel(level, tx, ty);
                    for c in 0..3 {
                        out[c] += lw as f64 * wy * wx * texel[c] as f64;
                    }
                }
            }
        }
        out.map(|v| v as f32)
    }
}
