//! glTF 2.0 scenes through `gltf` (paper section 7 renders whole scenes; this reads them from
//! the standard interchange format): meshes (triangle primitives with normals and UVs),
//! metallic-roughness materials mapped onto ours (section 4), base-colour textures, node
//! transforms as instances (section 3), the first perspective camera, `KHR_lights_punctual`
//! lights (section 5), and `KHR_materials_transmission` / `KHR_materials_ior` as glass.
//! Buffers and images may be in the GLB binary chunk, in files beside the scene, or in
//! base64 `data:` URIs.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use base64::Engine;
use coherent_accel::{Instance, Mesh};
use glam::{Affine3A, Mat4, Vec2, Vec3};

use super::{Camera, RenderScene, SceneError, ShadedMesh};
use crate::light::photometry::WATTS_PER_LUMEN;
use crate::light::{Light, Omni, Parallel, Spot, SpotFalloff};
use crate::material::Material;
use crate::texture::{InverseToneMap, Wrap};
use crate::tonemap::Operator;

/// What a glTF file holds, before defaults (the camera and light of a bare mesh) are added.
/// Material ids index `materials`; instances index `meshes`.
pub struct Loaded {
    pub meshes: Vec<ShadedMesh>,
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub camera: Option<Camera>,
    pub skipped_primitives: usize,
}

/// Reads the meshes, instances, materials, lights and camera of a `.gltf` or `.glb` file.
pub fn read_file(path: &Path) -> Result<Loaded, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read(path, &bytes)
}

fn err(path: &Path, problem: impl Into<String>) -> SceneError {
    SceneError::invalid(path.display().to_string(), "gltf", problem)
}

/// Reads a `.gltf` or `.glb` file as a scene: its camera (or one framing it), its lights (or
/// the default light), depth 2, the default resolution.
pub fn load_gltf(path: &Path) -> Result<RenderScene, SceneError> {
    let l = read_file(path)?;
    let name = path
        .file_stem()
        .map_or_else(|| "gltf".to_string(), |s| s.to_string_lossy().into_owned());
    let scene_box = bounds(&l.meshes, &l.instances);
    let camera = l
        .camera
        .unwrap_or_else(|| Camera::framing(scene_box.min, scene_box.max));
    let lights = if l.lights.is_empty() {
        vec![super::builtin::default_light(
            path,
            scene_box.min,
            scene_box.max,
        )?]
    } else {
        l.lights
    };
    if l.skipped_primitives > 0 {
        eprintln!(
            "warning: {}: skipped {} primitive(s) that are not triangles",
            path.display(),
            l.skipped_primitives
        );
    }
    let (width, height) = super::DEFAULT_RESOLUTION;
    Ok(RenderScene {
        name,
        meshes: l.meshes,
        instances: l.instances,
        materials: l.materials,
        lights,
        camera,
        width,
        height,
        depth: 2,
        spp: None,
        accuracy: None,
        tonemap: Operator::default(),
        background: [0.0; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    })
}

/// The world box of the instances.
fn bounds(meshes: &[ShadedMesh], instances: &[Instance]) -> coherent_accel::Aabb {
    instances
        .iter()
        .filter_map(|i| {
            Some(
                meshes
                    .get(i.mesh)?
                    .mesh
                    .bounds()
                    .transformed(&i.world_from_object),
            )
        })
        .fold(coherent_accel::Aabb::EMPTY, coherent_accel::Aabb::union)
}

/// Bytes of a `data:` URI (base64) or of a file relative to `dir`.
fn uri_bytes(path: &Path, dir: &Path, uri: &str) -> Result<Vec<u8>, SceneError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or_else(|| err(path, "a data: URI that is not base64"))?;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| err(path, format!("a data: URI is not valid base64: {e}")));
    }
    let file: PathBuf = dir.join(uri.replace("%20", " "));
    std::fs::read(&file).map_err(|source| SceneError::Io { path: file, source })
}

