//! `city`: a procedural city of many objects (beyond the paper's scenes, which have tens to
//! hundreds): 72 x 72 blocks of one building each, every building and every street lamp its
//! own mesh and instance at the identity transform, as a city model exported object by
//! object arrives. 5,184 buildings and 144 lamp posts (5,329 objects with the ground, 63,938
//! triangles), lit by the sun (a parallel light) and four street lamps (omni lights) along the
//! boulevard the camera looks down. Depth 1: the glass towers reflect.
//!
//! Generated deterministically from a fixed seed (no download). It is the scene where the
//! two-level tree meets thousands of top-level boxes; [`RenderScene::merge_static`] turns it
//! into one object tree.

use coherent_accel::shapes::cuboid;
use glam::Vec3;

use super::Builder;
use super::materials::{matte, mirror};
use super::shapes::quad;
use crate::light::{Light, Omni, Parallel};
use crate::scene::{Camera, RenderScene, ShadedMesh};

/// Blocks per side.
const BLOCKS: usize = 72;
/// A block's side (metres), street included.
const BLOCK: f32 = 20.0;
/// The street's width between blocks.
const STREET: f32 = 6.0;

/// A small deterministic generator (SplitMix64): the scene must not depend on a crate's
/// random stream.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The scene.
pub fn city() -> RenderScene {
    let mut b = Builder::default();
    let asphalt = b.material(matte("asphalt", [0.18, 0.18, 0.19]));
    let walls = [
        b.material(matte("concrete", [0.62, 0.6, 0.56])),
        b.material(matte("sandstone", [0.72, 0.62, 0.46])),
        b.material(matte("brick", [0.55, 0.27, 0.2])),
        b.material(matte("white render", [0.82, 0.82, 0.8])),
    ];
    let mut glass = mirror("tower glass", 0.55);
    glass.phong.diffuse = [0.08, 0.1, 0.14];
    let glass = b.material(glass);
    let steel = b.material(matte("lamp post", [0.25, 0.26, 0.28]));

    let side = BLOCKS as f32 * BLOCK;
    let half = 0.5 * side;
    b.add(quad(
        "ground",
        Vec3::new(-half, 0.0, half),
        Vec3::new(side, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -side),
        (1, 1),
        1.0,
        asphalt,
    ));

    let mut rng = Rng(2005);
    for i in 0..BLOCKS {
        for j in 0..BLOCKS {
            let x0 = -half + i as f32 * BLOCK + 0.5 * STREET;
            let z0 = -half + j as f32 * BLOCK + 0.5 * STREET;
            let lot = BLOCK - STREET;
            // Towers cluster near the centre; the outskirts stay low.
            let (ci, cj) = (
                i as f32 - 0.5 * BLOCKS as f32,
                j as f32 - 0.5 * BLOCKS as f32,
            );
            let centre = (-(ci * ci + cj * cj) / 300.0).exp();
            let height = 6.0 + rng.next() * 18.0 + centre * rng.next() * 110.0;
            let inset = |r: &mut Rng| 0.5 + r.next() * 2.5;
            let lo = Vec3::new(x0 + inset(&mut rng), 0.0, z0 + inset(&mut rng));
            let hi = Vec3::new(
                x0 + lot - inset(&mut rng),
                height,
                z0 + lot - inset(&mut rng),
            );
            let tower = height > 60.0;
            let material = if tower {
                glass
            } else {
                walls[(rng.next() * walls.len() as f32) as usize % walls.len()]
            };
            b.add(ShadedMesh::flat(
                cuboid(&format!("building {i},{j}"), lo, hi),
                material,
            ));
        }
    }
    // Lamp posts along both sides of the boulevard the camera looks down (x = 0).
    for k in 0..BLOCKS {
        for x in [-0.5 * STREET + 0.4, 0.5 * STREET - 0.6] {
            let z = -half + (k as f32 + 0.5) * BLOCK;
            b.add(ShadedMesh::flat(
                cuboid(
                    &format!("lamp post {k} {x}"),
                    Vec3::new(x, 0.0, z),
                    Vec3::new(x + 0.2, 5.0, z + 0.2),
                ),
                steel,
            ));
        }
    }

    let mut lights = vec![Light::Parallel(
        Parallel::new(Vec3::new(-0.45, -0.8, -0.4), [2.4, 2.25, 2.0]).expect("valid"),
    )];
    for k in 0..4 {
        let z = 0.5 * BLOCK - (k as f32) * 2.0 * BLOCK;
        lights.push(Light::Omni(
            Omni::new(Vec3::new(0.0, 5.5, z), [120.0, 100.0, 70.0]).expect("valid"),
        ));
    }
    let camera = Camera {
        position: Vec3::new(-2.0, 40.0, half * 0.55),
        look_at: Vec3::new(4.0, 12.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 50.0,
    };
    b.finish("city", camera, lights, 1, [0.45, 0.55, 0.7])
}
