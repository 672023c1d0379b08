//! The environment light (section 5, Figure 5's HDR panorama): a latitude-longitude RGB
//! radiance map, read from OpenEXR, around the scene. It is a light with a fixed number
//! of samples per shading point, each drawn by importance from a 2D distribution over the
//! map (a marginal distribution over rows and one conditional per row, texel weights =
//! luminance times `sin(theta)`), found per lane from a guide table of each cumulative
//! table and a binary search inside the guide's bounds (`Environment::search`). Rays that
//! miss everything see the map ([`Environment::radiance`], nearest texel, the same
//! piecewise-constant map the sampling assumes).
//!
//! The samples are stratified: the unit square of random numbers is cut into a grid of as
//! many cells as samples ([`strata_grid`]), and sample `k` of every shading point is drawn
//! in cell `k` (its own numbers place it inside the cell). Each cell has the same
//! probability, so the estimate stays unbiased and its variance can only fall. The reason
//! it is done here is coherence, the paper's theme: the importance warp is monotone in
//! both numbers, so sample `k` of every lane of a packet lands in the same part of the
//! map, and the packet's shadow rays leave in similar directions instead of over the whole
//! sphere (as the paper's surface lights share their fixed points, section 3).
//!
//! Map layout: column `i` of `w` covers azimuth `phi` in `[2 pi i / w, 2 pi (i + 1) / w)`,
//! row `j` of `h` covers `theta` (from the up axis) in `[pi j / h, pi (j + 1) / h)`; the
//! direction of `(theta, phi)` is `sin(theta) (cos(phi) x + sin(phi) y) + cos(theta) up`,
//! with `x` the light's forward axis (`phi = 0`).

// Index loops in per-packet code (see `tabulated`).
#![allow(clippy::needless_range_loop)]

use std::path::Path;
use std::sync::Arc;

use coherent_simd::{Lanes, Rgbs, SimdF32, SimdI32, SimdMask, Vec3s};
use glam::Vec3;

use super::sincos::sincos;
use super::{LightError, LightSample, check_dir, check_samples, finish};
use crate::approx::{acos, atan2};

/// A map has fewer texels than this.
pub const MAX_TEXELS: usize = 1 << 24;

/// Default samples per shading point.
pub const DEFAULT_SAMPLES: u32 = 16;

/// The map and its sampling tables (shared by clones).
#[derive(Debug, PartialEq)]
struct Map {
    width: usize,
    height: usize,
    /// Per texel `j * w + i`, its radiance and its density over the unit square of map
    /// coordinates, side by side: `texels[4 (j * w + i) ..][..4]` is `[r, g, b, pdf]`. A
    /// sample reads all four of its texel, from one cache line instead of four planes'.
    texels: Vec<f32>,
    /// Marginal CDF over rows: `h + 1` values, 0 to 1.
    marginal: Vec<f32>,
    /// Conditional CDFs per row: `h` runs of `w + 1` values, 0 to 1.
    conditional: Vec<f32>,
    /// Guide tables of the marginal CDF (`row_buckets + 1` entries) and of each row's
    /// conditional CDF (`h` runs of `col_buckets + 1`): see [`guide`].
    marginal_guide: Vec<u32>,
    conditional_guide: Vec<u32>,
    row_buckets: usize,
    col_buckets: usize,
}

/// An HDR latitude-longitude map as a light.
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    map: Arc<Map>,
    /// The map's x (phi = 0), y (phi = pi/2) and up axes in world space.
    axes: [Vec3; 3],
    scale: f32,
    samples: u32,
    /// The strata grid of the samples: cells along the column number and the row number.
    strata: [u32; 2],
    /// Negative channels set to zero when loaded.
    clamped: usize,
}

/// The grid of `samples` strata over the unit square of random numbers: `[columns, rows]`,
/// as square as `samples` allows, with at least as many rows (cells along the number that
/// picks the map's row) as columns. A prime count is stratified along rows only.
pub fn strata_grid(samples: u32) -> [u32; 2] {
    let samples = samples.max(1);
    let columns = (1..=samples)
        .take_while(|d| d * d <= samples)
        .filter(|d| samples.is_multiple_of(*d))
        .last()
        .unwrap_or(1);
    [columns, samples / columns]
}

