//! The two screen matrices of the progressive film (paper section 6.2): each holds a colour
//! sum and a sample count per pixel; a pixel's samples go alternately to one and the other,
//! and the difference of their estimates measures the accuracy.

use rayon::prelude::*;

use super::accuracy::display_difference;
use super::spare;
use super::superpixel::Superpixels;
use crate::tonemap::ToneMap;

/// Which matrix sample number `k` of pixel `p` goes to. Not simply `k % 2`: a pixel's
/// Halton samples of even and odd `k` lie in its left and right halves (the lowest binary
/// digit of the index above the tile's digits is `k`'s), so the two matrices would estimate
/// different things and never agree at an edge. Each pair `(2j, 2j + 1)` is split between
/// the matrices, which one gets the first decided by a hash of `(p, j)`: each matrix gets
/// half the samples, stratified in expectation.
#[inline]
pub fn matrix_of(p: u64, k: u64) -> usize {
    let mut h =
        p.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (k >> 1).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 31;
    h = h.wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^= h >> 29;
    ((k ^ (h >> 7)) & 1) as usize
}

/// Colour sums and sample counts per pixel.
///
/// The sums are `f32`, as the paper's screen matrices hold colours. The matrices are a
/// frame's largest allocation, fresh pages every frame, and each page costs a fault: at
/// 1024 x 768 they are 25 MB with `f32` sums against 44 MB with `f64` ones, and a
/// single-thread `coherent render cornell` took 10,118 page faults instead of 14,730. A
/// pixel's sum of `n` samples has a relative rounding error below `n * 2^-24`: under 4e-6 at
/// the adaptive method's default cap of 64 samples per pixel, far below a display step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScreenMatrix {
    pub sum: Vec<[f32; 3]>,
    pub count: Vec<u32>,
}

impl ScreenMatrix {
    /// Zeroed by writing, in parallel on the current rayon pool. `vec![0; n]` would map the
    /// system's shared zero page, and the first `+=` of each page would then copy it and
    /// flush the other threads' TLBs (an interrupt to every CPU of the pool, per page):
    /// with the samples filed in parallel, that made 2 threads slower than 1.
    fn new(pixels: usize) -> ScreenMatrix {
        let mut sum = Vec::with_capacity(pixels);
        sum.par_extend(rayon::iter::repeat_n([0.0f32; 3], pixels));
        let mut count = Vec::with_capacity(pixels);
        count.par_extend(rayon::iter::repeat_n(0u32, pixels));
        ScreenMatrix { sum, count }
    }
    /// Zeroed again, in parallel on the current rayon pool (pages the matrix already has: no
    /// faults, see [`spare`]).
    fn clear(&mut self) {
        const CHUNK: usize = 1 << 14;
        self.sum
            .par_chunks_mut(CHUNK)
            .for_each(|c| c.fill([0.0; 3]));
        self.count.par_chunks_mut(CHUNK).for_each(|c| c.fill(0));
    }
    /// Pixels the matrix holds.
    pub fn pixels(&self) -> usize {
        self.sum.len()
    }
    /// Mean colour of pixel `p` (zero without samples).
    pub fn mean(&self, p: usize) -> [f32; 3] {
        let n = self.count[p];
        if n == 0 {
            return [0.0; 3];
        }
        let s = self.sum[p];
        let k = 1.0 / n as f64;
        s.map(|c| (c as f64 * k) as f32)
    }
}

/// The film: two screen matrices (always the image's resolution), the superpixel corners
/// and which pixels are interpolated from them.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub matrices: [ScreenMatrix; 2],
    pub superpixels: Superpixels,
    /// Pixels whose value is interpolated from their superpixel's corners (until they have
    /// samples in both matrices).
    pub interpolated: Vec<bool>,
    /// The tone mapping the accuracy is measured through (see [`display_difference`]).
    pub tonemap: ToneMap,
}

impl Film {
    pub(crate) fn new(width: u32, height: u32, superpixels: Superpixels, tonemap: ToneMap) -> Film {
        let n = width as usize * height as usize;
        let matrices = match spare::take(n) {
            Some(mut m) => {
                m.iter_mut().for_each(ScreenMatrix::clear);
                m
            }
            None => [ScreenMatrix::new(n), ScreenMatrix::new(n)],
        };
        Film {
            width,
            height,
            matrices,
            superpixels,
            interpolated: vec![false; n],
            tonemap,
        }
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Samples in pixel `p`, both matrices.
    pub fn samples(&self, p: usize) -> u32 {
        self.matrices[0].count[p] + self.matrices[1].count[p]
    }

    /// Where the film's rows lie, for [`FilmLines::prefetch`] while the rows are lent out as
    /// bands.
    pub(crate) fn lines(&self) -> FilmLines {
        let [a, b] = &self.matrices;
        FilmLines {
            width: self.width as usize,
            sums: [a.sum.as_ptr() as usize, b.sum.as_ptr() as usize],
            counts: [a.count.as_ptr() as usize, b.count.as_ptr() as usize],
        }
    }

    /// The film cut into bands of `rows` whole rows each (the last may be shorter), in order
    /// from the top: each owns its rows of both matrices, so bands can be filled in parallel.
    pub(crate) fn bands(&mut self, rows: u32) -> Vec<FilmBand<'_>> {
        let n = rows.max(1) as usize * self.width as usize;
        let [a, b] = &mut self.matrices;
        a.sum
            .chunks_mut(n)
            .zip(a.count.chunks_mut(n))
            .zip(b.sum.chunks_mut(n).zip(b.count.chunks_mut(n)))
            .enumerate()
            .map(|(i, ((sa, ca), (sb, cb)))| FilmBand {
                first: i * n,
                sums: [sa, sb],
                counts: [ca, cb],
            })
            .collect()
    }

