//! Each approximation against `std` within its stated bound, on every backend usable here
//! (dense sweeps and proptests), and its documented behaviour outside the domain.

use proptest::prelude::*;

use super::{Approx, Bound, EvalSlices};
use crate::dispatch::Backend;

fn eval(backend: Backend, f: Approx, a: &[f32], b: &[f32]) -> Vec<f32> {
    backend
        .run(EvalSlices { f, a, b })
        .expect("available backend")
}

/// The arguments of a dense sweep over the domain (log-spaced where the domain spans decades).
fn sweep(f: Approx, n: usize) -> (Vec<f32>, Vec<f32>) {
    let (lo, hi) = f.domain();
    let mut a = Vec::with_capacity(n);
    let mut b = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 / (n - 1) as f64;
        let x = match f {
            Approx::Log => (lo.ln() as f64 + t * (hi.ln() as f64 - lo.ln() as f64)).exp(),
            Approx::Atan => {
                let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                s * (1e-4f64.ln() + t * (1e4f64.ln() - 1e-4f64.ln())).exp()
            }
            _ => lo as f64 + t * (hi as f64 - lo as f64),
        };
        a.push(x as f32);
        // atan2: x goes round the square at a different rate than y.
        b.push((lo as f64 + ((t * 7.31) % 1.0) * (hi - lo) as f64) as f32);
    }
    (a, b)
}

/// The largest error in units of the bound (<= 1 passes) and where it was.
fn worst(f: Approx, a: &[f32], b: &[f32], got: &[f32]) -> (f64, f32, f32) {
    let mut worst = (0.0, 0.0, 0.0);
    for i in 0..a.len() {
        let exact = f.reference(a[i], b[i]);
        let err = (got[i] as f64 - exact).abs();
        let ratio = match f.bound(a[i]) {
            Bound::Absolute(e) => err / e as f64,
            Bound::Relative(e) => err / (e as f64 * exact.abs()),
        };
        let ratio = if got[i].is_nan() {
            f64::INFINITY
        } else if err == 0.0 {
            0.0 // exact, also where the relative error is 0/0
        } else {
            ratio
        };
        if ratio.is_nan() || ratio > worst.0 {
            worst = (ratio, a[i], b[i]);
        }
    }
    worst
}

#[test]
fn dense_sweeps_within_bounds_on_every_backend() {
    for backend in Backend::usable() {
        for f in Approx::ALL {
            let (a, b) = sweep(f, 100_003);
            let got = eval(backend, f, &a, &b);
            let (ratio, x, y) = worst(f, &a, &b, &got);
            assert!(
                ratio <= 1.0,
                "{f} on {backend}: error {ratio:.3} x its bound at ({x}, {y})"
            );
        }
    }
}

#[test]
fn bounds_are_tight() {
    // A bound far above the measured error would be a test that cannot fail.
    for f in [
        Approx::Exp,
        Approx::ExpPoly,
        Approx::Log,
        Approx::Acos,
        Approx::Atan2,
    ] {
        let (a, b) = sweep(f, 100_003);
        let got = eval(Backend::Scalar, f, &a, &b);
        let (ratio, _, _) = worst(f, &a, &b, &got);
        assert!(
            ratio > 0.5,
            "{f}: bound is {:.1}x the measured error",
            1.0 / ratio
        );
    }
}

#[test]
fn table_parts_are_accurate() {
    // exp's table on [-14, -3.8] and log's on (0, 0.17] are far better than the Padé parts.
    let a: Vec<f32> = (0..10_000)
        .map(|i| -14.0 + 10.19 * i as f32 / 9999.0)
        .collect();
    let got = eval(Backend::Scalar, Approx::Exp, &a, &a);
    for (x, y) in a.iter().zip(&got) {
        let e = ((*y as f64) / (*x as f64).exp() - 1.0).abs();
        assert!(e < 2e-5, "exp({x}) relative error {e}");
    }
    let a: Vec<f32> = (1..10_000).map(|i| 0.17 * i as f32 / 9999.0).collect();
    let got = eval(Backend::Scalar, Approx::Log, &a, &a);
    for (x, y) in a.iter().zip(&got) {
        let e = (*y as f64 - (*x as f64).ln()).abs();
        assert!(e < 1e-6, "log({x}) absolute error {e}");
    }
}

fn one(backend: Backend, f: Approx, a: f32, b: f32) -> f32 {
    eval(backend, f, &[a], &[b])[0]
}

