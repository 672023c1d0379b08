//! Emission spectra: the CIE standard illuminants and blackbodies, and their 1 nm tables
//! scaled to a luminance `Y` of 1, the form in which a light carries its spectrum (its
//! intensity is kept apart, as RGB lights keep theirs).
//!
//! The illuminants' relative spectral powers come from the `colorimetry` crate's CIE 15:2018
//! tables (1 nm steps over 380..=780 nm), copied once into `f64` tables.

use std::sync::LazyLock;

use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask};
use colorimetry::illuminant::CieIlluminant;

use super::blackbody::Blackbody;
use super::cie::{self, SAMPLES};
use super::{LAMBDA_MIN, SpectrumError};

/// A CIE standard illuminant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Illuminant {
    /// A tungsten-filament lamp: a blackbody at about 2856 K.
    A,
    /// Horizon daylight, about 5003 K (the printing industry's white).
    D50,
    /// Average daylight, about 6504 K (sRGB's white).
    D65,
    /// Equal energy: the same power at every wavelength.
    E,
    /// Fluorescent lamps `F1` to `F12` (the number; no other number names an illuminant).
    F(u8),
}

impl Illuminant {
    /// Every illuminant, in the order of [`Illuminant::NAMES`].
    pub const ALL: [Illuminant; 16] = [
        Illuminant::A,
        Illuminant::D50,
        Illuminant::D65,
        Illuminant::E,
        Illuminant::F(1),
        Illuminant::F(2),
        Illuminant::F(3),
        Illuminant::F(4),
        Illuminant::F(5),
        Illuminant::F(6),
        Illuminant::F(7),
        Illuminant::F(8),
        Illuminant::F(9),
        Illuminant::F(10),
        Illuminant::F(11),
        Illuminant::F(12),
    ];

    /// The names [`Illuminant::parse`] knows (in any case), as [`Illuminant::name`] spells
    /// them.
    pub const NAMES: [&'static str; 16] = [
        "A", "D50", "D65", "E", "F1", "F2", "F3", "F4", "F5", "F6", "F7", "F8", "F9", "F10", "F11",
        "F12",
    ];

    /// The illuminant named `name` (any case, surrounding spaces ignored), or
    /// [`SpectrumError::UnknownSpectrum`] listing the known names.
    pub fn parse(name: &str) -> Result<Self, SpectrumError> {
        let trimmed = name.trim();
        Self::NAMES
            .iter()
            .position(|n| n.eq_ignore_ascii_case(trimmed))
            .map(|i| Self::ALL[i])
            .ok_or_else(|| SpectrumError::UnknownSpectrum {
                name: name.to_string(),
                known: Self::NAMES.join(", "),
            })
    }

    /// The CIE name: `A`, `D50`, `D65`, `E`, `F1` ... `F12`.
    pub fn name(&self) -> String {
        match self {
            Illuminant::A => "A".to_string(),
            Illuminant::D50 => "D50".to_string(),
            Illuminant::D65 => "D65".to_string(),
            Illuminant::E => "E".to_string(),
            Illuminant::F(n) => format!("F{n}"),
        }
    }

    /// The position in [`Illuminant::ALL`], `None` for an `F` number outside 1 to 12.
    fn index(&self) -> Option<usize> {
        match *self {
            Illuminant::A => Some(0),
            Illuminant::D50 => Some(1),
            Illuminant::D65 => Some(2),
            Illuminant::E => Some(3),
            Illuminant::F(n @ 1..=12) => Some(3 + usize::from(n)),
            Illuminant::F(_) => None,
        }
    }

    /// `colorimetry`'s name for it (`None` as [`Illuminant::index`]).
    fn source(&self) -> Option<CieIlluminant> {
        use CieIlluminant as C;
        const F: [CieIlluminant; 12] = [
            C::F1,
            C::F2,
            C::F3,
            C::F4,
            C::F5,
            C::F6,
            C::F7,
            C::F8,
            C::F9,
            C::F10,
            C::F11,
            C::F12,
        ];
        Some(match *self {
            Illuminant::A => C::A,
            Illuminant::D50 => C::D50,
            Illuminant::D65 => C::D65,
            Illuminant::E => C::E,
            Illuminant::F(n) => *F.get(usize::from(n).checked_sub(1)?)?,
        })
    }

