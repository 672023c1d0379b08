//! The Mitsuba exporter against closed forms: scenes whose radiance is known exactly,
//! exported, rendered by the installed Mitsuba (both variants the comparisons use) and by
//! us, each within 1% of the closed form. They skip with the reason when the peer is not
//! installed, unless `COHERENT_REQUIRE_PEER` asks for it (`scripts/test.sh` does where the
//! set-up provides it).

use std::f32::consts::PI;

use coherent::accel::shapes::icosphere;
use coherent::accel::{Accel, Instance, Mesh};
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::export::mitsuba::export;
use coherent::export::peer::{Peer, VARIANTS, installed};
use coherent::film::{FilmOptions, Method};
use coherent::light::{Light, Omni, Parallel};
use coherent::material::Material;
use coherent::render::{Renderer, render_frame};
use coherent::scene::{Camera, RenderScene, ShadedMesh};
use coherent::simd::Backend;
use glam::Vec3;

const W: u32 = 48;
const H: u32 = 36;
const SPP: u32 = 4;

/// Whether the peer is there; `None` (test skipped, with the reason) when it is not and not
/// required.
fn peer_or_skip(test: &str) -> Option<()> {
    match installed() {
        Ok(_) => Some(()),
        Err(e) if coherent::require::required("COHERENT_REQUIRE_PEER") => {
            panic!("{test}: COHERENT_REQUIRE_PEER is set, but {e}")
        }
        Err(e) => {
            eprintln!("{test}: skipped: {e}");
            None
        }
    }
}

fn scene(name: &str, mesh: Mesh, albedo: f32, light: Light, camera: Camera) -> RenderScene {
    RenderScene {
        name: name.to_string(),
        meshes: vec![ShadedMesh::flat(mesh, 0)],
        instances: vec![Instance::identity(0)],
        materials: vec![Material::phong("wall", [albedo; 3], [0.0; 3], 0.0)],
        lights: vec![light],
        camera,
        width: W,
        height: H,
        depth: 0,
        spp: None,
        accuracy: None,
        tonemap: Default::default(),
        background: [0.0; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    }
}

/// Our mean radiance (green channel) over the image.
fn ours(scene: &RenderScene) -> f32 {
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp)).unwrap();
    let r = Renderer::new(scene, accel, W, H).unwrap();
    let opts = FilmOptions::new(W, H, Method::Uniform { spp: SPP });
    let out = render_frame(Backend::Scalar, &r, &opts, &|_| {}).unwrap();
    let img = out.image();
    img.iter().map(|p| p[1]).sum::<f32>() / img.len() as f32
}

/// Mitsuba's mean radiance (green) over the image, per variant.
fn theirs(scene: &RenderScene) -> Vec<(&'static str, f32)> {
    let dir = tempfile::tempdir().unwrap();
    let ex = export(scene, dir.path()).unwrap();
    assert!(ex.skipped.is_empty(), "{:?}", ex.skipped);
    VARIANTS
        .iter()
        .map(|v| {
            let mut peer = Peer::start(&ex.xml, v, 2).unwrap();
            let out = dir.path().join(format!("{v}.exr"));
            peer.render(SPP, 0, Some(&out)).unwrap();
            let (w, h, px) = coherent::light::environment::read_exr(&out).unwrap();
            assert_eq!((w, h), (W as usize, H as usize));
            (*v, px.iter().map(|p| p[1]).sum::<f32>() / px.len() as f32)
        })
        .collect()
}

fn check(name: &str, expected: f32, scene: &RenderScene) {
    let us = ours(scene);
    assert!(
        (us / expected - 1.0).abs() < 0.01,
        "{name}: ours {us}, closed form {expected}"
    );
    for (variant, them) in theirs(scene) {
        assert!(
            (them / expected - 1.0).abs() < 0.01,
            "{name}: Mitsuba {variant} {them}, closed form {expected} (ours {us})"
        );
    }
}

#[test]
fn a_diffuse_quad_under_a_parallel_light_matches_the_closed_form() {
    let Some(()) = peer_or_skip("quad") else {
        return;
    };
    // A quad far larger than the view, facing +z, lit at 30 degrees off its normal.
    let s = 50.0;
    let mesh = Mesh::new(
        "quad",
        vec![
            Vec3::new(-s, -s, 0.0),
            Vec3::new(s, -s, 0.0),
            Vec3::new(s, s, 0.0),
            Vec3::new(-s, s, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let theta = 30f32.to_radians();
    let dir = Vec3::new(theta.sin(), 0.0, -theta.cos());
    let (albedo, e) = (0.5, 3.0);
    let camera = Camera {
        position: Vec3::new(0.3, -0.2, 2.0),
        look_at: Vec3::new(0.0, 0.1, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
    };
    let light = Light::Parallel(Parallel::new(dir, [e; 3]).unwrap());
    let sc = scene("quad", mesh, albedo, light, camera);
    check("quad", albedo / PI * e * theta.cos(), &sc);
}

#[test]
fn a_closed_sphere_lit_from_its_centre_matches_the_closed_form() {
    let Some(()) = peer_or_skip("sphere") else {
        return;
    };
    // Inside a sphere of radius r, a point light of intensity I at the centre gives the wall
    // the irradiance I / r^2, so the radiance rho I / (pi r^2) (direct light only). The
    // facets of 20 * 4^5 triangles lie within 0.02% of r.
    let (r, intensity, albedo) = (2.0, 5.0, 0.7);
    let mesh = icosphere("sphere", Vec3::ZERO, r, 5);
    let camera = Camera {
        position: Vec3::new(0.1, 0.05, 0.0),
        look_at: Vec3::new(0.3, 0.2, 1.0),
        up: Vec3::Y,
        vfov_deg: 60.0,
    };
    let light = Light::Omni(Omni::new(Vec3::ZERO, [intensity; 3]).unwrap());
    let sc = scene("sphere", mesh, albedo, light, camera);
    check("sphere", albedo * intensity / (PI * r * r), &sc);
}
