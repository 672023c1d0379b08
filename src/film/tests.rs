//! Tests of the progressive film on analytic images (constant, step edge, NaN).

use std::sync::Mutex;
use std::time::Duration;

use coherent_simd::{Backend, Lanes, Rgbs, SimdF32, SimdI32, SimdMask};

use super::*;

/// An analytic image: `f(x, y)` per lane; records the ids it is asked for.
struct Analytic<F> {
    f: F,
    ids: Option<Mutex<Vec<i32>>>,
}

impl<F: Fn(f32, f32) -> [f32; 3] + Sync> Analytic<F> {
    fn new(f: F) -> Self {
        Analytic { f, ids: None }
    }
    fn recording(f: F) -> Self {
        Analytic {
            f,
            ids: Some(Mutex::new(Vec::new())),
        }
    }
}

impl<F: Fn(f32, f32) -> [f32; 3] + Sync> SampleTracer for Analytic<F> {
    type Stats = u64;
    fn merge_stats(into: &mut u64, from: u64) {
        *into += from;
    }
    fn trace<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut u64,
    ) -> Rgbs<L> {
        let mut c = [[0.0f32; 3]; 16];
        for (m, cm) in c.iter_mut().enumerate().take(L::N) {
            if active.lane(m) {
                *cm = (self.f)(xs.lane(m), ys.lane(m));
                *stats += 1;
                if let Some(v) = &self.ids {
                    v.lock().unwrap().push(ids.lane(m));
                }
            }
        }
        Rgbs::new(
            l.from_fn(|m| c[m][0]),
            l.from_fn(|m| c[m][1]),
            l.from_fn(|m| c[m][2]),
        )
    }
}

fn quiet(_: &PassReport) {}

fn edge(x: f32, _y: f32) -> [f32; 3] {
    if x < 13.3 {
        [1.0, 0.8, 0.6]
    } else {
        [0.05, 0.05, 0.05]
    }
}

fn adaptive(accuracy: f32, cap: u32) -> Method {
    Method::Adaptive {
        accuracy,
        max_samples_per_pixel: cap,
        time_budget: None,
    }
}

#[test]
fn uniform_gives_every_pixel_spp_samples_and_constant_exactly() {
    let t = Analytic::new(|_, _| [0.5, 0.25, 2.0]);
    let opts = FilmOptions::new(37, 23, Method::Uniform { spp: 3 });
    for b in Backend::usable() {
        let r = render(b, &t, &opts, &quiet).unwrap();
        for p in 0..r.film.pixels() {
            assert_eq!(r.film.samples(p), 3, "{b}");
        }
        assert!(r.image().iter().all(|c| *c == [0.5, 0.25, 2.0]), "{b}");
        let corners = r.film.superpixels.corners.len() as u64;
        assert_eq!(r.rays, corners + 37 * 23 * 3, "{b}");
        assert_eq!(r.stats, r.rays, "{b}");
        assert_eq!(r.stop, StopReason::Done);
    }
}

#[test]
fn uniform_is_the_same_for_every_backend_and_thread_count() {
    let f = |x: f32, y: f32| [(x * 0.37).sin().abs(), (y * 0.11).cos().abs(), x * y * 1e-3];
    let opts = FilmOptions::new(40, 30, Method::Uniform { spp: 4 });
    let mut reference: Option<(Vec<[f32; 3]>, Vec<i32>)> = None;
    for b in Backend::usable() {
        for threads in [1, 2] {
            let t = Analytic::recording(f);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let r = pool.install(|| render(b, &t, &opts, &quiet)).unwrap();
            let mut ids = t.ids.unwrap().into_inner().unwrap();
            ids.sort();
            let n = ids.len();
            ids.dedup();
            assert_eq!(ids.len(), n, "{b}: sample ids repeat");
            let img = r.image();
            match &reference {
                None => reference = Some((img, ids)),
                Some((ri, rids)) => {
                    assert!(img == *ri, "{b} with {threads} threads: another image");
                    assert!(ids == *rids, "{b} with {threads} threads: other sample ids");
                }
            }
        }
    }
}