    /// The relative spectral power at 380, 381, ..., 780 nm, on the CIE table's scale
    /// (100 at 560 nm for A and the D series, 1 for E).
    ///
    /// # Panics
    ///
    /// For `F(n)` with `n` outside 1 to 12, which [`Illuminant::parse`] never gives.
    pub fn table(&self) -> &'static [f64; SAMPLES] {
        let i = self
            .index()
            .unwrap_or_else(|| panic!("{} is not a CIE illuminant", self.name()));
        &TABLES[i]
    }

    /// The relative spectral power at `lambda` (nm), linearly interpolated between the 1 nm
    /// samples, zero outside the module's range. Panics as [`Illuminant::table`].
    pub fn power(&self, lambda: f32) -> f64 {
        let t = self.table();
        match cie::grid_cell(lambda) {
            Some((i, w)) => t[i] * (1.0 - f64::from(w)) + t[i + 1] * f64::from(w),
            None => 0.0,
        }
    }
}

impl std::fmt::Display for Illuminant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// The illuminants' relative spectral powers, in the order of [`Illuminant::ALL`].
static TABLES: LazyLock<[[f64; SAMPLES]; 16]> = LazyLock::new(|| {
    Illuminant::ALL.map(|il| {
        let source = il.source().expect("ALL holds CIE illuminants");
        let spectrum: &colorimetry::spectrum::Spectrum = source.illuminant().as_ref();
        *spectrum.as_array()
    })
});

/// The spectrum a light emits: a CIE illuminant or a blackbody.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Emission {
    Illuminant(Illuminant),
    Blackbody(Blackbody),
}

impl Emission {
    /// A blackbody at `kelvin` K (see [`Blackbody::new`]).
    pub fn blackbody(kelvin: f32) -> Result<Self, SpectrumError> {
        Blackbody::new(kelvin).map(Emission::Blackbody)
    }

    /// An illuminant's name (as [`Illuminant::parse`]) or a colour temperature: a number and
    /// `K` (`2856K`, `6500 k`). An unknown name gives [`SpectrumError::UnknownSpectrum`], a
    /// temperature out of range [`SpectrumError::BadTemperature`].
    pub fn parse(name: &str) -> Result<Self, SpectrumError> {
        if let Ok(il) = Illuminant::parse(name) {
            return Ok(Emission::Illuminant(il));
        }
        let trimmed = name.trim();
        let number = trimmed
            .strip_suffix('K')
            .or_else(|| trimmed.strip_suffix('k'))
            .and_then(|n| n.trim_end().parse::<f32>().ok());
        match number {
            Some(kelvin) => Emission::blackbody(kelvin),
            None => Err(SpectrumError::UnknownSpectrum {
                name: name.to_string(),
                known: format!(
                    "{}, or a temperature such as 6500K",
                    Illuminant::NAMES.join(", ")
                ),
            }),
        }
    }

    /// The name [`Emission::parse`] reads back: the illuminant's, or the temperature and `K`.
    pub fn name(&self) -> String {
        match self {
            Emission::Illuminant(il) => il.name(),
            Emission::Blackbody(b) => format!("{}K", b.kelvin()),
        }
    }

    /// The spectrum at 1 nm, scaled to a luminance `Y` of 1. Panics as [`Illuminant::table`].
    pub fn table(&self) -> EmissionTable {
        let table = match self {
            Emission::Illuminant(il) => {
                let t = il.table();
                EmissionTable::with_unit_luminance(|l| t[(l - LAMBDA_MIN) as usize])
            }
            // The shape alone, which stays finite where the radiance underflows.
            Emission::Blackbody(b) => EmissionTable::with_unit_luminance(|l| b.relative(l)),
        };
        // Every CIE illuminant and every blackbody in range has some luminance.
        table.expect("an emission spectrum has a positive luminance")
    }
}

impl From<Illuminant> for Emission {
    fn from(il: Illuminant) -> Self {
        Emission::Illuminant(il)
    }
}

impl From<Blackbody> for Emission {
    fn from(b: Blackbody) -> Self {
        Emission::Blackbody(b)
    }
}

