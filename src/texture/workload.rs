//! Realistic texture lookups for timing (paper section 4.1; the `texture_trilinear` kernel):
//! a textured floor seen through a pinhole camera, as a renderer meets it. Pixels come in
//! 4 x 4 tiles of neighbours, so packets of consecutive lookups are coherent; each lookup
//! has its texture coordinates and hit distance, and the kernel chooses the mip level by
//! successive halving and filters trilinearly.

use std::hint::black_box;

use coherent_simd::{Kernel, Lanes, Rgbs, SimdF32};

use super::lod::{lod_by_halving, lod_from_differentials};
use super::pyramid::Texture;
use super::sample::Wrap;

/// Per lookup: texture coordinates and hit distance (a multiple of 16 lookups).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TextureInputs {
    pub s: Vec<f32>,
    pub t: Vec<f32>,
    pub dist: Vec<f32>,
    /// Ray differentials: the change of `s` and `t` to the next pixel right and down.
    pub ds_dx: Vec<f32>,
    pub dt_dx: Vec<f32>,
    pub ds_dy: Vec<f32>,
    pub dt_dy: Vec<f32>,
    /// Pixel footprint at unit distance, in finest-level texels (see [`lod_by_halving`]).
    pub spread: f32,
}

impl TextureInputs {
    /// Lookups held.
    pub fn len(&self) -> usize {
        self.s.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.s.is_empty()
    }

    /// A `size` x `size` image of the floor `y = 0` seen from height 1.5 looking slightly
    /// down, the texture repeating every 2 world units and `texels` texels wide; only
    /// tiles that all hit the floor within 200 units (and whose pixels' right and lower
    /// neighbours do, for the differentials) are kept.
    pub fn floor(size: usize, texels: usize) -> Self {
        let size = size.div_ceil(4) * 4;
        let (eye_y, pitch, half_fov) = (1.5f32, -0.35f32, 0.5f32);
        let (sp, cp) = pitch.sin_cos();
        let period = 2.0f32;
        let hit = |px: f32, py: f32| -> Option<(f32, f32, f32)> {
            let x = ((px + 0.5) / size as f32 * 2.0 - 1.0) * half_fov;
            let y = (1.0 - (py + 0.5) / size as f32 * 2.0) * half_fov;
            // Camera looking along -z, pitched down.
            let d = glam::Vec3::new(x, y * cp + sp, -cp + y * sp).normalize();
            if d.y >= -1e-3 {
                return None;
            }
            let t = eye_y / -d.y;
            let p = d * t;
            (t < 200.0).then_some((p.x / period, p.z / period, t))
        };
        let mut out = Self {
            spread: 2.0 * half_fov / size as f32 * texels as f32 / period,
            ..Self::default()
        };
        for ty in (0..size).step_by(4) {
            for tx in (0..size).step_by(4) {
                let pixel = |i: usize| {
                    let (px, py) = ((tx + i % 4) as f32, (ty + i / 4) as f32);
                    Some((hit(px, py)?, hit(px + 1.0, py)?, hit(px, py + 1.0)?))
                };
                let tile: Option<Vec<_>> = (0..16).map(pixel).collect();
                for ((s, t, d), (sx, tx_, _), (sy, ty_, _)) in tile.into_iter().flatten() {
                    out.s.push(s);
                    out.t.push(t);
                    out.dist.push(d);
                    out.ds_dx.push(sx - s);
                    out.dt_dx.push(tx_ - t);
                    out.ds_dy.push(sy - s);
                    out.dt_dy.push(ty_ - t);
                }
            }
        }
        out
    }
}

/// A `size` x `size` texture of a smooth pattern with a grid (repeating).
pub fn pattern_texture(size: usize) -> Texture {
    let texels: Vec<[f32; 3]> = (0..size * size)
        .map(|i| {
            let (x, y) = (
                (i % size) as f32 / size as f32,
                (i / size) as f32 / size as f32,
            );
            let line = ((x * 16.0).fract() < 0.06 || (y * 16.0).fract() < 0.06) as u8 as f32;
            let v = 0.5 + 0.4 * (x * 25.0).sin() * (y * 19.0).cos();
            [
                v * (1.0 - line),
                0.3 + 0.2 * x,
                0.2 + 0.6 * y * (1.0 - line),
            ]
        })
        .collect();
    Texture::from_linear("pattern", size, size, &texels, Wrap::Repeat).expect("valid pattern")
}

/// How a lookup's mip level is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LodMethod {
    /// The paper's: successive halving of the hit distance ([`lod_by_halving`]).
    Halving,
    /// From the ray differentials ([`lod_from_differentials`]).
    Differentials,
}

/// The mip level of the packet of lookups starting at `i`.
#[inline(always)]
pub fn lod_at<L: Lanes>(
    l: L,
    texture: &Texture,
    inputs: &TextureInputs,
    method: LodMethod,
    i: usize,
) -> L::F32s {
    let top = texture.levels().len() - 1;
    match method {
        LodMethod::Halving => lod_by_halving(l, l.load(&inputs.dist[i..]), inputs.spread, top),
        LodMethod::Differentials => {
            let finest = texture.levels()[0];
            lod_from_differentials(
                l,
                l.load(&inputs.ds_dx[i..]),
                l.load(&inputs.dt_dx[i..]),
                l.load(&inputs.ds_dy[i..]),
                l.load(&inputs.dt_dy[i..]),
                finest.width,
                finest.height,
                top,
            )
        }
    }
}

/// `lookups` trilinear lookups in `texture` over `inputs` (cycled), a packet at a time,
/// each with its mip level chosen by `lod`; returns the sum (so nothing is optimised
/// away).
#[derive(Debug, Clone, Copy)]
pub struct TextureLookups<'a> {
    pub texture: &'a Texture,
    pub inputs: &'a TextureInputs,
    pub lookups: usize,
    pub lod: LodMethod,
}

impl Kernel for TextureLookups<'_> {
    type Output = f32;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f32 {
        let n = self.inputs.len();
        assert!(
            n > 0 && n.is_multiple_of(16),
            "texture inputs must be whole 16-lookup tiles"
        );
        let mut sum = Rgbs::zero(l);
        let (mut done, mut i) = (0, 0);
        while done < self.lookups {
            // Each packet's inputs through `black_box`, on every backend alike (as the
            // approximation kernels do): the scalar loop stays one lookup at a time.
            let inputs = black_box(self.inputs);
            let s = l.load(&inputs.s[i..]);
            let t = l.load(&inputs.t[i..]);
            let lod = lod_at(l, self.texture, inputs, self.lod, i);
            sum += self.texture.sample(l, s, t, lod);
            done += L::N;
            i += L::N;
            if i == n {
                i = 0;
            }
        }
        let total = sum.r + sum.g + sum.b;
        (0..L::N).map(|k| total.lane(k)).sum()
    }
}

/// The scalar backend's loop of [`TextureLookups`], as a standalone symbol so that
/// `scripts/check-scalar-asm.sh` can check its assembly (no packed float ops, no libm calls):
/// the same generic code the `kernels` experiment times, monomorphised for `Scalar`.
#[inline(never)]
pub fn scalar_baseline_texture(
    texture: &Texture,
    inputs: &TextureInputs,
    lookups: usize,
    lod: LodMethod,
) -> f32 {
    TextureLookups {
        texture,
        inputs,
        lookups,
        lod,
    }
    .run(coherent_simd::scalar::Scalar)
}
