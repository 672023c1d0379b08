//! The built-in generated test scenes (paper section 7 compares scenes of various kinds; these
//! are generated stand-ins until real meshes are loaded): a field of instanced spheres, a
//! tessellated terrain, a room with objects, and a bunny-sized blob. Each comes with a view
//! for primary rays and a point light for shadow rays.

use glam::{Affine3A, Quat, Vec3};

use crate::shapes::{Rng, cuboid, icosphere, terrain, torus};
use crate::{Mesh, Ray1, Scene};

/// How big to make a scene: `Quick` for tests and `reproduce --quick`, `Full` for the paper's
/// sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneSize {
    Quick,
    Full,
}

/// A pinhole view: eye, target, up, vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_y_degrees: f32,
}

impl View {
    /// The primary ray through the centre of pixel `(x, y)` of a `width x height` image
    /// (`y` down), with an unnormalised direction (`t = 1` on the image plane at distance 1).
    pub fn primary_ray(&self, x: u32, y: u32, width: u32, height: u32) -> Ray1 {
        self.ray_at(
            (x as f32 + 0.5) / width as f32,
            (y as f32 + 0.5) / height as f32,
            width as f32 / height as f32,
        )
    }

    /// The ray through image point `(sx, sy)` in `[0, 1]^2` (`sy` down) for an image of
    /// aspect ratio `aspect` (width / height).
    pub fn ray_at(&self, sx: f32, sy: f32, aspect: f32) -> Ray1 {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let h = (self.fov_y_degrees.to_radians() * 0.5).tan();
        let dir = forward + right * ((2.0 * sx - 1.0) * h * aspect) + up * ((1.0 - 2.0 * sy) * h);
        Ray1::infinite(self.eye, dir)
    }
}

/// A generated scene with its view and light.
#[derive(Debug, Clone)]
pub struct BuiltinScene {
    pub name: &'static str,
    pub scene: Scene,
    pub view: View,
    /// A point light position (for shadow rays).
    pub light: Vec3,
}

/// Every built-in scene.
pub fn all(size: SceneSize) -> Vec<BuiltinScene> {
    vec![
        sphere_field(size),
        terrain_scene(size),
        room(size),
        blob(size),
    ]
}

/// The built-in scene `name`.
pub fn by_name(name: &str, size: SceneSize) -> Option<BuiltinScene> {
    match name {
        "spheres" => Some(sphere_field(size)),
        "terrain" => Some(terrain_scene(size)),
        "room" => Some(room(size)),
        "blob" => Some(blob(size)),
        _ => None,
    }
}

/// The names [`by_name`] knows.
pub const NAMES: [&str; 4] = ["spheres", "terrain", "room", "blob"];

