//! `cornell`: a small Cornell-like room (paper section 7 uses interiors; this one is for quick
//! checks and tests): a white floor, ceiling and back wall, a red left and a green right
//! wall, a tall mirror box and a glass sphere, one light under the ceiling. +y is up; the
//! room spans [-1, 1] x [0, 2] x [-1, 1] and is open towards the camera (+z).

use coherent_accel::shapes::{cuboid, icosphere};
use coherent_accel::{Instance, Mesh};
use glam::{Affine3A, Quat, Vec3};

use super::materials::{glass, matte, mirror};
use crate::light::{Light, Rectangular, rectangular};
use crate::scene::{Camera, RenderScene, ShadedMesh};
use crate::tonemap::Operator;

/// The scene (36 + 1,280 triangles: room, box, sphere).
pub fn cornell() -> RenderScene {
    let (white, red, green, mirror_id, glass_id) = (0, 1, 2, 3, 4);
    let materials = vec![
        matte("white", [0.73; 3]),
        matte("red", [0.65, 0.05, 0.05]),
        matte("green", [0.12, 0.45, 0.15]),
        mirror("mirror", 0.9),
        glass("glass", 1.5),
    ];
    let v = |x, y, z| Vec3::new(x, y, z);
    // Quads as two triangles each, facing into the room.
    let quads: [([Vec3; 4], u32); 5] = [
        (
            [
                v(-1., 0., 1.),
                v(1., 0., 1.),
                v(1., 0., -1.),
                v(-1., 0., -1.),
            ],
            white,
        ), // floor
        (
            [
                v(-1., 2., -1.),
                v(1., 2., -1.),
                v(1., 2., 1.),
                v(-1., 2., 1.),
            ],
            white,
        ), // ceiling
        (
            [
                v(-1., 0., -1.),
                v(1., 0., -1.),
                v(1., 2., -1.),
                v(-1., 2., -1.),
            ],
            white,
        ), // back
        (
            [
                v(-1., 0., 1.),
                v(-1., 0., -1.),
                v(-1., 2., -1.),
                v(-1., 2., 1.),
            ],
            red,
        ), // left
        (
            [v(1., 0., -1.), v(1., 0., 1.), v(1., 2., 1.), v(1., 2., -1.)],
            green,
        ), // right
    ];
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut material = Vec::new();
    for (q, m) in quads {
        let base = positions.len() as u32;
        positions.extend_from_slice(&q);
        indices.push([base, base + 1, base + 2]);
        indices.push([base, base + 2, base + 3]);
        material.extend([m, m]);
    }
    let room = ShadedMesh {
        mesh: Mesh::new("room", positions, indices),
        normals: None,
        uvs: None,
        material,
    };
    let tall_box = ShadedMesh::flat(
        cuboid(
            "mirror box",
            Vec3::new(-0.3, 0.0, -0.3),
            Vec3::new(0.3, 1.2, 0.3),
        ),
        mirror_id,
    );
    let sphere = ShadedMesh::flat(icosphere("glass sphere", Vec3::ZERO, 1.0, 3), glass_id)
        .with_smooth_normals();
    let instances = vec![
        Instance::identity(0),
        Instance::new(
            1,
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(0.3),
                Vec3::new(-0.4, 0.0, -0.35),
            ),
        ),
        Instance::new(
            2,
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(0.35),
                Quat::IDENTITY,
                Vec3::new(0.45, 0.35, 0.3),
            ),
        ),
    ];
    // A rectangular area light just under the ceiling, facing down (edge_u x edge_v = -y).
    let light = Rectangular::new(
        Vec3::new(-0.25, 1.98, -0.25),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.5),
        [12.0; 3],
        rectangular::DEFAULT_GRID,
        1,
        false,
    )
    .expect("a valid light");
    RenderScene {
        name: "cornell".to_string(),
        meshes: vec![room, tall_box, sphere],
        instances,
        materials,
        lights: vec![Light::Rectangular(light)],
        tonemap: Operator::default(),
        camera: Camera {
            position: Vec3::new(0.0, 1.0, 3.9),
            look_at: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            vfov_deg: 38.0,
        },
        width: super::super::DEFAULT_RESOLUTION.0,
        height: super::super::DEFAULT_RESOLUTION.1,
        depth: 2,
        spp: None,
        accuracy: None,
        background: [0.0; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    }
}