/// The guide table (Chen and Asau's cutpoints) of a CDF of `n + 1` values over `n` cells:
/// `buckets + 1` entries, entry `g` the largest cell `j` in `0..n` with `cdf[j] <= g /
/// buckets`. A number `u` in bucket `g = floor(u buckets)` has its cell between entries `g`
/// and `g + 1`. `buckets` is a power of two, so that `g / buckets` and `u * buckets` are
/// exact in `f32` and the bucket of `u` is never off by one.
fn guide(cdf: &[f32], buckets: usize, out: &mut Vec<u32>) {
    debug_assert!(buckets.is_power_of_two() && cdf.len() >= 2);
    let n = cdf.len() - 1;
    let mut j = 0;
    for g in 0..=buckets {
        let x = g as f32 / buckets as f32;
        while j + 1 < n && cdf[j + 1] <= x {
            j += 1;
        }
        out.push(j as u32);
    }
}

/// Guide buckets for `n` cells: the power of two at least `2 n` (at most one or two cells
/// per bucket where the weights are even).
fn buckets(n: usize) -> usize {
    (2 * n).next_power_of_two()
}

/// Turns weights into a CDF (`len + 1` values from 0 to 1); all-zero weights give a
/// uniform CDF. Returns the sum.
fn cdf(weights: &[f64], out: &mut Vec<f32>) -> f64 {
    let sum: f64 = weights.iter().sum();
    let mut acc = 0.0f64;
    out.push(0.0);
    for (k, &w) in weights.iter().enumerate() {
        acc += w;
        let v = if sum > 0.0 {
            acc / sum
        } else {
            (k + 1) as f64 / weights.len() as f64
        };
        out.push(v as f32);
    }
    *out.last_mut().unwrap() = 1.0;
    sum
}

