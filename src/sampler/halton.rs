//! The 2D Halton sequence on the screen (paper section 6.2): radical inverse in base 2 along
//! x and base 3 along y, with the digit arithmetic that tells which pixel of a 2^a x 3^b
//! tile an index falls in (the same index arithmetic as pbrt-v4's `HaltonSampler`).

/// Radical inverse of `i` in base 2: the binary digits of `i` mirrored about the point.
#[inline]
pub fn radical_inverse2(i: u64) -> f64 {
    i.reverse_bits() as f64 * (1.0 / 18_446_744_073_709_551_616.0)
}

/// Radical inverse of `i` in base 3.
#[inline]
pub fn radical_inverse3(mut i: u64) -> f64 {
    let mut inv_base_n = 1.0f64;
    let mut reversed = 0u64;
    while i > 0 {
        reversed = reversed * 3 + i % 3;
        i /= 3;
        inv_base_n /= 3.0;
    }
    reversed as f64 * inv_base_n
}

/// The low `digits` base-`base` digits of `i`, reversed (as an integer in `0..base^digits`).
#[inline]
fn reverse_low_digits(mut i: u64, base: u64, digits: u32) -> u64 {
    let mut r = 0;
    for _ in 0..digits {
        r = r * base + i % base;
        i /= base;
    }
    r
}

/// A tile of `2^a x 3^b` pixels sampled by the Halton sequence scaled to it: index `i` lies at
/// `(2^a phi_2(i), 3^b phi_3(i))`. Every block of `2^a 3^b` consecutive indices starting at
/// a multiple of `2^a 3^b` puts exactly one sample in each pixel of the tile (the low `a`
/// binary and `b` ternary digits of the index pick the pixel, and by the Chinese remainder
/// theorem every pair occurs once per block); the higher digits place it inside the pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HaltonTile {
    /// Binary digits: the tile is `2^a` pixels wide.
    pub a: u32,
    /// Ternary digits: the tile is `3^b` pixels high.
    pub b: u32,
}

impl HaltonTile {
    pub fn new(a: u32, b: u32) -> HaltonTile {
        assert!(a <= 8 && b <= 5, "tile 2^{a} x 3^{b} too large");
        HaltonTile { a, b }
    }
    /// Tile width in pixels.
    pub fn width(self) -> u32 {
        1 << self.a
    }
    /// Tile height in pixels.
    pub fn height(self) -> u32 {
        3u32.pow(self.b)
    }
    /// Indices per block (one sample per pixel of the tile): `2^a 3^b`.
    pub fn block(self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// The sample of index `i`: pixel `(px, py)` in the tile and the offset `(fx, fy)` in
    /// `[0, 1)^2` inside it. `2^a phi_2(i) = px + phi_2(i >> a)`, exactly, and likewise in
    /// base 3, so the pixel is found from integer digits with no rounding. This is pbrt-v4's
    /// arithmetic: `HaltonSampler::GetPixel2D` returns `(RadicalInverse(0, i >> a),
    /// RadicalInverse(1, i / 3^b))` and `StartPixelSample` picks the index whose low digits
    /// are the pixel's (reversed), stepping by `sampleStride = 2^a 3^b` per sample.
    #[inline]
    pub fn sample(self, i: u64) -> (u32, u32, f32, f32) {
        let px = reverse_low_digits(i, 2, self.a) as u32;
        let py = reverse_low_digits(i, 3, self.b) as u32;
        let fx = radical_inverse2(i >> self.a);
        let fy = radical_inverse3(i / 3u64.pow(self.b));
        (px, py, to_unit_f32(fx), to_unit_f32(fy))
    }

    /// The per-pixel sample number of index `i` (its block): `i / (2^a 3^b)`.
    #[inline]
    pub fn sample_number(self, i: u64) -> u64 {
        i / self.block()
    }
}

/// `x` in `[0, 1)` as an `f32` strictly below 1 (rounding could otherwise give 1.0).
#[inline]
fn to_unit_f32(x: f64) -> f32 {
    (x as f32).min(1.0 - f32::EPSILON / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textbook_values() {
        // Base 2: 0, 1/2, 1/4, 3/4, 1/8, 5/8, 3/8, 7/8.
        let b2 = [0.0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875];
        for (i, v) in b2.iter().enumerate() {
            assert_eq!(radical_inverse2(i as u64), *v, "phi_2({i})");
        }
        // Base 3: 0, 1/3, 2/3, 1/9, 4/9, 7/9, 2/9, 5/9, 8/9.
        let b3 = [0, 3, 6, 1, 4, 7, 2, 5, 8];
        for (i, v) in b3.iter().enumerate() {
            assert!(
                (radical_inverse3(i as u64) - *v as f64 / 9.0).abs() < 1e-15,
                "phi_3({i})"
            );
        }
    }

    #[test]
    fn tile_sample_matches_the_scaled_sequence() {
        let t = HaltonTile::new(4, 2);
        for i in 0..5000u64 {
            let (px, py, fx, fy) = t.sample(i);
            let x = 16.0 * radical_inverse2(i);
            let y = 9.0 * radical_inverse3(i);
            assert!((px as f64 + fx as f64 - x).abs() < 1e-6, "x of {i}");
            assert!((py as f64 + fy as f64 - y).abs() < 1e-5, "y of {i}");
            assert!(fx < 1.0 && fy < 1.0 && px < 16 && py < 9);
        }
    }

    #[test]
    fn every_block_covers_every_pixel_once() {
        let t = HaltonTile::new(3, 2);
        for block in 0..4u64 {
            let mut seen = vec![0u32; t.block() as usize];
            for i in block * t.block()..(block + 1) * t.block() {
                let (px, py, _, _) = t.sample(i);
                seen[(py * t.width() + px) as usize] += 1;
                assert_eq!(t.sample_number(i), block);
            }
            assert!(seen.iter().all(|&c| c == 1), "block {block}: {seen:?}");
        }
    }
}
