//! Blackbody emitters: the spectral radiance of an ideal thermal radiator by Planck's law,
//! for lights given by a colour temperature (incandescent lamps are close to one).

use super::{LAMBDA_MAX, LAMBDA_MIN, SpectrumError};

/// The Planck constant `h`, in J s (exact in the SI since 2019).
pub const PLANCK: f64 = 6.626_070_15e-34;
/// The speed of light in vacuum `c`, in m/s (exact).
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;
/// The Boltzmann constant `k`, in J/K (exact).
pub const BOLTZMANN: f64 = 1.380_649e-23;
/// Wien's displacement constant `b`, in m K: a blackbody's radiance per unit wavelength
/// peaks at `b / T`.
pub const WIEN: f64 = 2.897_771_955e-3;
/// The highest temperature accepted, in K (hotter than any star a scene would light with;
/// beyond it the visible spectrum no longer changes shape).
pub const MAX_KELVIN: f32 = 100_000.0;

/// The first radiation constant for spectral radiance, `2 h c^2`, in W m^2 / sr.
const C1L: f64 = 2.0 * PLANCK * SPEED_OF_LIGHT * SPEED_OF_LIGHT;
/// The second radiation constant `h c / k`, in m K.
const C2: f64 = PLANCK * SPEED_OF_LIGHT / BOLTZMANN;

/// A blackbody at a temperature in `(0, MAX_KELVIN]` K.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blackbody {
    kelvin: f32,
}

impl Blackbody {
    /// A blackbody at `kelvin` K: finite and in `(0, MAX_KELVIN]`, else
    /// [`SpectrumError::BadTemperature`].
    pub fn new(kelvin: f32) -> Result<Self, SpectrumError> {
        if kelvin > 0.0 && kelvin <= MAX_KELVIN {
            Ok(Self { kelvin })
        } else {
            Err(SpectrumError::BadTemperature { kelvin })
        }
    }

    /// The temperature, in K.
    pub fn kelvin(&self) -> f32 {
        self.kelvin
    }

    /// `h c / (λ k T)` for `lambda_nm` in nm: the exponent of Planck's law.
    fn exponent(&self, lambda_nm: f32) -> f64 {
        C2 / (f64::from(lambda_nm) * 1e-9 * f64::from(self.kelvin))
    }

    /// The spectral radiance at `lambda_nm` (nm) by Planck's law,
    /// `B(λ, T) = 2 h c^2 / λ^5 / (exp(h c / (λ k T)) - 1)`, in SI units: W / (m^2 sr m),
    /// per metre of wavelength (times `1e-9` per nm). Zero for wavelengths that are not
    /// positive, and where it underflows (short wavelengths of a cold body).
    pub fn radiance(&self, lambda_nm: f32) -> f64 {
        if lambda_nm.is_nan() || lambda_nm <= 0.0 {
            return 0.0;
        }
        let lambda = f64::from(lambda_nm) * 1e-9;
        C1L / lambda.powi(5) / self.exponent(lambda_nm).exp_m1()
    }

    /// `ln B(λ, T)` without overflow: finite for every temperature and positive wavelength
    /// (where the radiance itself underflows to zero).
    fn ln_radiance(&self, lambda_nm: f32) -> f64 {
        let lambda = f64::from(lambda_nm) * 1e-9;
        let x = self.exponent(lambda_nm);
        // ln(exp(x) - 1) = x + ln(1 - exp(-x)): exact above 1, where `exp` may overflow.
        let ln_expm1 = if x > 1.0 {
            x + (-(-x).exp()).ln_1p()
        } else {
            x.exp_m1().ln()
        };
        C1L.ln() - 5.0 * lambda.ln() - ln_expm1
    }

    /// The wavelength of the peak radiance (Wien's law), in nm.
    pub fn peak_nm(&self) -> f64 {
        WIEN / f64::from(self.kelvin) * 1e9
    }