/// [`read_file`] on the file's bytes, as if read from `path` (buffers and images outside the
/// file are read from its folder; errors name it).
pub fn read(path: &Path, bytes: &[u8]) -> Result<Loaded, SceneError> {
    check_glb_header(path, bytes)?;
    let unreadable = |e: gltf::Error| err(path, format!("not a readable glTF 2.0 file: {e}"));
    // Read unvalidated, checked here for what the gltf crate's own validation assumes, then
    // validated by it.
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(unreadable)?;
    let json = document.into_json();
    check_json(path, &json)?;
    let gltf = gltf::Gltf {
        document: gltf::Document::from_json(json).map_err(unreadable)?,
        blob,
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let doc = &gltf.document;
    let buffers = buffers(path, dir, &gltf)?;

    // Materials; the last is the default for primitives without one.
    let mut textures: HashMap<usize, Arc<crate::texture::Texture>> = HashMap::new();
    let mut materials = Vec::new();
    for m in doc.materials() {
        materials.push(material(path, dir, &buffers, &m, &mut textures)?);
    }
    let default_material = materials.len() as u32;
    materials.push(crate::mesh_file::default_material());

    // Meshes: one ShadedMesh per glTF mesh, its triangle primitives merged.
    let mut meshes = Vec::new();
    let mut skipped_primitives = 0;
    for mesh in doc.meshes() {
        meshes.push(shaded_mesh(
            path,
            &buffers,
            &mesh,
            default_material,
            &mut skipped_primitives,
        )?);
    }
    let (instances, lights, camera) = nodes(path, doc, &meshes)?;
    if instances.is_empty() {
        return Err(err(path, "the scene places no triangle mesh"));
    }
    Ok(Loaded {
        meshes,
        instances,
        materials,
        lights,
        camera,
        skipped_primitives,
    })
}

/// What the gltf crate takes for granted and does not check: its validation indexes the
/// accessors by a primitive's `POSITION` unchecked, and an image in a buffer view must name
/// its type (the crate unwraps it).
fn check_json(path: &Path, json: &gltf::json::Root) -> Result<(), SceneError> {
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(a) = prim.attributes.get(&position)
                && a.value() >= json.accessors.len()
            {
                return Err(err(
                    path,
                    format!(
                        "mesh {m} primitive {p}: POSITION is accessor {}, but the file has {}",
                        a.value(),
                        json.accessors.len()
                    ),
                ));
            }
        }
    }
    for (i, image) in json.images.iter().enumerate() {
        let problem = match (&image.buffer_view, &image.uri, &image.mime_type) {
            (Some(_), _, None) => "is in a buffer view but has no mimeType",
            (None, None, _) => "has neither a uri nor a bufferView",
            _ => continue,
        };
        return Err(err(path, format!("image {i} {problem}")));
    }
    Ok(())
}

/// A GLB file's header length, which the gltf crate subtracts the header's 12 bytes from
/// unchecked.
fn check_glb_header(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    if let Some(h) = bytes.get(..12)
        && h.starts_with(b"glTF")
    {
        let length = u32::from_le_bytes([h[8], h[9], h[10], h[11]]);
        if length < 12 {
            return Err(err(
                path,
                format!(
                    "the GLB header gives a length of {length} bytes, less than the header's 12"
                ),
            ));
        }
    }
    Ok(())
}

