//! The built-in scenes, generated deterministically in memory (no download): a Cornell-like
//! room for quick checks, and later stand-ins for the paper's four test scenes (section 7,
//! Table 4).

mod car;
mod city;
mod cornell;
mod glass1;
mod materials;
pub mod prism;
mod room2;
mod shapes;
mod spdemo;

use std::path::Path;

use super::{Camera, RenderScene, SceneError};
use coherent_accel::Instance;
use glam::Vec3;

use crate::light::{Light, Omni};
use crate::tonemap::Operator;

pub use car::car;
pub use city::city;
pub use cornell::cornell;
pub use glass1::glass1;
pub use prism::prism;
pub use room2::room2;
pub use spdemo::spdemo;

/// (name, one-line description) of every built-in scene.
pub const NAMES: [(&str, &str); 7] = [
    (
        "car",
        "stand-in for the paper's Car: tabulated-BDF paint, refractive glass, 4 lights (environment, parallel, spot, goniodiagram), depth 2",
    ),
    (
        "spdemo",
        "stand-in for the paper's SPDemo: mirror spheres and boxes over a reflective checker floor, 3 lights (omni, direct, linear), depth 2",
    ),
    (
        "glass1",
        "stand-in for the paper's Glass1: glass vases and spheres in a heavily textured room, 2 lights (circular, rectangular), depth 2",
    ),
    (
        "room2",
        "stand-in for the paper's Room2: a furnished interior, 4 lights (rectangular, goniodiagram, omni, spot), depth 1",
    ),
    (
        "cornell",
        "a Cornell-like room: coloured Phong walls, a mirror box and a glass sphere, one area light, depth 2",
    ),
    (
        "city",
        "many objects: 5,329 (a 72 x 72 grid of buildings, lamp posts, the ground), each its own mesh, 63,938 triangles, sun and 4 street lamps, depth 1",
    ),
    (
        "prism",
        "a spectrum from white light: a 60-degree F2 flint prism seen against a white slit on a black wall, one parallel light, depth 2 (render with a spectral colour form to see the colours)",
    ),
];

/// Built-in scenes made to show one effect rather than to be timed (`prism` shows its colours
/// only in a spectral colour form): the experiments that time every built-in scene leave them
/// out.
pub const SHOWCASES: [&str; 1] = ["prism"];

/// A row of the paper's Table 4: scene, triangles, lights, depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PaperScene {
    /// Our built-in stand-in's name.
    pub name: &'static str,
    /// The name in the paper.
    pub paper_name: &'static str,
    pub triangles: usize,
    pub lights: usize,
    pub depth: u32,
}

/// The paper's Table 4 (section 7), in its order; the built-in stand-ins match it within 10 %
/// in triangles and exactly in lights and depth.
pub const PAPER_TABLE4: [PaperScene; 4] = [
    PaperScene {
        name: "car",
        paper_name: "Car",
        triangles: 233_000,
        lights: 4,
        depth: 2,
    },
    PaperScene {
        name: "spdemo",
        paper_name: "SPDemo",
        triangles: 988,
        lights: 3,
        depth: 2,
    },
    PaperScene {
        name: "glass1",
        paper_name: "Glass1",
        triangles: 44_794,
        lights: 2,
        depth: 2,
    },
    PaperScene {
        name: "room2",
        paper_name: "Room2",
        triangles: 12_000,
        lights: 4,
        depth: 1,
    },
];

/// The built-in scene `name`.
pub fn by_name(name: &str) -> Option<RenderScene> {
    match name {
        "car" => Some(car()),
        "spdemo" => Some(spdemo()),
        "glass1" => Some(glass1()),
        "room2" => Some(room2()),
        "cornell" => Some(cornell()),
        "city" => Some(city()),
        "prism" => Some(prism()),
        _ => None,
    }
}

/// Collects the meshes, instances and materials of a generated scene.
#[derive(Default)]
struct Builder {
    meshes: Vec<super::ShadedMesh>,
    instances: Vec<Instance>,
    materials: Vec<crate::material::Material>,
}

impl Builder {
    /// Adds a material; returns its id.
    fn material(&mut self, m: crate::material::Material) -> u32 {
        self.materials.push(m);
        self.materials.len() as u32 - 1
    }

    /// Adds a mesh without placing it; returns its id.
    fn mesh(&mut self, m: super::ShadedMesh) -> usize {
        self.meshes.push(m);
        self.meshes.len() - 1
    }

    /// Places mesh `mesh` by `world_from_object`.
    fn place(&mut self, mesh: usize, world_from_object: glam::Affine3A) {
        self.instances.push(Instance::new(mesh, world_from_object));
    }

    /// Adds a mesh and places it once, as it is.
    fn add(&mut self, m: super::ShadedMesh) {
        let id = self.mesh(m);
        self.place(id, glam::Affine3A::IDENTITY);
    }

