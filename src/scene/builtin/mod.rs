//! The built-in scenes, generated deterministically in memory (no download): a Cornell-like
//! room for quick checks, and later stand-ins for the paper's four test scenes (section 7,
//! Table 4).

mod cornell;
mod materials;

use std::path::Path;

use super::{Camera, RenderScene, SceneError};
use coherent_accel::Instance;

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
        lights: Vec::new(),
        name,
        meshes: vec![file.mesh],
        instances: vec![Instance::identity(0)],
        materials: file.materials,
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
