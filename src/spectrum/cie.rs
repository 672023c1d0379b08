//! The CIE 1931 2-degree standard observer and the colour spaces built on it: CIE XYZ,
//! chromaticity, CIELAB and linear sRGB.
//!
//! The observer's colour-matching functions come from the `colorimetry` crate's CIE 1931
//! table (CIE 15:2018, 1 nm steps over 380..=780 nm, the module's range), copied once into
//! [`SAMPLES`]-long tables. Integrals over wavelength are sums over those 1 nm samples
//! times 1 nm, the CIE 15 practice, in `f64`.

use std::sync::LazyLock;

use super::{LAMBDA_MAX, LAMBDA_MIN};

/// The number of 1 nm samples over [`LAMBDA_MIN`, `LAMBDA_MAX`] (both ends included): the
/// length of every tabulated spectrum of the module.
pub const SAMPLES: usize = 401;

// The module's range, its 1 nm tables and `colorimetry`'s tables are the same grid.
const _: () = assert!(LAMBDA_MAX - LAMBDA_MIN == (SAMPLES - 1) as f32);
const _: () = assert!(colorimetry::spectrum::NS == SAMPLES);
const _: () =
    assert!(*colorimetry::spectrum::SPECTRUM_WAVELENGTH_RANGE.start() == LAMBDA_MIN as usize);

/// Linear sRGB to CIE XYZ (IEC 61966-2-1: the Rec. 709 primaries and the D65 white
/// `(0.3127, 0.3290)`), rows X, Y, Z. Derived from the primaries and white point in full
/// precision rather than the standard's 4-decimal rounding, so that it and
/// [`XYZ_TO_SRGB`] are inverses to `f32` precision and RGB `(1, 1, 1)` has `Y = 1` exactly.
pub const SRGB_TO_XYZ: [[f32; 3]; 3] = [
    [0.4123908, 0.35758433, 0.1804808],
    [0.212639, 0.71516865, 0.07219232],
    [0.019330818, 0.11919478, 0.95053214],
];

/// CIE XYZ to linear sRGB: the inverse of [`SRGB_TO_XYZ`].
pub const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [3.24097, -1.5373832, -0.49861076],
    [-0.96924365, 1.8759675, 0.04155506],
    [0.05563008, -0.20397696, 1.0569715],
];

/// The observer's tables, one plane per function (`x̄`, `ȳ`, `z̄`): `f64` for integrals,
/// `f32` for lookups.
struct Observer {
    f64s: [[f64; SAMPLES]; 3],
    f32s: [[f32; SAMPLES]; 3],
}

static OBSERVER: LazyLock<Observer> = LazyLock::new(|| {
    // `colorimetry` stores the observer as a 3 x 401 matrix: row = function, column = nm.
    let data = &colorimetry::observer::observer_data::CIE1931.data;
    let f64s: [[f64; SAMPLES]; 3] = std::array::from_fn(|c| std::array::from_fn(|i| data[(c, i)]));
    let f32s = f64s.map(|plane| plane.map(|v| v as f32));
    Observer { f64s, f32s }
});

/// The CIE 1931 colour-matching functions `x̄`, `ȳ`, `z̄` at 380, 381, ..., 780 nm.
pub fn cmf_table() -> &'static [[f64; SAMPLES]; 3] {
    &OBSERVER.f64s
}

/// The wavelength of sample `i` of a 1 nm table, in nm.
#[inline]
pub fn sample_lambda(i: usize) -> f32 {
    LAMBDA_MIN + i as f32
}

/// Where `lambda` falls on the 1 nm grid: the sample below it (at most `SAMPLES - 2`) and
/// the weight of the sample above, or `None` outside [`LAMBDA_MIN`, `LAMBDA_MAX`] (and for
/// NaN). The lane lookups ([`super::illuminant::EmissionTable::eval_lanes`]) take the same
/// steps, so that both give the same bits.
#[inline]
pub(crate) fn grid_cell(lambda: f32) -> Option<(usize, f32)> {
    let x = lambda - LAMBDA_MIN;
    if !(0.0..=(SAMPLES - 1) as f32).contains(&x) {
        return None;
    }
    let i = (x.floor() as i32).min(SAMPLES as i32 - 2);
    Some((i as usize, x - i as f32))
}

