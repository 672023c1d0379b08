//! RGB colours upsampled to smooth spectra (Jakob and Hanika, "A Low-Dimensional Function
//! Space for Efficient Spectral Upsampling", 2019): a reflectance is the sigmoid of a
//! quadratic in the wavelength, whose three coefficients come from a table over linear sRGB
//! that the build script optimises (build/rgb_to_spectrum.rs) so that the spectrum, lit by
//! the display's white (D65) and seen by the CIE 1931 observer, gives back its RGB.
//!
//! [`reflectance`] upsamples a colour in `[0, 1]^3` (a material's albedo, a texel);
//! [`emitter`] one of any magnitude (a light's colour) as pbrt-v4 does: a reflectance of at
//! most 1/2 times a scale.

use std::sync::LazyLock;

use coherent_simd::scalar::Scalar;
use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask};
use rgb2spec::RGB2Spec;

/// The table as the build script wrote it (`RGB2Spec::to_writer`'s format: `SPEC`, the
/// resolution, the nodes of the brightness axis, the coefficients).
static TABLE_BYTES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/srgb_to_spectrum.bin"));

/// The table, read from [`TABLE_BYTES`] on first use.
static TABLE: LazyLock<RGB2Spec> = LazyLock::new(|| {
    RGB2Spec::from_reader(&mut &TABLE_BYTES[..]).expect("build.rs writes a well-formed table")
});

/// Entries per axis of the RGB-to-spectrum table (its header's second word).
pub fn table_resolution() -> u32 {
    let word = &TABLE_BYTES[4..8];
    u32::from_le_bytes([word[0], word[1], word[2], word[3]])
}

/// The polynomial value at which the sigmoid rounds to exactly 1 (and its negative to
/// exactly 0) in `f32`: `x^2 + 1` rounds to `x^2`, and every step after is exact for a
/// power of two.
const SATURATED: f32 = 65536.0;

/// The largest difference between a grey's value and its constant spectrum's.
pub const GREY_ERROR: f32 = 1e-7;

/// A smooth spectrum with values in `[0, 1]`: `s(c0 λ^2 + c1 λ + c2)` for λ in nm, where
/// `s(x) = 1/2 + x / (2 sqrt(1 + x^2))` maps the real line onto `(0, 1)`. Three numbers per
/// spectrum, and at most one extremum over the range: no ringing, unlike a truncated basis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmoid {
    c: [f32; 3],
}

impl Sigmoid {
    /// The spectrum of coefficients `[c0, c1, c2]` (λ in nm), as `rgb2spec::RGB2Spec::fetch`
    /// returns them.
    pub const fn from_coefficients(c: [f32; 3]) -> Sigmoid {
        Sigmoid { c }
    }

    /// The coefficients `[c0, c1, c2]` of the quadratic, λ in nm.
    pub const fn coefficients(&self) -> [f32; 3] {
        self.c
    }

    /// The value at `lambda` (nm): the same operations, in the same order, as
    /// `rgb2spec::eval_precise`, and the same bits.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        let [c0, c1, c2] = self.c;
        let x = (c0 * lambda + c1) * lambda + c2;
        let y = 1.0 / (x * x + 1.0).sqrt();
        0.5 * x * y + 0.5
    }

    /// [`Sigmoid::eval`] per lane, with the same bits on every backend. Not `mul_add`: the
    /// terms of the quadratic in nm are up to hundreds of times its value, and fusing them
    /// on the backends with FMA moved values by up to 1e-6.
    #[inline(always)]
    pub fn eval_lanes<L: Lanes>(&self, l: L, lambda: L::F32s) -> L::F32s {
        let [c0, c1, c2] = self.c;
        let x = (lambda * c0 + c1) * lambda + c2;
        let y = l.splat(1.0) / (x * x + 1.0).sqrt();
        x * 0.5 * y + 0.5
    }

    /// The constant spectrum `v` (in `[0, 1]`): `c0 = c1 = 0`, so that every wavelength gives
    /// the same bits; `c2` is the sigmoid's inverse at `v`, so that 0, 1/2 and 1 come out
    /// exactly and other values within [`GREY_ERROR`] (the rounding of the sigmoid in `f32`).
    fn constant(v: f32) -> Sigmoid {
        let c = if v <= 0.0 {
            -SATURATED
        } else if v >= 1.0 {
            SATURATED
        } else {
            let v = f64::from(v);
            ((v - 0.5) / (v * (1.0 - v)).sqrt()) as f32
        };
        Sigmoid::from_coefficients([0.0, 0.0, c])
    }
}

