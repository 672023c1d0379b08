//! Scenes for the renderer (paper section 7: the test scenes and what they are made of):
//! the in-memory [`RenderScene`] every loader produces, validated once when loaded, and
//! [`load`], which takes a scene file, a built-in scene's name or a bare mesh file.

pub mod builtin;
pub mod camera;
pub mod error;
pub mod file;
#[cfg(test)]
mod file_tests;
pub mod gltf;
pub mod merge;
pub mod motion;
pub mod shaded;

use std::path::Path;

use coherent_accel::Instance;

use crate::material::Material;

pub use camera::Camera;
pub use error::SceneError;
pub use merge::MergeReport;
pub use motion::{InstanceMotion, Keyframe};
pub use shaded::ShadedMesh;

/// The largest image side a scene may ask for (pixels).
pub const MAX_SIDE: u32 = 16_384;
/// The largest image a scene may ask for (pixels): 64 Mpixel, about 1 GiB of HDR film.
pub const MAX_PIXELS: u64 = 1 << 26;
/// The deepest reflection/refraction recursion a scene may ask for.
pub const MAX_DEPTH: u32 = 64;
/// The default image size (the paper renders at 1024 x 768).
pub const DEFAULT_RESOLUTION: (u32, u32) = (1024, 768);

/// The in-memory scene every loader produces and the renderer consumes; validated once when
/// loaded.
#[derive(Debug, Clone)]
pub struct RenderScene {
    pub name: String,
    pub meshes: Vec<ShadedMesh>,
    /// Mesh id + world_from_object.
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub lights: Vec<crate::light::Light>,
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    /// Reflection/refraction depth; 0 = camera rays only (paper Table 4).
    pub depth: u32,
    pub spp: Option<u32>,
    pub accuracy: Option<f32>,
    pub tonemap: crate::tonemap::Operator,
    /// Radiance of rays that miss (plus any environment light).
    pub background: [f32; 3],
    /// Keyframed instance transforms (top level rebuilt per frame).
    pub motion: Vec<InstanceMotion>,
    /// Per light (in `lights`' order; missing ones name none), the emission spectrum a scene
    /// file names for it, which spectral renders use (RGB ones use its colour, already in
    /// the light's intensity).
    pub light_spectra: Vec<Option<crate::spectrum::illuminant::Emission>>,
}

impl RenderScene {
    /// What the accelerators build from (positions and indices only).
    pub fn accel_scene(&self) -> coherent_accel::Scene {
        coherent_accel::Scene::new(
            self.meshes.iter().map(|m| m.mesh.clone()).collect(),
            self.instances.clone(),
        )
    }

    /// Instanced triangle count (every instance counts its mesh's triangles).
    pub fn triangles(&self) -> usize {
        self.instances
            .iter()
            .map(|i| {
                self.meshes
                    .get(i.mesh)
                    .map_or(0, |m| m.mesh.triangle_count())
            })
            .sum()
    }

    /// The instance transforms at `time` (the keyframed ones moved, the others as they are).
    pub fn instances_at(&self, time: f32) -> Vec<Instance> {
        let mut out = self.instances.clone();
        for m in &self.motion {
            if let Some(i) = out.get_mut(m.instance) {
                i.world_from_object = m.at(time);
            }
        }
        out
    }

    /// Checks everything the renderer relies on: resolution in 1..=[`MAX_SIDE`] a side and at
    /// most [`MAX_PIXELS`], depth at most [`MAX_DEPTH`], the camera, the meshes and instances
    /// (as the accelerators check them), the shading data, the materials, the motion, the
    /// sampling settings and the background. Every loader calls it.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |field: &str, problem: String| SceneError::invalid(&self.name, field, problem);
        let (w, h) = (self.width, self.height);
        if w == 0
            || h == 0
            || w > MAX_SIDE
            || h > MAX_SIDE
            || u64::from(w) * u64::from(h) > MAX_PIXELS
        {
            return Err(bad(
                "resolution",
                format!(
                    "{w}x{h} is not usable (each side 1..={MAX_SIDE}, at most {MAX_PIXELS} pixels)"
                ),
            ));
        }
        if self.depth > MAX_DEPTH {
            return Err(bad(
                "depth",
                format!("{} is over the limit {MAX_DEPTH}", self.depth),
            ));
        }
        if let Some((field, problem)) = self.camera.problem() {
            return Err(bad(&format!("camera.{field}"), problem));
        }
        if self.materials.is_empty() {
            return Err(bad("materials", "the scene has no material".to_string()));
        }
        for m in &self.materials {
            m.validate().map_err(|source| SceneError::Material {
                scene: self.name.clone(),
                source,
            })?;
        }
        if self.lights.is_empty() && self.background.iter().all(|&v| v == 0.0) {
            return Err(bad(
                "lights",
                "the scene has no light and a black background: the image would be black"
                    .to_string(),
            ));
        }
        if self.instances.is_empty() {
            return Err(bad("instances", "the scene has no object".to_string()));
        }
        self.accel_scene()
            .validate()
            .map_err(|source| SceneError::Geometry {
                scene: self.name.clone(),
                source,
            })?;
        for m in &self.meshes {
            if let Some(p) = m.problem(self.materials.len()) {
                return Err(bad("meshes", p));
            }
        }
        for m in &self.motion {
            if m.instance >= self.instances.len() {
                return Err(bad(
                    "motion",
                    format!(
                        "instance {} does not exist (the scene has {})",
                        m.instance,
                        self.instances.len()
                    ),
                ));
            }
            if let Some(p) = m.problem() {
                return Err(bad("motion", format!("instance {}: {p}", m.instance)));
            }
        }
        if let Some(spp) = self.spp
            && spp == 0
        {
            return Err(bad("spp", "must be at least 1".to_string()));
        }
        if let Some(a) = self.accuracy
            && !(a.is_finite() && a > 0.0 && a <= 1.0)
        {
            return Err(bad(
                "accuracy",
                format!("{a} is not in (0, 1] (a difference of displayed colour)"),
            ));
        }
        if self
            .background
            .iter()
            .any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(bad(
                "background",
                format!("{:?} is not finite and >= 0", self.background),
            ));
        }
        Ok(())
    }
}