/// `table` at `lambda`, linearly interpolated between its 1 nm samples, zero outside
/// [`LAMBDA_MIN`, `LAMBDA_MAX`].
#[inline]
pub(crate) fn lerp_1nm(table: &[f32; SAMPLES], lambda: f32) -> f32 {
    match grid_cell(lambda) {
        Some((i, t)) => table[i] * (1.0 - t) + table[i + 1] * t,
        None => 0.0,
    }
}

/// The CIE 1931 colour-matching functions `[x̄, ȳ, z̄]` at `lambda` (nm), linearly
/// interpolated between the 1 nm samples; zero outside [`LAMBDA_MIN`, `LAMBDA_MAX`].
#[inline]
pub fn cmf(lambda: f32) -> [f32; 3] {
    let planes = &OBSERVER.f32s;
    match grid_cell(lambda) {
        Some((i, t)) => planes.each_ref().map(|p| p[i] * (1.0 - t) + p[i + 1] * t),
        None => [0.0; 3],
    }
}

/// The tristimulus values `∫ f(λ) [x̄, ȳ, z̄](λ) dλ` of a spectrum `f` (λ in nm), summed
/// over the 1 nm samples from 380 to 780 nm. `Y` is in the units of `f` times nm: a
/// spectrum with `Y = 1` has the luminance of the display's white.
pub fn xyz_of(f: impl Fn(f32) -> f64) -> [f64; 3] {
    let planes = &OBSERVER.f64s;
    let mut xyz = [0.0f64; 3];
    for i in 0..SAMPLES {
        let v = f(sample_lambda(i));
        for (acc, p) in xyz.iter_mut().zip(planes) {
            *acc += v * p[i];
        }
    }
    xyz
}

/// The chromaticity `(x, y) = (X, Y) / (X + Y + Z)`; NaN for black, which has none.
pub fn chromaticity(xyz: [f64; 3]) -> [f64; 2] {
    let sum = xyz[0] + xyz[1] + xyz[2];
    [xyz[0] / sum, xyz[1] / sum]
}