#[test]
fn outside_the_domains_as_documented() {
    for bk in Backend::usable() {
        let e = |x| one(bk, Approx::Exp, x, 0.0);
        assert_eq!(e(0.0), 1.0);
        assert_eq!(e(-14.5), 0.0);
        assert_eq!(e(f32::NEG_INFINITY), 0.0);
        assert_eq!(e(15.0), f32::INFINITY);
        assert_eq!(e(f32::INFINITY), f32::INFINITY);
        assert!(e(f32::NAN).is_nan());

        let ep = |x| one(bk, Approx::ExpPoly, x, 0.0);
        assert_eq!(ep(0.0), 1.0);
        assert_eq!(ep(1.0), core::f32::consts::E);
        assert_eq!(ep(-87.5), 0.0);
        assert_eq!(ep(f32::NEG_INFINITY), 0.0);
        assert_eq!(ep(88.5), f32::INFINITY);
        assert_eq!(ep(f32::INFINITY), f32::INFINITY);
        assert!(ep(f32::NAN).is_nan());
        assert!(ep(88.0).is_finite() && ep(-87.0) > 0.0);

        let lg = |x| one(bk, Approx::Log, x, 0.0);
        assert_eq!(lg(1.0), 0.0);
        assert_eq!(lg(0.0), f32::NEG_INFINITY);
        assert_eq!(lg(-0.0), f32::NEG_INFINITY);
        assert_eq!(lg(f32::INFINITY), f32::INFINITY);
        assert!(lg(-1.0).is_nan() && lg(f32::NEG_INFINITY).is_nan() && lg(f32::NAN).is_nan());
        let tiny = f32::from_bits(1); // the smallest denormal
        assert!((lg(tiny) as f64 - (tiny as f64).ln()).abs() < 1e-4);

        let p = |x| one(bk, Approx::Pow, x, 0.0);
        assert_eq!(p(0.0), 0.0);
        assert!(p(-1.0).is_nan() && p(f32::NAN).is_nan());

        let ac = |x| one(bk, Approx::Acos, x, 0.0);
        assert_eq!(ac(1.0), 0.0);
        assert!((ac(-1.0) - core::f32::consts::PI).abs() < 1e-4);
        assert!(ac(1.5).is_nan() && ac(-1.5).is_nan() && ac(f32::NAN).is_nan());
        assert!(one(bk, Approx::Asin, 2.0, 0.0).is_nan());

        let at = |x| one(bk, Approx::Atan, x, 0.0);
        assert_eq!(at(f32::INFINITY), core::f32::consts::FRAC_PI_2);
        assert_eq!(at(f32::NEG_INFINITY), -core::f32::consts::FRAC_PI_2);
        assert!(at(f32::NAN).is_nan());

        let a2 = |y, x| one(bk, Approx::Atan2, y, x);
        let pi = core::f32::consts::PI;
        assert_eq!(a2(0.0, 0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(a2(-0.0, 0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(a2(0.0, -0.0), pi);
        assert_eq!(a2(-0.0, -0.0), -pi);
        assert_eq!(a2(0.0, -1.0), pi);
        assert_eq!(a2(-0.0, -1.0), -pi);
        assert!(a2(f32::INFINITY, f32::INFINITY).is_nan());
        assert!(a2(f32::NAN, 1.0).is_nan() && a2(1.0, f32::NAN).is_nan());

        assert!(one(bk, Approx::CosSpot, f32::NAN, 0.0).is_nan());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_arguments_within_bounds(seed in any::<u64>(), which in 0usize..Approx::ALL.len()) {
        let f = Approx::ALL[which];
        let (lo, hi) = f.domain();
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let pick = |t: f64| match f {
            Approx::Log => (lo.ln() as f64 + t * (hi.ln() - lo.ln()) as f64).exp() as f32,
            _ => (lo as f64 + t * (hi - lo) as f64) as f32,
        };
        let a: Vec<f32> = (0..67).map(|_| pick(next())).collect();
        let b: Vec<f32> = (0..67).map(|_| pick(next())).collect();
        for backend in Backend::usable() {
            let got = eval(backend, f, &a, &b);
            let (ratio, x, y) = worst(f, &a, &b, &got);
            prop_assert!(ratio <= 1.0, "{} on {}: {:.3} x bound at ({}, {})", f, backend, ratio, x, y);
        }
    }
}

#[test]
#[ignore = "prints the measured errors for the doc comments"]
fn print_measured_errors() {
    for f in Approx::ALL {
        let (a, b) = sweep(f, 1_000_003);
        for backend in Backend::usable() {
            let got = eval(backend, f, &a, &b);
            let mut m = (0.0f64, 0.0f32);
            for i in 0..a.len() {
                let exact = f.reference(a[i], b[i]);
                let err = (got[i] as f64 - exact).abs();
                let err = match f.bound(a[i]) {
                    Bound::Absolute(_) => err,
                    Bound::Relative(_) => err / exact.abs(),
                };
                if err > m.0 {
                    m = (err, a[i]);
                }
            }
            println!("{f:8} {backend:7} max error {:.3e} at {}", m.0, m.1);
        }
    }
}

#[test]
fn exp_table_step_growth_is_expm1_of_the_step() {
    use super::exp::STEP_GROWTH;
    // the step build.rs generates the table with: 10.2 / 1024 on [-14, -3.8]
    let exact = (10.2f64 / 1024.0).exp_m1();
    // the nearest f32: within half an ulp of the f64 value
    assert!(
        (STEP_GROWTH as f64 - exact).abs()
            <= (exact as f32).abs() as f64 * f32::EPSILON as f64 / 2.0,
        "{STEP_GROWTH} against {exact}"
    );
}
