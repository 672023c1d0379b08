//! A texture's mipmap pyramid (paper section 4.1: textures are mipmapped and filtered
//! trilinearly). Linear RGB texels, one plane per channel so that a packet fetches a
//! channel with one gather; all levels of a channel in one array so that lanes on
//! different levels gather from it alike.
//!
//! Each level halves the previous one (`max(1, n / 2)` per side) with an area-weighted box
//! filter: a texel of the smaller level is the mean of the part of the larger level it
//! covers. For even sizes that is the plain 2 x 2 box; odd sizes lose nothing at the edge.

use super::error::TextureError;
use super::sample::Wrap;

/// Largest side of a texture, in texels (lane indices stay within 32 bits).
pub const MAX_SIDE: usize = 1 << 14;

/// Where one level lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelInfo {
    pub width: usize,
    pub height: usize,
    /// First texel of the level in each plane.
    pub offset: usize,
}

/// A mipmapped linear-RGB texture.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    pub(super) name: String,
    pub(super) wrap: Wrap,
    pub(super) levels: Vec<LevelInfo>,
    /// Red, green and blue planes, every level after the previous one, rows top to bottom.
    pub(super) planes: [Vec<f32>; 3],
    /// Per level: width, height (as `f32`, for the sampler's float texel arithmetic).
    pub(super) level_width: Vec<f32>,
    pub(super) level_height: Vec<f32>,
    /// Per level: offset into the planes (as `u32` bits, gathered as integers).
    pub(super) level_offset: Vec<u32>,
}

/// `n` source texels averaged onto `n / 2` (at least 1): for each destination texel, the
/// source texels it covers with their weights (the overlap lengths, summing to one).
fn box_weights(n: usize) -> Vec<Vec<(usize, f32)>> {
    let m = (n / 2).max(1);
    let scale = n as f64 / m as f64;
    (0..m)
        .map(|x| {
            let (lo, hi) = (x as f64 * scale, (x + 1) as f64 * scale);
            (lo.floor() as usize..(hi.ceil() as usize).min(n))
                .map(|s| {
                    let overlap = (hi.min(s as f64 + 1.0) - lo.max(s as f64)).max(0.0);
                    (s, (overlap / scale) as f32)
                })
                .filter(|&(_, w)| w > 0.0)
                .collect()
        })
        .collect()
}

/// The next level of one plane.
fn downsample(src: &[f32], w: usize, h: usize) -> (Vec<f32>, usize, usize) {
    let (wx, wy) = (box_weights(w), box_weights(h));
    let (w2, h2) = (wx.len(), wy.len());
    // Rows first, then columns.
    let mut rows = vec![0.0f32; w2 * h];
    for y in 0..h {
        for (x, taps) in wx.iter().enumerate() {
            rows[y * w2 + x] = taps.iter().map(|&(s, k)| k * src[y * w + s]).sum();
        }
    }
    let mut out = vec![0.0f32; w2 * h2];
    for (y, taps) in wy.iter().enumerate() {
        for x in 0..w2 {
            out[y * w2 + x] = taps.iter().map(|&(s, k)| k * rows[s * w2 + x]).sum();
        }
    }
    (out, w2, h2)
}

impl Texture {
    /// A texture from linear RGB texels (rows top to bottom), with its mip pyramid.
    /// `name` (a file or a label) is used in errors.
    pub fn from_linear(
        name: impl Into<String>,
        width: usize,
        height: usize,
        texels: &[[f32; 3]],
        wrap: Wrap,
    ) -> Result<Self, TextureError> {
        let name = name.into();
        if width == 0 || height == 0 {
            return Err(TextureError::Empty {
                name,
                width,
                height,
            });
        }
        if width > MAX_SIDE || height > MAX_SIDE {
            return Err(TextureError::TooLarge {
                name,
                width,
                height,
                max: MAX_SIDE,
            });
        }
        if texels.len() != width * height {
            return Err(TextureError::WrongSize {
                name,
                width,
                height,
                given: texels.len(),
            });
        }
        for (index, t) in texels.iter().enumerate() {
            if let Some(channel) = t.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(TextureError::BadTexel {
                    name,
                    index,
                    channel,
                    value: t[channel],
                });
            }
        }
        let mut planes: [Vec<f32>; 3] =
            core::array::from_fn(|c| texels.iter().map(|t| t[c]).collect());
        let mut levels = vec![LevelInfo {
            width,
            height,
            offset: 0,
        }];
        let (mut w, mut h, mut offset) = (width, height, 0);
        while w > 1 || h > 1 {
            let mut size = (0, 0);
            for plane in planes.iter_mut() {
                let (next, w2, h2) = downsample(&plane[offset..offset + w * h], w, h);
                plane.extend_from_slice(&next);
                size = (w2, h2);
            }
            offset += w * h;
            (w, h) = size;
            levels.push(LevelInfo {
                width: w,
                height: h,
                offset,
            });
        }
        Ok(Self {
            name,
            wrap,
            level_width: levels.iter().map(|l| l.width as f32).collect(),
            level_height: levels.iter().map(|l| l.height as f32).collect(),
            level_offset: levels.iter().map(|l| l.offset as u32).collect(),
            levels,
            planes,
        })
    }

    /// A 1 x 1 texture of one colour.
    pub fn constant(rgb: [f32; 3]) -> Result<Self, TextureError> {
        Self::from_linear("constant", 1, 1, &[rgb], Wrap::Repeat)
    }

    /// The file or label the texture came from.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// How coordinates outside `[0, 1]` are mapped.
    pub fn wrap(&self) -> Wrap {
        self.wrap
    }

    /// The same texture with another wrap mode.
    pub fn with_wrap(mut self, wrap: Wrap) -> Self {
        self.wrap = wrap;
        self
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[LevelInfo] {
        &self.levels
    }

    /// Texel `(x, y)` of level `level` (linear RGB).
    pub fn texel(&self, level: usize, x: usize, y: usize) -> [f32; 3] {
        let l = self.levels[level];
        assert!(
            x < l.width && y < l.height,
            "texel ({x}, {y}) outside level {level}"
        );
        let i = l.offset + y * l.width + x;
        core::array::from_fn(|c| self.planes[c][i])
    }
}