#[test]
fn adaptive_interpolates_a_constant_image_then_confirms_it_with_samples() {
    let t = Analytic::new(|_, _| [0.3, 0.3, 0.3]);
    let (w, h) = (32, 24);
    let opts = FilmOptions::new(w, h, adaptive(0.01, 64));
    for b in Backend::usable() {
        let r = render(b, &t, &opts, &quiet).unwrap();
        assert!(r.film.interpolated.iter().all(|i| *i), "{b}");
        assert!(r.image().iter().all(|c| *c == [0.3, 0.3, 0.3]), "{b}");
        // Every pixel checked in both matrices, with a few samples each.
        for p in 0..r.film.pixels() {
            assert!(r.film.error(p) == Some(0.0), "{b}: pixel {p} not confirmed");
        }
        let corners = r.film.superpixels.corners.len() as u64;
        assert!(
            r.rays <= corners + 6 * (w * h) as u64,
            "{b}: {} rays",
            r.rays
        );
        assert_eq!(r.stop, StopReason::Accuracy, "{b}");
        assert_eq!(r.passes.last().unwrap().estimate, 0.0, "{b}");
    }
}

#[test]
fn a_feature_between_agreeing_corners_is_found() {
    // A bright 2 x 2 pixel spot inside the superpixel (8..16, 6..12), whose corners all see
    // the dark ground and agree: interpolation alone would leave the spot out.
    let spot = |x: f32, y: f32| {
        if (11.0..13.0).contains(&x) && (8.0..10.0).contains(&y) {
            [1.0; 3]
        } else {
            [0.05; 3]
        }
    };
    let t = Analytic::new(spot);
    let (w, h) = (32, 24);
    let r = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(w, h, adaptive(0.02, 64)),
        &quiet,
    )
    .unwrap();
    assert!(
        r.film.interpolated[(9 * w + 11) as usize],
        "the spot's superpixel is smooth"
    );
    let img = r.image();
    for (x, y) in [(11, 8), (12, 8), (11, 9), (12, 9)] {
        let p = (y * w + x) as usize;
        assert_eq!(img[p], [1.0; 3], "({x}, {y})");
    }
    assert_eq!(r.stop, StopReason::Accuracy);
}

#[test]
fn adaptive_subdivides_a_step_edge_and_converges_on_it() {
    let t = Analytic::new(edge);
    let (w, h) = (48, 24);
    let opts = FilmOptions::new(w, h, adaptive(0.05, 64));
    for b in Backend::usable() {
        let r = render(b, &t, &opts, &quiet).unwrap();
        let img = r.image();
        for y in 0..h {
            for x in 0..w {
                let p = (y * w + x) as usize;
                // Superpixels (8 wide) across the edge at x = 13.3 are not interpolated.
                if (8..16).contains(&x) {
                    assert!(!r.film.interpolated[p], "{b}: ({x}, {y}) interpolated");
                }
                if x >= 24 {
                    assert!(r.film.interpolated[p], "{b}: ({x}, {y}) not interpolated");
                }
                // The edge pixel's value is its coverage, within twice the accuracy on the
                // display.
                let cover = if x < 13 {
                    1.0
                } else if x == 13 {
                    0.3
                } else {
                    0.0
                };
                let want = [
                    cover + (1.0 - cover) * 0.05,
                    cover * 0.8 + (1.0 - cover) * 0.05,
                    cover * 0.6 + (1.0 - cover) * 0.05,
                ];
                let d = display_difference(&r.tonemap, img[p], want);
                assert!(d <= 0.1, "{b}: ({x}, {y}) = {:?} want {want:?}", img[p]);
            }
        }
        // Adaptivity: fewer rays than 8 samples in every pixel (the cap is 64).
        assert!(r.rays < (w * h * 8) as u64, "{b}: {} rays", r.rays);
        let edge_samples = r.film.samples((5 * w + 13) as usize);
        assert!(
            edge_samples >= 8,
            "{b}: edge pixel has {edge_samples} samples"
        );
    }
}

