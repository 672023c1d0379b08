//! Superpixels (paper section 6.2): a sparse grid of samples at superpixel corners, which is
//! both the low-resolution pre-render of tone mapping (section 6.1) and the values that
//! pixels of smooth superpixels are bilinearly interpolated from.

// Per-packet code uses index loops over lanes (see docs/architecture.md#inlining).
#![allow(clippy::needless_range_loop)]

use super::accuracy::display_difference;
use crate::tonemap::ToneMap;

/// The corner grid: `(nx + 1) x (ny + 1)` corners for `nx x ny` superpixels of `sx x sy`
/// pixels (the last row and column may be narrower, ending at the image border).
#[derive(Clone, Debug, PartialEq)]
pub struct Superpixels {
    pub width: u32,
    pub height: u32,
    pub sx: u32,
    pub sy: u32,
    pub nx: u32,
    pub ny: u32,
    /// Corner colours, row by row (`(nx + 1) * (ny + 1)`); set after the pre-render.
    pub corners: Vec<[f32; 3]>,
}

impl Superpixels {
    pub fn new(width: u32, height: u32, sx: u32, sy: u32) -> Superpixels {
        let (nx, ny) = (width.div_ceil(sx), height.div_ceil(sy));
        Superpixels {
            width,
            height,
            sx,
            sy,
            nx,
            ny,
            corners: vec![[0.0; 3]; (nx as usize + 1) * (ny as usize + 1)],
        }
    }

    /// Continuous screen position of corner `(u, v)`: the superpixel boundary, kept inside
    /// the image (the right and bottom borders move in by 1/1024 pixel).
    pub fn corner_position(&self, u: u32, v: u32) -> (f32, f32) {
        let x = (u * self.sx).min(self.width) as f32;
        let y = (v * self.sy).min(self.height) as f32;
        (
            x.min(self.width as f32 - 1.0 / 1024.0),
            y.min(self.height as f32 - 1.0 / 1024.0),
        )
    }

    /// Every corner position, row by row.
    pub fn corner_positions(&self) -> Vec<(f32, f32)> {
        let mut v = Vec::with_capacity(self.corners.len());
        for cy in 0..=self.ny {
            for cx in 0..=self.nx {
                v.push(self.corner_position(cx, cy));
            }
        }
        v
    }

    fn corner(&self, u: u32, v: u32) -> [f32; 3] {
        self.corners[(v * (self.nx + 1) + u) as usize]
    }

    /// Whether superpixel `(u, v)`'s four corners differ pairwise by less than `accuracy`
    /// on the display.
    pub fn smooth(&self, u: u32, v: u32, accuracy: f32, t: &ToneMap) -> bool {
        let c = [
            self.corner(u, v),
            self.corner(u + 1, v),
            self.corner(u, v + 1),
            self.corner(u + 1, v + 1),
        ];
        for i in 0..4 {
            for j in i + 1..4 {
                if display_difference(t, c[i], c[j]).partial_cmp(&accuracy)
                    != Some(core::cmp::Ordering::Less)
                {
                    return false;
                }
            }
        }
        true
    }

    /// Bilinear interpolation of the corners at pixel `(x, y)`'s centre.
    pub fn interpolate(&self, x: u32, y: u32) -> [f32; 3] {
        let (u, v) = (
            (x / self.sx).min(self.nx - 1),
            (y / self.sy).min(self.ny - 1),
        );
        let (x0, y0) = self.corner_position(u, v);
        let (x1, y1) = self.corner_position(u + 1, v + 1);
        let tx = ((x as f32 + 0.5 - x0) / (x1 - x0)).clamp(0.0, 1.0);
        let ty = ((y as f32 + 0.5 - y0) / (y1 - y0)).clamp(0.0, 1.0);
        let (c00, c10, c01, c11) = (
            self.corner(u, v),
            self.corner(u + 1, v),
            self.corner(u, v + 1),
            self.corner(u + 1, v + 1),
        );
        let mut out = [0.0; 3];
        for c in 0..3 {
            let top = c00[c] + (c10[c] - c00[c]) * tx;
            let bottom = c01[c] + (c11[c] - c01[c]) * tx;
            out[c] = top + (bottom - top) * ty;
        }
        out
    }
}