/// `m · v`.
#[inline]
fn mat_vec(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// CIE XYZ to linear sRGB (no gamut clipping: colours outside sRGB get negative channels).
#[inline]
pub fn xyz_to_rgb(xyz: [f32; 3]) -> [f32; 3] {
    mat_vec(&XYZ_TO_SRGB, xyz)
}

/// Linear sRGB to CIE XYZ.
#[inline]
pub fn rgb_to_xyz(rgb: [f32; 3]) -> [f32; 3] {
    mat_vec(&SRGB_TO_XYZ, rgb)
}

/// The luminance `Y` of a linear sRGB colour (the `Y` row of [`SRGB_TO_XYZ`]): 1 for white.
#[inline]
pub fn luminance_rgb(rgb: [f32; 3]) -> f32 {
    let y = SRGB_TO_XYZ[1];
    y[0] * rgb[0] + y[1] * rgb[1] + y[2] * rgb[2]
}

/// CIELAB (CIE 1976 `L*a*b*`) of `xyz` relative to the reference `white` (same scale):
/// `L*` is 100 for the white, `a*` and `b*` are zero for its chromaticity.
pub fn lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    // The cube root, with the linear segment CIE 15 uses near black.
    const DELTA: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > DELTA * DELTA * DELTA {
            t.cbrt()
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let [fx, fy, fz] = [0, 1, 2].map(|c| f(xyz[c] / white[c]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The CIE 1976 colour difference `ΔE*ab` between two CIELAB colours: their Euclidean
/// distance. A `ΔE` of about 1 is a just-noticeable difference.
pub fn delta_e(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `XYZ` of chromaticity `(x, y)` with `Y = 1`.
    fn xyz_of_xy(x: f64, y: f64) -> [f64; 3] {
        [x / y, 1.0, (1.0 - x - y) / y]
    }

    #[test]
    fn the_srgb_matrices_are_inverses() {
        for (i, row) in XYZ_TO_SRGB.iter().enumerate() {
            for j in 0..3 {
                let p: f32 = row.iter().zip(&SRGB_TO_XYZ).map(|(a, r)| a * r[j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((p - want).abs() < 1e-6, "({i}, {j}): {p}");
            }
        }
    }

    /// The matrix agrees with IEC 61966-2-1's 4-decimal one, maps each primary to its
    /// chromaticity and white to D65's.
    #[test]
    fn srgb_has_the_rec709_primaries_and_the_d65_white() {
        let iec = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        for (got, want) in SRGB_TO_XYZ.iter().flatten().zip(iec.iter().flatten()) {
            assert!((got - want).abs() < 1e-4, "{got} vs {want}");
        }
        let primaries = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.3127, 0.3290]];
        let rgbs = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0; 3]];
        for (xy, rgb) in primaries.iter().zip(rgbs) {
            let xyz = rgb_to_xyz(rgb).map(f64::from);
            let c = chromaticity(xyz);
            assert!(
                (c[0] - xy[0]).abs() < 1e-6 && (c[1] - xy[1]).abs() < 1e-6,
                "{c:?}"
            );
        }
        assert!((luminance_rgb([1.0; 3]) - 1.0).abs() < 1e-6);
        let back = xyz_to_rgb(rgb_to_xyz([0.2, 0.5, 0.9]));
        for (b, w) in back.iter().zip([0.2, 0.5, 0.9]) {
            assert!((b - w).abs() < 1e-6, "{back:?}");
        }
    }

    #[test]
    fn cmf_interpolates_the_table_and_is_zero_outside() {
        let t = cmf_table();
        // The CIE 1931 table's values at 555 nm and 600 nm (CIE 15:2018, Table T.4).
        assert!((t[1][175] - 1.0).abs() < 1e-3, "{}", t[1][175]);
        assert!((t[0][220] - 1.0622).abs() < 1e-3, "{}", t[0][220]);
        for i in [0, 1, 175, 399, 400] {
            let c = cmf(sample_lambda(i));
            for (k, (got, plane)) in c.iter().zip(t).enumerate() {
                assert_eq!(*got, plane[i] as f32, "sample {i}, function {k}");
            }
        }
        let mid = cmf(555.5);
        let want = (t[1][175] + t[1][176]) / 2.0;
        assert!((mid[1] as f64 - want).abs() < 1e-6);
        for l in [
            379.9,
            780.1,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            assert_eq!(cmf(l), [0.0; 3], "{l}");
        }
        assert!(cmf(780.0)[0] > 0.0);
    }

    /// The equal-energy spectrum E has chromaticity (1/3, 1/3), and the three integrals are
    /// equal (the observer's normalisation), up to the truncation to 380..780 nm.
    #[test]
    fn equal_energy_is_achromatic() {
        let xyz = xyz_of(|_| 1.0);
        let c = chromaticity(xyz);
        assert!(
            (c[0] - 1.0 / 3.0).abs() < 5e-4 && (c[1] - 1.0 / 3.0).abs() < 5e-4,
            "{c:?}"
        );
        // 106.86 nm is the integral of ȳ at 1 nm (CIE 15: 683 lm/W times it is 72983 lm).
        assert!((xyz[1] - 106.86).abs() < 0.1, "{xyz:?}");
        // Black has no chromaticity.
        assert!(chromaticity([0.0; 3])[0].is_nan());
    }

    #[test]
    fn lab_of_the_white_is_100_0_0_and_delta_e_is_a_distance() {
        let white = xyz_of_xy(0.3127, 0.3290);
        let w = lab(white, white);
        assert!((w[0] - 100.0).abs() < 1e-9 && w[1].abs() < 1e-9 && w[2].abs() < 1e-9);
        // 18% grey: L* = 116 * 0.18^(1/3) - 16 = 49.50; black: L* = 0.
        let grey = lab(white.map(|v| 0.18 * v), white);
        assert!(
            (grey[0] - 49.496).abs() < 1e-2 && grey[1].abs() < 1e-9,
            "{grey:?}"
        );
        assert!(lab([0.0; 3], white)[0].abs() < 1e-9);
        // A colour off the white: positive a* for more X (red), positive b* for less Z.
        let warm = lab([white[0] * 1.1, 1.0, white[2] * 0.8], white);
        assert!(warm[1] > 0.0 && warm[2] > 0.0, "{warm:?}");
        assert_eq!(delta_e(w, w), 0.0);
        assert!((delta_e([50.0, 1.0, 2.0], [50.0, 4.0, 6.0]) - 5.0).abs() < 1e-12);
        assert_eq!(delta_e(w, warm), delta_e(warm, w));
    }
}
