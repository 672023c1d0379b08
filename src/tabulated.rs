//! Non-uniform tables over lanes (paper sections 4.2 and 5): the N-wide branch-free binary
//! search that finds each lane's cell on a non-uniform axis, and multilinear interpolation
//! inside the cell. Tabulated BDFs (3D and 4D) and goniodiagram lights (2D) share it.
//!
//! Every lane runs the same fixed number of search steps (`ceil(log2(cells))`), so the
//! search has no branch that depends on the data: each step compares the probed node per
//! lane and moves the lane's lower bound with a select. The first three levels of the
//! search probe at most 1, 2 and 4 distinct nodes: those are kept in registers and picked
//! with selects on the earlier steps' outcomes, so only the later steps gather. Packets of
//! 8 and 16 pick the fourth level's node from its 8 candidates by the three outcomes too
//! ([`Lanes::pick8`]: selects, or a lane permute where the backend has one), so the
//! paper's 17 x 7 x 17 x 13 table needs no gather in its search at those widths.
//!
//! Values are kept one plane per channel, so that the gathers of a corner's channels share
//! their index (and, on backends without a hardware gather, its range check).
//!
//! Interpolation is exact at the grid nodes: the weight of a cell's upper node is clamped
//! to `[0, 1]` with the stored reciprocal widths rounded up so that a coordinate on the
//! last node gives exactly 1, and each lerp is `a * (1 - t) + b * t`, exact at `t = 0` and
//! `t = 1` (also when the backend fuses the multiply-add). Coordinates outside the axis clamp to its ends; NaN coordinates land on the
//! first node (indices always stay inside the table, so inactive lanes need no care).

// Index loops, not iterator adapters, in the per-packet code: it must inline into the
// backends' `#[target_feature]` entry points (a non-inlined `array::from_fn` made the AVX2 backend 7x slower).
#![allow(clippy::needless_range_loop)]

use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask};
use thiserror::Error;

/// What is wrong with an axis or a table's shape.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TableError {
    #[error("axis {axis}: {len} node(s), at least 2 are needed")]
    TooFewNodes { axis: usize, len: usize },
    #[error("axis {axis}: node {index} is {value}, not a finite number")]
    NonFiniteNode {
        axis: usize,
        index: usize,
        value: f32,
    },
    #[error(
        "axis {axis}: nodes must increase strictly, but node {index} ({value}) is not above node {} ({previous})",
        index - 1
    )]
    NonMonotonic {
        axis: usize,
        index: usize,
        previous: f32,
        value: f32,
    },
    #[error(
        "{values} values given, the axes ({shape:?}) times {channels} channel(s) need {expected}"
    )]
    WrongValueCount {
        shape: Vec<usize>,
        channels: usize,
        values: usize,
        expected: usize,
    },
    #[error("{channels} channels: 1 to {MAX_CHANNELS} are supported")]
    BadChannels { channels: usize },
    #[error("value {index} is {value}, not a finite number")]
    NonFiniteValue { index: usize, value: f32 },
    #[error("table of {values} values is too large (at most 2^24 nodes)")]
    TooLarge { values: usize },
}

/// Most channels a [`Grid`] interpolates (RGB).
pub const MAX_CHANNELS: usize = 3;

/// One axis of a table: strictly increasing nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    nodes: Vec<f32>,
    /// `1 / (nodes[i + 1] - nodes[i])`, rounded up so that `width * inv >= 1` in `f32`;
    /// padded with a last 0 to the length of `nodes` (so that both gathers with the same
    /// index share their range check).
    inv_widths: Vec<f32>,
    /// `nodes` and `inv_widths` interleaved (`[n0, inv0, n1, inv1, ...]`), so that one
    /// 64-bit gather per lane reads a probed node and its cell's reciprocal width.
    node_invs: Vec<f32>,
    /// The sequence of step sizes of the fixed-length binary search.
    halves: Vec<i32>,
    /// The eight nodes the fourth step may probe (of axes searched in four steps or more),
    /// by the first three outcomes: entry `4 a + 2 b + c` follows outcomes `a`, `b`, `c`
    /// (1 = moved up). Zero for shorter axes.
    fourth_nodes: [f32; 8],
    /// The reciprocal widths of the cells above `fourth_nodes`.
    fourth_invs: [f32; 8],
}