impl std::fmt::Display for Emission {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// An emission spectrum at 380, 381, ..., 780 nm with luminance `Y = ∫ S ȳ dλ = 1` (as
/// [`cie::xyz_of`] integrates): the colour of a light, apart from its intensity.
#[derive(Debug, Clone, PartialEq)]
pub struct EmissionTable {
    values: [f32; SAMPLES],
}

impl EmissionTable {
    /// The spectrum `f` (λ in nm) at the 1 nm samples, scaled to `Y = 1`; a
    /// [`SpectrumError::BadCoefficient`] if its luminance is not a positive finite number
    /// (black, negative or non-finite values).
    pub fn with_unit_luminance(f: impl Fn(f32) -> f64) -> Result<Self, SpectrumError> {
        let raw: [f64; SAMPLES] = std::array::from_fn(|i| f(cie::sample_lambda(i)));
        let y = cie::xyz_of(|l| raw[(l - LAMBDA_MIN) as usize])[1];
        if !(y.is_finite() && y > 0.0) {
            return Err(SpectrumError::BadCoefficient {
                what: "the luminance Y of an emission spectrum".to_string(),
                value: y as f32,
                expected: "a positive finite number",
            });
        }
        Ok(Self {
            values: raw.map(|v| (v / y) as f32),
        })
    }

    /// The values at 380, 381, ..., 780 nm.
    pub fn values(&self) -> &[f32; SAMPLES] {
        &self.values
    }

    /// The spectrum at `lambda` (nm), linearly interpolated between the 1 nm samples, zero
    /// outside [`super::LAMBDA_MIN`, `super::LAMBDA_MAX`] (and for NaN).
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        cie::lerp_1nm(&self.values, lambda)
    }

    /// [`EmissionTable::eval`] per lane, with the same bits on every backend.
    #[inline(always)]
    pub fn eval_lanes<L: Lanes>(&self, l: L, lambda: L::F32s) -> L::F32s {
        let (zero, last) = (l.splat(0.0), l.splat((SAMPLES - 1) as f32));
        let x = lambda - LAMBDA_MIN;
        let inside = x.ge(zero) & x.le(last);
        // Clamped (NaN to 0) so that every lane's gather reads inside the table.
        let x = x.clamp(zero, last);
        let i = x.floor().to_i32().min(l.splat_i32(SAMPLES as i32 - 2));
        let t = x - i.to_f32();
        let (a, b) = l.gather2(&self.values, i);
        // Not `lerp`: its multiply-add is fused on some backends only.
        let v = a * (l.splat(1.0) - t) + b * t;
        inside.select(v, zero)
    }

    /// The tristimulus values (`Y` is 1 up to rounding).
    pub fn xyz(&self) -> [f64; 3] {
        cie::xyz_of(|l| f64::from(self.eval(l)))
    }

    /// The linear sRGB of the spectrum: with `Y = 1`, the colour a light of this spectrum
    /// gets in an RGB render (`(1, 1, 1)` for [`white`]).
    pub fn rgb(&self) -> [f32; 3] {
        cie::xyz_to_rgb(self.xyz().map(|v| v as f32))
    }
}

static WHITE: LazyLock<EmissionTable> =
    LazyLock::new(|| Emission::Illuminant(Illuminant::D65).table());

/// The display's white: D65 with `Y = 1`, whose [`EmissionTable::rgb`] is `(1, 1, 1)`.
pub fn white() -> &'static EmissionTable {
    &WHITE
}

#[cfg(test)]
mod tests {
    use coherent_simd::scalar::Scalar;
    use coherent_simd::{Backend, Kernel};

    use super::*;
    use crate::spectrum::LAMBDA_MAX;

    fn chromaticity_of(e: Emission) -> [f64; 2] {
        cie::chromaticity(e.table().xyz())
    }

    fn assert_xy(got: [f64; 2], want: [f64; 2], tol: f64, what: &str) {
        assert!(
            (got[0] - want[0]).abs() < tol && (got[1] - want[1]).abs() < tol,
            "{what}: {got:?}, expected {want:?} within {tol}"
        );
    }

