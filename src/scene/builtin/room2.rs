//! `room2`: stand-in for the paper's Room2 scene (section 7, Table 4: 12,000 triangles, 4
//! lights, depth 1, an interior): a closed furnished room (wooden floor, plaster walls, a
//! table and chairs, a sofa, a shelf, a lamp, a few objects) lit by a rectangular ceiling
//! panel, a goniodiagram downlight, an omni table lamp and a spot.

use std::path::Path;

use coherent_accel::shapes::{cuboid, icosphere};
use glam::{Affine3A, Quat, Vec3};

use super::Builder;
use super::materials::{matte, mirror};
use super::shapes::{lathe, quad, superellipsoid, torus, wood};
use crate::light::photometry::{PhotometricTable, PhotometricType};
use crate::light::{
    GonioLookup, Goniodiagram, Light, Omni, Rectangular, Spot, SpotFalloff, rectangular,
};
use crate::material::Material;
use crate::scene::{Camera, RenderScene, ShadedMesh};

/// A downlight's goniodiagram (type C, symmetric): a cosine-power beam (candela).
fn downlight_table() -> PhotometricTable {
    let angles: Vec<f32> = (0..=18).map(|k| k as f32 * 10.0).collect();
    let candela = angles
        .iter()
        .map(|&g| {
            if g >= 90.0 {
                0.0
            } else {
                8000.0 * g.to_radians().cos().powi(3)
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

/// The scene (12,012 triangles: walls 6,200, sofa 2,304, lamp shade 1,520, bowl 1,024, balls
/// 2 x 320, table 5 x 12, chairs 12 x 12, shelf 10 x 12).
pub fn room2() -> RenderScene {
    let mut b = Builder::default();
    let mut floor = Material::phong("wood floor", [1.0; 3], [0.2; 3], 40.0);
    floor.texture = Some(wood("floor wood", 256, 21));
    let floor = b.material(floor);
    let plaster = b.material(matte("plaster", [0.75, 0.73, 0.68]));
    let ceiling = b.material(matte("ceiling", [0.85; 3]));
    let oak = b.material(Material::phong("oak", [0.45, 0.3, 0.16], [0.2; 3], 30.0));
    let fabric = b.material(matte("fabric", [0.2, 0.3, 0.55]));
    let shade = b.material(matte("lamp shade", [0.9, 0.85, 0.7]));
    let ceramic = b.material(Material::phong("ceramic", [0.7, 0.25, 0.2], [0.5; 3], 80.0));
    let chrome = b.material(mirror("chrome", 0.8));

    walls(&mut b, floor, ceiling, plaster);
    furniture(&mut b, oak);
    let v = Vec3::new;
    b.add(superellipsoid(
        "sofa",
        v(1.1, 0.4, 0.45),
        (0.25, 0.25),
        (48, 24),
        fabric,
    ));
    b.instances.last_mut().expect("placed").world_from_object =
        Affine3A::from_translation(v(0.6, 0.4, -2.4));
    let shade_profile: Vec<(f32, f32)> = (0..20)
        .map(|k| (0.3 - 0.012 * k as f32, 0.02 * k as f32))
        .collect();
    b.add(lathe("lamp shade", &shade_profile, 40, shade));
    b.instances.last_mut().expect("placed").world_from_object =
        Affine3A::from_translation(v(2.4, 1.2, -2.4));
    b.add(torus("bowl", 0.18, 0.05, (32, 16), ceramic));
    b.instances.last_mut().expect("placed").world_from_object =
        Affine3A::from_translation(v(0.3, 0.82, 0.2));
    let ball = b.mesh(
        ShadedMesh::flat(icosphere("ball", Vec3::ZERO, 1.0, 2), chrome).with_smooth_normals(),
    );
    b.place(
        ball,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.12),
            Quat::IDENTITY,
            v(0.8, 0.89, 0.35),
        ),
    );
    b.place(
        ball,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.25),
            Quat::IDENTITY,
            v(1.8, 0.25, 1.5),
        ),
    );

    let lights = lights();
    let camera = Camera {
        position: v(2.4, 1.7, 2.7),
        look_at: v(-0.3, 0.7, -0.5),
        up: Vec3::Y,
        vfov_deg: 60.0,
    };
    b.finish("room2", camera, lights, 1, [0.0; 3])
}

