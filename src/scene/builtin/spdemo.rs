//! `spdemo`: stand-in for the paper's SPDemo scene (section 7, Table 4: 988 triangles, 3
//! lights, depth 2, "high reflective complexity"): three mirror spheres and two mirror boxes
//! on a reflective checker floor before a mirror wall, lit by an omni, a direct and a linear
//! light. Exactly 988 triangles: 3 x 320 (instanced spheres) + 2 x 12 + 2 + 2.

use coherent_accel::shapes::{cuboid, icosphere};
use glam::{Affine3A, Quat, Vec3};

use super::Builder;
use super::materials::mirror;
use super::shapes::{checker, quad};
use crate::light::{Direct, Light, Linear, Omni, linear};
use crate::material::Material;
use crate::scene::{Camera, RenderScene, ShadedMesh};

/// The scene.
pub fn spdemo() -> RenderScene {
    let mut b = Builder::default();
    let mut floor_mat = Material::phong("checker floor", [0.8; 3], [0.3; 3], 40.0);
    floor_mat.texture = Some(checker("checker", 256, 8, [0.9; 3], [0.08; 3]));
    floor_mat.optics.reflectance = [0.35; 3];
    let floor_mat = b.material(floor_mat);
    let chrome = b.material(mirror("chrome", 0.92));
    let mut gold = mirror("gold mirror", 0.8);
    gold.optics.reflectance = [0.95, 0.75, 0.35];
    gold.phong.diffuse = [0.08, 0.06, 0.02];
    let gold = b.material(gold);
    let wall = b.material(mirror("mirror wall", 0.85));

    b.add(quad(
        "floor",
        Vec3::new(-6.0, 0.0, 6.0),
        Vec3::new(12.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -12.0),
        (1, 1),
        1.0,
        floor_mat,
    ));
    b.add(quad(
        "mirror wall",
        Vec3::new(-6.0, 0.0, -4.0),
        Vec3::new(12.0, 0.0, 0.0),
        Vec3::new(0.0, 5.0, 0.0),
        (1, 1),
        1.0,
        wall,
    ));
    let sphere = b.mesh(
        ShadedMesh::flat(icosphere("sphere", Vec3::ZERO, 1.0, 2), chrome).with_smooth_normals(),
    );
    for (c, r) in [
        (Vec3::new(-1.6, 0.8, 0.0), 0.8),
        (Vec3::new(0.4, 1.0, -1.2), 1.0),
        (Vec3::new(1.9, 0.6, 0.9), 0.6),
    ] {
        b.place(
            sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, c),
        );
    }
    for (i, (c, h, a)) in [
        (Vec3::new(-0.2, 0.0, 1.6), 0.5, 0.5),
        (Vec3::new(2.6, 0.0, -1.8), 1.6, -0.3),
    ]
    .into_iter()
    .enumerate()
    {
        let id = b.mesh(ShadedMesh::flat(
            cuboid(
                &format!("box {i}"),
                Vec3::new(-0.4, 0.0, -0.4),
                Vec3::new(0.4, h, 0.4),
            ),
            gold,
        ));
        b.place(
            id,
            Affine3A::from_rotation_translation(Quat::from_rotation_y(a), c),
        );
    }

    let lights = vec![
        Light::Omni(Omni::new(Vec3::new(-3.0, 5.0, 4.0), [30.0; 3]).expect("valid")),
        Light::Direct(
            Direct::new(
                Vec3::new(3.0, 6.0, 3.0),
                Vec3::new(-0.4, -1.0, -0.4),
                [25.0, 24.0, 20.0],
            )
            .expect("valid"),
        ),
        Light::Linear(
            Linear::new(
                Vec3::new(-2.0, 4.5, -3.0),
                Vec3::new(2.0, 4.5, -3.0),
                [8.0, 9.0, 10.0],
                linear::DEFAULT_POINTS,
                3,
                false,
            )
            .expect("valid"),
        ),
    ];
    let camera = Camera {
        position: Vec3::new(0.5, 2.6, 7.5),
        look_at: Vec3::new(0.2, 0.8, -0.5),
        up: Vec3::Y,
        vfov_deg: 40.0,
    };
    b.finish("spdemo", camera, lights, 2, [0.02, 0.02, 0.03])
}
