//! The screen sampler of the progressive anti-aliasing (paper section 6.2): Halton samples
//! over tiles of `2^a x 3^b` pixels, traced in coherent groups `j, j + s, j + 2s, ...` of as
//! many samples as a packet has lanes, where `s = 2^k 3^n` is the *span*.
//!
//! Indices `i` and `i + m s` share their low `k` binary and low `n` ternary digits, so they
//! fall in the same cell of a `2^k x 3^n` grid over the tile: a cell of
//! `2^(a-k) x 3^(b-n)` pixels (smaller than a pixel once `k > a` or `n > b`). The paper's
//! coherence radius `R = x_res y_res / (pi s)` is the area of such a cell over pi (with the
//! tile as the screen); we read it as `pi R^2 = cell area`, i.e. `R = sqrt(area / pi)`
//! pixels, the radius of the disc with the cell's area.

pub mod halton;

pub use halton::{HaltonTile, radical_inverse2, radical_inverse3};

/// A span `s = 2^k 3^n`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    pub k: u32,
    pub n: u32,
}

impl Span {
    /// `2^k 3^n`.
    pub fn value(self) -> u64 {
        (1u64 << self.k) * 3u64.pow(self.n)
    }
    /// The coherence radius in pixels for a tile: `sqrt(tile area / (pi s))`.
    pub fn radius(self, tile: HaltonTile) -> f64 {
        (tile.block() as f64 / (std::f64::consts::PI * self.value() as f64)).sqrt()
    }
    /// The cell a group lies in: `2^a / 2^k` by `3^b / 3^n` pixels.
    pub fn cell(self, tile: HaltonTile) -> (f64, f64) {
        (
            tile.width() as f64 / (1u64 << self.k) as f64,
            tile.height() as f64 / 3u64.pow(self.n) as f64,
        )
    }

    /// The spans of the adaptive levels, coarse to fine: from one cell per tile, alternately
    /// doubling and tripling (keeping cells near square) up to one pixel per cell `(a, b)`.
    pub fn levels(tile: HaltonTile) -> Vec<Span> {
        let mut v = vec![Span { k: 0, n: 0 }];
        let (mut k, mut n) = (0, 0);
        while k < tile.a || n < tile.b {
            // Grow the dimension whose cells are larger in pixels.
            let (w, h) = Span { k, n }.cell(tile);
            if (w >= h && k < tile.a) || n >= tile.b {
                k += 1;
            } else {
                n += 1;
            }
            v.push(Span { k, n });
        }
        v
    }

    /// The span for a pass of one block (`2^a 3^b` indices) with packets of `lanes` lanes:
    /// `lanes * s` divides the block where the lane count allows (`s = 2^(a - log2 lanes) 3^b`),
    /// so every group is full; cells are then `lanes x 1` pixels.
    pub fn for_block(tile: HaltonTile, lanes: usize) -> Span {
        let log2 = lanes.trailing_zeros();
        Span {
            k: tile.a.saturating_sub(log2),
            n: tile.b,
        }
    }
}

/// The indices of one group: `base + j + m s` for `m` in `0..lanes`, those below `end`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Group {
    pub base: u64,
    pub j: u64,
    pub span: u64,
    pub end: u64,
}

impl Group {
    /// Index of lane `m`, or `None` past the end of the range.
    #[inline(always)]
    pub fn index(&self, m: usize) -> Option<u64> {
        let i = self.base + self.j + m as u64 * self.span;
        (i < self.end).then_some(i)
    }
}

/// The groups covering the index range `[start, end)` with span `s` and `lanes` lanes:
/// chunks of `lanes * s` indices, each split into the `s` residues `j` (no index twice).
pub fn groups(start: u64, end: u64, span: Span, lanes: usize) -> impl Iterator<Item = Group> {
    let s = span.value();
    let chunk = s * lanes as u64;
    let chunks = (end.saturating_sub(start)).div_ceil(chunk);
    (0..chunks).flat_map(move |c| {
        (0..s).filter_map(move |j| {
            let base = start + c * chunk;
            (base + j < end).then_some(Group {
                base,
                j,
                span: s,
                end,
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_cover_a_range_once() {
        for lanes in [1, 4, 8, 16] {
            for span in [
                Span { k: 0, n: 0 },
                Span { k: 2, n: 1 },
                Span { k: 4, n: 2 },
            ] {
                let (start, end) = (37, 37 + 500);
                let mut seen = vec![0u32; 600];
                for g in groups(start, end, span, lanes) {
                    for m in 0..lanes {
                        if let Some(i) = g.index(m) {
                            seen[i as usize] += 1;
                        }
                    }
                }
                for (i, c) in seen.iter().enumerate() {
                    let want = (start..end).contains(&(i as u64)) as u32;
                    assert_eq!(*c, want, "index {i}, lanes {lanes}, span {span:?}");
                }
            }
        }
    }

    /// A group lies inside one cell of the span's grid; its samples' mean distance to their
    /// centroid stays within the coherence radius, and none is farther than the cell's
    /// diagonal from another.
    #[test]
    fn groups_stay_within_their_coherence_radius() {
        let tile = HaltonTile::new(4, 2);
        for span in Span::levels(tile) {
            let (cw, ch) = span.cell(tile);
            let r = span.radius(tile);
            let diag = (cw * cw + ch * ch).sqrt();
            let (mut sum, mut count) = (0.0, 0);
            for g in groups(0, 8 * span.value(), span, 8) {
                let pts: Vec<(f64, f64)> = (0..8)
                    .filter_map(|m| g.index(m))
                    .map(|i| {
                        let (px, py, fx, fy) = tile.sample(i);
                        (px as f64 + fx as f64, py as f64 + fy as f64)
                    })
                    .collect();
                let (cx, cy) = (
                    pts.iter().map(|p| p.0).sum::<f64>() / pts.len() as f64,
                    pts.iter().map(|p| p.1).sum::<f64>() / pts.len() as f64,
                );
                for p in &pts {
                    sum += ((p.0 - cx).powi(2) + (p.1 - cy).powi(2)).sqrt();
                    count += 1;
                    for q in &pts {
                        let d = ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt();
                        assert!(d <= diag + 1e-9, "span {span:?}: {d} > diagonal {diag}");
                    }
                }
            }
            let mean = sum / count as f64;
            assert!(mean <= r, "span {span:?}: mean distance {mean} > R {r}");
        }
    }

    #[test]
    fn levels_end_at_one_pixel_cells() {
        let tile = HaltonTile::new(4, 2);
        let l = Span::levels(tile);
        assert_eq!(l[0].value(), 1);
        assert_eq!(*l.last().unwrap(), Span { k: 4, n: 2 });
        assert_eq!(Span::for_block(tile, 16), Span { k: 0, n: 2 });
        assert_eq!(Span::for_block(tile, 4).value() * 4, tile.block());
    }
}
