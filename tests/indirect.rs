//! Indirect light in the renderer (`Renderer::indirect`, `coherent render --indirect`) against
//! closed forms and against each other: off, every image is what it was; in a closed diffuse
//! sphere lit from its centre (the furnace) the path tracer and the illumination map both
//! give the wall's radiance `rho / pi * E_d / (1 - rho)`; on the Cornell box they agree
//! region by region within the path tracer's noise. Small images, few samples: debug builds
//! run the file in well under a minute.

use coherent::accel::{Accel, Instance};
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method};
use coherent::light::Light;
use coherent::material::Material;
use coherent::render::{Indirect, RayKind, RenderStats, Renderer, render_frame};
use coherent::scene::{Camera, RenderScene, ShadedMesh};
use coherent::simd::Backend;
use glam::Vec3;

const W: u32 = 32;
const H: u32 = 24;
/// Particles and cells of the tests' illumination maps.
const MAP_PARTICLES: u64 = 1_000_000;
const MAP_CELLS: u64 = 16_384;
/// The map's furnace error at most (its noise and filtering: 0.00% and 0.03% measured).
const MAP_FURNACE_BOUND: f64 = 0.02;
/// Samples per pixel of the path-traced Cornell box.
const CORNELL_SPP: u32 = 64;
/// The map's error (its noise and its cells' filtering) allowed beyond the path tracer's
/// noise, as a share of the indirect light (regions measured within 5%, the image 1.6%).
const CORNELL_MAP_BIAS: f64 = 0.05;

/// A frame of `scene` with `indirect` at `spp` samples per pixel: radiance per pixel and the
/// statistics.
fn frame(
    scene: &RenderScene,
    indirect: Indirect,
    spp: u32,
    backend: Backend,
) -> (Vec<[f32; 3]>, RenderStats) {
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp)).unwrap();
    let mut r = Renderer::new(scene, accel, W, H).unwrap();
    r.indirect = indirect;
    let opts = FilmOptions::new(W, H, Method::Uniform { spp });
    let out = render_frame(backend, &r, &opts, &|_| {}).unwrap();
    assert_eq!(out.stats.nan, 0);
    (out.image(), out.stats)
}

/// The furnace: a closed icosphere of radius `r` (`subdivisions` deep) of albedo `rho`, an
/// omni light of intensity `i` at its centre, the camera there too.
fn furnace(rho: f32, r: f32, i: f32, subdivisions: u32) -> RenderScene {
    let mut s = coherent::scene::load("cornell").unwrap();
    let sphere = coherent::accel::shapes::icosphere("furnace", Vec3::ZERO, r, subdivisions);
    s.meshes = vec![ShadedMesh::flat(sphere, 0)];
    s.instances = vec![Instance::identity(0)];
    s.materials = vec![Material::phong("wall", [rho; 3], [0.0; 3], 0.0)];
    s.lights = vec![Light::Omni(
        coherent::light::Omni::new(Vec3::ZERO, [i; 3]).unwrap(),
    )];
    s.camera = Camera {
        position: Vec3::new(0.0, 0.0, 0.1 * r),
        look_at: Vec3::new(0.3, 0.2, -1.0),
        up: Vec3::Y,
        vfov_deg: 60.0,
    };
    s.depth = 0;
    s.background = [0.0; 3];
    s.motion.clear();
    s.validate().unwrap();
    s
}