    /// The display difference of the two matrices' estimates at `p`, or `None` unless both
    /// have samples there.
    pub fn error(&self, p: usize) -> Option<f32> {
        let [a, b] = &self.matrices;
        // `&`, not `&&`: which matrix a pixel's first sample went to is a coin flip (see
        // [`matrix_of`]), and a branch on it was mispredicted for half the pixels (5 ms of a
        // 1024 x 768 pass, one thread).
        ((a.count[p] > 0) & (b.count[p] > 0))
            .then(|| display_difference(&self.tonemap, a.mean(p), b.mean(p)))
    }

    /// Per channel, how far apart the two matrices' means of pixel `p` are on the display
    /// (`std` maths; infinite when the pre-render was black and they differ), or `None` until
    /// the pixel has samples in both.
    pub fn difference(&self, p: usize) -> Option<[f32; 3]> {
        let [a, b] = &self.matrices;
        // `|` for the reason `error` gives.
        if (a.count[p] == 0) | (b.count[p] == 0) {
            return None;
        }
        let (x, y) = (a.mean(p), b.mean(p));
        if self.tonemap.is_black() {
            let d = if x == y { 0.0 } else { f32::INFINITY };
            return Some([d; 3]);
        }
        let (x, y) = (self.tonemap.apply_exact(x), self.tonemap.apply_exact(y));
        Some(std::array::from_fn(|c| {
            let r = (x[c] - y[c]).abs();
            if r.is_nan() { f32::INFINITY } else { r }
        }))
    }

    /// The estimate of pixel `p`: the mean of all its samples; the superpixel interpolation
    /// until it has one. A pixel's own sample beats its superpixel's corners: the corners
    /// miss what lies between them, which the adaptive passes go on to check.
    pub fn pixel(&self, p: usize) -> [f32; 3] {
        let n = self.samples(p);
        if n == 0 {
            let (x, y) = (p as u32 % self.width, p as u32 / self.width);
            return self.superpixels.interpolate(x, y);
        }
        let mut c = [0.0f64; 3];
        for m in &self.matrices {
            for (ci, s) in c.iter_mut().zip(m.sum[p]) {
                *ci += s as f64;
            }
        }
        let k = 1.0 / n as f64;
        [(c[0] * k) as f32, (c[1] * k) as f32, (c[2] * k) as f32]
    }

    /// The whole image, row by row.
    pub fn estimate(&self) -> Vec<[f32; 3]> {
        (0..self.pixels()).map(|p| self.pixel(p)).collect()
    }
}

impl Drop for Film {
    /// The matrices go to the next film of this size (see `spare`).
    fn drop(&mut self) {
        spare::keep(std::mem::take(&mut self.matrices));
    }
}

/// The addresses of a [`Film`]'s matrices (numbers, not pointers: nothing reads through
/// them), to prefetch the cache lines a tile is about to file into.
///
/// A tile's samples land on pixels in Halton order, so filing them is a read-modify-write
/// of scattered lines of four arrays (the sums and counts of both matrices) that the
/// hardware prefetcher cannot predict, and a 1024 x 768 film (25 MB) is far from the core's
/// cache: filing took 10.6 ms of a single-thread avx512 `cornell_pov` frame, 786,432
/// samples, 7.5 ms of it in [`FilmBand::add`]. Asked for before the tile is traced, the
/// lines are there when it files.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FilmLines {
    width: usize,
    sums: [usize; 2],
    counts: [usize; 2],
}

impl FilmLines {
    /// Prefetches the lines of the film's pixels `x0..x1` of rows `y0..y1` (inside the
    /// film) in both matrices.
    pub(crate) fn prefetch(&self, x0: u32, x1: u32, y0: u32, y1: u32) {
        const LINE: usize = 64;
        for y in y0 as usize..y1 as usize {
            let (first, last) = (y * self.width + x0 as usize, y * self.width + x1 as usize);
            for (base, size) in self
                .sums
                .iter()
                .map(|&b| (b, size_of::<[f32; 3]>()))
                .chain(self.counts.iter().map(|&b| (b, size_of::<u32>())))
            {
                let (start, end) = (base + first * size, base + last * size);
                let mut a = start & !(LINE - 1);
                while a < end {
                    prefetch(a);
                    a += LINE;
                }
            }
        }
    }
}

/// A hint that the line at address `a` will be read soon. Never a memory access: an address
/// outside the process is ignored, so nothing here needs to be valid.
#[inline(always)]
fn prefetch(a: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `prefetcht0` only hints the cache; it does not fault and reads nothing the
    // program sees, whatever the address. SSE is part of x86-64's baseline.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(a as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = a;
}

/// Whole rows of a [`Film`]'s two matrices (from [`Film::bands`]), where the samples of
/// pixels in these rows are filed.
pub(crate) struct FilmBand<'a> {
    /// The pixel index of the band's first pixel.
    first: usize,
    sums: [&'a mut [[f32; 3]]; 2],
    counts: [&'a mut [u32]; 2],
}

impl FilmBand<'_> {
    /// Adds sample number `k` of pixel `p` (a pixel of this band) to matrix
    /// [`matrix_of`]`(p, k)`.
    #[inline]
    pub(crate) fn add(&mut self, p: usize, k: u64, c: [f32; 3]) {
        let m = matrix_of(p as u64, k);
        let i = p - self.first;
        self.counts[m][i] += 1;
        for (s, v) in self.sums[m][i].iter_mut().zip(c) {
            *s += v;
        }
    }
}
