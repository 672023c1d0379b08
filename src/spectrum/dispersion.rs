//! Dispersive indices of refraction: the index as a function of wavelength, so that a
//! spectral sample refracts by its own angle (the colours of a prism or a diamond).
//!
//! The two usual fits, in their conventional units (λ in µm): Cauchy's
//! `n = A + B/λ^2 + C/λ^4` and Sellmeier's `n^2 = 1 + Σ Bi λ^2 / (λ^2 - Ci)` (Ci in µm^2,
//! the squares of the resonance wavelengths), which glass catalogues tabulate. The methods
//! take λ in nm, as the rest of the module does.

use super::{LAMBDA_MAX, LAMBDA_MIN, SpectrumError};

/// The helium d line (nm): the wavelength of a glass's nominal index `n_d`.
pub const LAMBDA_D: f32 = 587.5618;
/// The hydrogen F line (nm), the blue end of the Abbe number's difference.
pub const LAMBDA_F: f32 = 486.1327;
/// The hydrogen C line (nm), the red end of the Abbe number's difference.
pub const LAMBDA_C: f32 = 656.2725;

/// An index of refraction over wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Dispersion {
    /// The same index at every wavelength (no dispersion).
    Constant(f32),
    /// Cauchy's `n = A + B/λ^2 + C/λ^4`, λ in µm (`B` in µm^2, `C` in µm^4).
    Cauchy { a: f32, b: f32, c: f32 },
    /// Sellmeier's `n^2 = 1 + Σ Bi λ^2 / (λ^2 - Ci)`, λ in µm, `Ci` in µm^2.
    Sellmeier { b: [f32; 3], c: [f32; 3] },
}

/// The named glasses of [`preset`]: Sellmeier coefficients of the Schott catalogue.
pub const PRESETS: [(&str, Dispersion); 2] = [
    // Schott N-BK7, the common borosilicate crown: n_d = 1.5168, V_d = 64.17.
    (
        "BK7",
        sellmeier(
            [1.03961212, 0.231792344, 1.01046945],
            [0.00600069867, 0.0200179144, 103.560653],
        ),
    ),
    // Schott F2, a flint: n_d = 1.6200, V_d = 36.37.
    (
        "F2",
        sellmeier(
            [1.34533359, 0.209073176, 0.937357162],
            [0.00997743871, 0.0470450767, 111.886764],
        ),
    ),
];

/// A Sellmeier fit from the catalogue's digits (more than an `f32` keeps).
const fn sellmeier(b: [f64; 3], c: [f64; 3]) -> Dispersion {
    Dispersion::Sellmeier {
        b: [b[0] as f32, b[1] as f32, b[2] as f32],
        c: [c[0] as f32, c[1] as f32, c[2] as f32],
    }
}

/// The named glass `name` of [`PRESETS`] (case does not matter).
pub fn preset(name: &str) -> Result<Dispersion, SpectrumError> {
    PRESETS
        .iter()
        .find(|(known, _)| known.eq_ignore_ascii_case(name))
        .map(|&(_, d)| d)
        .ok_or_else(|| SpectrumError::UnknownGlass {
            name: name.to_owned(),
            known: PRESETS.map(|(known, _)| known).join(", "),
        })
}

/// `(λ / 1 µm)^2` of `lambda_nm`.
#[inline]
fn micron2(lambda_nm: f64) -> f64 {
    let um = lambda_nm * 1e-3;
    um * um
}

impl Dispersion {
    /// The index at `lambda_nm`. Evaluated in `f64`; for coefficients [`Dispersion::validate`]
    /// refuses the result may be NaN or infinite.
    #[inline]
    pub fn index(&self, lambda_nm: f32) -> f32 {
        self.index64(f64::from(lambda_nm)) as f32
    }

    fn index64(&self, lambda_nm: f64) -> f64 {
        match *self {
            Dispersion::Constant(n) => f64::from(n),
            Dispersion::Cauchy { a, b, c } => {
                let l2 = micron2(lambda_nm);
                f64::from(a) + f64::from(b) / l2 + f64::from(c) / (l2 * l2)
            }
            Dispersion::Sellmeier { b, c } => {
                let l2 = micron2(lambda_nm);
                let n2: f64 = 1.0
                    + (0..3)
                        .map(|i| f64::from(b[i]) * l2 / (l2 - f64::from(c[i])))
                        .sum::<f64>();
                n2.sqrt()
            }
        }
    }

    /// The two-term Cauchy glass of index `n_d` at the d line and Abbe number `abbe`: a
    /// glass a scene gives by its catalogue figures rather than by coefficients.
    pub fn cauchy_abbe(n_d: f32, abbe: f32) -> Dispersion {
        let (n_d, abbe) = (f64::from(n_d), f64::from(abbe));
        let spread = 1.0 / micron2(f64::from(LAMBDA_F)) - 1.0 / micron2(f64::from(LAMBDA_C));
        let b = (n_d - 1.0) / (abbe * spread);
        let a = n_d - b / micron2(f64::from(LAMBDA_D));
        Dispersion::Cauchy {
            a: a as f32,
            b: b as f32,
            c: 0.0,
        }
    }