/// An accessor the mesh reads, checked as the gltf crate's reader does not: its type (the
/// reader asserts the element size only in debug builds), and that its elements, sparse
/// indices and values lie inside their buffer views and buffers (the reader computes those
/// bounds without overflow checks). Without a buffer view, its elements are zeros (and
/// sparse values), as many as it says: at most 2^24.
fn check_accessor(
    path: &Path,
    mesh: &str,
    what: &str,
    a: &gltf::Accessor<'_>,
    types: &[gltf::accessor::DataType],
    dims: gltf::accessor::Dimensions,
    buffers: &[Vec<u8>],
) -> Result<(), SceneError> {
    let bad = |problem: String| {
        err(
            path,
            format!("mesh '{mesh}': {what} accessor {}: {problem}", a.index()),
        )
    };
    if a.dimensions() != dims || !types.contains(&a.data_type()) {
        return Err(bad(format!(
            "{:?} of {:?}, not {dims:?} of {}",
            a.dimensions(),
            a.data_type(),
            types
                .iter()
                .map(|t| format!("{t:?}"))
                .collect::<Vec<_>>()
                .join(" or ")
        )));
    }
    if a.count() == 0 {
        return Err(bad("no elements (count 0)".to_string()));
    }
    let fits = |view: gltf::buffer::View<'_>, offset: usize, count: usize, size: usize| {
        let stride = view.stride().unwrap_or(size);
        let end = stride
            .checked_mul(count - 1)
            .and_then(|n| n.checked_add(size))
            .and_then(|n| n.checked_add(offset));
        let view_end = view.offset().checked_add(view.length());
        let buffer = buffers.get(view.buffer().index()).map_or(0, Vec::len);
        if stride < size {
            Err(bad(format!(
                "buffer view {} has a stride of {stride} bytes, less than an element's {size}",
                view.index()
            )))
        } else if end.is_none_or(|e| e > view.length()) || view_end.is_none_or(|e| e > buffer) {
            Err(bad(format!(
                "{count} elements of {size} bytes from byte {offset} of buffer view {} do not \
                 fit in it or in its buffer",
                view.index()
            )))
        } else {
            Ok(())
        }
    };
    match a.view() {
        Some(view) => fits(view, a.offset(), a.count(), a.size())?,
        None if a.count() > 1 << 24 => {
            return Err(bad(format!(
                "{} elements without a buffer view: at most 2^24",
                a.count()
            )));
        }
        None => {}
    }
    if let Some(sparse) = a.sparse() {
        if sparse.count() == 0 {
            return Err(bad("a sparse part of no elements".to_string()));
        }
        let (i, v) = (sparse.indices(), sparse.values());
        fits(i.view(), i.offset(), sparse.count(), i.index_type().size())?;
        fits(v.view(), v.offset(), sparse.count(), a.size())?;
    }
    Ok(())
}

