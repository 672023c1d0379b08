//! The `prism` scene's spectrum against Snell's law: rendered in a narrow band around a
//! wavelength, the slit's image lies where the chief ray, refracted into and out of the F2
//! prism with the glass's index at that wavelength, reaches the slit
//! ([`coherent::scene::builtin::prism::slit_column`], in closed form); the images of 450 and
//! 650 nm lie apart (the render disperses); an RGB render puts the slit where the d line's
//! index (the material's `optics.ior`) does.
//!
//! The images are a short strip around the horizon (the camera looks horizontally, so the
//! middle rows' rays are horizontal and the deviation is the plane one), at the scene's
//! horizontal field of view ([`coherent::scene::builtin::prism::camera`]).

use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method};
use coherent::render::colour::{ColourForm, Layout};
use coherent::render::{Renderer, render_frame};
use coherent::scene::builtin::prism::{camera, slit_column};
use coherent::simd::Backend;
use coherent::spectrum::dispersion::LAMBDA_D;

/// The strip: 320 pixels wide (the spectrum from 450 to 650 nm spans about 19 of them),
/// 24 rows around the horizon.
const W: u32 = 320;
const H: u32 = 24;
/// Samples per pixel: the slit's image is about 2.5 pixels wide.
const SPP: u32 = 16;
/// The rows measured: two either side of the horizon (between rows H/2 - 1 and H/2).
const ROWS: std::ops::Range<u32> = H / 2 - 2..H / 2 + 2;
/// Half the width of the window the centroid is taken over, around the brightest column.
const HALF_WINDOW: usize = 6;
/// The flanks either side of the window that give the background.
const FLANK: usize = 5;

/// The linear radiance (HDR estimate, before tone mapping) of the strip, rendered in the
/// colour form `colour` (RGB when `None`).
fn render(colour: Option<ColourForm>) -> anyhow::Result<Vec<[f32; 3]>> {
    let mut scene = coherent::scene::load("prism")?;
    scene.camera = camera(W, H);
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
    let mut renderer = Renderer::new(&scene, accel, W, H)?;
    if let Some(colour) = colour {
        renderer.set_colour(colour)?;
    }
    let opts = FilmOptions::new(W, H, Method::Uniform { spp: SPP });
    let frame = render_frame(Backend::Scalar, &renderer, &opts, &|_| {})?;
    Ok(frame.image())
}

/// The slit's image centre (continuous pixel x, pixel `i` centred at `i + 0.5`): the
/// brightness-weighted mean column over the measured rows, in a window around the
/// brightest column, less the background (a line through the means of the flanks either
/// side of the window). Brightness is the sum of the channels: in a one-bin render every
/// pixel has the same spectrum, so any channel, or their sum, is proportional to radiance.
fn centroid(img: &[[f32; 3]], what: &str) -> f64 {
    let profile: Vec<f64> = (0..W as usize)
        .map(|x| {
            ROWS.map(|y| {
                img[y as usize * W as usize + x]
                    .iter()
                    .map(|&c| f64::from(c))
                    .sum::<f64>()
            })
            .sum()
        })
        .collect();
    let lo = HALF_WINDOW + FLANK;
    let hi = W as usize - HALF_WINDOW - FLANK;
    let peak = (lo..hi)
        .max_by(|&a, &b| profile[a].total_cmp(&profile[b]))
        .unwrap();
    let mean = |r: std::ops::Range<usize>| {
        let n = r.len() as f64;
        let c = (r.start + r.end) as f64 / 2.0;
        (r.map(|x| profile[x]).sum::<f64>() / n, c)
    };
    let (left, xl) = mean(peak - HALF_WINDOW - FLANK..peak - HALF_WINDOW);
    let (right, xr) = mean(peak + HALF_WINDOW + 1..peak + HALF_WINDOW + 1 + FLANK);
    let background = |x: f64| left + (right - left) * (x - xl) / (xr - xl);
    let (mut sum, mut moment) = (0.0, 0.0);
    for (x, p) in profile
        .iter()
        .enumerate()
        .take(peak + HALF_WINDOW + 1)
        .skip(peak - HALF_WINDOW)
    {
        let c = x as f64 + 0.5;
        let v = p - background(c);
        sum += v;
        moment += v * c;
    }
    assert!(
        sum > 0.0 && profile[peak] > 4.0 * left.max(right).max(1e-6),
        "{what}: no slit: peak {} at column {peak}, background {left} and {right}",
        profile[peak]
    );
    moment / sum
}

/// The slit's image in a one-bin render at `lambda` (a 1 nm band around it).
fn spectral_centroid(lambda: f32) -> anyhow::Result<f64> {
    let img = render(Some(ColourForm::Bins {
        bins: 1,
        layout: Layout::Rays,
        range: [lambda - 0.5, lambda + 0.5],
    }))?;
    Ok(centroid(&img, &format!("{lambda} nm")))
}

#[test]
fn the_slit_is_seen_where_snells_law_bends_each_wavelength() -> anyhow::Result<()> {
    let mut seen = Vec::new();
    for lambda in [450.0, 500.0, 550.0, 600.0, 650.0] {
        let want = slit_column(lambda, W, H).expect("the slit is in view");
        let got = spectral_centroid(lambda)?;
        eprintln!("{lambda} nm: centroid {got:.3}, closed form {want:.3}");
        seen.push((lambda, got, want));
    }
    for &(lambda, got, want) in &seen {
        assert!(
            (got - want).abs() <= 1.0,
            "{lambda} nm: the slit's image at column {got:.2}, Snell's law puts it at \
             {want:.2} (all: {seen:?})"
        );
    }
    // The band is spread by the dispersion: blue is bent most, so seen furthest left.
    let spread = seen[4].1 - seen[0].1;
    assert!(
        spread > 5.0,
        "450 to 650 nm spread over {spread:.2} pixels only: is the dispersion applied? \
         ({seen:?})"
    );
    Ok(())
}

#[test]
fn an_rgb_render_sees_the_slit_at_the_d_lines_index() -> anyhow::Result<()> {
    let want = slit_column(LAMBDA_D, W, H).expect("the slit is in view");
    let got = centroid(&render(None)?, "rgb");
    eprintln!("rgb: centroid {got:.3}, closed form at the d line {want:.3}");
    assert!(
        (got - want).abs() <= 1.0,
        "rgb: the slit's image at column {got:.2}, Snell's law with n_d puts it at {want:.2}"
    );
    Ok(())
}
