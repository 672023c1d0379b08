//! `car`: stand-in for the paper's Car scene (section 7, Table 4: 233,000 triangles, 4
//! lights, depth 2; "measured tabulated BRDF, transparent and refractive objects"): a
//! rounded car body in tabulated-BDF paint (an isotropic Ward lobe tabulated by
//! `bdf::tabulate_isotropic`, under a Fresnel clear coat), a refractive glass cabin and
//! headlamps, four instanced tyres, on asphalt under a generated sky (environment light),
//! the sun (parallel), a spot and a street lamp (goniodiagram).

use std::path::Path;
use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};

use super::Builder;
use super::materials::glass;
use super::shapes::{superellipsoid, torus};
use crate::bdf::{Analytic, Bdf, Ward, tabulate_isotropic};
use crate::light::photometry::{PhotometricTable, PhotometricType};
use crate::light::{Environment, GonioLookup, Goniodiagram, Light, Parallel, Spot, SpotFalloff};
use crate::material::Material;
use crate::scene::{Camera, RenderScene, ShadedMesh};

/// The car paint: a red isotropic Ward lobe tabulated on a 13 x 13 x 17 grid.
pub fn paint() -> Material {
    let ward = Analytic::Ward(Ward {
        diffuse: [0.32, 0.02, 0.03],
        specular: [0.25, 0.22, 0.22],
        alpha_x: 0.12,
        alpha_y: 0.12,
    });
    let table = tabulate_isotropic(&ward, [13, 13, 17]).expect("a valid grid");
    let mut m = Material::phong("tabulated paint", [0.0; 3], [0.0; 3], 0.0);
    m.bdf = Some(Arc::new(Bdf::Isotropic(table)));
    // The clear coat: a Fresnel-weighted mirror reflection (about 4 % head-on).
    m.optics.reflectance = [1.0; 3];
    m.optics.ior = 1.5;
    m.optics.fresnel = true;
    m
}

/// A street lamp's goniodiagram (type C, rotationally symmetric): most light 50-70 degrees
/// from the nadir, little straight down, none above the horizon (candela).
pub fn street_lamp_table() -> PhotometricTable {
    let angles: Vec<f32> = (0..=18).map(|k| k as f32 * 10.0).collect();
    let candela = angles
        .iter()
        .map(|&g| {
            if g >= 90.0 {
                0.0
            } else {
                let x = (g - 60.0) / 25.0;
                3000.0 + 9000.0 * (-x * x).exp()
            }
        })
        .collect();
    PhotometricTable {
        kind: PhotometricType::C,
        planes: vec![0.0],
        angles,
        candela,
    }
}

/// A sky: blue overhead to pale at the horizon, dark ground below (latitude-longitude map,
/// rows from the up pole down).
fn sky() -> Environment {
    let (w, h) = (64, 32);
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        let lat = 0.5 - (y as f32 + 0.5) / h as f32; // +0.5 up .. -0.5 down
        for _ in 0..w {
            texels.push(if lat > 0.0 {
                let t = (2.0 * lat).powf(0.5);
                [0.55 - 0.35 * t, 0.6 - 0.3 * t, 0.7]
            } else {
                [0.08, 0.07, 0.06]
            });
        }
    }
    Environment::new(
        "generated sky",
        w,
        h,
        &texels,
        1.0,
        Vec3::Y,
        Vec3::NEG_Z,
        16,
    )
    .expect("valid")
}

/// The scene (231,714 triangles: body 180,000, cabin 12,288, tyres 4 x 9,216, headlamps
/// 2 x 1,280, ground 2).
pub fn car() -> RenderScene {
    let mut b = Builder::default();
    let paint = b.material(paint());
    let glass_id = b.material(glass("car glass", 1.5));
    let rubber = b.material(Material::phong("rubber", [0.03; 3], [0.1; 3], 12.0));
    let asphalt = b.material(Material::phong(
        "asphalt",
        [0.18, 0.18, 0.19],
        [0.05; 3],
        8.0,
    ));

    b.add(super::shapes::quad(
        "ground",
        Vec3::new(-40.0, 0.0, 40.0),
        Vec3::new(80.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -80.0),
        (1, 1),
        20.0,
        asphalt,
    ));
    let body = b.mesh(superellipsoid(
        "body",
        Vec3::new(2.2, 0.5, 0.95),
        (0.3, 0.25),
        (450, 200),
        paint,
    ));
    b.place(body, Affine3A::from_translation(Vec3::new(0.0, 0.75, 0.0)));
    let cabin = b.mesh(superellipsoid(
        "cabin",
        Vec3::new(1.2, 0.45, 0.8),
        (0.45, 0.4),
        (96, 64),
        glass_id,
    ));
    b.place(
        cabin,
        Affine3A::from_translation(Vec3::new(-0.25, 1.2, 0.0)),
    );
    let tyre = b.mesh(torus("tyre", 0.3, 0.15, (96, 48), rubber));
    for (x, z) in [(1.35, 0.85), (1.35, -0.85), (-1.35, 0.85), (-1.35, -0.85)] {
        b.place(
            tyre,
            Affine3A::from_rotation_translation(
                Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                Vec3::new(x, 0.45, z),
            ),
        );
    }
    let lamp = b.mesh(
        ShadedMesh::flat(
            coherent_accel::shapes::icosphere("headlamp", Vec3::ZERO, 1.0, 3),
            glass_id,
        )
        .with_smooth_normals(),
    );
    for z in [0.55, -0.55] {
        b.place(
            lamp,
            Affine3A::from_scale_rotation_translation(
                Vec3::new(0.08, 0.1, 0.16),
                Quat::IDENTITY,
                Vec3::new(2.12, 0.8, z),
            ),
        );
    }

    let lights = vec![
        Light::Environment(sky()),
        Light::Parallel(
            Parallel::new(Vec3::new(-0.5, -1.0, -0.3), [2.2, 2.0, 1.7]).expect("valid"),
        ),
        Light::Spot(
            Spot::new(
                Vec3::new(4.0, 5.0, 3.0),
                Vec3::new(-4.0, -4.5, -3.0),
                [60.0; 3],
                0.35,
                0.6,
                SpotFalloff::default(),
            )
            .expect("valid"),
        ),
        Light::Goniodiagram(
            Goniodiagram::new(
                Vec3::new(-3.5, 5.0, -2.5),
                Vec3::Y,
                Vec3::X,
                &street_lamp_table(),
                [1.0, 0.9, 0.7],
                GonioLookup::default(),
                Path::new("generated street lamp"),
            )
            .expect("valid"),
        ),
    ];
    let camera = Camera {
        position: Vec3::new(5.2, 2.2, 5.6),
        look_at: Vec3::new(0.0, 0.7, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
    };
    b.finish("car", camera, lights, 2, [0.0; 3])
}