/// The file's buffers: the GLB binary chunk, data URIs and files beside it.
fn buffers(path: &Path, dir: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut buffers = Vec::new();
    for b in gltf.document.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| err(path, "buffer refers to a missing GLB binary chunk"))?,
            gltf::buffer::Source::Uri(uri) => uri_bytes(path, dir, uri)?,
        };
        if data.len() < b.length() {
            return Err(err(
                path,
                format!(
                    "buffer {} holds {} bytes, {} declared",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// One glTF mesh, its triangle primitives merged (other primitives are counted in
/// `skipped_primitives`), with the file's normals and UVs where every primitive has them.
fn shaded_mesh(
    path: &Path,
    buffers: &[Vec<u8>],
    mesh: &gltf::Mesh<'_>,
    default_material: u32,
    skipped_primitives: &mut usize,
) -> Result<ShadedMesh, SceneError> {
    let name = mesh
        .name()
        .map_or_else(|| format!("mesh {}", mesh.index()), str::to_string);
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut indices = Vec::new();
    let mut material_ids = Vec::new();
    let (mut all_normals, mut all_uvs) = (true, true);
    for prim in mesh.primitives() {
        if prim.mode() != gltf::mesh::Mode::Triangles {
            *skipped_primitives += 1;
            continue;
        }
        // The gltf crate reads any accessor as the type asked for; the format requires
        // these types.
        {
            use gltf::Semantic;
            use gltf::accessor::{DataType as T, Dimensions as D};
            for (semantic, what, types, dims) in [
                (Semantic::Positions, "POSITION", &[T::F32][..], D::Vec3),
                (Semantic::Normals, "NORMAL", &[T::F32], D::Vec3),
                (
                    Semantic::TexCoords(0),
                    "TEXCOORD_0",
                    &[T::F32, T::U8, T::U16],
                    D::Vec2,
                ),
            ] {
                if let Some(a) = prim.get(&semantic) {
                    check_accessor(path, &name, what, &a, types, dims, buffers)?;
                }
            }
            if let Some(a) = prim.indices() {
                check_accessor(
                    path,
                    &name,
                    "indices",
                    &a,
                    &[T::U8, T::U16, T::U32],
                    D::Scalar,
                    buffers,
                )?;
            }
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let Some(p) = reader.read_positions() else {
            return Err(err(
                path,
                format!("mesh '{name}': a primitive without positions"),
            ));
        };
        let base = positions.len() as u32;
        positions.extend(p.map(Vec3::from));
        let count = positions.len() - base as usize;
        match reader.read_normals() {
            Some(n) => normals.extend(n.map(|v| Vec3::from(v).try_normalize().unwrap_or(Vec3::Z))),
            None => all_normals = false,
        }
        match reader.read_tex_coords(0) {
            Some(t) => uvs.extend(t.into_f32().map(Vec2::from)),
            None => all_uvs = false,
        }
        let idx: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..count as u32).collect(),
        };
        if !idx.len().is_multiple_of(3) {
            return Err(err(
                path,
                format!("mesh '{name}': {} indices, not a multiple of 3", idx.len()),
            ));
        }
        if let Some(&bad) = idx.iter().find(|&&i| i as usize >= count) {
            return Err(err(
                path,
                format!("mesh '{name}': index {bad} is out of range ({count} vertices)"),
            ));
        }
        let mat = prim
            .material()
            .index()
            .map_or(default_material, |i| i as u32);
        for t in idx.chunks_exact(3) {
            indices.push([base + t[0], base + t[1], base + t[2]]);
            material_ids.push(mat);
        }
    }
    let n = positions.len();
    let shaded = ShadedMesh {
        mesh: Mesh::new(name, positions, indices),
        normals: None,
        uvs: (all_uvs && uvs.len() == n).then_some(uvs),
        material: material_ids,
    };
    let shaded = if all_normals && normals.len() == n {
        ShadedMesh {
            normals: Some(normals),
            ..shaded
        }
    } else {
        shaded.with_smooth_normals()
    };
    Ok(shaded)
}

/// The nodes of the default scene (or the first), with their world transforms: the mesh
/// instances, the punctual lights and the first perspective camera.
#[allow(clippy::type_complexity)]
fn nodes(
    path: &Path,
    doc: &gltf::Document,
    meshes: &[ShadedMesh],
) -> Result<(Vec<Instance>, Vec<Light>, Option<Camera>), SceneError> {
    let mut instances = Vec::new();
    let mut lights = Vec::new();
    let mut camera = None;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err(path, "the file has no scene"))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    // glTF's nodes form disjoint trees: a node met twice is a cycle (which would never end)
    // or a node with two parents.
    let mut seen = vec![false; doc.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(err(
                path,
                format!(
                    "node {} is reached twice: the node hierarchy has a cycle or a node with \
                     two parents (glTF nodes must form trees)",
                    node.index()
                ),
            ));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let affine = Affine3A::from_mat4(world);
        if let Some(m) = node.mesh()
            && !meshes[m.index()].mesh.indices.is_empty()
        {
            instances.push(Instance::new(m.index(), affine));
        }
        let origin = affine.transform_point3(Vec3::ZERO);
        let forward = affine.transform_vector3(Vec3::NEG_Z);
        if camera.is_none()
            && let Some(c) = node.camera()
            && matches!(c.projection(), gltf::camera::Projection::Orthographic(_))
        {
            eprintln!(
                "warning: {}: camera {} is orthographic, which is not supported; it is skipped",
                path.display(),
                c.index()
            );
        }
        if camera.is_none()
            && let Some(c) = node.camera()
            && let gltf::camera::Projection::Perspective(p) = c.projection()
        {
            camera = Some(Camera {
                position: origin,
                look_at: origin + forward.normalize_or_zero(),
                up: affine.transform_vector3(Vec3::Y),
                vfov_deg: p.yfov().to_degrees(),
            });
        }
        if let Some(l) = node.light() {
            lights.push(light(path, &l, origin, forward)?);
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    Ok((instances, lights, camera))
}

/// A punctual light (`KHR_lights_punctual`) at `origin`, shining along `forward`.
fn light(
    path: &Path,
    l: &gltf::khr_lights_punctual::Light<'_>,
    origin: Vec3,
    forward: Vec3,
) -> Result<Light, SceneError> {
    let c = l.color();
    let w = l.intensity() * WATTS_PER_LUMEN;
    let rgb = [c[0] * w, c[1] * w, c[2] * w];
    let name = l.name().unwrap_or("light").to_string();
    match l.kind() {
        gltf::khr_lights_punctual::Kind::Point => Omni::new(origin, rgb).map(Light::Omni),
        gltf::khr_lights_punctual::Kind::Directional => {
            Parallel::new(forward, rgb).map(Light::Parallel)
        }
        gltf::khr_lights_punctual::Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => Spot::new(
            origin,
            forward,
            rgb,
            inner_cone_angle,
            outer_cone_angle,
            SpotFalloff::default(),
        )
        .map(Light::Spot),
    }
    .map_err(|e| err(path, format!("light '{name}': {e}")))
}

/// A metallic-roughness material as ours: diffuse = base colour x (1 - metallic) (times the
/// base-colour texture), a Phong lobe from the roughness (`n = 2 / r^4 - 2`, the Blinn-Phong
/// exponent of the same microfacet width) with specular 0.04 for dielectrics and the base
/// colour for metals, a mirror reflection of the base colour for metals scaled by
/// `(1 - roughness)`, and glass (Fresnel reflection and refraction of index `ior`) where
/// `KHR_materials_transmission` is above one half.
fn material(
    path: &Path,
    dir: &Path,
    buffers: &[Vec<u8>],
    m: &gltf::Material,
    textures: &mut HashMap<usize, Arc<crate::texture::Texture>>,
) -> Result<Material, SceneError> {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let base = [r, g, b];
    let metal = pbr.metallic_factor().clamp(0.0, 1.0);
    let rough = pbr.roughness_factor().clamp(0.02, 1.0);
    let name = m.name().map_or_else(
        || format!("material {}", m.index().unwrap_or(0)),
        str::to_string,
    );
    let exponent = (2.0 / rough.powi(4) - 2.0).clamp(0.0, 10_000.0);
    let specular = base.map(|c| 0.04 * (1.0 - metal) + c * metal);
    let mut out = Material::phong(&name, base.map(|c| c * (1.0 - metal)), specular, exponent);
    out.optics.reflectance = base.map(|c| c * metal * (1.0 - rough));
    let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
    if transmission > 0.5 {
        out.phong.diffuse = [0.0; 3];
        out.optics.reflectance = [1.0; 3];
        out.optics.transmittance = base.map(|c| c * transmission);
        out.optics.ior = m.ior().unwrap_or(1.5);
        out.optics.fresnel = true;
    }
    if let Some(info) = pbr.base_color_texture() {
        let image = info.texture().source();
        let idx = image.index();
        if let Some(t) = textures.get(&idx) {
            out.texture = Some(t.clone());
        } else {
            let (bytes, ext, label) = match image.source() {
                gltf::image::Source::View { view, mime_type } => {
                    let buf = &buffers[view.buffer().index()];
                    let end = view.offset().saturating_add(view.length());
                    if end > buf.len() {
                        return Err(err(path, format!("image {idx}: buffer view out of range")));
                    }
                    let ext = if mime_type.contains("png") {
                        "png"
                    } else {
                        "jpg"
                    };
                    (
                        buf[view.offset()..end].to_vec(),
                        ext.to_string(),
                        format!("{} image {idx}", path.display()),
                    )
                }
                gltf::image::Source::Uri { uri, .. } => {
                    let ext = Path::new(uri)
                        .extension()
                        .and_then(|e| e.to_str())
                        .map_or_else(|| "png".to_string(), str::to_ascii_lowercase);
                    let ext = if uri.starts_with("data:image/jpeg") {
                        "jpg".to_string()
                    } else {
                        ext
                    };
                    (
                        uri_bytes(path, dir, uri)?,
                        ext,
                        dir.join(uri).display().to_string(),
                    )
                }
            };
            let t = crate::texture::load::decode_display(
                label,
                &bytes,
                &ext,
                Wrap::Repeat,
                &InverseToneMap::default(),
            )
            .map_err(|e| err(path, format!("material '{name}': {e}")))?;
            let t = Arc::new(t);
            textures.insert(idx, t.clone());
            out.texture = Some(t);
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A glTF with one quad (two triangles, data-URI buffer), a glass material, a camera and a
    /// point light, placed by a translated node.
    pub(crate) fn quad_gltf() -> String {
        let mut buf = Vec::new();
        for p in [
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ] {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        for i in [0u16, 1, 2, 0, 2, 3] {
            buf.extend_from_slice(&i.to_le_bytes());
        }
        let data = base64::engine::general_purpose::STANDARD.encode(&buf);
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "point", "intensity": 683, "color": [1, 1, 1]}}]}}}},
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{data}"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ],
  "materials": [{{"name": "glass", "pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0}},
                  "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}, "KHR_materials_ior": {{"ior": 1.33}}}}}}],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "znear": 0.1}}}}],
  "nodes": [
    {{"mesh": 0, "translation": [0, 0, -2]}},
    {{"camera": 0, "translation": [0.5, 0.5, 3]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}, "translation": [0, 2, 0]}}
  ],
  "scenes": [{{"nodes": [0, 1, 2]}}],
  "scene": 0
}}"#,
            len = buf.len()
        )
    }

    #[test]
    fn a_gltf_scene_with_camera_light_and_glass() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("quad.gltf");
        std::fs::write(&p, quad_gltf()).unwrap();
        let s = super::super::load(p.to_str().unwrap()).unwrap();
        assert_eq!(s.triangles(), 2);
        assert_eq!(s.instances[0].world_from_object.translation.z, -2.0);
        assert_eq!(s.camera.position, Vec3::new(0.5, 0.5, 3.0));
        assert!((s.camera.vfov_deg - 0.7f32.to_degrees()).abs() < 1e-4);
        assert_eq!(s.lights.len(), 1);
        let m = &s.materials[s.meshes[0].material[0] as usize];
        assert!(m.optics.fresnel && m.optics.ior == 1.33 && m.optics.transmittance == [1.0; 3]);
        // The same quad as an OBJ gives the same triangles.
        let obj = d.path().join("quad.obj");
        std::fs::write(
            &obj,
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n",
        )
        .unwrap();
        let o = crate::mesh_file::load(&obj).unwrap();
        assert_eq!(o.positions, s.meshes[0].mesh.positions);
        assert_eq!(o.indices, s.meshes[0].mesh.indices);
    }

    #[test]
    fn broken_gltf_is_named() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("bad.gltf");
        std::fs::write(&p, quad_gltf().replace("\"count\": 4", "\"count\": 2")).unwrap();
        let e = super::super::load(p.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.gltf"), "{e}");
        std::fs::write(&p, "{ not json").unwrap();
        let e = super::super::load(p.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.gltf") && e.contains("glTF"), "{e}");
        let e = super::super::load(d.path().join("none.glb").to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("none.glb"), "{e}");
    }

    #[test]
    fn a_node_that_is_its_own_child_is_an_error_not_an_endless_walk() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("cycle.gltf");
        let text = quad_gltf().replace(
            r#"{"mesh": 0, "translation": [0, 0, -2]}"#,
            r#"{"mesh": 0, "translation": [0, 0, -2], "children": [0]}"#,
        );
        assert!(text.contains(r#""children": [0]"#));
        std::fs::write(&p, text).unwrap();
        let e = super::super::load(p.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cycle.gltf") && e.contains("node 0 is reached twice"),
            "{e}"
        );
    }

    /// Files the gltf crate would panic on (in its validation or its accessor reader) are
    /// errors naming the problem.
    #[test]
    fn accessors_out_of_range_or_of_the_wrong_type_are_errors() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("bad.gltf");
        for (from, to, want) in [
            (
                r#""POSITION": 0}"#,
                r#""POSITION": 7}"#,
                "POSITION is accessor 7, but the file has 2",
            ),
            (
                r#""count": 4, "type": "VEC3""#,
                r#""count": 4000000000, "type": "VEC3""#,
                "4000000000 elements of 12 bytes",
            ),
            (
                r#""componentType": 5123"#,
                r#""componentType": 5126"#,
                "indices accessor 1: Scalar of F32",
            ),
        ] {
            let text = quad_gltf();
            assert!(text.contains(from), "{from}");
            std::fs::write(&p, text.replace(from, to)).unwrap();
            let e = super::super::load(p.to_str().unwrap())
                .unwrap_err()
                .to_string();
            assert!(e.contains("bad.gltf") && e.contains(want), "{e}");
        }
    }

    #[test]
    fn positions_that_are_not_three_floats_are_an_error() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("vec2.gltf");
        let from = r#""count": 4, "type": "VEC3""#;
        let text = quad_gltf();
        assert!(text.contains(from));
        std::fs::write(&p, text.replace(from, r#""count": 4, "type": "VEC2""#)).unwrap();
        let e = super::super::load(p.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("vec2.gltf") && e.contains("Vec2 of F32, not Vec3 of F32"),
            "{e}"
        );
    }
}