/// The room: 6 x 3 x 6, every wall facing in.
fn walls(b: &mut Builder, floor: u32, ceiling: u32, plaster: u32) {
    let (x0, x1, z0, z1, h) = (-3.0, 3.0, -3.0, 3.0, 3.0);
    let v = Vec3::new;
    b.add(quad(
        "floor",
        v(x0, 0.0, z1),
        v(6.0, 0.0, 0.0),
        v(0.0, 0.0, -6.0),
        (30, 30),
        3.0,
        floor,
    ));
    b.add(quad(
        "ceiling",
        v(x0, h, z0),
        v(6.0, 0.0, 0.0),
        v(0.0, 0.0, 6.0),
        (20, 20),
        1.0,
        ceiling,
    ));
    b.add(quad(
        "back wall",
        v(x0, 0.0, z0),
        v(6.0, 0.0, 0.0),
        v(0.0, h, 0.0),
        (30, 15),
        1.0,
        plaster,
    ));
    b.add(quad(
        "front wall",
        v(x1, 0.0, z1),
        v(-6.0, 0.0, 0.0),
        v(0.0, h, 0.0),
        (30, 15),
        1.0,
        plaster,
    ));
    b.add(quad(
        "left wall",
        v(x0, 0.0, z1),
        v(0.0, 0.0, -6.0),
        v(0.0, h, 0.0),
        (30, 15),
        1.0,
        plaster,
    ));
    b.add(quad(
        "right wall",
        v(x1, 0.0, z0),
        v(0.0, 0.0, 6.0),
        v(0.0, h, 0.0),
        (30, 15),
        1.0,
        plaster,
    ));
}

/// Boxes: table, chairs and a shelf, instances of one unit cube.
fn furniture(b: &mut Builder, oak: u32) {
    let v = Vec3::new;
    let cube = b.mesh(ShadedMesh::flat(
        cuboid("cube", Vec3::splat(-0.5), Vec3::splat(0.5)),
        oak,
    ));
    let block = |b: &mut Builder, c: Vec3, s: Vec3, a: f32| {
        b.place(
            cube,
            Affine3A::from_scale_rotation_translation(s, Quat::from_rotation_y(a), c),
        );
    };
    block(b, v(0.3, 0.74, 0.2), v(1.6, 0.06, 0.9), 0.0);
    for (x, z) in [(-0.4, -0.15), (1.0, -0.15), (-0.4, 0.55), (1.0, 0.55)] {
        block(b, v(x, 0.36, z), v(0.06, 0.72, 0.06), 0.0);
    }
    for (cx, cz, a) in [
        (0.3_f32, 1.1_f32, 0.0_f32),
        (0.3, -0.75, std::f32::consts::PI),
    ] {
        let (s, c) = a.sin_cos();
        let at = |dx: f32, y: f32, dz: f32| v(cx + c * dx + s * dz, y, cz - s * dx + c * dz);
        block(b, at(0.0, 0.45, 0.0), v(0.45, 0.05, 0.45), a);
        block(b, at(0.0, 0.75, 0.2), v(0.45, 0.6, 0.05), a);
        for (dx, dz) in [(-0.2, -0.2), (0.2, -0.2), (-0.2, 0.2), (0.2, 0.2)] {
            block(b, at(dx, 0.22, dz), v(0.04, 0.44, 0.04), a);
        }
    }
    for k in 0..5 {
        block(
            b,
            v(-2.8, 0.4 + 0.45 * k as f32, -1.0),
            v(0.35, 0.04, 1.6),
            0.0,
        );
    }
    for k in 0..5 {
        let z = -1.8 + 0.4 * k as f32;
        block(b, v(-2.8, 1.2, z), v(0.35, 2.0, 0.04), 0.0);
    }
}

/// A rectangular ceiling light, a goniodiagram downlight, the lamp's omni light and a spot.
fn lights() -> Vec<Light> {
    let v = Vec3::new;
    vec![
        Light::Rectangular(
            Rectangular::new(
                v(-0.5, 2.98, -0.5),
                v(1.0, 0.0, 0.0),
                v(0.0, 0.0, 1.0),
                [6.0, 6.0, 5.5],
                rectangular::DEFAULT_GRID,
                7,
                false,
            )
            .expect("valid"),
        ),
        Light::Goniodiagram(
            Goniodiagram::new(
                v(-1.8, 2.95, 1.5),
                Vec3::Y,
                Vec3::X,
                &downlight_table(),
                [1.0, 0.95, 0.85],
                GonioLookup::default(),
                Path::new("generated downlight"),
            )
            .expect("valid"),
        ),
        Light::Omni(Omni::new(v(2.4, 1.3, -2.4), [2.0, 1.7, 1.2]).expect("valid")),
        Light::Spot(
            Spot::new(
                v(2.5, 2.8, 2.5),
                v(-2.2, -2.0, -2.3),
                [12.0; 3],
                0.3,
                0.5,
                SpotFalloff::default(),
            )
            .expect("valid"),
        ),
    ]
}