#[test]
fn error_estimate_decreases_as_passes_go() {
    let t = Analytic::new(|x: f32, y: f32| {
        if x + 0.7 * y < 20.0 {
            [1.0; 3]
        } else {
            [0.0; 3]
        }
    });
    let opts = FilmOptions::new(32, 24, Method::Uniform { spp: 32 });
    let r = render(Backend::Scalar, &t, &opts, &quiet).unwrap();
    let e: Vec<f64> = r.passes.iter().map(|p| p.error).collect();
    assert!(
        e[0].is_nan() && e[1].is_nan(),
        "no estimate before both matrices have samples"
    );
    // (From pass 3 on: at pass 2 each matrix holds one sample, and most edge pixels saw
    // the same side twice.)
    assert!(e[32] < 0.6 * e[3], "errors {e:?}");
    assert!(e[32] < e[8] && e[8] < e[3], "errors {e:?}");
    // The image's estimate counts a pixel not yet in both matrices as wholly wrong.
    let est: Vec<f64> = r.passes.iter().map(|p| p.estimate).collect();
    assert_eq!(est[0], 1.0, "{est:?}");
    assert!(est[32] < 0.05 * est[1], "{est:?}");
}

/// The estimate is statistical: from one pass to the next it may wiggle up (a new sample at
/// an edge moves one matrix's mean away from the other's; docs/findings/rendering.md), but
/// once the rays traced have grown four times it is lower, on every pair of passes.
#[test]
fn the_estimate_falls_as_the_rays_grow_fourfold_on_a_still_scene() {
    let disc = |x: f32, y: f32| {
        let (dx, dy) = (x - 17.3, y - 11.1);
        if dx * dx + dy * dy < 60.0 {
            [0.9, 0.5, 0.2]
        } else {
            [0.02; 3]
        }
    };
    let t = Analytic::new(disc);
    for method in [adaptive(0.01, 256), Method::Uniform { spp: 64 }] {
        let r = render(
            Backend::Scalar,
            &t,
            &FilmOptions::new(40, 30, method),
            &quiet,
        )
        .unwrap();
        let p = &r.passes;
        let rises = p
            .windows(2)
            .filter(|w| w[1].estimate > w[0].estimate)
            .count();
        for (j, a) in p.iter().enumerate() {
            for b in &p[j..] {
                if b.rays >= 4 * a.rays {
                    assert!(
                        b.estimate <= a.estimate,
                        "{method:?}: {} rays: {}, {} rays: {} ({rises} rises in {} passes)",
                        a.rays,
                        a.estimate,
                        b.rays,
                        b.estimate,
                        p.len()
                    );
                }
            }
        }
    }
}

#[test]
fn reaching_the_accuracy_stops_tracing() {
    let t = Analytic::new(edge);
    let loose = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(32, 24, adaptive(0.2, 1024)),
        &quiet,
    )
    .unwrap();
    let tight = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(32, 24, adaptive(0.001, 1024)),
        &quiet,
    )
    .unwrap();
    assert_eq!(loose.stop, StopReason::Accuracy);
    assert!(loose.rays < tight.rays, "{} vs {}", loose.rays, tight.rays);
    // The last pass of a converged render traced nothing new that was needed: stopping
    // happened because no pixel needed rays, not because of the cap.
    let max = (0..loose.film.pixels())
        .map(|p| loose.film.samples(p))
        .max();
    assert!(max < Some(1024), "{max:?}");
    let capped = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(32, 24, adaptive(1e-6, 8)),
        &quiet,
    )
    .unwrap();
    assert_eq!(capped.stop, StopReason::SampleBudget);
    assert!((0..capped.film.pixels()).all(|p| capped.film.samples(p) <= 8 + 1));
}

#[test]
fn time_budget_stops_after_a_pass() {
    let t = Analytic::new(edge);
    let m = Method::Adaptive {
        accuracy: 1e-6,
        max_samples_per_pixel: 1 << 20,
        time_budget: Some(Duration::ZERO),
    };
    let r = render(Backend::Scalar, &t, &FilmOptions::new(32, 24, m), &quiet).unwrap();
    assert_eq!(r.stop, StopReason::TimeBudget);
    assert_eq!(r.passes.len(), 2);
    assert!(r.image().iter().all(|c| c.iter().all(|v| v.is_finite())));
}

