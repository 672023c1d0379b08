//! The TOML scene file (paper section 7: a scene is meshes placed by transforms, materials,
//! lights, a camera and the rendering settings): parsed through `serde` with unknown keys
//! rejected, paths relative to the scene file, and every error naming the file, the line
//! and the problem. A file under a `.cache` folder is an asset the project's set-up fetches:
//! missing or unreadable, it is a [`SceneError::Asset`] naming it and the command that
//! fetches it.
//!
//! ```toml
//! resolution = [1024, 768]        # default 1024 x 768
//! depth = 2                       # reflection/refraction depth, 0 = camera rays only
//! spp = 4                         # or: accuracy = 0.01 (adaptive)
//! tonemap = "tumblin"             # tumblin | reinhard | ward
//! background = [0.0, 0.0, 0.0]
//!
//! [camera]
//! position = [0, 1, 4]
//! look_at = [0, 1, 0]
//! up = [0, 1, 0]                  # default +y
//! vfov_deg = 40                   # default 45
//!
//! [materials.red]
//! type = "phong"                  # phong | mirror | glass | textured | bdf
//! diffuse = [0.7, 0.1, 0.1]
//!
//! [[objects]]
//! mesh = "bunny.obj"              # .obj/.ply/.off, or a .gltf/.glb placed whole (its nodes,
//!                                 # materials and lights); or: shape = "box" | "sphere" | "quad"
//! material = "red"                # default: the file's own materials
//! translate = [0, 0, 0]
//! rotate_deg = [0, 90, 0]         # about x, then y, then z
//! scale = [1, 1, 1]
//! keyframes = [{ time = 1.0, translate = [0, 1, 0] }]   # optional motion
//!
//! [materials.prism]
//! type = "glass"
//! glass = "F2"                    # or: ior = 1.5 | cauchy = [A, B, C] (um)
//!                                 # | sellmeier = { b = [..], c = [..] } (um^2)
//!
//! [[lights]]
//! type = "omni"                   # omni | spot | parallel | direct | linear | circular |
//!                                 # rectangular | goniodiagram (file = "lamp.ies" or ".ldt")
//!                                 # | environment (file = "sky.exr")
//! position = [0, 3, 0]
//! intensity = [10, 10, 10]
//! spectrum = "A"                  # optional: a CIE illuminant (D65, A, F1-F12, ...),
//!                                 # or: temperature = 2856 (a blackbody, kelvin)
//!
//! [assets]                        # optional: files under `.cache/` come from the set-up
//! fetch = "assimp hdr"            # the `scripts/native.py` steps that fetch them
//! on_demand = false               # true: fetched only when asked for by name
//! ```

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use coherent_accel::shapes::{cuboid, icosphere};
use coherent_accel::{Instance, Mesh};
use glam::{EulerRot, Quat, Vec3};
use serde::Deserialize;
use toml::Spanned;

use super::{Camera, InstanceMotion, Keyframe, RenderScene, SceneError, ShadedMesh};
use crate::light::{self, Light, SpotFalloff};
use crate::material::Material;
use crate::spectrum::blackbody::Blackbody;
use crate::spectrum::dispersion::{self, Dispersion};
use crate::spectrum::illuminant::{Emission, Illuminant};
use crate::texture::{InverseToneMap, Wrap};
use crate::tonemap::Operator;

type V3 = [f32; 3];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneSpec {
    name: Option<String>,
    resolution: Option<Spanned<[u32; 2]>>,
    depth: Option<u32>,
    spp: Option<u32>,
    accuracy: Option<f32>,
    tonemap: Option<Spanned<String>>,
    #[serde(default)]
    background: V3,
    camera: Spanned<CameraSpec>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialSpec>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectSpec>>,
    #[serde(default)]
    lights: Vec<Spanned<LightSpec>>,
    assets: Option<AssetsSpec>,
}

/// Where a scene's fetched files (those under `.cache/`) come from.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AssetsSpec {
    /// The `scripts/native.py` steps that fetch them (space-separated).
    fetch: String,
    /// Fetched only when that step is asked for by name (a large download).
    #[serde(default)]
    on_demand: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSpec {
    position: V3,
    look_at: V3,
    #[serde(default = "y_up")]
    up: V3,
    #[serde(default = "default_vfov")]
    vfov_deg: f32,
}