/// `spheres`: a ground quad and a grid of instanced icospheres of random sizes (quick: 10 x 10
/// instances of 1,280 triangles; full: 32 x 32 = 1,024 instances of 5,120). Many instances:
/// the top-level tree matters.
pub fn sphere_field(size: SceneSize) -> BuiltinScene {
    let (n, subdiv) = match size {
        SceneSize::Quick => (10, 3),
        SceneSize::Full => (32, 4),
    };
    let mut scene = Scene::default();
    let sphere = scene.add_mesh(icosphere("sphere", Vec3::ZERO, 1.0, subdiv));
    let half = n as f32 * 1.5;
    let ground = scene.add_mesh(Mesh::new(
        "ground",
        vec![
            Vec3::new(-half, -half, 0.0),
            Vec3::new(half, -half, 0.0),
            Vec3::new(half, half, 0.0),
            Vec3::new(-half, half, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    ));
    scene.add_instance(ground, Affine3A::IDENTITY);
    let mut rng = Rng::new(17);
    for i in 0..n {
        for j in 0..n {
            let r = rng.range(0.4, 1.2);
            let c = Vec3::new(
                (i as f32 + 0.5) * 3.0 - half + rng.range(-0.5, 0.5),
                (j as f32 + 0.5) * 3.0 - half + rng.range(-0.5, 0.5),
                r,
            );
            scene.add_instance(
                sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, c),
            );
        }
    }
    BuiltinScene {
        name: "spheres",
        scene,
        view: View {
            eye: Vec3::new(-half * 1.1, -half * 1.3, half * 0.6),
            target: Vec3::new(0.0, 0.0, 0.0),
            up: Vec3::Z,
            fov_y_degrees: 50.0,
        },
        light: Vec3::new(half * 0.5, -half * 0.8, half * 1.5),
    }
}

/// `terrain`: one tessellated heightfield (quick: 128 x 128 quads, 32,768 triangles; full:
/// 512 x 512, 524,288 triangles), seen from above at an angle.
pub fn terrain_scene(size: SceneSize) -> BuiltinScene {
    let n = match size {
        SceneSize::Quick => 128,
        SceneSize::Full => 512,
    };
    let scene = Scene::single(terrain("terrain", 100.0, n, 12.0, 5));
    BuiltinScene {
        name: "terrain",
        scene,
        view: View {
            eye: Vec3::new(-45.0, -60.0, 35.0),
            target: Vec3::new(5.0, 10.0, 0.0),
            up: Vec3::Z,
            fov_y_degrees: 55.0,
        },
        light: Vec3::new(30.0, -40.0, 80.0),
    }
}

/// `room`: a closed room (walls, floor, ceiling) with a table, shelves and instanced objects
/// (spheres, tori, boxes), seen from inside (quick: about 10^4 triangles; full: about
/// 1.5 * 10^5).
pub fn room(size: SceneSize) -> BuiltinScene {
    let (subdiv, tor) = match size {
        SceneSize::Quick => (3, (32, 16)),
        SceneSize::Full => (5, (128, 64)),
    };
    let mut scene = Scene::default();
    // The room: an inward box 10 x 8 x 3 (inverted winding does not matter to the tracer).
    let walls = scene.add_mesh(cuboid(
        "walls",
        Vec3::new(-5.0, -4.0, 0.0),
        Vec3::new(5.0, 4.0, 3.0),
    ));
    scene.add_instance(walls, Affine3A::IDENTITY);
    let slab = scene.add_mesh(cuboid("slab", Vec3::splat(-0.5), Vec3::splat(0.5)));
    let boxes = [
        // Table top and legs.
        (Vec3::new(0.0, 0.0, 0.78), Vec3::new(2.4, 1.2, 0.06)),
        (Vec3::new(-1.1, -0.5, 0.375), Vec3::new(0.08, 0.08, 0.75)),
        (Vec3::new(1.1, -0.5, 0.375), Vec3::new(0.08, 0.08, 0.75)),
        (Vec3::new(-1.1, 0.5, 0.375), Vec3::new(0.08, 0.08, 0.75)),
        (Vec3::new(1.1, 0.5, 0.375), Vec3::new(0.08, 0.08, 0.75)),
        // Shelves on the back wall.
        (Vec3::new(0.0, 3.7, 1.0), Vec3::new(4.0, 0.5, 0.04)),
        (Vec3::new(0.0, 3.7, 1.6), Vec3::new(4.0, 0.5, 0.04)),
        (Vec3::new(0.0, 3.7, 2.2), Vec3::new(4.0, 0.5, 0.04)),
        // A cupboard.
        (Vec3::new(-4.3, -2.5, 1.0), Vec3::new(1.2, 1.8, 2.0)),
    ];
    for (c, s) in boxes {
        scene.add_instance(
            slab,
            Affine3A::from_scale_rotation_translation(s, Quat::IDENTITY, c),
        );
    }
    let ball = scene.add_mesh(icosphere("ball", Vec3::ZERO, 1.0, subdiv));
    let ring = scene.add_mesh(torus("ring", Vec3::ZERO, 1.0, 0.3, tor.0, tor.1));
    let mut rng = Rng::new(23);
    // Objects on the table and the shelves.
    for i in 0..24 {
        let (base, spread) = if i < 8 {
            (Vec3::new(0.0, 0.0, 0.81), Vec3::new(1.0, 0.45, 0.0))
        } else {
            let shelf = [1.02, 1.62, 2.22][i % 3];
            (Vec3::new(0.0, 3.7, shelf), Vec3::new(1.8, 0.15, 0.0))
        };
        let s = rng.range(0.06, 0.18);
        let p = base
            + Vec3::new(
                rng.range(-spread.x, spread.x),
                rng.range(-spread.y, spread.y),
                s,
            );
        let q = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, core::f32::consts::TAU));
        let mesh = if i % 2 == 0 { ball } else { ring };
        scene.add_instance(
            mesh,
            Affine3A::from_scale_rotation_translation(Vec3::splat(s), q, p),
        );
    }
    // A big decorative torus and a big ball on the floor.
    scene.add_instance(
        ring,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.6),
            Quat::from_rotation_x(1.2),
            Vec3::new(3.2, -2.0, 0.8),
        ),
    );
    scene.add_instance(
        ball,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.7),
            Quat::IDENTITY,
            Vec3::new(2.8, 2.0, 0.7),
        ),
    );
    BuiltinScene {
        name: "room",
        scene,
        view: View {
            eye: Vec3::new(4.2, -3.5, 2.2),
            target: Vec3::new(-0.5, 1.0, 0.8),
            up: Vec3::Z,
            fov_y_degrees: 65.0,
        },
        light: Vec3::new(0.5, -0.5, 2.8),
    }
}

/// `blob`: one closed, bumpy mesh of bunny size (full: 81,920 triangles, like the Stanford
/// bunny's 69,666; quick: 20,480), filling most of the view (the setting of the Embree
/// reference figures in the issue).
pub fn blob(size: SceneSize) -> BuiltinScene {
    let subdiv = match size {
        SceneSize::Quick => 5,
        SceneSize::Full => 6,
    };
    let mut mesh = icosphere("blob", Vec3::ZERO, 1.0, subdiv);
    for p in &mut mesh.positions {
        let bump = 0.12 * (5.0 * p.x).sin() * (4.0 * p.y + 1.0).cos()
            + 0.06 * (11.0 * p.z + 2.0 * p.x).sin()
            + 0.03 * (23.0 * p.y).sin() * (19.0 * p.z).cos();
        *p *= 1.0 + bump;
    }
    BuiltinScene {
        name: "blob",
        scene: Scene::single(mesh),
        view: View {
            eye: Vec3::new(0.6, -3.2, 0.9),
            target: Vec3::ZERO,
            up: Vec3::Z,
            fov_y_degrees: 45.0,
        },
        light: Vec3::new(2.0, -3.0, 4.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_are_valid_and_sized() {
        for s in all(SceneSize::Quick) {
            s.scene.validate().unwrap();
            assert!(s.scene.instanced_triangles() > 2000, "{}", s.name);
            assert!(by_name(s.name, SceneSize::Quick).is_some());
        }
    }

    #[test]
    fn primary_rays_span_the_view() {
        let v = View {
            eye: Vec3::ZERO,
            target: Vec3::Y,
            up: Vec3::Z,
            fov_y_degrees: 90.0,
        };
        let c = v.ray_at(0.5, 0.5, 1.0);
        assert!(c.dir.distance(Vec3::Y) < 1e-6);
        let tl = v.ray_at(0.0, 0.0, 1.0);
        assert!(
            tl.dir.distance(Vec3::new(-1.0, 1.0, 1.0)) < 1e-5,
            "{:?}",
            tl.dir
        );
    }
}