/// The smooth reflectance spectrum of the linear sRGB colour `rgb`: each channel clamped to
/// `[0, 1]` (NaN to 0) first. A grey (three equal channels) gives a constant spectrum with
/// that value (exactly 0 for black and 1 for white); any other colour the table's trilinear
/// interpolation between its optimised coefficients.
pub fn reflectance(rgb: [f32; 3]) -> Sigmoid {
    let rgb = rgb.map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 });
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        return Sigmoid::constant(rgb[0]);
    }
    Sigmoid::from_coefficients(TABLE.fetch(rgb))
}

/// The spectrum of an RGB light or emissive texel of any magnitude, relative to the
/// display's white: `scale · shape(λ)`.
///
/// The radiance spectrum is this times the display's white, [`super::illuminant::white`]
/// (the D65 spectrum scaled to a luminance `Y` of 1): the caller multiplies, so that one
/// evaluation of the white serves every emitter at a wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emitter {
    scale: f32,
    shape: Sigmoid,
}

impl Emitter {
    /// The factor of the shape: twice the brightest channel.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The reflectance-like shape, at most 1/2 at the brightest channel's colour.
    pub fn shape(&self) -> Sigmoid {
        self.shape
    }

    /// The value at `lambda` (nm).
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.shape.eval(lambda)
    }

    /// [`Emitter::eval`] per lane, with the same bits on every backend.
    #[inline(always)]
    pub fn eval_lanes<L: Lanes>(&self, l: L, lambda: L::F32s) -> L::F32s {
        self.shape.eval_lanes(l, lambda) * self.scale
    }
}

/// The spectrum of the linear sRGB emission `rgb` (pbrt-v4's `RGBIlluminantSpectrum`): with
/// `m` the brightest channel, `scale = 2m` and a shape of brightest channel 1/2: the table's
/// interpolation at `rgb / 2m` ([`emitter_lanes`], one lane). The shape depends on the
/// colour's chromaticity, not its magnitude, and halving keeps it off the sigmoid's saturated
/// end, where the table's spectra are box-like; a grey light is a constant `m`. Black gives
/// zero. Negative and NaN channels count as 0, and channels are capped at `f32::MAX / 2` (so
/// that the scale is finite).
pub fn emitter(rgb: [f32; 3]) -> Emitter {
    let l = Scalar;
    let [c0, c1, c2, scale] = emitter_lanes(l, rgb, l.splat_mask(true));
    Emitter {
        scale,
        shape: Sigmoid::from_coefficients([c0, c1, c2]),
    }
}

/// The table where every emitter's shape lies: brightness 1/2 (an emitter's colour over
/// twice its brightest channel has that channel at exactly 1/2). The two brightness slices
/// around 1/2 are blended once, here, so that a lookup is a bilinear interpolation of four
/// nodes instead of `RGB2Spec::fetch`'s trilinear one of eight after a search of the
/// brightness axis: in exact arithmetic the same coefficients (the interpolation is linear
/// in each axis), in `f32` within rounding of them ([`HALF_SHAPE_ERROR`]).
struct HalfSlice {
    /// Entries per axis.
    res: i32,
    /// A channel's coordinate on the slice's axes per unit of the channel: `(res - 1) / 0.5`.
    to_grid: f32,
    /// Per coefficient, the node `(i * res + y) * res + x` of the table whose brightest channel
    /// is `i` (`x` and `y`: the next two channels after it, cyclically).
    planes: [Vec<f32>; 3],
}