fn y_up() -> V3 {
    [0.0, 1.0, 0.0]
}
fn default_vfov() -> f32 {
    45.0
}
fn ones() -> V3 {
    [1.0; 3]
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum MaterialSpec {
    Phong {
        diffuse: V3,
        #[serde(default)]
        specular: V3,
        #[serde(default)]
        exponent: f32,
        #[serde(default)]
        ambient: V3,
        #[serde(default)]
        reflectance: V3,
    },
    Mirror {
        #[serde(default = "ones")]
        reflectance: V3,
        #[serde(default)]
        diffuse: V3,
    },
    /// Glass of a constant index (`ior`, 1.5 by default) or of a dispersive one: a named glass
    /// (`glass = "BK7"`), Cauchy's coefficients or Sellmeier's (one of the four). An RGB
    /// render uses the dispersive index at the helium d line (587.56 nm).
    Glass {
        ior: Option<f32>,
        glass: Option<String>,
        /// A, B (um^2) and optionally C (um^4).
        cauchy: Option<Vec<f32>>,
        sellmeier: Option<SellmeierSpec>,
        #[serde(default = "ones")]
        tint: V3,
    },
    Textured {
        texture: String,
        #[serde(default = "ones")]
        diffuse: V3,
        #[serde(default)]
        specular: V3,
        #[serde(default)]
        exponent: f32,
        #[serde(default)]
        ambient: V3,
        #[serde(default)]
        clamp: bool,
    },
    Bdf {
        file: String,
        texture: Option<String>,
    },
}

/// Sellmeier's coefficients: `n^2 = 1 + sum b_i l^2 / (l^2 - c_i)`, `l` in um, `c_i` in um^2.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SellmeierSpec {
    b: V3,
    c: V3,
}

