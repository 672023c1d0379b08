//! Which random numbers pick the light samples (area-light points, environment directions):
//! each image sample's own, or one set shared by the samples of a 4 x 4 pixel tile.
//!
//! The paper's surface lights are "subdivided into" a fixed set of points (section 5, Table
//! 2: 7 for the linear light, 7 x 3 for the rectangular one), the same for every ray of a
//! packet, so a packet's shadow rays meet at one point and traverse the BSP in one order
//! (section 3). Per-sample jitter (our default, [`LightSamples::Pixel`]) decorrelates the
//! noise of neighbouring pixels but scatters the shadow rays of an environment light over
//! the sphere: on the real scenes lit by a sky, those incoherent shadow packets are most of
//! the frame. [`LightSamples::Tile`] gives every sample of a 4 x 4 tile (in the same pass) the
//! numbers of the tile's first pixel, so the environment's shadow rays of a packet are
//! parallel and the area lights' meet at common points, as in the paper. Each pixel's
//! estimate is unchanged in distribution (still unbiased); what changes is that the noise of
//! a tile's pixels is correlated. The image is the same for every backend and thread count,
//! as with per-pixel numbers.

use coherent_simd::{Lanes, SimdF32};

/// How light samples are drawn (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightSamples {
    /// Each image sample draws its own (the default).
    #[default]
    Pixel,
    /// The samples of a 4 x 4 pixel tile share theirs.
    Tile,
}

/// Side of the tiles whose samples share light samples, in pixels.
pub const TILE: i32 = 4;

impl LightSamples {
    pub const ALL: [LightSamples; 2] = [LightSamples::Pixel, LightSamples::Tile];

    /// The name used on the command line and in results.
    pub fn name(self) -> &'static str {
        match self {
            LightSamples::Pixel => "pixel",
            LightSamples::Tile => "tile",
        }
    }

    /// The ids the light samples' random numbers derive from, for samples `ids` at image
    /// points `(xs, ys)` of an image `width` pixels wide.
    ///
    /// With [`LightSamples::Tile`]: the film numbers a pass's samples `base + pixel index`
    /// (`y * width + x`), so subtracting the pixel's offset from its tile's first pixel gives
    /// that pixel's id, the same for the whole tile. Samples numbered otherwise (the
    /// pre-render's points) get some other id of their own, still the same for every backend.
    #[inline(always)]
    pub fn ids<L: Lanes>(
        self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        width: u32,
    ) -> L::I32s {
        match self {
            LightSamples::Pixel => ids,
            LightSamples::Tile => {
                let low = l.splat_i32(TILE - 1);
                let dx = xs.floor().to_i32() & low;
                let dy = ys.floor().to_i32() & low;
                ids - (dy * l.splat_i32(width as i32) + dx)
            }
        }
    }
}

impl std::fmt::Display for LightSamples {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LightSamples {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown light sampling `{s}`: pixel or tile"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::SimdI32;
    use coherent_simd::scalar::Scalar;

    #[test]
    fn a_tile_shares_the_id_of_its_first_pixel() {
        let l = Scalar;
        let (w, base) = (37u32, 1000i32);
        for y in 0..12u32 {
            for x in 0..w {
                let id = base + (y * w + x) as i32;
                let (fx, fy) = (0.25 + 0.01 * x as f32, 0.99);
                let at = |m: LightSamples| {
                    m.ids(
                        l,
                        l.splat(x as f32 + fx),
                        l.splat(y as f32 + fy),
                        l.splat_i32(id),
                        w,
                    )
                    .lane(0)
                };
                assert_eq!(at(LightSamples::Pixel), id);
                let corner = base + ((y & !3) * w + (x & !3)) as i32;
                assert_eq!(at(LightSamples::Tile), corner, "pixel ({x}, {y})");
            }
        }
        assert_eq!("tile".parse::<LightSamples>(), Ok(LightSamples::Tile));
        assert!("tiles".parse::<LightSamples>().is_err());
    }
}