/// The mean of the channels' mean over `img` and its standard error (pixels as independent
/// samples: they draw their own random numbers).
fn mean_and_error(img: &[[f32; 3]]) -> (f64, f64) {
    let n = img.len() as f64;
    let grey = |c: &[f32; 3]| c.iter().map(|&v| f64::from(v)).sum::<f64>() / 3.0;
    let mean = img.iter().map(grey).sum::<f64>() / n;
    let var = img.iter().map(|c| (grey(c) - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn indirect_none_leaves_the_image_bit_for_bit() {
    // The default renderer against one told `none`, on a scene with mirrors and glass.
    let scene = coherent::scene::load("cornell").unwrap();
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp)).unwrap();
    let plain = Renderer::new(&scene, accel, W, H).unwrap();
    let opts = FilmOptions::new(W, H, Method::Uniform { spp: 2 });
    let a = render_frame(Backend::widest(), &plain, &opts, &|_| {}).unwrap();
    let (b, stats) = frame(&scene, Indirect::None, 2, Backend::widest());
    let (a, b): (Vec<_>, Vec<_>) = (
        a.image().iter().flatten().map(|v| v.to_bits()).collect(),
        b.iter().flatten().map(|v| v.to_bits()).collect(),
    );
    assert_eq!(a, b);
    assert_eq!(stats.rays(RayKind::Diffuse), 0);
    assert!(!stats.summary().contains("diffuse"), "{}", stats.summary());
}

#[test]
fn path_tracing_fills_the_furnace() {
    let (r, i) = (2.0f32, 5.0f32);
    for rho in [0.3f32, 0.6] {
        let scene = furnace(rho, r, i, 4);
        let (rho, r, i) = (f64::from(rho), f64::from(r), f64::from(i));
        let direct_closed = rho / std::f64::consts::PI * i / (r * r);
        // Direct light only: the wall as lit from the centre, up to the tessellation (the
        // faces lie up to 0.1% inside the sphere at 4 subdivisions: under 1% brighter).
        let (direct, _) = frame(&scene, Indirect::None, 1, Backend::widest());
        let (d, _) = mean_and_error(&direct);
        assert!(
            (d / direct_closed - 1.0).abs() < 0.01,
            "rho {rho}: direct {d} against {direct_closed}"
        );
        let (img, stats) = frame(&scene, Indirect::path(), 4, Backend::widest());
        let (m, se) = mean_and_error(&img);
        let want = direct_closed / (1.0 - rho);
        let err = (m / want - 1.0).abs();
        let bound = 4.0 * se / want + 0.01;
        eprintln!(
            "furnace rho {rho}: path {m:.5} +- {se:.5} against {want:.5} (error {:.2}%, \
             bound {:.2}%), {} diffuse rays",
            100.0 * err,
            100.0 * bound,
            stats.rays(RayKind::Diffuse)
        );
        assert!(err < bound, "rho {rho}: path {m} +- {se} against {want}");
        assert!(stats.rays(RayKind::Diffuse) > 0);
    }
}

/// The illumination map of `scene` over `accel`: `particles` particles, `cells` cells.
fn map_of(
    scene: &RenderScene,
    accel: &AnyAccel,
    particles: u64,
    cells: u64,
) -> coherent::illum::IllumMap {
    let opts = coherent::illum::MapOptions {
        particles,
        cells,
        ..Default::default()
    };
    coherent::illum::build_map(Backend::widest(), scene, accel, &opts, &|_| {})
        .unwrap()
        .0
}

/// A frame of `scene` with the indirect light of an illumination map of `particles`
/// particles on `cells` cells.
fn map_frame(scene: &RenderScene, particles: u64, cells: u64, spp: u32) -> Vec<[f32; 3]> {
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp)).unwrap();
    let map = map_of(scene, &accel, particles, cells);
    let mut r = Renderer::new(scene, accel, W, H).unwrap();
    r.indirect = Indirect::Map(std::sync::Arc::new(map));
    let opts = FilmOptions::new(W, H, Method::Uniform { spp });
    let out = render_frame(Backend::widest(), &r, &opts, &|_| {}).unwrap();
    assert_eq!(out.stats.nan, 0);
    assert_eq!(out.stats.rays(RayKind::Diffuse), 0);
    out.image()
}