impl Environment {
    /// A map of `width * height` RGB texels (rows from the up pole down), radiance scaled
    /// by `scale`, oriented by `up` and `forward` (made orthogonal to `up`), with `samples`
    /// samples per shading point. `name` is used in errors.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        width: usize,
        height: usize,
        texels: &[[f32; 3]],
        scale: f32,
        up: Vec3,
        forward: Vec3,
        samples: u32,
    ) -> Result<Self, LightError> {
        let file = |problem: String| LightError::File {
            path: name.into(),
            problem,
        };
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(file(format!(
                "{width} x {height} map with {} texels",
                texels.len()
            )));
        }
        if width * height >= MAX_TEXELS {
            return Err(file(format!("{width} x {height} map: at most 2^24 texels")));
        }
        if let Some((k, t)) = texels
            .iter()
            .enumerate()
            .find(|(_, t)| !t.iter().all(|c| c.is_finite() && *c >= 0.0))
        {
            return Err(file(format!(
                "texel ({}, {}) is {t:?}: radiance must be finite and non-negative",
                k % width,
                k / width
            )));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(LightError::bad(
                "environment",
                "scale",
                scale,
                "not finite and non-negative",
            ));
        }
        check_samples("environment", "samples", u64::from(samples), samples)?;
        let ez = check_dir("environment", "up", up)?;
        let ex =
            check_dir("environment", "forward", forward - ez * forward.dot(ez)).map_err(|_| {
                LightError::bad("environment", "forward", forward, "parallel to up or zero")
            })?;
        let ey = ez.cross(ex);
        let (w, h) = (width, height);
        // Weights: luminance times sin(theta) at the row's centre (the solid angle of a
        // texel), so that bright and large texels are drawn more often.
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut row_sums = Vec::with_capacity(h);
        let mut weights = vec![0.0f64; w];
        for j in 0..h {
            let sin = ((j as f64 + 0.5) * std::f64::consts::PI / h as f64).sin();
            for i in 0..w {
                let t = texels[j * w + i];
                let lum = 0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64;
                weights[i] = lum * sin;
            }
            row_sums.push(cdf(&weights, &mut conditional));
        }
        let mut marginal = Vec::with_capacity(h + 1);
        cdf(&row_sums, &mut marginal);
        let (row_buckets, col_buckets) = (buckets(h), buckets(w));
        let mut marginal_guide = Vec::with_capacity(row_buckets + 1);
        guide(&marginal, row_buckets, &mut marginal_guide);
        let mut conditional_guide = Vec::with_capacity(h * (col_buckets + 1));
        for row in conditional.chunks_exact(w + 1) {
            guide(row, col_buckets, &mut conditional_guide);
        }
        // Density over the unit square: the probability of the texel (product of its row's
        // and its column's CDF steps, as sampled) times w h.
        let mut interleaved = vec![0.0f32; 4 * w * h];
        for j in 0..h {
            let pr = (marginal[j + 1] - marginal[j]) as f64;
            for i in 0..w {
                let pc = (conditional[j * (w + 1) + i + 1] - conditional[j * (w + 1) + i]) as f64;
                let k = j * w + i;
                let [r, g, b] = texels[k].map(|c| c * scale);
                let pdf = (pr * pc * (w * h) as f64) as f32;
                interleaved[4 * k..4 * k + 4].copy_from_slice(&[r, g, b, pdf]);
            }
        }
        Ok(Environment {
            map: Arc::new(Map {
                width: w,
                height: h,
                texels: interleaved,
                marginal,
                conditional,
                marginal_guide,
                conditional_guide,
                row_buckets,
                col_buckets,
            }),
            axes: [ex, ey, ez],
            scale,
            samples,
            strata: strata_grid(samples),
            clamped: 0,
        })
    }

    /// A constant map of radiance `c` (for tests and a uniform sky).
    pub fn constant(
        c: [f32; 3],
        up: Vec3,
        forward: Vec3,
        samples: u32,
    ) -> Result<Self, LightError> {
        Environment::new("constant", 8, 4, &[c; 32], 1.0, up, forward, samples)
    }

    /// Loads an OpenEXR latitude-longitude map (its first RGB layer; alpha ignored).
    /// Negative channels, which lossy EXR compression (DWAA/DWAB, B44) leaves around dark
    /// texels (Blender's studio-light maps hold a few of -1e-4 or so), are set to zero and
    /// counted ([`Environment::clamped`]); NaN or infinite texels are errors.
    pub fn load(
        path: &Path,
        scale: f32,
        up: Vec3,
        forward: Vec3,
        samples: u32,
    ) -> Result<Self, LightError> {
        let bytes = std::fs::read(path).map_err(|source| LightError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(path, &bytes, scale, up, forward, samples)
    }

    /// [`Environment::load`] on the file's bytes, as if read from `path` (which errors name).
    pub fn from_bytes(
        path: &Path,
        bytes: &[u8],
        scale: f32,
        up: Vec3,
        forward: Vec3,
        samples: u32,
    ) -> Result<Self, LightError> {
        let (width, height, mut texels) = decode_exr(path, bytes)?;
        let mut clamped = 0;
        for t in &mut texels {
            for c in t.iter_mut() {
                if *c < 0.0 {
                    *c = 0.0;
                    clamped += 1;
                }
            }
        }
        let mut env = Environment::new(
            &path.display().to_string(),
            width,
            height,
            &texels,
            scale,
            up,
            forward,
            samples,
        )?;
        env.clamped = clamped;
        Ok(env)
    }

    /// How many negative channels [`Environment::load`] set to zero.
    pub fn clamped(&self) -> usize {
        self.clamped
    }

    pub fn samples(&self) -> u32 {
        self.samples
    }

    pub fn size(&self) -> (usize, usize) {
        (self.map.width, self.map.height)
    }

    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The map's x (phi = 0), y (phi = pi/2) and up axes in world space.
    pub fn axes(&self) -> [Vec3; 3] {
        self.axes
    }

    /// The map's radiance (before [`Environment::scale`]), rows top (theta = 0) to bottom,
    /// `[r, g, b]` per texel.
    pub fn texels(&self) -> impl Iterator<Item = [f32; 3]> + '_ {
        self.map.texels.chunks_exact(4).map(|t| [t[0], t[1], t[2]])
    }

    /// The same map with another sample count (at least 1).
    pub fn with_samples(mut self, samples: u32) -> Self {
        self.samples = samples.max(1);
        self.strata = strata_grid(self.samples);
        self
    }

    /// The largest cell `j` with `cdf[offset + j] <= u` per lane (`u` in `[0, 1)`), the
    /// search started from the CDF's guide table (`guide[goffset..]`, `buckets` buckets):
    /// the bucket of `u` bounds the cell from both sides, and a binary search closes the
    /// bounds, as long as any lane of the packet has two or more cells left (none, for
    /// most lanes of a smooth map; a few steps in the dark parts of a map with a sun). The
    /// cell is the one a binary search over the whole CDF finds.
    #[inline(always)]
    fn search<L: Lanes>(
        l: L,
        cdf: &[f32],
        offset: L::I32s,
        guide: &[u32],
        goffset: L::I32s,
        buckets: usize,
        u: L::F32s,
    ) -> L::I32s {
        // Clamped, so that no number (not even a NaN, whose conversion gives `i32::MIN`)
        // reads outside the guide.
        let bucket = (u * buckets as f32)
            .to_i32()
            .max(l.splat_i32(0))
            .min(l.splat_i32(buckets as i32 - 1));
        let at = goffset + bucket;
        let mut lo = l.gather_u32(guide, at);
        let mut hi = l.gather_u32(&guide[1..], at);
        let one = l.splat_i32(1);
        // Each step leaves `lo` (whose value is at most `u`) or lowers `hi` below the
        // midpoint, so the bounds meet; lanes whose bounds met stay as they are.
        while hi.gt(lo).any() {
            let mid = (lo + hi + one).shr_logical(1);
            let below = l.gather(cdf, offset + mid).le(u);
            lo = below.select_i32(mid, lo);
            hi = below.select_i32(hi, mid - one);
        }
        lo
    }

    /// The texel index (`j * w + i`) of map coordinates per lane, clamped to the map.
    #[inline(always)]
    fn texel<L: Lanes>(&self, l: L, dir: &Vec3s<L>) -> L::I32s {
        let m = &*self.map;
        let x = Vec3s::splat(l, self.axes[0]).dot(*dir);
        let y = Vec3s::splat(l, self.axes[1]).dot(*dir);
        let z = Vec3s::splat(l, self.axes[2]).dot(*dir);
        let theta = acos(l, z);
        let phi = atan2(l, y, x);
        let phi = phi
            .lt(l.splat(0.0))
            .select(phi + std::f32::consts::TAU, phi);
        let i = (phi * (m.width as f32 / std::f32::consts::TAU))
            .floor()
            .clamp(l.splat(0.0), l.splat((m.width - 1) as f32));
        let j = (theta * (m.height as f32 / std::f32::consts::PI))
            .floor()
            .clamp(l.splat(0.0), l.splat((m.height - 1) as f32));
        (j * m.width as f32 + i).to_i32()
    }

    /// The radiance of the map towards unit directions `dir` (nearest texel).
    #[inline(always)]
    pub fn radiance<L: Lanes>(&self, l: L, dir: &Vec3s<L>) -> Rgbs<L> {
        let m = &*self.map;
        let t = self.texel(l, dir) << 2;
        Rgbs::new(
            l.gather(&m.texels, t),
            l.gather(&m.texels[1..], t),
            l.gather(&m.texels[2..], t),
        )
    }

    /// The sampling density over solid angle towards `dir` (scalar, for tests).
    pub fn pdf1(&self, dir: Vec3) -> f32 {
        let l = coherent_simd::scalar::Scalar;
        let m = &*self.map;
        let t = self.texel(l, &Vec3s::splat(l, dir)).lane(0) as usize;
        let z = dir.dot(self.axes[2]).clamp(-1.0, 1.0);
        let sin_dir = (1.0 - z * z).sqrt().max(f32::MIN_POSITIVE);
        m.texels[4 * t + 3] / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin_dir)
    }

    /// Sample `k` per lane: an importance-drawn direction in stratum `k` (of
    /// [`Self::samples`]), placed in the stratum by `u`, weighted for [`Self::samples`]
    /// samples.
    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        _p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
        k: u32,
        u: [L::F32s; 2],
    ) -> LightSample<L> {
        let m = &*self.map;
        let (w, h) = (m.width, m.height);
        let zero = l.splat(0.0);
        let below_one = l.splat(1.0f32.next_down());
        let [gx, gy] = self.strata;
        let (kx, ky) = ((k % gx) as f32, ((k / gx) % gy) as f32);
        let (sx, sy) = (1.0 / gx as f32, 1.0 / gy as f32);
        let u0 = (u[0].clamp(zero, below_one) + kx) * sx;
        let u1 = (u[1].clamp(zero, below_one) + ky) * sy;
        let (u0, u1) = (u0.min(below_one), u1.min(below_one));
        // Row from the marginal CDF, then the column from that row's conditional CDF; the
        // position inside the texel is the remainder of the number, rescaled.
        let j = Self::search(
            l,
            &m.marginal,
            l.splat_i32(0),
            &m.marginal_guide,
            l.splat_i32(0),
            m.row_buckets,
            u1,
        );
        let (r0, r1) = l.gather2(&m.marginal, j);
        let fv = ((u1 - r0) / (r1 - r0)).clamp(zero, below_one);
        let row = j * l.splat_i32(w as i32 + 1);
        let i = Self::search(
            l,
            &m.conditional,
            row,
            &m.conditional_guide,
            j * l.splat_i32(m.col_buckets as i32 + 1),
            m.col_buckets,
            u0,
        );
        let (c0, c1) = l.gather2(&m.conditional, row + i);
        let fu = ((u0 - c0) / (c1 - c0)).clamp(zero, below_one);
        let v = (j.to_f32() + fv) * (1.0 / h as f32);
        let uu = (i.to_f32() + fu) * (1.0 / w as f32);
        let theta = v * std::f32::consts::PI;
        // phi - pi in [-pi, pi): sin and cos of phi are the negated ones.
        let (sp, cp) = sincos(l, uu * std::f32::consts::TAU - std::f32::consts::PI);
        let (st, ct) = sincos(l, theta);
        let (sp, cp) = (-sp, -cp);
        let ax = [
            Vec3s::splat(l, self.axes[0]),
            Vec3s::splat(l, self.axes[1]),
            Vec3s::splat(l, self.axes[2]),
        ];
        let wi = ax[0].mul_add(st * cp, ax[1].mul_add(st * sp, ax[2] * ct));
        let texel = (j * l.splat_i32(w as i32) + i) << 2;
        let pdf = l.gather(&m.texels[3..], texel);
        // li = L / (pdf_omega * samples), pdf_omega = pdf / (2 pi^2 sin(theta)).
        let weight =
            st * (2.0 * std::f32::consts::PI * std::f32::consts::PI / self.samples as f32) / pdf;
        let active = active & n.dot(wi).gt(zero) & pdf.gt(zero) & st.gt(zero);
        let li = Rgbs::new(
            l.gather(&m.texels, texel) * weight,
            l.gather(&m.texels[1..], texel) * weight,
            l.gather(&m.texels[2..], texel) * weight,
        );
        finish(l, n, active, wi, l.splat(f32::INFINITY), li)
    }
}