    #[test]
    fn the_white_is_d65_with_unit_luminance_and_rgb_one() {
        let w = white();
        assert!((w.xyz()[1] - 1.0).abs() < 1e-6, "{:?}", w.xyz());
        for c in w.rgb() {
            assert!((c - 1.0).abs() < 1e-3, "{:?}", w.rgb());
        }
        assert_eq!(*w, Emission::Illuminant(Illuminant::D65).table());
    }

    /// The CIE's published chromaticities (CIE 15:2018, Table T.8 and T.10).
    #[test]
    fn illuminants_have_their_cie_chromaticities() {
        let cases = [
            (Illuminant::A, [0.44758, 0.40745], 5e-4),
            (Illuminant::D65, [0.31272, 0.32903], 5e-4),
            (Illuminant::D50, [0.34567, 0.35850], 5e-4),
            (Illuminant::E, [1.0 / 3.0, 1.0 / 3.0], 5e-4),
            (Illuminant::F(2), [0.37208, 0.37529], 1e-3),
            (Illuminant::F(7), [0.31292, 0.32933], 1e-3),
            (Illuminant::F(11), [0.38052, 0.37713], 1e-3),
        ];
        for (il, xy, tol) in cases {
            assert_xy(chromaticity_of(il.into()), xy, tol, &il.name());
        }
        // Every table has unit luminance, whatever its scale.
        for il in Illuminant::ALL {
            let y = Emission::from(il).table().xyz()[1];
            assert!((y - 1.0).abs() < 1e-6, "{il}: {y}");
        }
    }

    /// Illuminant A is a 2856 K blackbody (by the older second radiation constant).
    #[test]
    fn a_2856_kelvin_blackbody_has_the_chromaticity_of_a() {
        let b = Emission::blackbody(2856.0).unwrap();
        assert_xy(chromaticity_of(b), [0.44758, 0.40745], 1e-3, "2856 K");
        // Hotter is bluer; tiny and huge temperatures still give finite tables.
        let x = |k: f32| chromaticity_of(Emission::blackbody(k).unwrap())[0];
        assert!(x(2000.0) > x(2856.0) && x(2856.0) > x(6500.0) && x(6500.0) > x(20000.0));
        for k in [f32::MIN_POSITIVE, 1.0, 100_000.0] {
            let t = Emission::blackbody(k).unwrap().table();
            assert!(
                t.values().iter().all(|v| v.is_finite() && *v >= 0.0),
                "{k} K"
            );
        }
    }