#[test]
fn the_illumination_map_fills_the_furnace() {
    let (r, i) = (2.0f32, 5.0f32);
    for rho in [0.3f32, 0.6] {
        let scene = furnace(rho, r, i, 4);
        let img = map_frame(&scene, MAP_PARTICLES, MAP_CELLS, 1);
        let (rho, r, i) = (f64::from(rho), f64::from(r), f64::from(i));
        let want = rho / std::f64::consts::PI * i / (r * r) / (1.0 - rho);
        let (m, _) = mean_and_error(&img);
        let err = (m / want - 1.0).abs();
        eprintln!(
            "furnace rho {rho}: map {m:.5} against {want:.5} (error {:.2}%, bound {:.2}%)",
            100.0 * err,
            100.0 * MAP_FURNACE_BOUND
        );
        assert!(err < MAP_FURNACE_BOUND, "rho {rho}: map {m} against {want}");
    }
}

/// The Cornell box with its mirror box and glass sphere made matte: light reaching a wall by
/// way of a mirror or glass is in the map (its particles bounce specularly) but not in the
/// path tracer's image (lights are not geometry), so those would differ by the caustics.
fn matte_cornell() -> RenderScene {
    let mut s = coherent::scene::load("cornell").unwrap();
    for m in &mut s.materials {
        if m.optics.reflectance.iter().any(|&r| r > 0.0)
            || m.optics.transmittance.iter().any(|&t| t > 0.0)
        {
            *m = Material::phong(m.name.clone(), [0.5; 3], [0.0; 3], 0.0);
        }
    }
    s.validate().unwrap();
    s
}

/// Region means (8 x 8 pixels) of the first channel of `img`, with their standard errors.
fn regions(img: &[[f32; 3]]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for ry in (0..H).step_by(8) {
        for rx in (0..W).step_by(8) {
            let px: Vec<[f32; 3]> = (ry..ry + 8)
                .flat_map(|y| (rx..rx + 8).map(move |x| (x, y)))
                .map(|(x, y)| img[(y * W + x) as usize])
                .collect();
            out.push(mean_and_error(&px));
        }
    }
    out
}

#[test]
fn map_and_path_agree_on_the_cornell_box() {
    let scene = matte_cornell();
    let (direct, _) = frame(&scene, Indirect::None, CORNELL_SPP, Backend::widest());
    let (path, _) = frame(&scene, Indirect::path(), CORNELL_SPP, Backend::widest());
    let map = map_frame(&scene, MAP_PARTICLES, MAP_CELLS, CORNELL_SPP);
    // The same samples, so the camera's hits see the same light samples in all three: the
    // differences are the indirect light and its noise.
    let indirect = |img: &[[f32; 3]]| -> Vec<[f32; 3]> {
        img.iter()
            .zip(&direct)
            .map(|(a, d)| [a[0] - d[0], a[1] - d[1], a[2] - d[2]])
            .collect()
    };
    let (p, m) = (regions(&indirect(&path)), regions(&indirect(&map)));
    let (mut worst, mut sum_p, mut sum_m, mut var_p) = (0.0f64, 0.0, 0.0, 0.0);
    for (k, (&(pm, pe), &(mm, _))) in p.iter().zip(&m).enumerate() {
        let bound = 4.0 * pe + CORNELL_MAP_BIAS * pm.abs();
        eprintln!(
            "cornell region {k}: indirect path {pm:.4} +- {pe:.4}, map {mm:.4} \
             ({:+.1}%; bound {bound:.4})",
            100.0 * (mm / pm - 1.0)
        );
        worst = worst.max((mm - pm).abs() / bound);
        sum_p += pm;
        sum_m += mm;
        var_p += pe * pe;
        assert!(
            (mm - pm).abs() < bound,
            "region {k}: map {mm} against path {pm} +- {pe}"
        );
    }
    // Over the whole image (regions of equal size).
    let (err, se) = ((sum_m / sum_p - 1.0).abs(), var_p.sqrt() / sum_p);
    eprintln!(
        "cornell: indirect light over the image: map {:+.2}% against path (+- {:.2}%); worst \
         region at {worst:.2} of its bound",
        100.0 * (sum_m / sum_p - 1.0),
        100.0 * se
    );
    assert!(
        err < 4.0 * se + CORNELL_MAP_BIAS,
        "image: map {sum_m} against path {sum_p}"
    );
}