    /// The scene at the paper's 1024 x 768, tone mapped with the default operator.
    fn finish(
        self,
        name: &str,
        camera: Camera,
        lights: Vec<Light>,
        depth: u32,
        background: [f32; 3],
    ) -> RenderScene {
        let (width, height) = super::DEFAULT_RESOLUTION;
        RenderScene {
            name: name.to_string(),
            meshes: self.meshes,
            instances: self.instances,
            materials: self.materials,
            lights,
            camera,
            width,
            height,
            depth,
            spp: None,
            accuracy: None,
            tonemap: Operator::default(),
            background,
            motion: Vec::new(),
            light_spectra: Vec::new(),
        }
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
        lights: vec![default_light(path, b.min, b.max)?],
        tonemap: Operator::default(),
        camera: Camera::framing(b.min, b.max),
        width,
        height,
        depth: 1,
        spp: None,
        accuracy: None,
        background: [0.05; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    })
}

/// The default light of a bare mesh: an omni light above and behind the default camera
/// ([`Camera::framing`]), bright enough to give the near side of the box a radiance of
/// about one. An error naming `path` when the box is too large for a finite light (a mesh
/// with coordinates near `f32::MAX`).
pub fn default_light(path: &Path, min: Vec3, max: Vec3) -> Result<Light, SceneError> {
    let center = 0.5 * (min + max);
    let radius = (0.5 * (max - min).length()).max(1e-3);
    let position = center + Vec3::new(-0.5, 2.0, 1.5) * radius;
    let d2 = (position - center).length_squared();
    // A Lambertian surface of albedo 0.6 facing the light at distance d: L = 0.6 I / (pi d^2).
    let intensity = d2 * std::f32::consts::PI / 0.6 * 0.8;
    Omni::new(position, [intensity; 3])
        .map(Light::Omni)
        .map_err(|_| {
            SceneError::invalid(
                path.display().to_string(),
                "default light",
                format!(
                    "the mesh's bounding box ({:?} to {:?}) is too large for a light placed \
                     from it (its position or intensity would overflow); render the mesh from \
                     a scene file with its own lights and camera",
                    min.to_array(),
                    max.to_array()
                ),
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::LightKind;

    #[test]
    fn stand_ins_match_the_papers_table4() {
        let mut kinds = std::collections::BTreeSet::new();
        for row in PAPER_TABLE4 {
            let s = by_name(row.name).unwrap();
            s.validate().unwrap();
            let t = s.triangles();
            let off = (t as f64 / row.triangles as f64 - 1.0).abs();
            assert!(
                off <= 0.10,
                "{}: {t} triangles vs the paper's {}",
                row.name,
                row.triangles
            );
            assert_eq!(s.lights.len(), row.lights, "{}", row.name);
            assert_eq!(s.depth, row.depth, "{}", row.name);
            assert_eq!((s.width, s.height), (1024, 768));
            kinds.extend(s.lights.iter().map(|l| l.kind()));
        }
        assert_eq!(
            kinds.len(),
            LightKind::ALL.len(),
            "every light kind is used: {kinds:?}"
        );
        // The paper's materials: tabulated BDF and glass in car, textures and glass in glass1.
        let car = car();
        assert!(car.materials.iter().any(|m| m.bdf.is_some()));
        assert!(
            car.materials
                .iter()
                .any(|m| m.optics.transmittance[0] > 0.0)
        );
        let g = glass1();
        assert!(g.materials.iter().filter(|m| m.texture.is_some()).count() >= 4);
        assert!(g.materials.iter().any(|m| m.optics.transmittance[0] > 0.0));
        assert!(g.meshes.iter().all(|m| {
            m.uvs.is_some()
                || m.material
                    .iter()
                    .all(|&i| g.materials[i as usize].texture.is_none())
        }));
    }

    /// The camera sees the scene: a 32 x 24 grid of primary rays through the BSP hits
    /// geometry in most pixels (all of them inside a closed room; car shows the sky above
    /// the horizon) and several materials.
    #[test]
    fn cameras_frame_the_scenes() {
        use coherent_accel::Accel;
        use coherent_accel::scenes::View;
        for (name, min_hit) in [
            ("car", 0.5),
            ("spdemo", 0.9),
            ("glass1", 0.9),
            ("room2", 1.0),
            ("cornell", 0.6),
            ("city", 0.6),
            ("prism", 0.9),
        ] {
            let s = by_name(name).unwrap();
            let accel = coherent_bsp::Bsp::build(&s.accel_scene(), &Default::default()).unwrap();
            let c = s.camera;
            let view = View {
                eye: c.position,
                target: c.look_at,
                up: c.up,
                fov_y_degrees: c.vfov_deg,
            };
            let (mut hits, mut materials) = (0, std::collections::BTreeSet::new());
            for y in 0..24 {
                for x in 0..32 {
                    let r =
                        view.ray_at((x as f32 + 0.5) / 32.0, (y as f32 + 0.5) / 24.0, 4.0 / 3.0);
                    if let Some(h) = accel.intersect1(&r) {
                        hits += 1;
                        let mesh = s.instances[h.inst as usize].mesh;
                        materials.insert(s.meshes[mesh].material[h.prim as usize]);
                    }
                }
            }
            let frac = hits as f64 / (32.0 * 24.0);
            assert!(frac >= min_hit, "{name}: {frac} of the primary rays hit");
            assert!(materials.len() >= 3, "{name}: sees materials {materials:?}");
        }
    }

    #[test]
    fn builtins_are_deterministic() {
        let (a, b) = (spdemo(), spdemo());
        assert_eq!(a.meshes, b.meshes);
        assert_eq!(a.instances, b.instances);
    }
}