/// [`HalfSlice`] from [`TABLE_BYTES`] on first use.
static HALF: LazyLock<HalfSlice> = LazyLock::new(|| {
    let words: Vec<f32> = TABLE_BYTES[8..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let res = table_resolution() as usize;
    let (nodes, data) = words.split_at(res);
    // `RGB2Spec::fetch`'s interval and weight along the brightness axis, at 1/2.
    let z = (0..res - 1).rfind(|&k| nodes[k] <= 0.5).unwrap_or(0);
    let z1 = (0.5 - nodes[z]) / (nodes[z + 1] - nodes[z]);
    let z0 = 1.0 - z1;
    let at = |i: usize, z: usize, y: usize, x: usize, k: usize| {
        data[(((i * res + z) * res + y) * res + x) * 3 + k]
    };
    let planes = std::array::from_fn(|k| {
        let mut plane = Vec::with_capacity(3 * res * res);
        for i in 0..3 {
            for y in 0..res {
                for x in 0..res {
                    plane.push(at(i, z, y, x, k) * z0 + at(i, z + 1, y, x, k) * z1);
                }
            }
        }
        plane
    });
    HalfSlice {
        res: res as i32,
        to_grid: (res - 1) as f32 / 0.5,
        planes,
    }
});

/// The largest difference between an emitter's shape and the reflectance `RGB2Spec::fetch`
/// gives its colour over twice its brightest channel, at any wavelength: the rounding of the
/// interpolations done in another order. The quadratic's terms in nm are up to hundreds of
/// times its value, so a coefficient's last bit moves the spectrum by up to 3.1e-5 (the
/// largest over 300,000 random colours at every 5 nm).
pub const HALF_SHAPE_ERROR: f32 = 1e-4;

/// [`emitter`] per lane for the lanes of `mask`: `[c0, c1, c2, scale]`, zero in the other
/// lanes. Gathers from one table instead of a lookup lane by lane, with the same operations
/// on every backend (no fused multiply-adds), so that every backend and [`emitter`] give the
/// same bits. Written out, without closures or array adaptors: it must inline into the
/// backends' entry points, or each vector operation becomes a call.
#[inline(always)]
pub fn emitter_lanes<L: Lanes>(l: L, rgb: [L::F32s; 3], mask: L::Mask) -> [L::F32s; 4] {
    let t = &*HALF;
    let zero = l.splat(0.0);
    let cap = l.splat(f32::MAX / 2.0);
    let r = rgb[0].gt(zero).select(rgb[0].min(cap), zero);
    let g = rgb[1].gt(zero).select(rgb[1].min(cap), zero);
    let b = rgb[2].gt(zero).select(rgb[2].min(cap), zero);
    let m = r.max(g).max(b);
    let lit = mask & m.gt(zero);
    let scale = lit.select(m * 2.0, zero);
    // Black lanes divide by one instead of zero: their values are replaced below.
    let div = lit.select(scale, l.splat(1.0));
    let (r, g, b) = (r / div, g / div, b / div);
    let grey = r.eq(g) & g.eq(b);
    // The brightest channel `i` (the last of equals, as `RGB2Spec::fetch` picks it) and the
    // two after it, cyclically.
    let g_top = g.ge(r);
    let b_top = b.ge(g_top.select(g, r));
    let x = b_top.select(r, g_top.select(b, g));
    let y = b_top.select(g, g_top.select(r, b));
    let i = b_top.select_i32(
        l.splat_i32(2),
        g_top.select_i32(l.splat_i32(1), l.splat_i32(0)),
    );
    let res = l.splat_i32(t.res);
    let last = l.splat_i32(t.res - 2);
    let (x, y) = (x * t.to_grid, y * t.to_grid);
    let (xi, yi) = (x.to_i32().min(last), y.to_i32().min(last));
    let (x1, y1) = (x - xi.to_f32(), y - yi.to_f32());
    let (x0, y0) = (l.splat(1.0) - x1, l.splat(1.0) - y1);
    let look = lit.and_not(grey);
    let idx = look.select_i32((i * res + yi) * res + xi, l.splat_i32(0));
    let next = idx + res;
    let w = [x0, x1, y0, y1];
    let c0 = look.select(bilinear(l, &t.planes[0], idx, next, w), zero);
    let c1 = look.select(bilinear(l, &t.planes[1], idx, next, w), zero);
    let c2 = look.select(bilinear(l, &t.planes[2], idx, next, w), zero);
    // A grey is the constant 1/2 (all zero); black the constant 0.
    let c2 = mask.and_not(lit).select(l.splat(-SATURATED), c2);
    [c0, c1, c2, scale]
}

/// The plane's bilinear interpolation between the nodes `idx`, `idx + 1` (row `y`) and
/// `next`, `next + 1` (row `y + 1`), weights `[x0, x1, y0, y1]`.
#[inline(always)]
fn bilinear<L: Lanes>(
    l: L,
    plane: &[f32],
    idx: L::I32s,
    next: L::I32s,
    w: [L::F32s; 4],
) -> L::F32s {
    let (p00, p10) = l.gather2_near(plane, idx);
    let (p01, p11) = l.gather2_near(plane, next);
    (p00 * w[0] + p10 * w[1]) * w[2] + (p01 * w[0] + p11 * w[1]) * w[3]
}

/// The RGB a reflectance gives back once upsampled, lit by the display's white and seen by
/// the CIE 1931 observer, and the CIELAB Delta E between the two (relative to that white):
/// the model's error for `rgb` (`examples/upsample_error.rs` maps it over the sRGB cube).
pub fn round_trip(rgb: [f32; 3]) -> (f64, [f32; 3]) {
    use crate::spectrum::{cie, illuminant};
    let s = reflectance(rgb);
    let white = illuminant::white();
    let xyz = cie::xyz_of(|l| f64::from(s.eval(l)) * f64::from(white.eval(l)));
    let back = cie::xyz_to_rgb(xyz.map(|v| v as f32));
    let ref_white = cie::rgb_to_xyz([1.0; 3]).map(f64::from);
    let lab = |rgb: [f32; 3]| cie::lab(cie::rgb_to_xyz(rgb).map(f64::from), ref_white);
    (cie::delta_e(lab(rgb), lab(back)), back)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
    use coherent_simd::{Backend, Kernel, MAX_LANES, scalar::Scalar};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// 380, 381, ..., 780 nm.
    fn every_nm() -> impl Iterator<Item = f32> {
        (0..=(LAMBDA_MAX - LAMBDA_MIN) as u32).map(|i| LAMBDA_MIN + i as f32)
    }

    #[test]
    fn the_table_is_well_formed() {
        assert_eq!(&TABLE_BYTES[..4], b"SPEC");
        // build/rgb_to_spectrum.rs's resolution.
        let res = table_resolution() as usize;
        assert_eq!(res, 48);
        // Header, the brightness axis, three coefficients per entry of the three tables.
        assert_eq!(TABLE_BYTES.len(), 8 + 4 * res + 4 * 3 * 3 * res * res * res);
        assert!(format!("{:?}", *TABLE).contains("resolution: 48"));
    }

    #[test]
    fn greys_are_exact_constants() {
        let mut worst = 0.0f32;
        for k in 0..=1000 {
            let g = k as f32 / 1000.0;
            let s = reflectance([g; 3]);
            let [c0, c1, c2] = s.coefficients();
            assert_eq!((c0, c1), (0.0, 0.0), "{g}");
            let v = s.eval(LAMBDA_MIN);
            for lambda in every_nm() {
                assert_eq!(s.eval(lambda).to_bits(), v.to_bits(), "{g} at {lambda} nm");
            }
            assert!((v - g).abs() <= GREY_ERROR, "{g}: {v} (c2 = {c2})");
            worst = worst.max((v - g).abs());
        }
        let mut rng = StdRng::seed_from_u64(5);
        for _ in 0..100_000 {
            let g: f32 = rng.random();
            let v = reflectance([g; 3]).eval(550.0);
            assert!((v - g).abs() <= GREY_ERROR, "{g}: {v}");
            worst = worst.max((v - g).abs());
        }
        eprintln!("largest grey error: {worst:e}");
        for lambda in every_nm() {
            assert_eq!(reflectance([0.0; 3]).eval(lambda), 0.0);
            assert_eq!(reflectance([1.0; 3]).eval(lambda), 1.0);
            assert_eq!(reflectance([0.5; 3]).eval(lambda), 0.5);
        }
        // Clamped first: out-of-range and NaN greys are black or white.
        assert_eq!(reflectance([-2.0; 3]).eval(500.0), 0.0);
        assert_eq!(reflectance([f32::NAN; 3]).eval(500.0), 0.0);
        assert_eq!(reflectance([7.0; 3]).eval(500.0), 1.0);
        assert_eq!(reflectance([f32::INFINITY; 3]).eval(500.0), 1.0);
        assert_eq!(
            reflectance([1.5, 2.0, f32::INFINITY]),
            reflectance([1.0; 3])
        );
    }

    #[test]
    fn emitters_scale_a_shape_of_at_most_one_half() {
        for lambda in every_nm() {
            assert_eq!(emitter([0.0; 3]).eval(lambda), 0.0);
            assert_eq!(emitter([3.0; 3]).eval(lambda), 3.0);
            assert_eq!(emitter([0.2; 3]).eval(lambda), 0.2);
            assert_eq!(emitter([-1.0, f32::NAN, 0.0]).eval(lambda), 0.0);
        }
        let e = emitter([40.0, 10.0, 2.0]);
        assert_eq!(e.scale(), 80.0);
        let want = reflectance([0.5, 0.125, 0.025]);
        for lambda in every_nm() {
            assert_eq!(e.eval(lambda), 80.0 * e.shape().eval(lambda));
            let d = (e.shape().eval(lambda) - want.eval(lambda)).abs();
            assert!(d <= HALF_SHAPE_ERROR, "{lambda} nm: {d:e}");
        }
        assert!(emitter([f32::INFINITY, 0.0, 0.0]).scale().is_finite());
    }

    /// The blended slice against `RGB2Spec::fetch`'s trilinear lookup, over colours of every
    /// brightest channel and on the slice's edges: it prints the largest difference
    /// ([`HALF_SHAPE_ERROR`] cites it).
    #[test]
    fn emitter_shapes_are_the_tables_within_rounding() {
        let mut rng = StdRng::seed_from_u64(13);
        let edges = (0..27).map(|k| [k % 3, k / 3 % 3, k / 9].map(|i| i as f32 / 2.0));
        let random = (0..300_000).map(|_| [rng.random(), rng.random(), rng.random()]);
        let mut worst = 0.0f32;
        for rgb in edges.chain(random) {
            let m: f32 = rgb[0].max(rgb[1]).max(rgb[2]);
            if m == 0.0 {
                continue;
            }
            let e = emitter(rgb);
            let want = reflectance(rgb.map(|v| v / (2.0 * m)));
            for lambda in every_nm().step_by(5) {
                let d = (e.shape().eval(lambda) - want.eval(lambda)).abs();
                assert!(d <= HALF_SHAPE_ERROR, "{rgb:?} at {lambda} nm: {d:e}");
                worst = worst.max(d);
            }
        }
        eprintln!("largest difference from the trilinear lookup: {worst:e}");
    }

    /// `emitter_lanes` per lane, with some lanes masked off (zero there).
    #[derive(Clone)]
    struct Upsample<'a> {
        colours: &'a [[f32; 3]],
    }

    impl Kernel for Upsample<'_> {
        type Output = Vec<[f32; 4]>;

        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> Vec<[f32; 4]> {
            let mut out = Vec::new();
            for (k, chunk) in self.colours.chunks(L::N).enumerate() {
                let rgb =
                    std::array::from_fn(|c| l.from_fn(|i| chunk.get(i).map_or(1.0, |v| v[c])));
                // Every third lane off, shifting with the chunk.
                let mask = l.mask_from_bits(!(0x9249_2492u32 >> (k % 3)));
                let p = emitter_lanes(l, rgb, mask);
                let mut v = [[0.0f32; MAX_LANES]; 4];
                for (x, o) in p.iter().zip(&mut v) {
                    x.store(o);
                }
                out.extend((0..chunk.len()).map(|i| std::array::from_fn(|j| v[j][i])));
            }
            out
        }
    }

    #[test]
    fn emitter_lanes_is_emitter_on_every_backend() {
        let mut rng = StdRng::seed_from_u64(17);
        let mut colours: Vec<[f32; 3]> = vec![
            [0.0; 3],
            [1.0; 3],
            [3.0; 3],
            [-1.0, f32::NAN, 0.0],
            [f32::INFINITY, 0.0, 0.0],
            [1.0, 1.0, 0.5],
            [0.5, 1.0, 1.0],
            [1.0, 0.5, 1.0],
            [1e-40, 0.0, 0.0],
        ];
        colours.extend((0..500).map(|_| {
            let m: f32 = rng.random_range(0.001..1000.0);
            [rng.random(), rng.random(), rng.random()].map(|v: f32| v * m)
        }));
        let kernel = Upsample { colours: &colours };
        for b in Backend::usable() {
            let got = b.run(kernel.clone()).expect("usable backend");
            assert_eq!(got.len(), colours.len());
            for (n, (rgb, got)) in colours.iter().zip(&got).enumerate() {
                let chunk = n / b.lanes();
                let on = !(0x9249_2492u32 >> (chunk % 3)) >> (n % b.lanes()) & 1 == 1;
                let want = if on {
                    let e = emitter(*rgb);
                    let c = e.shape().coefficients();
                    [c[0], c[1], c[2], e.scale()]
                } else {
                    [0.0; 4]
                };
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{b} {rgb:?}: {got:?} {want:?}"
                );
            }
        }
    }

    /// The values of `rgb2spec`'s own evaluation, and of the table's lookup.
    #[test]
    fn eval_is_rgb2specs() {
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..2000 {
            let rgb = [rng.random(), rng.random(), rng.random()];
            let s = reflectance(rgb);
            assert_eq!(s.coefficients(), TABLE.fetch(rgb));
            let lambda = rng.random_range(LAMBDA_MIN..=LAMBDA_MAX);
            let want = rgb2spec::eval_precise(s.coefficients(), lambda);
            assert_eq!(s.eval(lambda).to_bits(), want.to_bits(), "{rgb:?} {lambda}");
        }
    }

    /// A reflectance's values over the range, at every nm.
    fn spectrum(rgb: [f32; 3]) -> Vec<f32> {
        let s = reflectance(rgb);
        every_nm().map(|l| s.eval(l)).collect()
    }

    /// The saturated primaries: at most one turn (the form allows no more), high where the
    /// primary's colour lies and low elsewhere.
    #[test]
    fn primaries_are_smooth_and_where_expected() {
        let wavelength_of_max = |v: &[f32]| {
            let k = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
            LAMBDA_MIN + k as f32
        };
        for (rgb, from, to) in [
            ([1.0, 0.0, 0.0], 600.0, 780.0),
            ([0.0, 1.0, 0.0], 490.0, 580.0),
            ([0.0, 0.0, 1.0], 380.0, 480.0),
        ] {
            let v = spectrum(rgb);
            let turns = v
                .windows(3)
                .filter(|w| (w[1] - w[0]) * (w[2] - w[1]) < 0.0)
                .count();
            assert!(turns <= 1, "{rgb:?}: {turns} turns");
            let at = wavelength_of_max(&v);
            assert!((from..=to).contains(&at), "{rgb:?}: largest at {at} nm");
            let hi = v.iter().copied().fold(0.0f32, f32::max);
            let lo = v.iter().copied().fold(1.0f32, f32::min);
            assert!(hi > 0.9 && lo < 0.1, "{rgb:?}: from {lo} to {hi}");
        }
        // Green's turn is its peak: a negative leading coefficient.
        assert!(reflectance([0.0, 1.0, 0.0]).coefficients()[0] < 0.0);
    }

    /// The largest colour difference of `rgb` from its reflectance lit by the display's
    /// white, integrated by the CIE 1931 observer and taken back to linear sRGB (both in
    /// CIELAB relative to sRGB's white).
    #[test]
    fn reflectances_round_trip_within_a_just_noticeable_difference() {
        let mut rng = StdRng::seed_from_u64(3);
        let grid = (0..6 * 6 * 6).map(|k| [k % 6, k / 6 % 6, k / 36].map(|i| i as f32 / 5.0));
        let random = (0..500).map(|_| [rng.random(), rng.random(), rng.random()]);
        let mut worst = (0.0, [0.0; 3], [0.0; 3]);
        for rgb in grid.chain(random) {
            let (de, back) = round_trip(rgb);
            assert!(de < 1.0, "{rgb:?} came back as {back:?}: Delta E {de}");
            if de > worst.0 {
                worst = (de, rgb, back);
            }
        }
        eprintln!(
            "largest Delta E {:.3} for {:?} (back as {:?})",
            worst.0, worst.1, worst.2
        );
    }

    proptest! {
        #[test]
        fn reflectances_lie_in_0_1(
            r in 0.0f32..=1.0, g in 0.0f32..=1.0, b in 0.0f32..=1.0,
            lambda in LAMBDA_MIN..=LAMBDA_MAX,
        ) {
            let s = reflectance([r, g, b]);
            let v = s.eval(lambda);
            prop_assert!((0.0..=1.0).contains(&v), "{:?} at {} nm: {}", [r, g, b], lambda, v);
            let e = emitter([r, g, b]);
            let v = e.eval(lambda);
            prop_assert!((0.0..=2.0 * r.max(g).max(b)).contains(&v));
        }
    }

    /// Sigmoids and emitters at wavelengths, per lane; `Output`: both values per wavelength.
    #[derive(Clone)]
    struct Sweep<'a> {
        emitters: &'a [Emitter],
        lambdas: &'a [f32],
    }

    impl Kernel for Sweep<'_> {
        type Output = Vec<[f32; 2]>;

        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> Vec<[f32; 2]> {
            let mut out = Vec::new();
            for e in self.emitters {
                for chunk in self.lambdas.chunks(L::N) {
                    let lambda = l.from_fn(|i| chunk.get(i).copied().unwrap_or(LAMBDA_MIN));
                    let mut s = [0.0f32; MAX_LANES];
                    let mut v = [0.0f32; MAX_LANES];
                    e.shape().eval_lanes(l, lambda).store(&mut s);
                    e.eval_lanes(l, lambda).store(&mut v);
                    out.extend((0..chunk.len()).map(|i| [s[i], v[i]]));
                }
            }
            out
        }
    }

    #[test]
    fn eval_lanes_is_eval_on_every_backend() {
        let mut rng = StdRng::seed_from_u64(11);
        // Black and white reflectances first: exact on every backend.
        let mut emitters: Vec<Emitter> = [[0.0; 3], [1.0; 3]]
            .map(|rgb| Emitter {
                scale: 1.0,
                shape: reflectance(rgb),
            })
            .to_vec();
        emitters.extend([[0.0; 3], [1.0; 3], [0.3; 3], [2.0, 0.5, 0.0]].map(emitter));
        emitters.extend([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(emitter));
        emitters.extend((0..200).map(|_| {
            let m: f32 = rng.random_range(0.01..100.0);
            emitter([rng.random(), rng.random(), rng.random()].map(|v: f32| v * m))
        }));
        let lambdas: Vec<f32> = (0..97)
            .map(|k| LAMBDA_MIN + (LAMBDA_MAX - LAMBDA_MIN) * k as f32 / 96.0)
            .chain((0..50).map(|_| rng.random_range(LAMBDA_MIN..=LAMBDA_MAX)))
            .collect();
        let sweep = Sweep {
            emitters: &emitters,
            lambdas: &lambdas,
        };
        let want: Vec<[f32; 2]> = emitters
            .iter()
            .flat_map(|e| lambdas.iter().map(|&l| [e.shape().eval(l), e.eval(l)]))
            .collect();
        let scalar = sweep.clone().run(Scalar);
        for (k, (got, want)) in scalar.iter().zip(&want).enumerate() {
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "entry {k}");
        }
        for b in Backend::usable() {
            let got = b.run(sweep.clone()).expect("usable backend");
            assert_eq!(got.len(), want.len());
            for (k, (got, want)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{b} entry {k}: {got:?} {want:?}"
                );
                if k < 2 * lambdas.len() {
                    let exact = (k / lambdas.len()) as f32;
                    assert_eq!(*got, [exact; 2], "{b} entry {k}");
                }
            }
        }
    }
}