#[test]
fn progress_sees_every_pass() {
    let t = Analytic::new(edge);
    let seen = Mutex::new(Vec::new());
    let r = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(16, 9, Method::Uniform { spp: 2 }),
        &|p: &PassReport| {
            seen.lock()
                .unwrap()
                .push((p.record.pass, p.film.estimate().len()))
        },
    )
    .unwrap();
    assert_eq!(*seen.lock().unwrap(), vec![(0, 144), (1, 144), (2, 144)]);
    assert_eq!(r.passes.len(), 3);
}

#[test]
fn bad_resolutions_and_options_are_clear_errors() {
    let t = Analytic::new(edge);
    for (w, h) in [(0, 10), (10, 0), (100_000, 10), (16_000, 16_000)] {
        let e = render(
            Backend::Scalar,
            &t,
            &FilmOptions::new(w, h, Method::Uniform { spp: 1 }),
            &quiet,
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains(&format!("{w}x{h}")), "{e}");
    }
    for m in [
        Method::Uniform { spp: 0 },
        adaptive(0.0, 4),
        adaptive(f32::NAN, 4),
        adaptive(0.1, 0),
    ] {
        let e = render(Backend::Scalar, &t, &FilmOptions::new(8, 8, m), &quiet);
        assert!(matches!(e, Err(FilmError::Options(_))), "{m:?}");
    }
}

#[test]
fn nan_and_negative_radiance_are_counted_and_fixed() {
    let t = Analytic::new(|x: f32, _| {
        if x < 4.0 {
            [f32::NAN, 1.0, 1.0]
        } else if x < 8.0 {
            [-1.0, 1.0, 1.0]
        } else {
            [1.0; 3]
        }
    });
    let r = render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(16, 9, Method::Uniform { spp: 2 }),
        &quiet,
    )
    .unwrap();
    assert!(r.fixups.non_finite >= 4 * 9 * 2, "{:?}", r.fixups);
    assert!(r.fixups.negative >= 4 * 9 * 2, "{:?}", r.fixups);
    assert!(
        r.image()
            .iter()
            .all(|c| c.iter().all(|v| v.is_finite() && *v >= 0.0))
    );
}

/// A 16 x 9 image of `f`, one sample per pixel, on the scalar backend.
fn one_sample_16x9(f: fn(f32, f32) -> [f32; 3]) -> Rendered<u64> {
    let t = Analytic::new(f);
    render(
        Backend::Scalar,
        &t,
        &FilmOptions::new(16, 9, Method::Uniform { spp: 1 }),
        &quiet,
    )
    .unwrap()
}

#[test]
fn images_are_written_and_bad_paths_named() {
    let r = one_sample_16x9(edge);
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.exr", "a.png"] {
        r.write(&dir.path().join(name)).unwrap();
        assert!(std::fs::metadata(dir.path().join(name)).unwrap().len() > 0);
    }
    r.write_matrix_exr(1, &dir.path().join("m1.exr")).unwrap();
    let bad = dir.path().join("missing/dir/x.exr");
    let e = r.write(&bad).unwrap_err().to_string();
    assert!(e.contains("missing/dir/x.exr"), "{e}");
    let e = r.write(&dir.path().join("x.bmp")).unwrap_err().to_string();
    assert!(e.contains("x.bmp") && e.contains(".png"), "{e}");
    let e = r
        .write_png(&dir.path().join("missing/y.png"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("y.png"), "{e}");
}

/// Bright saturated blue beside a dim grey: the tone map brings the blue's luminance into
/// `[0, 1]`, so its blue channel goes above 1.
fn saturated(x: f32, _y: f32) -> [f32; 3] {
    if x < 8.0 {
        [0.0, 0.0, 50.0]
    } else {
        [0.05, 0.05, 0.05]
    }
}