impl Axis {
    /// An axis over `nodes`; `axis` is the axis number used in error messages.
    pub fn new(axis: usize, nodes: Vec<f32>) -> Result<Self, TableError> {
        if nodes.len() < 2 {
            return Err(TableError::TooFewNodes {
                axis,
                len: nodes.len(),
            });
        }
        if nodes.len() > i32::MAX as usize / 2 {
            return Err(TableError::TooLarge {
                values: nodes.len(),
            });
        }
        for (index, &value) in nodes.iter().enumerate() {
            if !value.is_finite() {
                return Err(TableError::NonFiniteNode { axis, index, value });
            }
            if index > 0 && value <= nodes[index - 1] {
                return Err(TableError::NonMonotonic {
                    axis,
                    index,
                    previous: nodes[index - 1],
                    value,
                });
            }
        }
        let mut inv_widths: Vec<f32> = nodes
            .windows(2)
            .map(|w| {
                let width = w[1] - w[0];
                let mut inv = 1.0 / width;
                while width * inv < 1.0 {
                    inv = inv.next_up();
                }
                inv
            })
            .collect();
        inv_widths.push(0.0);
        let mut halves = Vec::new();
        let mut n = nodes.len() - 1;
        while n > 1 {
            let half = n / 2;
            halves.push(half as i32);
            n -= half;
        }
        if halves.is_empty() {
            // One cell: a step that never moves (probing node 0, which never lies above
            // a lane's lower bound 0) keeps the search code free of a special case.
            halves.push(0);
        }
        let node_invs = nodes
            .iter()
            .zip(&inv_widths)
            .flat_map(|(&n, &inv)| [n, inv])
            .collect();
        let (mut fourth_nodes, mut fourth_invs) = ([0.0; 8], [0.0; 8]);
        if let [h0, h1, h2, h3, ..] = halves[..] {
            for (i, (node, inv)) in fourth_nodes.iter_mut().zip(&mut fourth_invs).enumerate() {
                let up = |bit: usize, h: i32| if i >> bit & 1 == 1 { h } else { 0 };
                let probe = (up(2, h0) + up(1, h1) + up(0, h2) + h3) as usize;
                (*node, *inv) = (nodes[probe], inv_widths[probe]);
            }
        }
        Ok(Self {
            nodes,
            inv_widths,
            node_invs,
            halves,
            fourth_nodes,
            fourth_invs,
        })
    }