/// A glass's index of refraction from whichever of its four settings it gives.
fn glass_index(
    ior: Option<f32>,
    glass: &Option<String>,
    cauchy: &Option<Vec<f32>>,
    sellmeier: &Option<SellmeierSpec>,
) -> Result<Dispersion, String> {
    let given = [
        ior.is_some(),
        glass.is_some(),
        cauchy.is_some(),
        sellmeier.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() > 1 {
        return Err("give one of `ior`, `glass`, `cauchy` and `sellmeier`".to_string());
    }
    let d = if let Some(name) = glass {
        dispersion::preset(name).map_err(|e| format!("glass: {e}"))?
    } else if let Some(k) = cauchy {
        match *k.as_slice() {
            [a, b] => Dispersion::Cauchy { a, b, c: 0.0 },
            [a, b, c] => Dispersion::Cauchy { a, b, c },
            _ => return Err("cauchy: expected [A, B] or [A, B, C]".to_string()),
        }
    } else if let Some(s) = sellmeier {
        Dispersion::Sellmeier { b: s.b, c: s.c }
    } else {
        // The material's own check applies (finite and positive: a relative index, such as
        // an air bubble's in water, may be below 1).
        return Ok(Dispersion::Constant(ior.unwrap_or(1.5)));
    };
    d.validate().map_err(|e| e.to_string())?;
    Ok(d)
}

#[derive(Debug, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Shape {
    Box,
    Sphere,
    Quad,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectSpec {
    mesh: Option<Spanned<String>>,
    shape: Option<Shape>,
    material: Option<Spanned<String>>,
    #[serde(default)]
    translate: V3,
    #[serde(default)]
    rotate_deg: V3,
    #[serde(default = "ones")]
    scale: V3,
    #[serde(default)]
    keyframes: Vec<KeyframeSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyframeSpec {
    time: f32,
    translate: Option<V3>,
    rotate_deg: Option<V3>,
    scale: Option<V3>,
}

/// A light. Every kind but the environment map may name its emission spectrum: `spectrum`, a
/// CIE illuminant ("D65", "A", "F2", ...), or `temperature`, a blackbody's in kelvin (see
/// [`emission`]).
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightSpec {
    Omni {
        position: V3,
        intensity: V3,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Spot {
        position: V3,
        axis: V3,
        intensity: V3,
        inner_deg: f32,
        outer_deg: f32,
        #[serde(default)]
        exact: bool,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Parallel {
        direction: V3,
        irradiance: V3,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Direct {
        position: V3,
        axis: V3,
        intensity: V3,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Linear {
        a: V3,
        b: V3,
        intensity: V3,
        #[serde(default = "linear_points")]
        points: u32,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Circular {
        center: V3,
        normal: V3,
        radius: f32,
        radiance: V3,
        #[serde(default = "circular_grid")]
        grid: [u32; 2],
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Rectangular {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        radiance: V3,
        #[serde(default = "rectangular_grid")]
        grid: [u32; 2],
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Goniodiagram {
        file: String,
        position: V3,
        #[serde(default = "y_up")]
        up: V3,
        #[serde(default = "x_axis")]
        x: V3,
        #[serde(default = "ones")]
        colour: V3,
        #[serde(default)]
        uniform: bool,
        spectrum: Option<String>,
        temperature: Option<f32>,
    },
    Environment {
        file: String,
        #[serde(default = "unit")]
        scale: f32,
        #[serde(default = "y_up")]
        up: V3,
        #[serde(default = "minus_z")]
        forward: V3,
        #[serde(default = "environment_samples")]
        samples: u32,
    },
}

fn x_axis() -> V3 {
    [1.0, 0.0, 0.0]
}
fn unit() -> f32 {
    1.0
}
fn minus_z() -> V3 {
    [0.0, 0.0, -1.0]
}
fn environment_samples() -> u32 {
    light::environment::DEFAULT_SAMPLES
}

fn linear_points() -> u32 {
    light::linear::DEFAULT_POINTS
}
fn circular_grid() -> [u32; 2] {
    let (a, b) = light::circular::DEFAULT_GRID;
    [a, b]
}
fn rectangular_grid() -> [u32; 2] {
    let (a, b) = light::rectangular::DEFAULT_GRID;
    [a, b]
}

/// The scene file being read: its path, text and folder, for messages and relative paths.
struct Source<'a> {
    path: &'a Path,
    text: &'a str,
    dir: PathBuf,
    /// The scene file's `[assets]` table: (step, on_demand).
    assets: Option<(String, bool)>,
}

impl Source<'_> {
    /// 1-based line and column of byte `offset`.
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        (line, col)
    }

    /// An error at `span` about `field`.
    fn at(&self, span: Range<usize>, field: &str, problem: impl std::fmt::Display) -> SceneError {
        let (line, column) = self.line_col(span.start);
        SceneError::Syntax {
            path: self.path.to_path_buf(),
            line,
            column,
            problem: format!("{field}: {problem}"),
        }
    }

    /// The line and column (1-based) of top-level key `key` (`key = ...` before the first
    /// table header), if the file has it.
    fn key_line(&self, key: &str) -> Option<(usize, usize)> {
        for (i, l) in self.text.lines().enumerate() {
            let t = l.trim_start();
            if t.starts_with('[') {
                return None;
            }
            if let Some(rest) = t.strip_prefix(key)
                && rest.trim_start().starts_with('=')
            {
                return Some((i + 1, l.len() - t.len() + 1));
            }
        }
        None
    }

    fn resolve(&self, p: &str) -> PathBuf {
        self.dir.join(p)
    }

    /// Whether `p` (as the scene file gives it) is fetched by the project's set-up: a path
    /// through a `.cache` folder.
    fn is_fetched(p: &Path) -> bool {
        p.components().any(|c| c.as_os_str() == ".cache")
    }

    /// An [`SceneError::Asset`] about `asset` at `span`.
    fn asset(
        &self,
        span: Range<usize>,
        field: &str,
        asset: PathBuf,
        problem: String,
        missing: bool,
    ) -> SceneError {
        let (step, on_demand) = self
            .assets
            .clone()
            .map_or((None, false), |(s, d)| (Some(s), d));
        SceneError::Asset {
            path: self.path.to_path_buf(),
            line: self.line_col(span.start).0,
            field: field.into(),
            asset,
            problem: problem.into(),
            step,
            on_demand,
            missing,
        }
    }

    /// The error for file `file` (as the scene file gives it) that failed to load with `e`:
    /// an asset error with the way to fetch it when the set-up fetches it (`missing`: a file
    /// it refers to, e.g. a glTF's buffer, is not there), else [`Source::at`].
    fn file_err(
        &self,
        span: Range<usize>,
        field: &str,
        file: &str,
        e: impl std::fmt::Display,
        missing: Option<PathBuf>,
    ) -> SceneError {
        let path = self.resolve(file);
        if !Self::is_fetched(&path) {
            return self.at(span, field, e);
        }
        match missing {
            Some(inner) => self.asset(span, field, inner, "is missing".to_string(), true),
            None => self.asset(span, field, path, format!("cannot be read: {e}"), false),
        }
    }

    /// Every fetched file the scene names must be there: the first that is not is an
    /// [`SceneError::Asset`] (before anything is loaded, so the message is about fetching).
    fn check_assets(&self, spec: &SceneSpec) -> Result<(), SceneError> {
        let mut files: Vec<(Range<usize>, String, &str)> = Vec::new();
        for (k, o) in spec.objects.iter().enumerate() {
            if let Some(m) = &o.get_ref().mesh {
                files.push((m.span(), format!("objects[{k}].mesh"), m.get_ref()));
            }
        }
        for (name, m) in &spec.materials {
            match m.get_ref() {
                MaterialSpec::Textured { texture, .. } => {
                    files.push((m.span(), format!("materials.{name}.texture"), texture));
                }
                MaterialSpec::Bdf { file, texture } => {
                    files.push((m.span(), format!("materials.{name}.file"), file));
                    if let Some(t) = texture {
                        files.push((m.span(), format!("materials.{name}.texture"), t));
                    }
                }
                _ => {}
            }
        }
        for (k, l) in spec.lights.iter().enumerate() {
            if let LightSpec::Goniodiagram { file, .. } | LightSpec::Environment { file, .. } =
                l.get_ref()
            {
                files.push((l.span(), format!("lights[{k}].file"), file));
            }
        }
        for (span, field, file) in files {
            let path = self.resolve(file);
            if Self::is_fetched(&path) && !path.exists() {
                return Err(self.asset(span, &field, path, "is missing".to_string(), true));
            }
        }
        Ok(())
    }
}

/// The file a glTF load found missing (a buffer or image beside it, or itself).
fn missing_file(e: &SceneError) -> Option<PathBuf> {
    match e {
        SceneError::Io { path, source } if source.kind() == std::io::ErrorKind::NotFound => {
            Some(path.clone())
        }
        _ => None,
    }
}

/// Reads and checks a scene file.
pub fn load_file(path: &Path) -> Result<RenderScene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_bytes(path, &bytes)
}

/// [`parse`] on the file's bytes: text that is not UTF-8 is an error naming the file.
pub fn parse_bytes(path: &Path, bytes: &[u8]) -> Result<RenderScene, SceneError> {
    let text = std::str::from_utf8(bytes).map_err(|e| SceneError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })?;
    parse(path, text)
}

/// Parses scene-file text as if read from `path` (relative paths resolve from its folder).
pub fn parse(path: &Path, text: &str) -> Result<RenderScene, SceneError> {
    let src = Source {
        path,
        text,
        dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        assets: None,
    };
    let spec: SceneSpec = toml::from_str(text).map_err(|e| {
        let (line, column) = e.span().map_or((0, 0), |s| src.line_col(s.start));
        SceneError::Syntax {
            path: path.to_path_buf(),
            line,
            column,
            problem: e.message().trim().to_string(),
        }
    })?;
    let src = Source {
        assets: spec.assets.as_ref().map(|a| (a.fetch.clone(), a.on_demand)),
        ..src
    };
    src.check_assets(&spec)?;
    build(&src, spec)
}

fn build(src: &Source, spec: SceneSpec) -> Result<RenderScene, SceneError> {
    let name = spec.name.clone().unwrap_or_else(|| {
        src.path
            .file_stem()
            .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned())
    });
    let (width, height) = resolution(src, &spec)?;
    let camera = camera(src, &spec)?;
    let tonemap = match &spec.tonemap {
        None => Operator::default(),
        Some(t) => t
            .get_ref()
            .parse()
            .map_err(|e| src.at(t.span(), "tonemap", e))?,
    };
    // Materials, in name order; mesh files append theirs.
    let mut objects = Objects::default();
    for (mname, m) in &spec.materials {
        let mat = material(src, mname, m)?;
        mat.validate()
            .map_err(|e| src.at(m.span(), &format!("materials.{mname}"), e))?;
        objects
            .ids
            .insert(mname.clone(), objects.materials.len() as u32);
        objects.materials.push(mat);
    }
    for (k, o) in spec.objects.iter().enumerate() {
        objects.place(src, &spec, k, o)?;
    }
    if objects.instances.is_empty() {
        return Err(SceneError::Syntax {
            path: src.path.to_path_buf(),
            line: 1,
            column: 1,
            problem: "objects: the scene has no object (add an [[objects]] table)".to_string(),
        });
    }
    let (lights, light_spectra) = lights(src, &spec, objects.gltf_lights)?;
    let scene = RenderScene {
        name,
        meshes: objects.meshes,
        instances: objects.instances,
        materials: objects.materials,
        lights,
        camera,
        width,
        height,
        depth: spec.depth.unwrap_or(1),
        spp: spec.spp,
        accuracy: spec.accuracy,
        tonemap,
        background: spec.background,
        motion: objects.motion,
        light_spectra,
    };
    scene.validate().map_err(|e| match e {
        // At the key's line when it is a top-level key of the file (`spp = 0`), else naming
        // the file without a line.
        SceneError::Invalid { field, problem, .. } => match src.key_line(&field) {
            Some((line, column)) => SceneError::Syntax {
                path: src.path.to_path_buf(),
                line,
                column,
                problem: format!("{field}: {problem}"),
            },
            None => SceneError::invalid(src.path.display().to_string(), field, problem),
        },
        e => e,
    })?;
    Ok(scene)
}

/// The image's size: the file's, checked, or the default.
fn resolution(src: &Source, spec: &SceneSpec) -> Result<(u32, u32), SceneError> {
    Ok(match &spec.resolution {
        None => super::DEFAULT_RESOLUTION,
        Some(r) => {
            let [w, h] = *r.get_ref();
            let pixels = u64::from(w) * u64::from(h);
            if w == 0
                || h == 0
                || w > super::MAX_SIDE
                || h > super::MAX_SIDE
                || pixels > super::MAX_PIXELS
            {
                return Err(src.at(
                    r.span(),
                    "resolution",
                    format!(
                        "{w}x{h} is not usable (each side 1..={}, at most {} pixels)",
                        super::MAX_SIDE,
                        super::MAX_PIXELS
                    ),
                ));
            }
            (w, h)
        }
    })
}

/// The camera, checked.
fn camera(src: &Source, spec: &SceneSpec) -> Result<Camera, SceneError> {
    let c = spec.camera.get_ref();
    let camera = Camera {
        position: Vec3::from(c.position),
        look_at: Vec3::from(c.look_at),
        up: Vec3::from(c.up),
        vfov_deg: c.vfov_deg,
    };
    if let Some((field, problem)) = camera.problem() {
        return Err(src.at(spec.camera.span(), &format!("camera.{field}"), problem));
    }
    Ok(camera)
}

/// The lights: the glTF files' punctual lights, then the file's; and each one's emission
/// spectrum, if it names one.
type Lights = (Vec<Light>, Vec<Option<Emission>>);
fn lights(src: &Source, spec: &SceneSpec, gltf_lights: Vec<Light>) -> Result<Lights, SceneError> {
    let mut spectra = vec![None; gltf_lights.len()];
    let mut lights = gltf_lights;
    for (k, l) in spec.lights.iter().enumerate() {
        // A setting out of range is the scene file's error, not its file's (even when the
        // light's file was fetched by the set-up).
        let spectrum =
            emission(l.get_ref()).map_err(|e| src.at(l.span(), &format!("lights[{k}]"), e))?;
        spectra.push(spectrum);
        let tint = spectrum.map_or([1.0; 3], |e| e.table().rgb());
        let light =
            make_light(src, l.get_ref(), k as u64, tint).map_err(|e| match l.get_ref() {
                LightSpec::Goniodiagram { file, .. } | LightSpec::Environment { file, .. }
                    if !matches!(e, light::LightError::BadParameter { .. }) =>
                {
                    src.file_err(l.span(), &format!("lights[{k}].file"), file, e, None)
                }
                _ => src.at(l.span(), &format!("lights[{k}]"), e),
            })?;
        lights.push(light);
    }
    Ok((lights, spectra))
}

/// A light's emission spectrum, if it names one. In an RGB render the light's colour becomes
/// the spectrum's linear sRGB at a luminance of 1 times its RGB intensity: a grey intensity
/// keeps its luminance and takes the spectrum's colour, a coloured one filters it.
fn emission(l: &LightSpec) -> Result<Option<Emission>, String> {
    let (spectrum, temperature) = match l {
        LightSpec::Omni {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Spot {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Parallel {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Direct {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Linear {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Circular {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Rectangular {
            spectrum,
            temperature,
            ..
        }
        | LightSpec::Goniodiagram {
            spectrum,
            temperature,
            ..
        } => (spectrum, temperature),
        LightSpec::Environment { .. } => return Ok(None),
    };
    let e = match (spectrum, temperature) {
        (None, None) => return Ok(None),
        (Some(_), Some(_)) => {
            return Err("give `spectrum` or `temperature`, not both".to_string());
        }
        (Some(name), None) => {
            Emission::Illuminant(Illuminant::parse(name).map_err(|e| format!("spectrum: {e}"))?)
        }
        (None, Some(k)) => {
            Emission::Blackbody(Blackbody::new(*k).map_err(|e| format!("temperature: {e}"))?)
        }
    };
    Ok(Some(e))
}

/// The scene's objects as they are placed: each mesh (file or shape, with its material)
/// built once and instanced.
#[derive(Default)]
struct Objects {
    materials: Vec<Material>,
    /// Material ids by the file's names.
    ids: HashMap<String, u32>,
    meshes: Vec<ShadedMesh>,
    /// Mesh ids by (`mesh:FILE` or `shape:SHAPE`, material).
    mesh_ids: HashMap<(String, Option<u32>), usize>,
    instances: Vec<Instance>,
    motion: Vec<InstanceMotion>,
    gltf_lights: Vec<Light>,
}

impl Objects {
    /// Places `objects[k]`.
    fn place(
        &mut self,
        src: &Source,
        spec: &SceneSpec,
        k: usize,
        o: &Spanned<ObjectSpec>,
    ) -> Result<(), SceneError> {
        let field = format!("objects[{k}]");
        let span = o.span();
        let o = o.get_ref();
        let mat = self.material_id(src, spec, &field, o)?;
        let base = Keyframe {
            time: 0.0,
            translation: Vec3::from(o.translate),
            rotation: rotation(o.rotate_deg),
            scale: Vec3::from(o.scale),
        };
        let world = base.transform();
        if let Some(m) = &o.mesh
            && is_gltf(m.get_ref())
        {
            return self.place_gltf(src, &field, span, o, m, mat, world);
        }
        let mesh_id = self.mesh_id(src, &field, span.clone(), o, mat)?;
        let inst = Instance::new(mesh_id, world);
        inst.object_from_world(self.instances.len(), self.meshes.len())
            .map_err(|_| {
                src.at(
                    span.clone(),
                    &field,
                    format!(
                        "the transform (scale {:?}, rotate_deg {:?}) is singular or not finite",
                        o.scale, o.rotate_deg
                    ),
                )
            })?;
        if !o.keyframes.is_empty() {
            let mut keys = vec![base];
            for kf in &o.keyframes {
                let prev = *keys.last().unwrap_or(&base);
                keys.push(Keyframe {
                    time: kf.time,
                    translation: kf.translate.map_or(prev.translation, Vec3::from),
                    rotation: kf.rotate_deg.map_or(prev.rotation, rotation),
                    scale: kf.scale.map_or(prev.scale, Vec3::from),
                });
            }
            let m = InstanceMotion {
                instance: self.instances.len(),
                keys,
            };
            if let Some(p) = m.problem() {
                return Err(src.at(span, &format!("{field}.keyframes"), p));
            }
            self.motion.push(m);
        }
        self.instances.push(inst);
        Ok(())
    }

    /// The id of the object's `material`, if it names one.
    fn material_id(
        &self,
        src: &Source,
        spec: &SceneSpec,
        field: &str,
        o: &ObjectSpec,
    ) -> Result<Option<u32>, SceneError> {
        Ok(match &o.material {
            None => None,
            Some(m) => Some(*self.ids.get(m.get_ref()).ok_or_else(|| {
                let known: Vec<_> = spec.materials.keys().map(String::as_str).collect();
                src.at(
                    m.span(),
                    &format!("{field}.material"),
                    format!(
                        "no material \"{}\" is defined (materials: {})",
                        m.get_ref(),
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                )
            })?),
        })
    }

    /// Places a glTF file's nodes, with its materials (unless the object names one) and its
    /// lights.
    #[allow(clippy::too_many_arguments)]
    fn place_gltf(
        &mut self,
        src: &Source,
        field: &str,
        span: Range<usize>,
        o: &ObjectSpec,
        m: &Spanned<String>,
        mat: Option<u32>,
        world: glam::Affine3A,
    ) -> Result<(), SceneError> {
        if !o.keyframes.is_empty() {
            return Err(src.at(
                span,
                &format!("{field}.keyframes"),
                "keyframes move one instance; a glTF object places many (animate its nodes \
                 by placing them as separate objects)",
            ));
        }
        let l = super::gltf::read_file(&src.resolve(m.get_ref())).map_err(|e| {
            let missing = missing_file(&e);
            src.file_err(m.span(), &format!("{field}.mesh"), m.get_ref(), e, missing)
        })?;
        let (mesh_base, mat_base) = (self.meshes.len(), self.materials.len() as u32);
        for mut sm in l.meshes {
            match mat {
                Some(id) => sm.material.iter_mut().for_each(|x| *x = id),
                None => sm.material.iter_mut().for_each(|x| *x += mat_base),
            }
            self.meshes.push(sm);
        }
        if mat.is_none() {
            self.materials.extend(l.materials);
        }
        for i in l.instances {
            let inst = Instance::new(mesh_base + i.mesh, world * i.world_from_object);
            inst.object_from_world(self.instances.len(), self.meshes.len())
                .map_err(|e| src.at(span.clone(), field, e))?;
            self.instances.push(inst);
        }
        self.gltf_lights.extend(l.lights);
        Ok(())
    }

    /// The object's mesh, built on its first use with its material.
    fn mesh_id(
        &mut self,
        src: &Source,
        field: &str,
        span: Range<usize>,
        o: &ObjectSpec,
        mat: Option<u32>,
    ) -> Result<usize, SceneError> {
        let key = match (&o.mesh, &o.shape) {
            (Some(m), None) => format!("mesh:{}", m.get_ref()),
            (None, Some(s)) => format!("shape:{s:?}"),
            _ => {
                return Err(src.at(span, field, "give exactly one of `mesh` and `shape`"));
            }
        };
        Ok(match self.mesh_ids.get(&(key.clone(), mat)) {
            Some(&id) => id,
            None => {
                let shaded = match (&o.mesh, &o.shape) {
                    (Some(m), _) => {
                        let path = src.resolve(m.get_ref());
                        let file = crate::mesh_file::load_shaded(&path).map_err(|e| {
                            src.file_err(m.span(), &format!("{field}.mesh"), m.get_ref(), e, None)
                        })?;
                        let mut shaded = file.mesh;
                        match mat {
                            Some(id) => shaded.material.iter_mut().for_each(|x| *x = id),
                            None => {
                                let base = self.materials.len() as u32;
                                shaded.material.iter_mut().for_each(|x| *x += base);
                                self.materials.extend(file.materials);
                            }
                        }
                        shaded
                    }
                    (None, Some(s)) => {
                        let id = match mat {
                            Some(id) => id,
                            None => {
                                self.materials.push(crate::mesh_file::default_material());
                                self.materials.len() as u32 - 1
                            }
                        };
                        shape(s, id)
                    }
                    _ => unreachable!("checked above"),
                };
                self.meshes.push(shaded);
                self.mesh_ids.insert((key, mat), self.meshes.len() - 1);
                self.meshes.len() - 1
            }
        })
    }
}

/// An object's rotation from its Euler angles in degrees.
fn rotation(r: V3) -> Quat {
    let r = Vec3::from(r) * (std::f32::consts::PI / 180.0);
    Quat::from_euler(EulerRot::ZYX, r.z, r.y, r.x)
}

/// Whether `file` names a glTF file (placed as a whole: its nodes, materials and lights).
fn is_gltf(file: &str) -> bool {
    let ext = Path::new(file)
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    matches!(ext.as_deref(), Some("gltf" | "glb"))
}

/// A unit shape: a box `[-0.5, 0.5]^3`, a sphere of radius 1 (1,280 triangles, smooth
/// normals), a quad `[-0.5, 0.5]^2` in the xz plane facing +y.
fn shape(s: &Shape, material: u32) -> ShadedMesh {
    match s {
        Shape::Box => {
            ShadedMesh::flat(cuboid("box", Vec3::splat(-0.5), Vec3::splat(0.5)), material)
        }
        Shape::Sphere => ShadedMesh::flat(icosphere("sphere", Vec3::ZERO, 1.0, 3), material)
            .with_smooth_normals(),
        Shape::Quad => {
            let p = |x, z| Vec3::new(x, 0.0, z);
            let mesh = Mesh::new(
                "quad",
                vec![p(-0.5, 0.5), p(0.5, 0.5), p(0.5, -0.5), p(-0.5, -0.5)],
                vec![[0, 1, 2], [0, 2, 3]],
            );
            ShadedMesh::flat(mesh, material).with_uvs(vec![
                glam::Vec2::new(0.0, 0.0),
                glam::Vec2::new(1.0, 0.0),
                glam::Vec2::new(1.0, 1.0),
                glam::Vec2::new(0.0, 1.0),
            ])
        }
    }
}

fn material(src: &Source, name: &str, m: &Spanned<MaterialSpec>) -> Result<Material, SceneError> {
    let field = format!("materials.{name}");
    let texture = |file: &str, wrap: Wrap| {
        let p = src.resolve(file);
        crate::texture::load(&p, wrap, &InverseToneMap::default())
            .map(Arc::new)
            .map_err(|e| src.file_err(m.span(), &format!("{field}.texture"), file, e, None))
    };
    Ok(match m.get_ref() {
        MaterialSpec::Phong {
            diffuse,
            specular,
            exponent,
            ambient,
            reflectance,
        } => {
            let mut out = Material::phong(name, *diffuse, *specular, *exponent);
            out.phong.ambient = *ambient;
            out.optics.reflectance = *reflectance;
            out
        }
        MaterialSpec::Mirror {
            reflectance,
            diffuse,
        } => {
            let mut out = Material::phong(name, *diffuse, [0.0; 3], 0.0);
            out.optics.reflectance = *reflectance;
            out
        }
        MaterialSpec::Glass {
            ior,
            glass,
            cauchy,
            sellmeier,
            tint,
        } => {
            let index = glass_index(*ior, glass, cauchy, sellmeier)
                .map_err(|e| src.at(m.span(), &field, e))?;
            let mut out = Material::phong(name, [0.0; 3], [0.0; 3], 0.0);
            out.optics.reflectance = [1.0; 3];
            out.optics.transmittance = *tint;
            out.optics.ior = index.index_d();
            out.optics.fresnel = true;
            out.optics.dispersion = Some(index);
            out
        }
        MaterialSpec::Textured {
            texture: file,
            diffuse,
            specular,
            exponent,
            ambient,
            clamp,
        } => {
            let mut out = Material::phong(name, *diffuse, *specular, *exponent);
            out.phong.ambient = *ambient;
            out.texture = Some(texture(
                file,
                if *clamp { Wrap::Clamp } else { Wrap::Repeat },
            )?);
            out
        }
        MaterialSpec::Bdf { file, texture: tex } => {
            let p = src.resolve(file);
            let bdf = crate::bdf::format::read(&p)
                .map_err(|e| src.file_err(m.span(), &format!("{field}.file"), file, e, None))?;
            let mut out = Material::phong(name, [0.0; 3], [0.0; 3], 0.0);
            out.bdf = Some(Arc::new(bdf));
            if let Some(t) = tex {
                out.texture = Some(texture(t, Wrap::Repeat)?);
            }
            out
        }
    })
}

fn make_light(
    src: &Source,
    l: &LightSpec,
    seed: u64,
    tint: V3,
) -> Result<Light, light::LightError> {
    let v = Vec3::from;
    let c = |x: V3| [x[0] * tint[0], x[1] * tint[1], x[2] * tint[2]];
    Ok(match *l {
        LightSpec::Goniodiagram {
            ref file,
            position,
            up,
            x,
            colour,
            uniform,
            ..
        } => Light::Goniodiagram(light::Goniodiagram::load(
            &src.resolve(file),
            v(position),
            v(up),
            v(x),
            c(colour),
            if uniform {
                light::GonioLookup::Uniform
            } else {
                light::GonioLookup::Search
            },
        )?),
        LightSpec::Environment {
            ref file,
            scale,
            up,
            forward,
            samples,
        } => Light::Environment(light::Environment::load(
            &src.resolve(file),
            scale,
            v(up),
            v(forward),
            samples,
        )?),
        LightSpec::Omni {
            position,
            intensity,
            ..
        } => Light::Omni(light::Omni::new(v(position), c(intensity))?),
        LightSpec::Spot {
            position,
            axis,
            intensity,
            inner_deg,
            outer_deg,
            exact,
            ..
        } => {
            // Checked in the file's degrees (the light checks its radians again).
            if !(outer_deg.is_finite() && outer_deg > 0.0 && outer_deg <= 180.0) {
                return Err(light::LightError::bad(
                    "spot",
                    "outer_deg",
                    outer_deg,
                    "not in (0, 180] degrees",
                ));
            }
            if !(inner_deg.is_finite() && inner_deg >= 0.0 && inner_deg < outer_deg) {
                return Err(light::LightError::bad(
                    "spot",
                    "inner_deg",
                    inner_deg,
                    "not in [0, outer_deg) degrees",
                ));
            }
            Light::Spot(light::Spot::new(
                v(position),
                v(axis),
                c(intensity),
                inner_deg.to_radians(),
                outer_deg.to_radians(),
                if exact {
                    SpotFalloff::Exact
                } else {
                    SpotFalloff::default()
                },
            )?)
        }
        LightSpec::Parallel {
            direction,
            irradiance,
            ..
        } => Light::Parallel(light::Parallel::new(v(direction), c(irradiance))?),
        LightSpec::Direct {
            position,
            axis,
            intensity,
            ..
        } => Light::Direct(light::Direct::new(v(position), v(axis), c(intensity))?),
        LightSpec::Linear {
            a,
            b,
            intensity,
            points,
            ..
        } => Light::Linear(light::Linear::new(
            v(a),
            v(b),
            c(intensity),
            points,
            seed,
            false,
        )?),
        LightSpec::Circular {
            center,
            normal,
            radius,
            radiance,
            grid,
            ..
        } => Light::Circular(light::Circular::new(
            v(center),
            v(normal),
            radius,
            c(radiance),
            (grid[0], grid[1]),
            seed,
            false,
        )?),
        LightSpec::Rectangular {
            corner,
            edge_u,
            edge_v,
            radiance,
            grid,
            ..
        } => Light::Rectangular(light::Rectangular::new(
            v(corner),
            v(edge_u),
            v(edge_v),
            c(radiance),
            (grid[0], grid[1]),
            seed,
            false,
        )?),
    })
}
