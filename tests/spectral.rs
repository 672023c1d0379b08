//! Spectral colour in the renderer (the paper's future work): a white surface renders to the
//! display's white under D65 and to the illuminant's chromaticity under A; a coloured albedo,
//! upsampled and lit by a white light, comes back as its RGB; both layouts of the
//! bins give the same image; the command line refuses bad spectral flags before rendering.
//! Small images: the file runs in seconds.

use coherent::accel::{Accel, Instance, Mesh};
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method};
use coherent::light::{Light, Omni};
use coherent::material::Material;
use coherent::render::colour::{ColourForm, Layout, spectral_refusal};
use coherent::render::{Renderer, render_frame};
use coherent::scene::{Camera, RenderScene, ShadedMesh};
use coherent::simd::Backend;
use coherent::spectrum::cie;
use coherent::spectrum::illuminant::{Emission, Illuminant};
use glam::Vec3;

const W: u32 = 16;
const H: u32 = 12;

/// A quad of albedo `kd` filling the view, lit by a grey omni light in front of it whose
/// spectrum, in spectral renders, is `spectrum`.
fn plate(kd: [f32; 3], spectrum: Option<Emission>) -> RenderScene {
    let mut s = coherent::scene::load("cornell").unwrap();
    let r = 4.0;
    let quad = Mesh::new(
        "plate",
        vec![
            Vec3::new(-r, -r, 0.0),
            Vec3::new(r, -r, 0.0),
            Vec3::new(r, r, 0.0),
            Vec3::new(-r, r, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    s.meshes = vec![ShadedMesh::flat(quad, 0)];
    s.instances = vec![Instance::identity(0)];
    s.materials = vec![Material::phong("plate", kd, [0.0; 3], 0.0)];
    s.lights = vec![Light::Omni(
        Omni::new(Vec3::new(0.0, 0.0, 3.0), [10.0; 3]).unwrap(),
    )];
    s.light_spectra = vec![spectrum];
    s.camera = Camera {
        position: Vec3::new(0.0, 0.0, 3.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 40.0,
    };
    s.depth = 0;
    s.background = [0.0; 3];
    s.motion.clear();
    s.validate().unwrap();
    s
}

/// The linear image of `s` in colour `form` on `backend`, `spp` samples per pixel.
fn render(s: &RenderScene, form: ColourForm, backend: Backend, spp: u32) -> Vec<[f32; 3]> {
    let accel = AnyAccel::build(&s.accel_scene(), &AnyParams::of(AccelKind::Bsp)).unwrap();
    let mut r = Renderer::new(s, accel, W, H).unwrap();
    r.set_colour(form).unwrap();
    let opts = FilmOptions::new(W, H, Method::Uniform { spp });
    let frame = render_frame(backend, &r, &opts, &|_| {}).unwrap();
    assert_eq!(frame.stats.nan, 0);
    frame.image()
}

fn mean(img: &[[f32; 3]]) -> [f64; 3] {
    let mut m = [0.0f64; 3];
    for p in img {
        for (a, v) in m.iter_mut().zip(p) {
            *a += f64::from(*v);
        }
    }
    m.map(|v| v / img.len() as f64)
}

fn bins(n: u32, layout: Layout) -> ColourForm {
    ColourForm::bins(n, layout).unwrap()
}

/// The spectral forms the tests render.
fn forms() -> [ColourForm; 3] {
    [
        ColourForm::Hero,
        bins(32, Layout::Rays),
        bins(32, Layout::Wavelengths),
    ]
}

fn chromaticity(rgb: [f64; 3]) -> [f64; 2] {
    let xyz = cie::rgb_to_xyz(rgb.map(|v| v as f32)).map(f64::from);
    let s = xyz[0] + xyz[1] + xyz[2];
    [xyz[0] / s, xyz[1] / s]
}

#[test]
fn a_white_surface_under_d65_renders_to_the_display_s_white() {
    let s = plate([1.0; 3], Some(Emission::Illuminant(Illuminant::D65)));
    let rgb = mean(&render(&s, ColourForm::Rgb, Backend::Scalar, 4));
    assert!(rgb[0] > 0.01, "the plate is lit: {rgb:?}");
    for form in forms() {
        let got = mean(&render(&s, form, Backend::Scalar, 16));
        for c in 0..3 {
            let rel = got[c] / rgb[c] - 1.0;
            assert!(
                rel.abs() < 0.01,
                "{}: channel {c} {} against RGB's {} ({rel:+.4})",
                form.label(),
                got[c],
                rgb[c]
            );
        }
    }
}

#[test]
fn a_white_surface_under_illuminant_a_renders_to_a_s_chromaticity() {
    let a = Emission::Illuminant(Illuminant::A);
    let s = plate([1.0; 3], Some(a));
    let want = chromaticity(a.table().rgb().map(f64::from));
    // The CIE's figures for A (2° observer).
    assert!((want[0] - 0.44757).abs() < 1e-3 && (want[1] - 0.40745).abs() < 1e-3);
    for form in forms() {
        let got = chromaticity(mean(&render(&s, form, Backend::Scalar, 16)));
        let d = (got[0] - want[0]).hypot(got[1] - want[1]);
        assert!(
            d < 2e-3,
            "{}: xy {got:?} against A's {want:?}",
            form.label()
        );
    }
}

#[test]
fn an_rgb_albedo_lit_by_a_white_light_comes_back_within_a_delta_e_of_1() {
    // A grey RGB light: equal energy in each display primary, the display's white (D65) as a
    // spectrum, under which the upsampling model is fitted. Under CIE illuminant E instead,
    // relative to E's white, a saturated red comes back about 3 Delta E away: the model has
    // no chromatic adaptation.
    let e = None;
    let white = mean(&render(
        &plate([1.0; 3], e),
        bins(32, Layout::Rays),
        Backend::Scalar,
        1,
    ));
    let white_xyz = cie::rgb_to_xyz(white.map(|v| v as f32)).map(f64::from);
    for kd in [
        [0.8, 0.2, 0.1],
        [0.1, 0.6, 0.2],
        [0.2, 0.3, 0.9],
        [0.5, 0.5, 0.5],
        [0.9, 0.8, 0.3],
    ] {
        let got = mean(&render(
            &plate(kd, e),
            bins(32, Layout::Rays),
            Backend::Scalar,
            1,
        ));
        // Relative to the white plate's colour.
        let got_xyz = cie::rgb_to_xyz(got.map(|v| v as f32)).map(f64::from);
        let got_lab = cie::lab(got_xyz, white_xyz);
        let want_lab = cie::lab(
            cie::rgb_to_xyz(kd).map(f64::from),
            cie::rgb_to_xyz([1.0; 3]).map(f64::from),
        );
        let de = cie::delta_e(got_lab, want_lab);
        assert!(de < 1.0, "albedo {kd:?}: Delta E {de:.3}");
    }
}

/// Cornell's box with its glass sphere dispersive, so that refraction keeps one wavelength.
fn dispersive_cornell() -> RenderScene {
    let mut s = coherent::scene::load("cornell").unwrap();
    for m in &mut s.materials {
        if m.optics.transmittance.iter().any(|&t| t > 0.0) {
            m.optics.dispersion = Some(coherent::spectrum::dispersion::preset("F2").unwrap());
        }
    }
    assert!(s.materials.iter().any(|m| m.optics.dispersion.is_some()));
    s
}

#[test]
fn both_layouts_give_the_same_image_bit_for_bit_on_the_scalar_backend() {
    let s = dispersive_cornell();
    let rays = render(&s, bins(12, Layout::Rays), Backend::Scalar, 2);
    let waves = render(&s, bins(12, Layout::Wavelengths), Backend::Scalar, 2);
    assert!(rays.iter().any(|p| p[0] > 0.0));
    assert_eq!(rays, waves);
}

#[test]
fn every_hand_written_backend_gives_the_scalar_image_in_each_spectral_form() {
    let s = dispersive_cornell();
    for form in [
        ColourForm::Hero,
        bins(12, Layout::Rays),
        bins(12, Layout::Wavelengths),
    ] {
        let reference = render(&s, form, Backend::Scalar, 1);
        let peak = reference
            .iter()
            .flat_map(|p| p.iter().copied())
            .fold(0.0f32, f32::max);
        for b in Backend::hand_written().filter(|b| b.is_available()) {
            if let Some(why) = spectral_refusal(&form, b) {
                eprintln!("skipping backend {b}: {why}");
                continue;
            }
            let img = render(&s, form, b, 1);
            // Up to rounding: horizontal sums over wavelengths, fused multiply-adds and the
            // approximate reciprocals of the wider backends; a ray that grazes an edge may hit
            // the other triangle, so a few pixels may differ more.
            let off = img
                .iter()
                .zip(&reference)
                .filter(|(a, b)| a.iter().zip(*b).any(|(x, y)| (x - y).abs() > 1e-3 * peak))
                .count();
            assert!(
                off <= 2,
                "{} on {}: {off} pixels differ",
                form.label(),
                b.name()
            );
        }
    }
    for b in Backend::skipped() {
        eprintln!("skipped: {} ({})", b.0.name(), b.1);
    }
}

fn coherent(args: &[&str]) -> std::process::Output {
    coherent::require::command(env!("CARGO_BIN_EXE_coherent"))
        .args(args)
        .output()
        .expect("the coherent binary runs")
}

#[test]
fn bad_spectral_flags_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let out = out.to_str().unwrap();
    let base = [
        "render",
        "cornell",
        "--resolution",
        "8x6",
        "--spp",
        "1",
        "--quiet",
        "--out",
        out,
    ];
    let cases = [
        (&["--colour", "bins", "--bins", "0"][..], "--bins 0"),
        (&["--colour", "bins", "--bins", "1025"][..], "--bins 1025"),
        (&["--bins", "8"][..], "needs --colour bins"),
        (&["--layout", "wavelengths"][..], "needs --colour bins"),
        (&["--colour", "cmyk"][..], "unknown colour"),
        (
            &["--colour", "bins", "--layout", "diagonal"][..],
            "unknown layout",
        ),
        (&["--colour", "hero", "--regroup"][..], "--regroup"),
    ];
    // A backend that runs here but has no spectral renderer in this build (none in a build
    // without the `wide` and `pulp` features).
    let other = Backend::every()
        .filter(|b| b.is_available() && spectral_refusal(&ColourForm::Hero, *b).is_some())
        .map(|b| b.name())
        .next();
    let other_case = other.map(|name| ["--colour", "hero", "--backend", name]);
    let cases = cases
        .into_iter()
        .chain(other_case.iter().map(|c| (&c[..], "in this build")));
    for (extra, says) in cases {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        let o = coherent(&args);
        let text = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} rendered");
        assert!(text.contains(says), "{extra:?}: {text}");
        assert!(!text.contains("panicked"), "{extra:?}: {text}");
        assert!(
            !std::path::Path::new(out).exists(),
            "{extra:?} wrote an image"
        );
    }
}

#[test]
fn a_spectral_render_writes_its_image_and_says_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hero.png");
    let o = coherent(&[
        "render",
        "glass1",
        "--resolution",
        "16x12",
        "--spp",
        "1",
        "--threads",
        "1",
        "--quiet",
        "--colour",
        "bins",
        "--bins",
        "8",
        "--layout",
        "wavelengths",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(text.contains("bins8-wavelengths colour"), "{text}");
    assert!(out.exists());
}