#[test]
fn displayed_clips_the_channels_a_display_cannot_show() {
    let r = one_sample_16x9(saturated);
    let mapped = r.tone_mapped(Backend::Scalar).unwrap();
    let shown = r.displayed(Backend::Scalar).unwrap();
    assert!(
        mapped.iter().any(|c| c[2] > 1.0),
        "the blue half should map above 1: {:?}",
        mapped[0]
    );
    assert_eq!(mapped.len(), shown.len());
    for (m, s) in mapped.iter().zip(&shown) {
        for c in 0..3 {
            assert_eq!(s[c], m[c].clamp(0.0, 1.0));
        }
    }
    assert!(
        shown
            .iter()
            .all(|c| c.iter().all(|v| (0.0..=1.0).contains(v)))
    );
}

#[test]
fn matrices_split_each_pair_of_samples() {
    for p in 0..50u64 {
        for j in 0..50u64 {
            assert_ne!(matrix_of(p, 2 * j), matrix_of(p, 2 * j + 1));
        }
        let firsts = (0..50u64).filter(|j| matrix_of(p, 2 * j) == 0).count();
        assert!((10..=40).contains(&firsts), "pixel {p}: {firsts} of 50");
    }
}

#[test]
fn a_film_after_another_of_its_size_starts_from_zero() {
    let t = Analytic::new(edge);
    let opts = FilmOptions::new(29, 17, Method::Uniform { spp: 2 });
    let first = render(Backend::Scalar, &t, &opts, &quiet).unwrap();
    let image = first.image();
    // Its matrices are kept for the next film of this size, which zeroes them.
    drop(first);
    let second = render(Backend::Scalar, &t, &opts, &quiet).unwrap();
    assert!((0..second.film.pixels()).all(|p| second.film.samples(p) == 2));
    assert_eq!(second.image(), image);
}

#[test]
fn the_pre_render_traced_in_blocks_gives_each_corner_its_own_colour_and_id() {
    // 37 x 23 pixels of 8 x 6 superpixels: a grid of 6 x 5 corners, which the blocks of 4
    // lanes and more do not tile exactly, so every block shape meets a ragged edge.
    let f = |x: f32, y: f32| [x, y, x * 0.5 + y];
    let opts = FilmOptions::new(37, 23, Method::Uniform { spp: 1 });
    for b in Backend::usable() {
        let t = Analytic::recording(f);
        let p = Progressive::new(b, &t, &opts).unwrap();
        let sp = p.film().superpixels.clone();
        drop(p);
        let positions = sp.corner_positions();
        assert_eq!(positions.len(), 30, "{b}");
        for (i, (c, &(x, y))) in sp.corners.iter().zip(&positions).enumerate() {
            assert_eq!(*c, f(x, y), "{b}: corner {i}");
        }
        let mut ids = t.ids.unwrap().into_inner().unwrap();
        ids.sort();
        assert_eq!(ids, (0..30).collect::<Vec<i32>>(), "{b}: the corners' ids");
    }
}

#[test]
fn a_pass_without_pixels_sampled_twice_has_the_figures_of_the_pixel_by_pixel_sum() {
    use super::render::pixel_errors;
    let f = |x: f32, y: f32| [(x * 0.37).sin().abs(), (y * 0.11).cos().abs(), 0.5];
    for spp in [1, 2] {
        let opts = FilmOptions::new(40, 30, Method::Uniform { spp });
        let r = render(Backend::Scalar, &Analytic::new(f), &opts, &quiet).unwrap();
        // The figures alone, and with each pixel's difference kept, are the same numbers.
        let (alone, kept) = (pixel_errors(&r.film, false), pixel_errors(&r.film, true));
        assert_eq!(
            alone.estimate.to_bits(),
            kept.estimate.to_bits(),
            "{spp} spp"
        );
        assert_eq!(alone.mean.to_bits(), kept.mean.to_bits(), "{spp} spp");
        let last = r.passes.last().unwrap();
        assert_eq!(
            last.estimate.to_bits(),
            alone.estimate.to_bits(),
            "{spp} spp"
        );
        if spp == 1 {
            // No pixel has a sample in both matrices: nothing is known yet.
            assert!(last.error.is_nan());
            assert_eq!(last.estimate, 1.0);
        } else {
            assert!(last.estimate < 1.0, "{}", last.estimate);
        }
    }
}