    /// The nodes.
    pub fn nodes(&self) -> &[f32] {
        &self.nodes
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Always false (an axis has at least two nodes); here for clippy's `len` rule.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Number of cells (`len - 1`).
    pub fn cells(&self) -> usize {
        self.nodes.len() - 1
    }

    /// First node.
    pub fn first(&self) -> f32 {
        self.nodes[0]
    }

    /// Last node.
    pub fn last(&self) -> f32 {
        self.nodes[self.nodes.len() - 1]
    }

    /// Number of search steps per lookup (the same for every lane).
    pub fn search_steps(&self) -> usize {
        self.halves.len()
    }

    /// Each lane's cell and the weight of the cell's upper node, by the branch-free
    /// N-wide binary search.
    #[inline(always)]
    pub fn locate<L: Lanes>(&self, l: L, x: L::F32s) -> Cell<L> {
        // One lane, and the 4-lane packets of SSE2-level backends (a select is three
        // instructions there and packets of 4 mostly share each axis's cell): read the
        // lower node back once after the search. Wider packets carry it (see below).
        if L::N <= 4 {
            return self.locate_coherent(l, x);
        }
        // Wider packets: the search carries each lane's lower node and reciprocal width along
        // with its index (a select each per step), so that no lane needs reading back
        // and no data-dependent branch is taken after the search.
        let h = &self.halves;
        let n = |i: i32| l.splat(self.nodes[i as usize]);
        let w = |i: i32| l.splat(self.inv_widths[i as usize]);
        let mut base = l.splat_i32(0);
        let mut lower = n(0);
        let mut inv = w(0);
        // Level 1: one node for every lane.
        let hit0 = n(h[0]).le(x);
        base = hit0.select_i32(l.splat_i32(h[0]), base);
        lower = hit0.select(n(h[0]), lower);
        inv = hit0.select(w(h[0]), inv);
        if h.len() > 1 {
            // Level 2: two candidate nodes, picked by level 1's outcome.
            let probe = hit0.select(n(h[0] + h[1]), n(h[1]));
            let probe_inv = hit0.select(w(h[0] + h[1]), w(h[1]));
            let hit1 = probe.le(x);
            base = hit1.select_i32(base + l.splat_i32(h[1]), base);
            lower = hit1.select(probe, lower);
            inv = hit1.select(probe_inv, inv);
            if h.len() > 2 {
                // Level 3: four candidates.
                let probe = hit0.select(
                    hit1.select(n(h[0] + h[1] + h[2]), n(h[0] + h[2])),
                    hit1.select(n(h[1] + h[2]), n(h[2])),
                );
                let probe_inv = hit0.select(
                    hit1.select(w(h[0] + h[1] + h[2]), w(h[0] + h[2])),
                    hit1.select(w(h[1] + h[2]), w(h[2])),
                );
                let hit2 = probe.le(x);
                base = hit2.select_i32(base + l.splat_i32(h[2]), base);
                lower = hit2.select(probe, lower);
                inv = hit2.select(probe_inv, inv);
                let mut rest = &h[3..];
                // Packets of 8 and 16: level 4 from its eight candidates by the three
                // outcomes (`Lanes::pick8`: selects, or a lane permute where the backend has
                // one), not by a gather, which waits for level 3's outcome and then for
                // memory. Measured (`kernels`, BDF, Zen 4): avx2 5.4x -> 5.9-6.1x over
                // the scalar loop as it was then (it got faster since);
                // docs/findings/backends.md has the rest.
                if L::N >= 8 && h.len() > 3 {
                    let probe = l.pick8(&self.fourth_nodes, hit0, hit1, hit2);
                    let probe_inv = l.pick8(&self.fourth_invs, hit0, hit1, hit2);
                    let hit3 = probe.le(x);
                    base = hit3.select_i32(base + l.splat_i32(h[3]), base);
                    lower = hit3.select(probe, lower);
                    inv = hit3.select(probe_inv, inv);
                    rest = &h[4..];
                }
                // Further levels gather the probed node and its width per lane, one
                // 64-bit gather for both (axes are short: backends with slow gathers may
                // read the whole axis into registers instead).
                for &half in rest {
                    let probe = base + l.splat_i32(half);
                    let (node, node_inv) = l.gather2_near(&self.node_invs, probe + probe);
                    let hit = node.le(x);
                    base = hit.select_i32(probe, base);
                    lower = hit.select(node, lower);
                    inv = hit.select(node_inv, inv);
                }
            }
        }
        let t = ((x - lower) * inv).clamp(l.splat(0.0), l.splat(1.0));
        Cell { index: base, t }
    }

    /// [`Axis::locate`] as used for one lane and packets of 4: find the index, then read
    /// its node once when every lane shares it (gather it otherwise). Gives the same cells
    /// and weights.
    #[inline(always)]
    pub fn locate_coherent<L: Lanes>(&self, l: L, x: L::F32s) -> Cell<L> {
        let h = &self.halves;
        let n = |i: i32| l.splat(self.nodes[i as usize]);
        let mut base = l.splat_i32(0);
        // Level 1: one node for every lane.
        let hit0 = n(h[0]).le(x);
        base = hit0.select_i32(l.splat_i32(h[0]), base);
        if h.len() > 1 {
            // Level 2: two candidate nodes, picked by level 1's outcome.
            let probe = hit0.select(n(h[0] + h[1]), n(h[1]));
            let hit1 = probe.le(x);
            base = hit1.select_i32(base + l.splat_i32(h[1]), base);
            if h.len() > 2 {
                // Level 3: four candidates.
                let probe = hit0.select(
                    hit1.select(n(h[0] + h[1] + h[2]), n(h[0] + h[2])),
                    hit1.select(n(h[1] + h[2]), n(h[2])),
                );
                let hit2 = probe.le(x);
                base = hit2.select_i32(base + l.splat_i32(h[2]), base);
                // Further levels gather the probed node per lane.
                for &half in &h[3..] {
                    let probe = base + l.splat_i32(half);
                    let hit = l.gather(&self.nodes, probe).le(x);
                    base = hit.select_i32(probe, base);
                }
            }
        }
        // Coherent packets mostly share the cell: then read its node once.
        let b0 = base.lane(0);
        let (lower, inv) = if base.eq(l.splat_i32(b0)).all() {
            (
                l.splat(self.nodes[b0 as usize]),
                l.splat(self.inv_widths[b0 as usize]),
            )
        } else {
            (
                l.gather(&self.nodes, base),
                l.gather(&self.inv_widths, base),
            )
        };
        let t = ((x - lower) * inv).clamp(l.splat(0.0), l.splat(1.0));
        Cell { index: base, t }
    }

    /// The scalar reference of [`Axis::locate`] (a plain `partition_point`), for tests.
    pub fn locate1(&self, x: f32) -> (usize, f32) {
        let i = self
            .nodes
            .partition_point(|&n| n <= x)
            .saturating_sub(1)
            .min(self.cells() - 1);
        let t = ((x - self.nodes[i]) * self.inv_widths[i]).clamp(0.0, 1.0);
        (i, if t.is_nan() { 0.0 } else { t })
    }
}

/// A lane's cell on one axis: the index of the cell's lower node and the weight of its
/// upper node.
#[derive(Debug, Clone, Copy)]
pub struct Cell<L: Lanes> {
    pub index: L::I32s,
    pub t: L::F32s,
}

/// A table over `D` non-uniform axes with `channels` values per node, stored row-major
/// (axis 0 slowest, channels innermost).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid<const D: usize> {
    axes: [Axis; D],
    channels: usize,
    values: Vec<f32>,
    /// The same values one plane per channel: channel `c` of node `i` at
    /// `planes[c * nodes + i]`.
    planes: Vec<f32>,
    /// Number of nodes.
    nodes: usize,
    /// Distance in nodes between neighbours along each axis.
    strides: [usize; D],
    /// Offset in nodes of each corner of a cell, relative to its lower corner
    /// (bit `k` of the corner number set = upper node on axis `k`).
    corner_offsets: Vec<i32>,
}