    /// The nominal index `n_d`, at the helium d line ([`LAMBDA_D`]).
    pub fn index_d(&self) -> f32 {
        self.index(LAMBDA_D)
    }

    /// The Abbe number `V_d = (n_d - 1) / (n_F - n_C)`: the larger, the less the glass
    /// disperses (crowns above 50, flints below). Infinite without dispersion.
    pub fn abbe(&self) -> f32 {
        let [d, f, c] = [LAMBDA_D, LAMBDA_F, LAMBDA_C].map(|l| self.index64(f64::from(l)));
        if f == c {
            return f32::INFINITY;
        }
        ((d - 1.0) / (f - c)) as f32
    }

    /// Whether the index can be used over [`LAMBDA_MIN`, `LAMBDA_MAX`]: every coefficient
    /// finite and at least 0 (a constant index finite and at least 1), no Sellmeier pole
    /// (`λ^2 = Ci`) in the range, and the index finite and at least 1 over the range.
    ///
    /// With non-negative coefficients and no pole in the range, each Cauchy and Sellmeier
    /// term decreases with λ, so the index is largest at [`LAMBDA_MIN`] and smallest at
    /// [`LAMBDA_MAX`]: checking the two ends checks the range.
    pub fn validate(&self) -> Result<(), SpectrumError> {
        let bad = |what: String, value: f32, expected: &'static str| {
            Err(SpectrumError::BadCoefficient {
                what,
                value,
                expected,
            })
        };
        let non_negative = |what: String, v: f32| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                bad(what, v, "finite and at least 0")
            }
        };
        let kind = match *self {
            Dispersion::Constant(n) => {
                if n.is_finite() && n >= 1.0 {
                    return Ok(());
                }
                return bad("constant index".to_owned(), n, "finite and at least 1");
            }
            Dispersion::Cauchy { a, b, c } => {
                non_negative("cauchy A".to_owned(), a)?;
                non_negative("cauchy B".to_owned(), b)?;
                non_negative("cauchy C".to_owned(), c)?;
                "cauchy"
            }
            Dispersion::Sellmeier { b, c } => {
                for (i, &v) in b.iter().enumerate() {
                    non_negative(format!("sellmeier B{}", i + 1), v)?;
                }
                for (i, &v) in c.iter().enumerate() {
                    non_negative(format!("sellmeier C{}", i + 1), v)?;
                }
                let range = micron2(f64::from(LAMBDA_MIN))..=micron2(f64::from(LAMBDA_MAX));
                for (i, &v) in c.iter().enumerate() {
                    if range.contains(&f64::from(v)) {
                        return bad(
                            format!("sellmeier C{}", i + 1),
                            v,
                            "outside [0.1444, 0.6084] µm^2 (a pole inside 380-780 nm)",
                        );
                    }
                }
                "sellmeier"
            }
        };
        // The smallest index first: below 1 there is the usual failure.
        for lambda in [LAMBDA_MAX, LAMBDA_MIN] {
            let n = self.index(lambda);
            if !(n.is_finite() && n >= 1.0) {
                return bad(
                    format!("{kind} index at {lambda} nm"),
                    n,
                    "finite and at least 1",
                );
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(got: f32, want: f32, tol: f32) -> bool {
        (got - want).abs() <= tol
    }

    #[test]
    fn a_cauchy_glass_from_its_catalogue_figures_has_them() {
        for (n_d, abbe) in [(1.5, 36.37), (1.52, 64.17), (1.7, 30.0)] {
            let d = Dispersion::cauchy_abbe(n_d, abbe);
            assert!(close(d.index_d(), n_d, 1e-6), "{d:?}");
            assert!(close(d.abbe(), abbe, 1e-3 * abbe), "{d:?}: {}", d.abbe());
            d.validate().unwrap();
        }
    }

    #[test]
    fn bk7_matches_the_schott_catalogue() {
        let g = preset("BK7").unwrap();
        g.validate().unwrap();
        let (d, f, c) = (g.index_d(), g.index(LAMBDA_F), g.index(LAMBDA_C));
        assert!(close(d, 1.5168, 1e-4), "n_d {d}");
        assert!(close(f, 1.5224, 2e-4), "n_F {f}");
        assert!(close(c, 1.5143, 2e-4), "n_C {c}");
        assert!(close(g.abbe(), 64.17, 0.3), "V_d {}", g.abbe());
    }

    #[test]
    fn f2_matches_the_schott_catalogue() {
        let g = preset("f2").unwrap();
        g.validate().unwrap();
        assert!(close(g.index_d(), 1.6200, 1e-4), "n_d {}", g.index_d());
        assert!(close(g.abbe(), 36.37, 0.3), "V_d {}", g.abbe());
        // A flint disperses more than a crown.
        assert!(g.abbe() < preset("bk7").unwrap().abbe());
    }

    #[test]
    fn presets_are_case_insensitive_and_unknown_names_list_the_known() {
        assert_eq!(preset("Bk7"), preset("BK7"));
        assert_eq!(preset("F2"), Ok(PRESETS[1].1));
        let e = preset("SF11").unwrap_err();
        assert_eq!(
            e,
            SpectrumError::UnknownGlass {
                name: "SF11".to_owned(),
                known: "BK7, F2".to_owned()
            }
        );
        assert!(e.to_string().contains("BK7, F2"), "{e}");
    }

    #[test]
    fn glasses_index_falls_with_wavelength() {
        for (name, g) in PRESETS {
            let mut last = f32::INFINITY;
            for k in 0..=400 {
                let n = g.index(LAMBDA_MIN + k as f32);
                assert!(
                    n < last,
                    "{name} at {} nm: {n} after {last}",
                    LAMBDA_MIN + k as f32
                );
                last = n;
            }
        }
        let cauchy = Dispersion::Cauchy {
            a: 1.5046,
            b: 0.00420,
            c: 0.0,
        };
        cauchy.validate().unwrap();
        assert!(cauchy.index(400.0) > cauchy.index(700.0));
        assert!(close(cauchy.index(500.0), 1.5046 + 0.0042 / 0.25, 1e-6));
    }

    #[test]
    fn a_constant_index_is_itself_everywhere() {
        let d = Dispersion::Constant(1.33);
        d.validate().unwrap();
        for k in 0..=400 {
            assert_eq!(d.index(LAMBDA_MIN + k as f32), 1.33);
        }
        assert_eq!(d.index_d(), 1.33);
        assert_eq!(d.abbe(), f32::INFINITY);
    }

    fn what(d: Dispersion) -> (String, f32) {
        match d.validate() {
            Err(SpectrumError::BadCoefficient { what, value, .. }) => (what, value),
            other => panic!("{d:?}: {other:?}"),
        }
    }

    #[test]
    fn bad_coefficients_are_refused_by_name() {
        let bk7 = preset("BK7").unwrap();
        let Dispersion::Sellmeier { b, c } = bk7 else {
            unreachable!()
        };
        for bad in [-0.1, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for i in 0..3 {
                let mut bb = b;
                bb[i] = bad;
                let (w, v) = what(Dispersion::Sellmeier { b: bb, c });
                assert_eq!(w, format!("sellmeier B{}", i + 1));
                assert!(v.to_bits() == bad.to_bits());
                let mut cc = c;
                cc[i] = bad;
                assert_eq!(
                    what(Dispersion::Sellmeier { b, c: cc }).0,
                    format!("sellmeier C{}", i + 1)
                );
            }
            let cauchy = |a, b, c| Dispersion::Cauchy { a, b, c };
            assert_eq!(what(cauchy(bad, 0.0, 0.0)).0, "cauchy A");
            assert_eq!(what(cauchy(1.5, bad, 0.0)).0, "cauchy B");
            assert_eq!(what(cauchy(1.5, 0.0, bad)).0, "cauchy C");
            assert_eq!(what(Dispersion::Constant(bad)).0, "constant index");
        }
        for n in [0.0, 0.5, 0.999] {
            assert_eq!(
                what(Dispersion::Constant(n)),
                ("constant index".to_owned(), n)
            );
        }
        // Non-negative coefficients whose index falls below 1 at the long end.
        let (w, v) = what(Dispersion::Cauchy {
            a: 0.9,
            b: 0.01,
            c: 0.0,
        });
        assert_eq!(w, "cauchy index at 780 nm");
        assert!(v < 1.0);
        let e = Dispersion::Constant(0.5).validate().unwrap_err();
        assert!(e.to_string().contains("constant index is 0.5"), "{e}");
    }

    #[test]
    fn a_pole_inside_the_range_is_refused() {
        // Resonances at 380, 500 and 780 nm: squares of 0.38, 0.5 and 0.78 µm.
        for (i, pole) in [(0, 0.1444f32), (1, 0.25), (2, 0.6084)] {
            let mut c = [0.01, 0.02, 100.0];
            c[i] = pole;
            let d = Dispersion::Sellmeier {
                b: [1.0, 0.2, 1.0],
                c,
            };
            assert_eq!(what(d), (format!("sellmeier C{}", i + 1), pole));
        }
        // A pole just past the long end drives n^2 negative there.
        let d = Dispersion::Sellmeier {
            b: [1.0, 0.0, 0.0],
            c: [0.62, 0.0, 0.0],
        };
        let (w, v) = what(d);
        assert_eq!(w, "sellmeier index at 780 nm");
        assert!(v.is_nan(), "{v}");
        // Poles outside the range are fine where the index stays above 1.
        Dispersion::Sellmeier {
            b: [1.0, 0.0, 0.0],
            c: [0.1, 0.0, 0.0],
        }
        .validate()
        .unwrap();
    }
}