    #[test]
    fn parse_ignores_case_and_lists_the_names_it_knows() {
        for (name, want) in [
            ("A", Illuminant::A),
            ("a", Illuminant::A),
            ("d65", Illuminant::D65),
            (" D50 ", Illuminant::D50),
            ("e", Illuminant::E),
            ("f2", Illuminant::F(2)),
            ("F12", Illuminant::F(12)),
        ] {
            assert_eq!(Illuminant::parse(name), Ok(want), "{name}");
        }
        for (il, name) in Illuminant::ALL.iter().zip(Illuminant::NAMES) {
            assert_eq!(il.name(), name);
            assert_eq!(Illuminant::parse(name), Ok(*il));
        }
        for bad in ["D75", "F0", "F13", "", "illuminant A"] {
            match Illuminant::parse(bad) {
                Err(SpectrumError::UnknownSpectrum { name, known }) => {
                    assert_eq!(name, bad);
                    for n in Illuminant::NAMES {
                        assert!(known.split(", ").any(|k| k == n), "{n} not in {known}");
                    }
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
        let message = Illuminant::parse("D75").unwrap_err().to_string();
        assert!(
            message.contains("D75") && message.contains("F12"),
            "{message}"
        );
    }

    #[test]
    fn emissions_parse_illuminants_and_temperatures() {
        assert_eq!(
            Emission::parse("d65"),
            Ok(Emission::Illuminant(Illuminant::D65))
        );
        for name in ["2856K", "2856k", " 2856 K "] {
            assert_eq!(Emission::parse(name), Emission::blackbody(2856.0), "{name}");
        }
        for e in [
            Emission::blackbody(6500.5).unwrap(),
            Illuminant::F(3).into(),
        ] {
            assert_eq!(Emission::parse(&e.name()), Ok(e));
        }
        for bad in ["0K", "-1K", "100001K", "nanK", "infK"] {
            assert!(
                matches!(
                    Emission::parse(bad),
                    Err(SpectrumError::BadTemperature { .. })
                ),
                "{bad}"
            );
        }
        for bad in ["K", "hot", "6500", "65OOK"] {
            match Emission::parse(bad) {
                Err(SpectrumError::UnknownSpectrum { known, .. }) => {
                    assert!(known.contains("D65") && known.contains("6500K"), "{known}");
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
    }

    #[test]
    fn power_interpolates_the_cie_table() {
        let d65 = Illuminant::D65;
        // CIE D65 is 100 at 560 nm and 117.812 at 460 nm.
        assert!((d65.power(560.0) - 100.0).abs() < 1e-9);
        assert!((d65.power(460.0) - 117.812).abs() < 1e-3);
        let t = d65.table();
        assert!((d65.power(460.5) - (t[80] + t[81]) / 2.0).abs() < 1e-9);
        assert_eq!(d65.power(379.0), 0.0);
        assert_eq!(d65.power(f32::NAN), 0.0);
        assert_eq!(Illuminant::E.power(600.0), 1.0);
    }

    #[test]
    fn eval_interpolates_the_table_and_is_zero_outside() {
        let w = white();
        let v = w.values();
        assert_eq!(w.eval(380.0), v[0]);
        assert_eq!(w.eval(560.0), v[180]);
        assert_eq!(w.eval(780.0), v[400]);
        let mid = w.eval(560.25);
        assert!((mid - (0.75 * v[180] + 0.25 * v[181])).abs() < 1e-6 * v[180]);
        for l in [379.99, 780.01, 0.0, -400.0, f32::NAN, f32::INFINITY] {
            assert_eq!(w.eval(l), 0.0, "{l}");
        }
        assert!(matches!(
            EmissionTable::with_unit_luminance(|_| 0.0),
            Err(SpectrumError::BadCoefficient { .. })
        ));
        assert!(EmissionTable::with_unit_luminance(|_| f64::NAN).is_err());
    }

    /// Wavelengths in and around the range: the grid's nodes, points between them, the ends
    /// and their neighbours, and values outside (NaN, infinities), padded to whole packets.
    fn probe_lambdas() -> Vec<f32> {
        let mut ls: Vec<f32> = (0..=800).map(|k| 370.0 + k as f32 * 0.51).collect();
        ls.extend([
            LAMBDA_MIN,
            LAMBDA_MIN.next_down(),
            LAMBDA_MIN.next_up(),
            LAMBDA_MAX,
            LAMBDA_MAX.next_down(),
            LAMBDA_MAX.next_up(),
            0.0,
            -0.0,
            -1e30,
            1e30,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ]);
        ls.resize(ls.len().next_multiple_of(16), 555.5);
        ls
    }

    struct EvalAll<'a> {
        table: &'a EmissionTable,
        lambdas: &'a [f32],
    }

    impl Kernel for EvalAll<'_> {
        type Output = Vec<f32>;
        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> Vec<f32> {
            let mut out = Vec::with_capacity(self.lambdas.len());
            for chunk in self.lambdas.chunks_exact(L::N) {
                let v = self.table.eval_lanes(l, l.load(chunk));
                out.extend((0..L::N).map(|k| v.lane(k)));
            }
            out
        }
    }

    #[test]
    fn eval_lanes_is_eval_on_every_backend() {
        let lambdas = probe_lambdas();
        for table in [white().clone(), Emission::from(Illuminant::F(12)).table()] {
            let want: Vec<f32> = lambdas.iter().map(|&l| table.eval(l)).collect();
            for (&l, &w) in lambdas.iter().zip(&want) {
                let got = table.eval_lanes(Scalar, l);
                assert_eq!(got.to_bits(), w.to_bits(), "scalar at {l} nm");
            }
            for b in Backend::usable() {
                let got = b
                    .run(EvalAll {
                        table: &table,
                        lambdas: &lambdas,
                    })
                    .unwrap();
                for ((&l, &w), &g) in lambdas.iter().zip(&want).zip(&got) {
                    assert!((g - w).abs() <= 1e-6 * w.abs(), "{b} at {l} nm: {g} vs {w}");
                }
            }
        }
    }
}