impl<const D: usize> Grid<D> {
    /// A table over `axes`; `values` holds `channels` numbers per node, row-major.
    /// Values must be finite.
    pub fn new(axes: [Axis; D], channels: usize, values: Vec<f32>) -> Result<Self, TableError> {
        if channels == 0 || channels > MAX_CHANNELS {
            return Err(TableError::BadChannels { channels });
        }
        let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
        let expected = shape.iter().product::<usize>() * channels;
        if values.len() != expected {
            return Err(TableError::WrongValueCount {
                shape,
                channels,
                values: values.len(),
                expected,
            });
        }
        // Node indices are computed in f32: keep them exact.
        if expected / channels >= 1 << 24 {
            return Err(TableError::TooLarge { values: expected });
        }
        if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(TableError::NonFiniteValue { index, value });
        }
        let mut strides = [0usize; D];
        let mut stride = 1;
        for k in (0..D).rev() {
            strides[k] = stride;
            stride *= axes[k].len();
        }
        let corner_offsets = (0..1usize << D)
            .map(|c| {
                (0..D)
                    .filter(|k| c >> (D - 1 - k) & 1 == 1)
                    .map(|k| strides[k] as i32)
                    .sum()
            })
            .collect();
        let nodes = expected / channels;
        let planes = (0..channels)
            .flat_map(|c| values.iter().skip(c).step_by(channels).copied())
            .collect();
        Ok(Self {
            axes,
            channels,
            values,
            planes,
            nodes,
            strides,
            corner_offsets,
        })
    }

    /// The axes.
    pub fn axes(&self) -> &[Axis; D] {
        &self.axes
    }

    /// Values per node.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// All values, row-major, channels innermost.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The values of the node with indices `at`.
    pub fn node(&self, at: [usize; D]) -> &[f32] {
        let i: usize = (0..D).map(|k| at[k] * self.strides[k]).sum::<usize>() * self.channels;
        &self.values[i..i + self.channels]
    }

    /// Each lane's cell on every axis.
    #[inline(always)]
    pub fn locate<L: Lanes>(&self, l: L, x: [L::F32s; D]) -> [Cell<L>; D] {
        // Plain loops, not `array::from_fn`: everything here must inline into the
        // backend's `#[target_feature]` entry point (a non-inlined helper loses AVX).
        let mut cells = [Cell {
            index: l.splat_i32(0),
            t: l.splat(0.0),
        }; D];
        for k in 0..D {
            cells[k] = self.axes[k].locate(l, x[k]);
        }
        cells
    }

    /// Multilinear interpolation of channel `c` (and, when `out` is longer, of the
    /// following channels) in the cells `cells`: writes `out.len().min(channels)` values.
    #[inline(always)]
    pub fn interpolate<L: Lanes>(&self, l: L, cells: &[Cell<L>; D], out: &mut [L::F32s]) {
        // Index of each lane's lower corner, in floating point (exact: tables stay below
        // 2^24 nodes) to spare the integer multiplies SSE2 lacks.
        let mut base = cells[0].index.to_f32() * self.strides[0] as f32;
        for k in 1..D {
            base = cells[k]
                .index
                .to_f32()
                .mul_add(l.splat(self.strides[k] as f32), base);
        }
        let base = base.to_i32();
        // Coherent packets fall in few cells (Table 1's packets of 16: one cell in half of
        // them, at most three in 96%): then each cell's 2^D nodes are read once, splatted
        // and selected into its lanes, instead of gathered lane by lane. More cells than
        // `cap` and the packet gathers.
        let cap = L::N / 4 + 1;
        let mut bases = [0usize; 16];
        let mut masks = [l.splat_mask(false); 16];
        // The first cell is lane 0's: a fixed lane, read without a search.
        let first = base.lane(0);
        masks[0] = base.eq(l.splat_i32(first));
        bases[0] = first as usize;
        let mut cells_seen = 1;
        let mut todo = !masks[0];
        while todo.any() && cells_seen < cap.min(16) {
            let b = base.lane(todo.bitmask().trailing_zeros() as usize);
            let mine = base.eq(l.splat_i32(b));
            bases[cells_seen] = b as usize;
            masks[cells_seen] = mine;
            todo = todo.and_not(mine);
            cells_seen += 1;
        }
        let splat = todo.none();
        // Offsets of each pair of neighbouring corners from the lower corner; the last
        // pair's end is the span of a cell's nodes.
        let mut pair_offsets = [0usize; 8];
        for pair in 0..1 << (D - 1) {
            pair_offsets[pair] = self.corner_offsets[2 * pair] as usize;
        }
        let span = pair_offsets[(1 << (D - 1)) - 1] + 2;
        let one = l.splat(1.0);
        // The last axis's lerp joins each pair as soon as it is read, so that 2^(D-1)
        // values, not 2^D, wait for the other axes: the same operations on the same values
        // (bit for bit as before), fewer of them live at once (`bdf_anisotropic`, Intel
        // host, six runs against two: sse 28.8-29.5 -> 27.2-27.5 ms, pulp8 17.8-18.0 -> 15.9-16.6,
        // pulp16 9.5-10.0 -> 7.7-8.3; avx2 14.3-14.9 -> 14.1-14.5).
        let t_last = cells[D - 1].t;
        let s_last = one - t_last;
        let channels = out.len().min(self.channels);
        for c in 0..channels {
            let plane = &self.planes[c * self.nodes..(c + 1) * self.nodes];
            // The 2^D corners, lerped down one axis at a time, last axis first (corner bit
            // 0 is the last axis, so corners `2p` and `2p + 1` are neighbouring nodes:
            // one read serves both, and their lerp gives `v[p]`).
            let mut v = [l.splat(0.0); 8];
            if splat && L::N == 1 {
                // One lane (the scalar baseline): its cell's nodes as one slice, one range
                // check instead of one per pair (10-12% faster there; used for packets too,
                // it made sse and pulp 5-8% slower: see docs/findings/scalar-baseline.md).
                // All corners are read before the first lerp: in that order LLVM's SLP
                // vectoriser packs 80 operations of one call, as before the packets'
                // pair-first lerp, not 50.
                let cell = &plane[bases[0]..bases[0] + span];
                let mut corners = [(l.splat(0.0), l.splat(0.0)); 8];
                for pair in 0..1 << (D - 1) {
                    let off = pair_offsets[pair];
                    corners[pair] = (l.splat(cell[off]), l.splat(cell[off + 1]));
                }
                for pair in 0..1 << (D - 1) {
                    let (lo, hi) = corners[pair];
                    v[pair] = lo.mul_add(s_last, hi * t_last);
                }
            } else if splat {
                for pair in 0..1 << (D - 1) {
                    let off = self.corner_offsets[2 * pair] as usize;
                    let at = bases[0] + off;
                    let block = &plane[at..at + 2];
                    let mut lo = l.splat(block[0]);
                    let mut hi = l.splat(block[1]);
                    for j in 1..cells_seen {
                        let at = bases[j] + off;
                        let block = &plane[at..at + 2];
                        lo = masks[j].select(l.splat(block[0]), lo);
                        hi = masks[j].select(l.splat(block[1]), hi);
                    }
                    v[pair] = lo.mul_add(s_last, hi * t_last);
                }
            } else {
                for pair in 0..1 << (D - 1) {
                    let corner = base + l.splat_i32(self.corner_offsets[2 * pair]);
                    let (lo, hi) = l.gather2(plane, corner);
                    v[pair] = lo.mul_add(s_last, hi * t_last);
                }
            }
            let mut n = 1usize << (D - 1);
            for k in (0..D - 1).rev() {
                let t = cells[k].t;
                let s = one - t;
                n /= 2;
                for j in 0..n {
                    // Exact at t = 0 and t = 1, fused or not.
                    v[j] = v[2 * j].mul_add(s, v[2 * j + 1] * t);
                }
            }
            out[c] = v[0];
        }
    }

    /// The scalar reference of [`Grid::interpolate`]: multilinear interpolation with
    /// weights as products, using [`Axis::locate1`], for tests.
    pub fn interpolate1(&self, x: [f32; D]) -> Vec<f32> {
        let cells: [(usize, f32); D] = core::array::from_fn(|k| self.axes[k].locate1(x[k]));
        let mut out = vec![0.0f64; self.channels];
        for corner in 0..1usize << D {
            let mut w = 1.0f64;
            let mut at = [0usize; D];
            for k in 0..D {
                let upper = corner >> (D - 1 - k) & 1 == 1;
                at[k] = cells[k].0 + upper as usize;
                w *= if upper {
                    cells[k].1 as f64
                } else {
                    1.0 - cells[k].1 as f64
                };
            }
            for (c, o) in out.iter_mut().enumerate() {
                *o += w * self.node(at)[c] as f64;
            }
        }
        out.into_iter().map(|v| v as f32).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;

    fn axis(nodes: &[f32]) -> Axis {
        Axis::new(0, nodes.to_vec()).unwrap()
    }

    #[test]
    fn locate_matches_partition_point() {
        for len in 2..40 {
            let nodes: Vec<f32> = (0..len).map(|i| (i as f32).powf(1.7) * 0.3 - 2.0).collect();
            let a = axis(&nodes);
            let mut x = nodes[0] - 1.0;
            while x < nodes[len - 1] + 1.0 {
                let c = a.locate(Scalar, x);
                let (i, t) = a.locate1(x);
                assert_eq!(c.index.0 as usize, i, "len {len} x {x}");
                assert_eq!(c.t, t, "len {len} x {x}");
                x += 0.037;
            }
            for (i, &n) in nodes.iter().enumerate() {
                let c = a.locate(Scalar, n);
                if i + 1 < len {
                    assert_eq!((c.index.0 as usize, c.t), (i, 0.0));
                } else {
                    assert_eq!((c.index.0 as usize, c.t), (i - 1, 1.0));
                }
            }
        }
    }

    #[test]
    fn nan_lands_on_first_node() {
        let a = axis(&[0.0, 1.0, 3.0]);
        let c = a.locate(Scalar, f32::NAN);
        assert_eq!((c.index.0, c.t), (0, 0.0));
    }

    #[test]
    fn bad_axes_are_rejected() {
        assert_eq!(
            Axis::new(2, vec![1.0]),
            Err(TableError::TooFewNodes { axis: 2, len: 1 })
        );
        let e = Axis::new(1, vec![0.0, 2.0, 2.0]).unwrap_err();
        assert!(matches!(
            e,
            TableError::NonMonotonic {
                axis: 1,
                index: 2,
                ..
            }
        ));
        assert!(e.to_string().contains("increase strictly"), "{e}");
        assert!(matches!(
            Axis::new(0, vec![0.0, f32::NAN]),
            Err(TableError::NonFiniteNode { index: 1, .. })
        ));
    }

    #[test]
    fn grid_checks_shape() {
        let e = Grid::new([axis(&[0.0, 1.0]), axis(&[0.0, 1.0, 2.0])], 1, vec![0.0; 5]);
        assert!(matches!(
            e,
            Err(TableError::WrongValueCount { expected: 6, .. })
        ));
        let e = Grid::new([axis(&[0.0, 1.0])], 1, vec![0.0, f32::INFINITY]);
        assert!(matches!(
            e,
            Err(TableError::NonFiniteValue { index: 1, .. })
        ));
    }

    #[test]
    fn bilinear_reproduces_a_bilinear_function() {
        let ax = axis(&[0.0, 0.5, 2.0, 2.25]);
        let ay = axis(&[-1.0, 0.0, 4.0]);
        let f = |x: f32, y: f32| 1.0 + 2.0 * x - 3.0 * y + 0.5 * x * y;
        let mut values = Vec::new();
        for &x in ax.nodes() {
            for &y in ay.nodes() {
                values.push(f(x, y));
                values.push(2.0 * f(x, y));
            }
        }
        let g = Grid::new([ax, ay], 2, values).unwrap();
        for i in 0..50 {
            let x = i as f32 * 0.045;
            let y = -1.0 + i as f32 * 0.1;
            let cells = g.locate(Scalar, [x, y]);
            let mut out = [0.0; 2];
            g.interpolate(Scalar, &cells, &mut out);
            assert!(
                (out[0] - f(x, y)).abs() < 1e-4,
                "{x} {y}: {} vs {}",
                out[0],
                f(x, y)
            );
            assert!((out[1] - 2.0 * f(x, y)).abs() < 2e-4);
            let r = g.interpolate1([x, y]);
            assert!((out[0] - r[0]).abs() < 1e-5);
        }
    }
}