/// Mesh file extensions [`load`] takes as a bare mesh (besides `.gltf` and `.glb`).
pub const MESH_EXTENSIONS: [&str; 3] = ["obj", "ply", "off"];

/// A scene file (.toml, see [`file`](mod@file)), a built-in scene's name, or a bare mesh file (framed by a default
/// camera and light).
pub fn load(spec: &str) -> Result<RenderScene, SceneError> {
    let path = Path::new(spec);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let scene = match ext.as_deref() {
        Some(e) if MESH_EXTENSIONS.contains(&e) => builtin::bare_mesh(path)?,
        Some("toml") => file::load_file(path)?,
        Some("gltf" | "glb") => gltf::load_gltf(path)?,
        _ => match builtin::by_name(spec) {
            Some(s) => s,
            None => {
                let file = scenes_dir().join(format!("{spec}.toml"));
                let why = if path.is_file() {
                    format!(
                        "a file, but not of a format read here (scene files: .toml, .gltf, \
                         .glb; meshes: .{})",
                        MESH_EXTENSIONS.join(", .")
                    )
                } else if file.is_file() {
                    format!(
                        "not a built-in scene; the scene file {} has that name",
                        file.display()
                    )
                } else {
                    "not a file, and not a built-in scene".to_string()
                };
                return Err(SceneError::Unknown {
                    spec: spec.to_string(),
                    why,
                    known: builtin_names()
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        },
    };
    scene.validate()?;
    Ok(scene)
}

/// The folder of the repository's scene files (`scenes/*.toml`): `$COHERENT_SCENES` if set,
/// else the `scenes/` folder of the source tree this crate was built from (`coherent scenes`
/// lists it; `table3` and `table5` render it).
pub fn scenes_dir() -> std::path::PathBuf {
    match std::env::var_os("COHERENT_SCENES") {
        Some(d) => std::path::PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"),
    }
}

/// (name, one-line description) of every built-in scene, for `coherent scenes`.
pub fn builtin_names() -> Vec<(&'static str, &'static str)> {
    builtin::NAMES.to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_loads_and_validates() {
        for (name, _) in builtin_names() {
            let s = load(name).unwrap();
            assert_eq!(s.name, name);
            assert!(s.triangles() > 0);
            assert_eq!(s.accel_scene().instanced_triangles(), s.triangles());
        }
    }

    #[test]
    fn unknown_scene_lists_the_builtins() {
        let e = load("no-such-scene").unwrap_err().to_string();
        assert!(e.contains("cornell"), "{e}");
    }

    #[test]
    fn bad_settings_are_named() {
        let base = load("cornell").unwrap();
        let mut s = base.clone();
        s.width = 0;
        assert!(s.validate().unwrap_err().to_string().contains("resolution"));
        let mut s = base.clone();
        s.width = 100_000;
        assert!(s.validate().unwrap_err().to_string().contains("resolution"));
        let mut s = base.clone();
        s.camera.up = s.camera.look_at - s.camera.position;
        assert!(s.validate().unwrap_err().to_string().contains("camera.up"));
        let mut s = base.clone();
        s.meshes[0].mesh.positions[0].x = f32::NAN;
        let e = s.validate().unwrap_err().to_string();
        assert!(
            e.contains("not finite") && e.contains(&s.meshes[0].mesh.name),
            "{e}"
        );
        let mut s = base;
        s.meshes[0].mesh.indices[0][1] = 9999;
        let e = s.validate().unwrap_err().to_string();
        assert!(
            e.contains("9999") && e.contains(&s.meshes[0].mesh.name),
            "{e}"
        );
    }
}
