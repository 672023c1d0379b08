use super::*;
use coherent_simd::Backend;

#[test]
fn names_round_trip() {
    for o in Operator::ALL {
        assert_eq!(o.name().parse::<Operator>().unwrap(), o);
    }
    assert_eq!(Operator::default(), Operator::Tumblin);
    let e = "drago".parse::<Operator>().unwrap_err().to_string();
    assert!(e.contains("drago") && e.contains("tumblin"), "{e}");
}

fn absolute() -> Display {
    Display {
        world_log_average: None,
        ..Display::default()
    }
}

/// Closed forms worked by hand (python, f64) from the published formulas: Tumblin-Rushmeier
/// with L_avg = 1, L_dmax = 80, C_max = 36 gives y = 0.96618, scale = 0.0240907, so
/// L = 10 shows at 0.19508; Ward's scale factor for L_wa = 1 is 10.0835, so L = 1 shows at
/// 10.0835 / 80; Reinhard with key 0.18, L_avg = 1, white 0.18 * 100 maps L = 1 to
/// 0.18 (1 + 0.18 / 18^2) / 1.18.
#[test]
fn closed_forms() {
    let a = Adaptation {
        log_average: 1.0,
        max: 100.0,
    };
    let t = ToneMap::new(Operator::Tumblin, a, absolute());
    assert!((t.display_exact(10.0) - 0.195_080_04).abs() < 2e-6);
    assert_eq!(t.display_exact(1.0), 0.0, "below the display's black level");
    let w = ToneMap::new(Operator::Ward, a, absolute());
    assert!((w.display_exact(1.0) - 10.083_509 / 80.0).abs() < 1e-6);
    let r = ToneMap::new(Operator::Reinhard, a, absolute());
    let want = 0.18 * (1.0 + 0.18 / (18.0f32 * 18.0)) / 1.18;
    assert!((r.display_exact(1.0) - want).abs() < 1e-6);
    // The default world scale maps the log average to 50 cd/m^2 whatever the radiance unit.
    let t1 = ToneMap::new(Operator::Tumblin, a, Display::default());
    let a2 = Adaptation {
        log_average: 1e-3,
        max: 0.1,
    };
    let t2 = ToneMap::new(Operator::Tumblin, a2, Display::default());
    assert!((t1.display_exact(3.0) - t2.display_exact(3e-3)).abs() < 1e-5);
}

fn hdr_image(n: usize) -> Vec<[f32; 3]> {
    // Luminances over 7 decades, coloured, with black and a few odd pixels.
    (0..n)
        .map(|i| {
            let l = 10f32.powf(-3.0 + 7.0 * (i as f32 / n as f32));
            let c = [l * 1.3, l * 0.9, l * 0.4 * (1.0 + (i % 7) as f32 / 7.0)];
            match i % 97 {
                0 => [0.0; 3],
                1 => [f32::NAN, 1.0, 1.0],
                2 => [-1.0, 2.0, 0.5],
                _ => c,
            }
        })
        .collect()
}

