//! The built-in scenes, generated deterministically in memory (no download): a Cornell-like
//! room for quick checks, and later stand-ins for the paper's four test scenes (section 7,
//! Table 4).

mod cornell;
mod materials;

use std::path::Path;

use super::{Camera, RenderScene, SceneError};
use coherent_accel::Instance;
use glam::Vec3;

use crate::light::{Light, Omni};
use crate::tonemap::Operator;

pub use cornell::cornell;

/// (name, one-line description) of every built-in scene.
pub const NAMES: [(&str, &str); 1] = [(
    "cornell",
    "a Cornell-like room: coloured Phong walls, a mirror box and a glass sphere, one light (36 + 1,280 triangles)",
)];

/// The built-in scene `name`.
pub fn by_name(name: &str) -> Option<RenderScene> {
    match name {
        "cornell" => Some(cornell()),
        _ => None,
    }
}

/// A bare mesh file as a scene: its own materials (a grey Phong default when it names none),
/// framed by [`Camera::framing`], depth 1.
pub fn bare_mesh(path: &Path) -> Result<RenderScene, SceneError> {
    let file = crate::mesh_file::load_shaded(path)?;
    let b = file.mesh.mesh.bounds();
    let name = file.mesh.mesh.name.clone();
    let (width, height) = super::DEFAULT_RESOLUTION;
    Ok(RenderScene {
        name,
        meshes: vec![file.mesh],
        instances: vec![Instance::identity(0)],
        materials: file.materials,
        lights: vec![default_light(b.min, b.max)],
        tonemap: Operator::default(),
        camera: Camera::framing(b.min, b.max),
        width,
        height,
        depth: 1,
        spp: None,
        accuracy: None,
        background: [0.05; 3],
        motion: Vec::new(),
    })
}

/// The default light of a bare mesh: an omni light above and behind the default camera
/// ([`Camera::framing`]), bright enough to give the near side of the box a radiance of
/// about one.
pub fn default_light(min: Vec3, max: Vec3) -> Light {
    let center = 0.5 * (min + max);
    let radius = (0.5 * (max - min).length()).max(1e-3);
    let position = center + Vec3::new(-0.5, 2.0, 1.5) * radius;
    let d2 = (position - center).length_squared();
    // A Lambertian surface of albedo 0.6 facing the light at distance d: L = 0.6 I / (pi d^2).
    let intensity = d2 * std::f32::consts::PI / 0.6 * 0.8;
    Light::Omni(Omni::new(position, [intensity; 3]).expect("finite position and intensity"))
}