    /// The radiance at `lambda_nm` (nm) relative to the brightest wavelength of the module's
    /// range (the peak, or the end of the range nearest it), in `[0, 1]`: the spectrum's
    /// shape, computed in logarithms so that it stays finite and non-zero where the
    /// absolute radiance underflows (a body of a few kelvin). Zero for wavelengths that
    /// are not positive.
    pub fn relative(&self, lambda_nm: f32) -> f64 {
        if lambda_nm.is_nan() || lambda_nm <= 0.0 {
            return 0.0;
        }
        // The radiance rises up to the peak and falls after it.
        let brightest = (self.peak_nm() as f32).clamp(LAMBDA_MIN, LAMBDA_MAX);
        (self.ln_radiance(lambda_nm) - self.ln_radiance(brightest))
            .exp()
            .min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temperatures_outside_0_to_100000_kelvin_are_refused() {
        for kelvin in [
            0.0,
            -0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            100_001.0,
        ] {
            match Blackbody::new(kelvin) {
                Err(SpectrumError::BadTemperature { kelvin: k }) => {
                    assert!(k.to_bits() == kelvin.to_bits(), "{k} for {kelvin}");
                }
                other => panic!("{kelvin} K: {other:?}"),
            }
        }
        for kelvin in [f32::MIN_POSITIVE, 1.0, 2856.0, 100_000.0] {
            assert_eq!(Blackbody::new(kelvin).unwrap().kelvin(), kelvin);
        }
        let message = Blackbody::new(-1.0).unwrap_err().to_string();
        assert!(message.contains("-1 K"), "{message}");
    }

    /// Against the radiation constants as CODATA tabulates them, at 500 nm and 5000 K.
    #[test]
    fn radiance_is_plancks_law_in_si_units() {
        let (c1l, c2) = (1.191_042_972e-16, 1.438_776_877e-2);
        let (lambda, t) = (500e-9f64, 5000.0f64);
        let want = c1l / lambda.powi(5) / ((c2 / (lambda * t)).exp() - 1.0);
        let got = Blackbody::new(5000.0).unwrap().radiance(500.0);
        assert!((got / want - 1.0).abs() < 1e-8, "{got} vs {want}");
        // Per metre of wavelength: 1.2107e4 W / (m^2 sr nm).
        assert!((got / 1.2107e13 - 1.0).abs() < 1e-4, "{got}");
        assert_eq!(Blackbody::new(5000.0).unwrap().radiance(0.0), 0.0);
        assert_eq!(Blackbody::new(5000.0).unwrap().radiance(f32::NAN), 0.0);
    }

    /// `π ∫ B dλ = σ T^4` (the Stefan-Boltzmann law): the units and the constants together.
    #[test]
    fn radiance_integrates_to_the_stefan_boltzmann_law() {
        const SIGMA: f64 = 5.670_374_419e-8;
        let t = 5000.0;
        let b = Blackbody::new(t).unwrap();
        // Trapezoids in ln λ from 10 nm to 1 mm.
        let (lo, hi, n) = (10f64.ln(), 1e6f64.ln(), 20_000);
        let h = (hi - lo) / n as f64;
        let f = |k: usize| {
            let nm = (lo + k as f64 * h).exp();
            b.radiance(nm as f32) * nm * 1e-9
        };
        let integral: f64 = (1..n).map(f).sum::<f64>() * h + (f(0) + f(n)) * h / 2.0;
        let want = SIGMA * f64::from(t).powi(4);
        let got = std::f64::consts::PI * integral;
        assert!((got / want - 1.0).abs() < 1e-4, "{got} vs {want}");
    }

    #[test]
    fn the_peak_of_a_5000_kelvin_blackbody_is_at_wiens_wavelength() {
        let b = Blackbody::new(5000.0).unwrap();
        let want = 2.897771955e6 / 5000.0;
        // The brightest of 0.1 nm steps over the range.
        let peak = (0..=4000)
            .map(|k| LAMBDA_MIN + k as f32 * 0.1)
            .max_by(|a, c| b.radiance(*a).total_cmp(&b.radiance(*c)))
            .unwrap();
        assert!(
            (f64::from(peak) - want).abs() < 1.0,
            "{peak} nm vs {want} nm"
        );
        assert!((b.peak_nm() - want).abs() < 1e-9);
    }

    /// The relative spectrum is the radiance over its largest value in range, and stays
    /// finite for the coldest and hottest bodies.
    #[test]
    fn relative_radiance_is_the_shape_at_any_temperature() {
        let b = Blackbody::new(2856.0).unwrap();
        // Peak beyond 780 nm: the longest wavelength is the brightest.
        assert_eq!(b.relative(LAMBDA_MAX), 1.0);
        for nm in [380.0, 500.0, 650.0] {
            let want = b.radiance(nm) / b.radiance(LAMBDA_MAX);
            assert!((b.relative(nm) / want - 1.0).abs() < 1e-9, "{nm}");
        }
        let hot = Blackbody::new(MAX_KELVIN).unwrap();
        assert_eq!(hot.relative(LAMBDA_MIN), 1.0);
        assert!(hot.relative(LAMBDA_MAX) > 0.0 && hot.relative(LAMBDA_MAX) < 1.0);
        let sun = Blackbody::new(5000.0).unwrap();
        assert!((sun.relative(sun.peak_nm() as f32) - 1.0).abs() < 1e-9);
        for kelvin in [f32::MIN_POSITIVE, 1e-3, 1.0, 300.0] {
            let cold = Blackbody::new(kelvin).unwrap();
            assert_eq!(cold.relative(LAMBDA_MAX), 1.0, "{kelvin} K");
            let r = cold.relative(LAMBDA_MIN);
            assert!((0.0..1.0).contains(&r), "{kelvin} K: {r}");
        }
        assert_eq!(sun.relative(-5.0), 0.0);
    }
}