fn lum(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[test]
fn packets_match_std_within_the_bound_on_every_backend() {
    let img = hdr_image(3001);
    // The pre-render sees part of the image only: pixels brighter than its max occur.
    let a = Adaptation::from_luminances(img.iter().step_by(5).take(500).map(|c| lum(*c)));
    for op in Operator::ALL {
        for d in [Display::default(), absolute()] {
            let t = ToneMap::new(op, a, d);
            let bound = t.max_abs_error();
            if op == Operator::Tumblin {
                assert!(bound < 0.03, "{bound}");
            }
            for b in Backend::usable() {
                let got = apply_image(b, &t, &img).unwrap();
                for (i, (g, c)) in got.iter().zip(&img).enumerate() {
                    let want = t.apply_exact(*c);
                    let c0 = [c[0].max(0.0), c[1].max(0.0), c[2].max(0.0)];
                    let l = lum(c0);
                    for ch in 0..3 {
                        let scale = if l > 0.0 { c0[ch] / l } else { 0.0 };
                        let err = (g[ch] - want[ch]).abs();
                        assert!(
                            g[ch].is_finite() && err <= bound * scale.max(1.0) + 1e-6,
                            "{op} on {b}, pixel {i} channel {ch}: {} vs {} (bound {bound})",
                            g[ch],
                            want[ch]
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn monotone_in_luminance() {
    let a = Adaptation {
        log_average: 0.5,
        max: 40.0,
    };
    let greys: Vec<[f32; 3]> = (0..2000)
        .map(|i| [10f32.powf(-4.0 + 7.0 * i as f32 / 2000.0); 3])
        .collect();
    for op in Operator::ALL {
        let t = ToneMap::new(op, a, Display::default());
        let exact: Vec<f32> = greys.iter().map(|c| t.apply_exact(*c)[0]).collect();
        // (Up to rounding: a grey's channel is `d * c / L` and `c / L` is 1 within an ulp.)
        assert!(exact.windows(2).all(|w| w[0] <= w[1] + 1e-6), "{op} exact");
        assert!(exact[1999] > exact[0], "{op} not constant");
        for b in Backend::usable() {
            let got = apply_image(b, &t, &greys).unwrap();
            // The approximation may wobble by its error bound, never more.
            let mut hi = 0.0f32;
            for (i, g) in got.iter().enumerate() {
                assert!(g[0] >= hi - 2.0 * t.max_abs_error(), "{op} on {b} at {i}");
                hi = hi.max(g[0]);
            }
        }
    }
}

#[test]
fn black_and_constant_images_are_safe() {
    let black = vec![[0.0f32; 3]; 40];
    let a = Adaptation::from_luminances(black.iter().map(|c| lum(*c)));
    assert_eq!(a.max, 0.0);
    let nan_only = Adaptation::from_luminances([f32::NAN, -1.0, f32::INFINITY]);
    assert_eq!(nan_only.max, 0.0);
    let grey = vec![[0.7f32; 3]; 40];
    let ag = Adaptation::from_luminances(grey.iter().map(|c| lum(*c)));
    for op in Operator::ALL {
        for d in [Display::default(), absolute()] {
            for adapt in [a, nan_only] {
                let t = ToneMap::new(op, adapt, d);
                for b in Backend::usable() {
                    let out = apply_image(b, &t, &black).unwrap();
                    assert!(out.iter().all(|c| *c == [0.0; 3]), "{op} on {b}");
                    let out = apply_image(b, &t, &grey).unwrap();
                    assert!(
                        out.iter().all(|c| *c == [0.0; 3]),
                        "{op} on {b}: black pre-render"
                    );
                }
            }
            let t = ToneMap::new(op, ag, d);
            for b in Backend::usable() {
                let out = apply_image(b, &t, &grey).unwrap();
                assert!(
                    out.iter().all(|c| c[0].is_finite() && *c == out[0]),
                    "{op} on {b}: {:?}",
                    out[0]
                );
            }
        }
    }
}

#[test]
fn planar_matches_interleaved_on_every_backend() {
    let img = hdr_image(1001);
    let a = Adaptation::from_luminances(img.iter().map(|c| lum(*c)));
    let t = ToneMap::new(Operator::Tumblin, a, Display::default());
    let (r, g, b): (Vec<f32>, Vec<f32>, Vec<f32>) = (
        img.iter().map(|c| c[0]).collect(),
        img.iter().map(|c| c[1]).collect(),
        img.iter().map(|c| c[2]).collect(),
    );
    for be in Backend::usable() {
        let want = apply_image(be, &t, &img).unwrap();
        let (mut or, mut og, mut ob) = (vec![0.0; 1001], vec![0.0; 1001], vec![0.0; 1001]);
        apply_planar(
            be,
            &t,
            Planar {
                r: &r,
                g: &g,
                b: &b,
            },
            PlanarMut {
                r: &mut or,
                g: &mut og,
                b: &mut ob,
            },
        )
        .unwrap();
        for i in 0..1001 {
            let got = [or[i], og[i], ob[i]];
            assert!(
                got == want[i] || (got[0].is_nan() && want[i][0].is_nan()),
                "{be} pixel {i}: {got:?} vs {:?}",
                want[i]
            );
        }
    }
}
