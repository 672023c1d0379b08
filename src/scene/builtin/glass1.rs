//! `glass1`: stand-in for the paper's Glass1 scene (section 7, Table 4: 44,794 triangles, 2
//! lights, depth 2; "high reflective complexity ... heavily textured", Figure 4): glass vases
//! and spheres on a wooden table in a room of marble, brick and wood textures (generated in
//! memory), lit by a circular ceiling lamp and a rectangular window light.

use glam::{Affine3A, Quat, Vec3};

use super::Builder;
use super::materials::glass;
use super::shapes::{brick, checker, lathe, marble, quad, superellipsoid, torus, wood};
use crate::light::{Circular, Light, Rectangular, circular, rectangular};
use crate::material::Material;
use crate::spectrum::dispersion::Dispersion;

/// The glasses' Abbe number in spectral renders: F2's.
const FLINT_ABBE: f32 = 36.37;
use crate::scene::{Camera, RenderScene, ShadedMesh};

fn textured(name: &str, tex: std::sync::Arc<crate::texture::Texture>, specular: f32) -> Material {
    let mut m = Material::phong(name, [1.0; 3], [specular; 3], 30.0);
    m.texture = Some(tex);
    m
}

/// The vase profile: 64 points of (radius, height), a foot, a belly and a flared neck.
fn vase_profile() -> Vec<(f32, f32)> {
    (0..64)
        .map(|k| {
            let t = k as f32 / 63.0;
            let r = 0.18 + 0.22 * (std::f32::consts::PI * (t * 1.2).min(1.0)).sin() - 0.1 * t
                + 0.12 * (t - 0.8).max(0.0) * 5.0;
            (r.max(0.02), 1.1 * t)
        })
        .collect()
}

/// The scene (44,584 triangles: floor 5,000, walls 5,040 + 1,152, table 2,304, vases
/// 2 x 12,600, spheres 3 x 1,280, rings 2 x 1,024).
pub fn glass1() -> RenderScene {
    let mut b = Builder::default();
    let floor_m = b.material(textured("marble floor", marble("marble", 256, 11), 0.3));
    let wall_m = b.material(textured("brick wall", brick("brick", 256, 12), 0.02));
    let side_m = b.material(textured("wood panel", wood("panel wood", 256, 13), 0.1));
    let table_m = b.material(textured("table wood", wood("table wood", 256, 14), 0.25));
    let ring_m = b.material(textured(
        "checker ring",
        checker("ring checker", 128, 16, [0.85, 0.7, 0.2], [0.1, 0.1, 0.4]),
        0.4,
    ));
    // Flint-like dispersion (Abbe number 36, F2's) about the indices RGB renders use, so
    // that spectral renders show the vases' colour fringes.
    let mut clear = glass("glass", 1.5);
    clear.optics.dispersion = Some(Dispersion::cauchy_abbe(1.5, FLINT_ABBE));
    let glass_m = b.material(clear);
    let mut tinted = glass("green glass", 1.52);
    tinted.optics.transmittance = [0.6, 0.9, 0.65];
    tinted.optics.dispersion = Some(Dispersion::cauchy_abbe(1.52, FLINT_ABBE));
    let tinted = b.material(tinted);

    b.add(quad(
        "floor",
        Vec3::new(-5.0, 0.0, 5.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -10.0),
        (50, 50),
        4.0,
        floor_m,
    ));
    b.add(quad(
        "back wall",
        Vec3::new(-5.0, 0.0, -3.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 5.0, 0.0),
        (70, 36),
        3.0,
        wall_m,
    ));
    b.add(quad(
        "side wall",
        Vec3::new(-3.5, 0.0, 5.0),
        Vec3::new(0.0, 0.0, -8.0),
        Vec3::new(0.0, 5.0, 0.0),
        (24, 24),
        2.0,
        side_m,
    ));
    b.add(superellipsoid(
        "table",
        Vec3::new(2.0, 0.5, 1.1),
        (0.15, 0.15),
        (48, 24),
        table_m,
    ));
    b.instances.last_mut().expect("placed").world_from_object =
        Affine3A::from_translation(Vec3::new(0.0, 0.5, 0.0));

    let vase = b.mesh(lathe("vase", &vase_profile(), 100, glass_m));
    let vase_tinted = b.mesh(lathe("tinted vase", &vase_profile(), 100, tinted));
    b.place(vase, Affine3A::from_translation(Vec3::new(-0.8, 1.0, -0.2)));
    b.place(
        vase_tinted,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.8),
            Quat::IDENTITY,
            Vec3::new(0.9, 1.0, -0.4),
        ),
    );
    let sphere = b.mesh(
        ShadedMesh::flat(
            coherent_accel::shapes::icosphere("glass sphere", Vec3::ZERO, 1.0, 3),
            glass_m,
        )
        .with_smooth_normals(),
    );
    for (c, r) in [
        (Vec3::new(0.1, 1.2, 0.5), 0.2),
        (Vec3::new(-1.4, 1.15, 0.6), 0.15),
        (Vec3::new(1.6, 0.35, 1.8), 0.35),
    ] {
        b.place(
            sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, c),
        );
    }
    let ring = b.mesh(torus("ring", 0.25, 0.06, (32, 16), ring_m));
    b.place(ring, Affine3A::from_translation(Vec3::new(0.4, 1.06, 0.7)));
    b.place(
        ring,
        Affine3A::from_rotation_translation(Quat::from_rotation_x(1.2), Vec3::new(-1.5, 0.3, 1.6)),
    );

    let lights = vec![
        Light::Circular(
            Circular::new(
                Vec3::new(0.0, 4.5, 0.5),
                Vec3::NEG_Y,
                0.6,
                [14.0, 13.0, 11.0],
                circular::DEFAULT_GRID,
                5,
                false,
            )
            .expect("valid"),
        ),
        Light::Rectangular(
            Rectangular::new(
                Vec3::new(4.5, 1.0, 2.5),
                Vec3::new(0.0, 0.0, -3.0),
                Vec3::new(0.0, 2.5, 0.0),
                [4.0, 4.5, 5.0],
                rectangular::DEFAULT_GRID,
                6,
                false,
            )
            .expect("valid"),
        ),
    ];
    let camera = Camera {
        position: Vec3::new(0.6, 2.4, 5.0),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 45.0,
    };
    b.finish("glass1", camera, lights, 2, [0.0; 3])
}
