//! Illumination maps as OpenEXR files: the cells' irradiance as `f32` RGB, cell `k` at pixel
//! `(k % WIDTH, k / WIDTH)` of an image [`WIDTH`] pixels wide (pixels past the last cell are
//! zero), with header attributes that tie the file to its scene and its cells: the scene's
//! [`fingerprint`], the cells target, the cell count and the particle count. A file for
//! another scene or another cell resolution, or one that cannot be read, is an error naming
//! the path and the problem; a map loaded is the map saved, bit for bit.

use std::fmt::Write as _;
use std::io::Cursor;
use std::path::Path;

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    Encoding, Image, Layer, LayerAttributes, ReadChannels, ReadLayers, RgbaChannels,
    SpecificChannels, Vec2, WritableImage,
};

use super::IllumError;
use super::cells::{CellLayout, MAP_BUDGET};
use super::map::IllumMap;
use crate::scene::RenderScene;

/// The image width the cells are laid out in (pixels).
pub const WIDTH: usize = 1024;

const FINGERPRINT: &str = "coherent.illum.fingerprint";
const CELLS_TARGET: &str = "coherent.illum.cellsTarget";
const CELLS: &str = "coherent.illum.cells";
const PARTICLES: &str = "coherent.illum.particles";

/// 64-bit FNV-1a.
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u64(&mut self, x: u64) {
        self.bytes(&x.to_le_bytes());
    }
    fn f32s(&mut self, xs: &[f32]) {
        for x in xs {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

impl std::fmt::Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// A stable hash (FNV-1a) of what a map depends on: every mesh's positions, indices, normals,
/// texture coordinates and material ids, the instances and their transforms, the lights
/// (their `Debug` text) and the materials (name, Phong and optics attributes, texture name,
/// whether a BDF is tabulated).
pub fn fingerprint(scene: &RenderScene) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.u64(scene.meshes.len() as u64);
    for m in &scene.meshes {
        h.u64(m.mesh.positions.len() as u64);
        for p in &m.mesh.positions {
            h.f32s(&p.to_array());
        }
        h.u64(m.mesh.indices.len() as u64);
        for t in &m.mesh.indices {
            for &k in t {
                h.u64(u64::from(k));
            }
        }
        for n in m.normals.iter().flatten() {
            h.f32s(&n.to_array());
        }
        for uv in m.uvs.iter().flatten() {
            h.f32s(&uv.to_array());
        }
        for &k in &m.material {
            h.u64(u64::from(k));
        }
    }
    h.u64(scene.instances.len() as u64);
    for i in &scene.instances {
        h.u64(i.mesh as u64);
        h.f32s(&glam::Mat4::from(i.world_from_object).to_cols_array());
    }
    // Writing into the hash cannot fail.
    let _ = write!(h, "{:?}", scene.lights);
    for m in &scene.materials {
        let _ = write!(
            h,
            "{:?}{:?}{:?}{:?}{}",
            m.name,
            m.phong,
            m.optics,
            m.texture.as_ref().map(|t| t.name()),
            m.bdf.is_some()
        );
    }
    h.0
}

impl IllumMap {
    /// Writes the map to `path` as OpenEXR (see the module documentation).
    pub fn save(&self, path: &Path) -> Result<(), IllumError> {
        let irr = self.cell_irradiance();
        let height = irr.len().div_ceil(WIDTH).max(1);
        let mut attrs = LayerAttributes::named("illumination map");
        let mut put = |name: &str, value: String| {
            attrs.other.insert(
                Text::from(name),
                AttributeValue::Text(Text::from(value.as_str())),
            );
        };
        put(FINGERPRINT, format!("{:016x}", self.fingerprint()));
        put(CELLS_TARGET, self.cells_target().to_string());
        put(CELLS, self.cells().to_string());
        put(PARTICLES, self.particles().to_string());
        let layer = Layer::new(
            (WIDTH, height),
            attrs,
            Encoding::SMALL_LOSSLESS,
            SpecificChannels::rgb(|p: Vec2<usize>| {
                let e = irr.get(p.y() * WIDTH + p.x()).copied().unwrap_or([0.0; 3]);
                (e[0], e[1], e[2])
            }),
        );
        Image::from_layer(layer)
            .write()
            .to_file(path)
            .map_err(|e| IllumError::File {
                path: path.to_path_buf(),
                problem: format!("cannot write: {e}"),
            })
    }

    /// Reads a map saved by [`IllumMap::save`] for `scene` with `cells_target` cells. A file
    /// made for another scene (its fingerprint differs) or another cells target, with another
    /// cell count, or unreadable, truncated or holding negative or non-finite values, is an
    /// error naming `path` and the problem.
    pub fn load(
        path: &Path,
        scene: &RenderScene,
        cells_target: u64,
    ) -> Result<IllumMap, IllumError> {
        let file = |problem: String| IllumError::File {
            path: path.to_path_buf(),
            problem,
        };
        let bytes = std::fs::read(path).map_err(|e| file(format!("cannot read: {e}")))?;
        let unusable = |e: exr::error::Error| file(format!("not a usable OpenEXR map: {e}"));
        let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&bytes), false)
            .map_err(unusable)?;
        let [header] = meta.headers.as_slice() else {
            return Err(file(format!(
                "{} layers; a map has one",
                meta.headers.len()
            )));
        };
        let attr = |name: &str| -> Result<String, IllumError> {
            match header.own_attributes.other.get(&Text::from(name)) {
                Some(AttributeValue::Text(t)) => Ok(t.to_string()),
                Some(_) => Err(file(format!("header attribute {name} is not text"))),
                None => Err(file(format!(
                    "no header attribute {name}: not an illumination map"
                ))),
            }
        };
        let number = |name: &str| -> Result<u64, IllumError> {
            let s = attr(name)?;
            s.parse()
                .map_err(|_| file(format!("header attribute {name} is `{s}`, not a count")))
        };
        let want = fingerprint(scene);
        let got = attr(FINGERPRINT)?;
        if u64::from_str_radix(&got, 16).ok() != Some(want) {
            return Err(file(format!(
                "made for another scene: fingerprint {got}, scene {} has {want:016x}",
                scene.name
            )));
        }
        let target = number(CELLS_TARGET)?;
        if target != cells_target {
            return Err(file(format!(
                "made for a cells target of {target}, not {cells_target}"
            )));
        }
        let cells = number(CELLS)?;
        let particles = number(PARTICLES)?;
        let layout = CellLayout::new(scene, cells_target, MAP_BUDGET)?;
        if cells != layout.cells() as u64 {
            return Err(file(format!(
                "holds {cells} cells; scene {} with a cells target of {cells_target} has {}",
                scene.name,
                layout.cells()
            )));
        }
        let size = (header.layer_size.width(), header.layer_size.height());
        let want_size = (WIDTH, layout.cells().div_ceil(WIDTH).max(1));
        if size != want_size {
            return Err(file(format!(
                "{} x {} pixels; {cells} cells take {} x {}",
                size.0, size.1, want_size.0, want_size.1
            )));
        }
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |size: Vec2<usize>, _: &RgbaChannels| vec![[0.0f32; 3]; size.area()],
                |px: &mut Vec<[f32; 3]>, at: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                    px[at.y() * WIDTH + at.x()] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(Cursor::new(&bytes))
            .map_err(unusable)?;
        let mut irr = image.layer_data.channel_data.pixels;
        irr.truncate(layout.cells());
        if let Some((k, e)) = irr
            .iter()
            .enumerate()
            .find(|(_, e)| !e.iter().all(|c| c.is_finite() && *c >= 0.0))
        {
            return Err(file(format!(
                "cell {k} holds irradiance {e:?}: not finite and >= 0"
            )));
        }
        IllumMap::from_cells(scene, layout, irr, particles)
    }
}