/// Reads the first RGB layer of an OpenEXR file. DWAA/DWAB files are read too (the `exr`
/// crate decodes them since 1.74).
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), LightError> {
    let bytes = std::fs::read(path).map_err(|source| LightError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode_exr(path, &bytes)
}

/// [`read_exr`] on the file's bytes, as if read from `path` (which errors name).
pub fn decode_exr(path: &Path, bytes: &[u8]) -> Result<(usize, usize, Vec<[f32; 3]>), LightError> {
    use exr::prelude::*;
    let file = |problem: String| LightError::File {
        path: path.to_path_buf(),
        problem,
    };
    let unusable = |e: exr::error::Error| file(format!("not a usable OpenEXR RGB map: {e}"));
    // Refused from the headers, before the decoder allocates the texels they claim.
    let sizes = crate::texture::load::exr_layer_sizes(bytes).map_err(unusable)?;
    if let Some((w, h)) = sizes
        .into_iter()
        .find(|&(w, h)| w.saturating_mul(h) >= MAX_TEXELS)
    {
        return Err(file(format!("{w} x {h} map: at most 2^24 texels")));
    }
    crate::texture::load::check_exr_dwa_blocks(bytes).map_err(unusable)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size: Vec2<usize>, _: &RgbaChannels| {
                (size.width(), size.height(), vec![[0.0f32; 3]; size.area()])
            },
            |(w, _, texels): &mut (usize, usize, Vec<[f32; 3]>),
             at: Vec2<usize>,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                texels[at.y() * *w + at.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(unusable)?;
    let (width, height, texels) = image.layer_data.channel_data.pixels;
    Ok((width, height, texels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;

    /// A map with a bright spot and a gradient.
    fn varied() -> Environment {
        let (w, h) = (32, 16);
        let mut t = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let spot = if (10..13).contains(&i) && (3..5).contains(&j) {
                    50.0
                } else {
                    0.0
                };
                t.push([0.1 + i as f32 * 0.01 + spot, 0.2 + spot, 0.05 * j as f32]);
            }
        }
        Environment::new("varied", w, h, &t, 1.0, Vec3::Z, Vec3::X, 64).unwrap()
    }

    /// Each texel's record holds its own three channels and its density, in that order:
    /// the direction through every texel's centre sees that texel's radiance, and its density
    /// is the product of the texel's row and column CDF steps.
    #[test]
    fn every_texel_centre_sees_its_own_channels_and_density() {
        let env = varied();
        let m = &*env.map;
        let (w, h) = (m.width, m.height);
        let l = coherent_simd::scalar::Scalar;
        for j in 0..h {
            for i in 0..w {
                let theta = std::f32::consts::PI * (j as f32 + 0.5) / h as f32;
                let phi = std::f32::consts::TAU * (i as f32 + 0.5) / w as f32;
                let d = theta.sin() * (phi.cos() * Vec3::X + phi.sin() * Vec3::Y)
                    + theta.cos() * Vec3::Z;
                let spot = if (10..13).contains(&i) && (3..5).contains(&j) {
                    50.0
                } else {
                    0.0
                };
                let want = [0.1 + i as f32 * 0.01 + spot, 0.2 + spot, 0.05 * j as f32];
                assert_eq!(
                    env.radiance(l, &Vec3s::splat(l, d)).lane(0),
                    want,
                    "({i}, {j})"
                );
                let pr = m.marginal[j + 1] - m.marginal[j];
                let row = &m.conditional[j * (w + 1)..];
                let pdf = pr * (row[i + 1] - row[i]) * (w * h) as f32;
                let sin = (1.0 - d.z * d.z).sqrt();
                let got = env.pdf1(d) * 2.0 * std::f32::consts::PI * std::f32::consts::PI * sin;
                assert!(
                    (got - pdf).abs() <= 1e-4 * pdf,
                    "({i}, {j}): {got} vs {pdf}"
                );
            }
        }
    }

    #[test]
    fn the_sampling_pdf_integrates_to_one_over_the_sphere() {
        for env in [
            varied(),
            Environment::constant([1.0; 3], Vec3::Y, Vec3::X, 4).unwrap(),
        ] {
            // Midpoint rule over (theta, phi), fine enough to resolve the texels.
            let (nt, np) = (400, 800);
            let mut sum = 0.0f64;
            for a in 0..nt {
                let theta = (a as f64 + 0.5) * std::f64::consts::PI / nt as f64;
                for b in 0..np {
                    let phi = (b as f64 + 0.5) * std::f64::consts::TAU / np as f64;
                    let local = glam::DVec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    );
                    let d = (env.axes[0].as_dvec3() * local.x
                        + env.axes[1].as_dvec3() * local.y
                        + env.axes[2].as_dvec3() * local.z)
                        .as_vec3();
                    let dw = theta.sin()
                        * (std::f64::consts::PI / nt as f64)
                        * (std::f64::consts::TAU / np as f64);
                    sum += env.pdf1(d) as f64 * dw;
                }
            }
            assert!((sum - 1.0).abs() < 2e-3, "integral {sum}");
        }
    }

    #[test]
    fn a_constant_map_gives_constant_irradiance_pi_l() {
        let env = Light::Environment(
            Environment::constant([0.5, 1.0, 2.0], Vec3::Z, Vec3::X, 4096).unwrap(),
        );
        for n in [
            Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, -0.8).normalize(),
            -Vec3::Z,
        ] {
            let e = irradiance1(&env, Vec3::ZERO, n);
            for c in 0..3 {
                let want = std::f32::consts::PI * [0.5, 1.0, 2.0][c];
                assert!((e[c] - want).abs() < 0.03 * want, "normal {n}: {e:?}");
            }
        }
    }

    #[test]
    fn samples_are_drawn_where_the_map_is_bright_and_see_what_radiance_sees() {
        let env = varied();
        let l = coherent_simd::scalar::Scalar;
        let mut bright = 0;
        for k in 0..1000 {
            let u = [
                ((k as f32 + 0.5) * 0.618_034).fract(),
                ((k as f32 + 0.5) * 0.754_877_7).fract(),
            ];
            let s = env.sample(
                l,
                &Vec3s::splat(l, Vec3::ZERO),
                &Vec3s::splat(l, Vec3::Z),
                l.splat_mask(true),
                k,
                [u[0], u[1]],
            );
            let d = s.wi.lane(0);
            let seen = env.radiance(l, &Vec3s::splat(l, d)).lane(0);
            if seen[1] > 10.0 {
                bright += 1;
            }
            if s.active.lane(0) {
                // li = L / (pdf * samples) for the texel the direction lies in.
                let want = seen[1] / (env.pdf1(d) * 64.0);
                assert!(
                    (s.li.lane(0)[1] - want).abs() <= 2e-2 * want,
                    "{k}: {:?} vs {want}",
                    s.li.lane(0)
                );
            }
        }
        // The spot is 6 of 512 texels but holds most of the weight.
        assert!(bright > 500, "{bright} of 1000 samples in the bright spot");
    }

    /// Searches every number of `us` in `cdf` (one row, through its guide) on a backend.
    #[derive(Clone, Copy)]
    struct Searches<'a> {
        cdf: &'a [f32],
        guide: &'a [u32],
        buckets: usize,
        us: &'a [f32],
    }

    impl coherent_simd::Kernel for Searches<'_> {
        type Output = Vec<i32>;
        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> Vec<i32> {
            let mut out = Vec::new();
            for chunk in self.us.chunks_exact(L::N) {
                let zero = l.splat_i32(0);
                let j = Environment::search(
                    l,
                    self.cdf,
                    zero,
                    self.guide,
                    zero,
                    self.buckets,
                    l.load(chunk),
                );
                out.extend((0..L::N).map(|k| j.lane(k)));
            }
            out
        }
    }

    /// The guided search finds the cell a search of the whole table finds (the largest `j`
    /// below `n` with `cdf[j] <= u`), on every backend, for even weights, a sun among dark
    /// texels (long runs in one bucket), zero weights and a single cell, at every bucket's
    /// edge, every CDF value and random numbers between.
    #[test]
    fn the_guided_search_finds_the_cell_of_a_full_search_on_every_backend() {
        let mut tables: Vec<Vec<f64>> = vec![
            vec![1.0; 37],
            (0..100)
                .map(|i| {
                    if i == 40 {
                        1e6
                    } else {
                        1e-3 * (1 + i % 3) as f64
                    }
                })
                .collect(),
            (0..64)
                .map(|i| if i % 7 < 3 { 0.0 } else { i as f64 })
                .collect(),
            vec![0.0; 9],
            vec![2.5],
        ];
        tables.push(
            (0..1000)
                .map(|i| ((i as f64) * 0.37).sin().powi(8))
                .collect(),
        );
        let mut rng = 0x9e37_79b9u32;
        for weights in &tables {
            let mut table = Vec::new();
            cdf(weights, &mut table);
            let n = weights.len();
            let b = buckets(n);
            let mut g = Vec::new();
            guide(&table, b, &mut g);
            let below_one = 1.0f32.next_down();
            let mut us: Vec<f32> = (0..=b).map(|k| k as f32 / b as f32).collect();
            us.extend(table.iter().copied());
            us.extend(table.iter().map(|c| c.next_down().max(0.0)));
            for _ in 0..2000 {
                rng ^= rng << 13;
                rng ^= rng >> 17;
                rng ^= rng << 5;
                us.push((rng >> 8) as f32 / (1u32 << 24) as f32);
            }
            for u in &mut us {
                *u = u.clamp(0.0, below_one);
            }
            us.resize(us.len().next_multiple_of(16), 0.5);
            let want: Vec<i32> = us
                .iter()
                .map(|&u| (0..n).rev().find(|&j| table[j] <= u).unwrap() as i32)
                .collect();
            for backend in coherent_simd::Backend::usable() {
                let got = backend
                    .run(Searches {
                        cdf: &table,
                        guide: &g,
                        buckets: b,
                        us: &us,
                    })
                    .unwrap();
                for (k, (got, want)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        got,
                        want,
                        "{} cells, {backend}: u {} in {:?}..",
                        n,
                        us[k],
                        &table[*want as usize..]
                    );
                }
                // A NaN (or a number out of range) reads inside the tables and gives a cell.
                let odd = [f32::NAN, -1.0, 1.0, 7.5, f32::INFINITY, f32::NEG_INFINITY];
                let odd: Vec<f32> = odd.iter().copied().cycle().take(16).collect();
                let got = backend
                    .run(Searches {
                        cdf: &table,
                        guide: &g,
                        buckets: b,
                        us: &odd,
                    })
                    .unwrap();
                assert!(
                    got.iter().all(|&j| (0..n as i32).contains(&j)),
                    "{backend}: {got:?}"
                );
            }
        }
    }

    #[test]
    fn strata_grids_are_as_square_as_the_count_allows() {
        assert_eq!(strata_grid(16), [4, 4]);
        assert_eq!(strata_grid(8), [2, 4]);
        assert_eq!(strata_grid(12), [3, 4]);
        assert_eq!(strata_grid(7), [1, 7]);
        assert_eq!(strata_grid(1), [1, 1]);
        assert_eq!(strata_grid(0), [1, 1]);
    }

    /// Sample `k` of any shading point falls in stratum `k`: the map's cumulative tables,
    /// read at the drawn direction, give back numbers inside the stratum's cell.
    #[test]
    fn sample_k_is_drawn_in_stratum_k_whatever_its_numbers() {
        for samples in [16u32, 8, 7] {
            let env = varied().with_samples(samples);
            let m = &*env.map;
            let [gx, gy] = strata_grid(samples);
            let l = coherent_simd::scalar::Scalar;
            let mut rng = 0x2545_f491u32;
            let mut next = || {
                rng ^= rng << 13;
                rng ^= rng >> 17;
                rng ^= rng << 5;
                (rng >> 8) as f32 / (1u32 << 24) as f32
            };
            for k in 0..samples {
                for _ in 0..200 {
                    let u = [next(), next()];
                    // Directions below the normal are inactive: draw with both normals.
                    let d = [Vec3::Z, -Vec3::Z]
                        .into_iter()
                        .map(|n| {
                            env.sample(
                                l,
                                &Vec3s::splat(l, Vec3::ZERO),
                                &Vec3s::splat(l, n),
                                l.splat_mask(true),
                                k,
                                u,
                            )
                        })
                        .find(|s| s.active.lane(0))
                        .map(|s| s.wi.lane(0));
                    let Some(d) = d else { continue };
                    let theta = d.z.clamp(-1.0, 1.0).acos();
                    let phi = d.y.atan2(d.x).rem_euclid(std::f32::consts::TAU);
                    let v = (theta / std::f32::consts::PI * m.height as f32)
                        .clamp(0.0, m.height as f32 - 1e-3);
                    let (j, fv) = (v as usize, v.fract());
                    let cu1 = m.marginal[j] + fv * (m.marginal[j + 1] - m.marginal[j]);
                    let x = (phi / std::f32::consts::TAU * m.width as f32)
                        .clamp(0.0, m.width as f32 - 1e-3);
                    let (i, fu) = (x as usize, x.fract());
                    let row = &m.conditional[j * (m.width + 1)..];
                    let cu0 = row[i] + fu * (row[i + 1] - row[i]);
                    let (kx, ky) = ((k % gx) as f32, (k / gx) as f32);
                    let tol = 2e-3;
                    assert!(
                        cu1 >= ky / gy as f32 - tol && cu1 <= (ky + 1.0) / gy as f32 + tol,
                        "{samples} samples, k {k}, u {u:?}: row number {cu1}"
                    );
                    assert!(
                        cu0 >= kx / gx as f32 - tol && cu0 <= (kx + 1.0) / gx as f32 + tol,
                        "{samples} samples, k {k}, u {u:?}: column number {cu0}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_maps_are_errors() {
        let e = Environment::new(
            "m.exr",
            2,
            1,
            &[[1.0; 3], [f32::NAN, 0.0, 0.0]],
            1.0,
            Vec3::Z,
            Vec3::X,
            4,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("m.exr") && e.to_string().contains("texel (1, 0)"),
            "{e}"
        );
        let e = Environment::load(Path::new("/nonexistent/map.exr"), 1.0, Vec3::Z, Vec3::X, 4)
            .unwrap_err();
        assert!(e.to_string().contains("/nonexistent/map.exr"), "{e}");
    }

    #[test]
    fn an_exr_file_round_trips_and_one_without_rgb_is_an_error() {
        let dir = std::env::temp_dir().join(format!("coherent-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sky.exr");
        exr::prelude::write_rgb_file(&path, 8, 4, |x, y| (x as f32, y as f32, 1.0f32)).unwrap();
        let env = Environment::load(&path, 2.0, Vec3::Z, Vec3::X, 8).unwrap();
        assert_eq!(env.size(), (8, 4));
        // A luminance-only image.
        use exr::prelude::*;
        let gray = dir.join("gray.exr");
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![1.0; 8 * 4]));
        let image =
            Image::from_channels((8, 4), AnyChannels::sort(SmallVec::from_vec(vec![channel])));
        image.write().to_file(&gray).unwrap();
        let e = Environment::load(&gray, 1.0, Vec3::Z, Vec3::X, 8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("gray.exr"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