/// `coherent render` at 16 x 12, 1 spp, one thread, quiet, with `args` after the scene.
fn coherent_render(scene: &str, out: &std::path::Path, args: &[&str]) -> std::process::Output {
    let mut all = vec![
        "render",
        scene,
        "--resolution",
        "16x12",
        "--spp",
        "1",
        "--threads",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    coherent::require::command(env!("CARGO_BIN_EXE_coherent"))
        .args(&all)
        .output()
        .expect("the coherent binary runs")
}

fn text(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A room (a box seen from inside) lit by an omni light, or by none with a background.
fn room_file(dir: &std::path::Path, lit: bool) -> std::path::PathBuf {
    let light = if lit {
        "[[lights]]\ntype = \"omni\"\nposition = [0.0, 0.5, 0.0]\nintensity = [5.0, 5.0, 5.0]\n"
    } else {
        "background = [0.2, 0.2, 0.2]\n"
    };
    let path = dir.join(if lit { "room.toml" } else { "dark.toml" });
    std::fs::write(
        &path,
        format!(
            "{}[camera]\nposition = [0.0, 0.0, 1.5]\nlook_at = [0.0, 0.0, 0.0]\n\n\
             [materials.grey]\ntype = \"phong\"\ndiffuse = [0.5, 0.5, 0.5]\n\n\
             [[objects]]\nshape = \"box\"\nmaterial = \"grey\"\nscale = [4, 4, 4]\n\n{}",
            if lit { "" } else { light },
            if lit { light } else { "" }
        ),
    )
    .unwrap();
    path
}

#[test]
fn the_command_line_builds_loads_and_refuses_maps() {
    let dir = tempfile::tempdir().unwrap();
    let room = room_file(dir.path(), true);
    let room = room.to_str().unwrap();
    let out = dir.path().join("room.png");
    let refused = |args: &[&str], wanted: &[&str]| {
        let o = coherent_render(room, &out, args);
        let t = text(&o);
        assert!(!o.status.success(), "{args:?} was accepted:\n{t}");
        for w in wanted {
            assert!(t.contains(w), "{args:?}: no `{w}` in:\n{t}");
        }
        assert!(!t.contains("panicked"), "{t}");
    };
    refused(
        &["--indirect", "imap", "--particles", "0"],
        &["--particles 0"],
    );
    refused(
        &["--particles", "1000"],
        &["--particles", "--indirect imap"],
    );
    refused(
        &["--indirect", "path", "--imap-cells", "64"],
        &["--imap-cells"],
    );
    refused(&["--indirect", "imaps"], &["none, imap or path"]);
    assert!(!out.exists(), "an image was written");

    // Built beside the scene file, then loaded; another cells target is refused.
    let map = dir.path().join("room.imap.exr");
    let imap = [
        "--indirect",
        "imap",
        "--particles",
        "2000",
        "--imap-cells",
        "64",
    ];
    let o = coherent_render(room, &out, &imap);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("illumination map: built"), "{}", text(&o));
    assert!(map.is_file(), "{}", text(&o));
    let o = coherent_render(room, &out, &imap);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("illumination map: loaded"),
        "{}",
        text(&o)
    );
    refused(
        &["--indirect", "imap", "--imap-cells", "128"],
        &[map.to_str().unwrap(), "delete", "--imap"],
    );

    // Path tracing counts its bounces.
    let o = coherent_render(room, &out, &["--indirect", "path"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("diffuse "), "{}", text(&o));

    // A scene without a light has nothing to trace particles from.
    let dark = room_file(dir.path(), false);
    let o = coherent_render(dark.to_str().unwrap(), &out, &["--indirect", "imap"]);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("no light emits"), "{}", text(&o));
}
