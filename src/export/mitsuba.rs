//! Mitsuba 3's scene description (its XML format, version 3.0.0) for a scene, written with
//! the meshes as binary PLY files and the textures and the environment as EXR beside it.
//!
//! [`export`] writes the [`matched`](super::matched::matched) form of the scene, so the file
//! holds only what both renderers compute alike, and returns what was left out. The
//! correspondences:
//! - a mesh: one PLY per material it uses (Mitsuba binds one BSDF per shape), placed by its
//!   instance's transform; a mesh with several instances becomes a `shapegroup` and
//!   `instance` shapes;
//! - a material: `diffuse` with reflectance `kd` (a texture is written with `kd` multiplied
//!   in: Mitsuba's `bitmap` has no scale), inside `twosided`, as our opaque surfaces shade
//!   both sides;
//! - omni: `point` with the same intensity (W/sr); parallel: `directional` with the same
//!   irradiance; rectangular and circular: `rectangle` and `disk` shapes with an `area`
//!   emitter of the same radiance (one-sided, towards the same normal); the environment:
//!   `envmap` over the map re-laid out in Mitsuba's convention, scaled;
//! - the camera: `perspective` with the vertical field of view, the same look-at, and a box
//!   pixel filter, so that a pixel integrates over its own square as ours does;
//! - the integrator: `direct` with as many emitter samples per pixel sample as our renderer
//!   traces shadow rays per hit and no BSDF samples, the same work, and emitters hidden from
//!   camera rays, as ours are (not with an environment, which camera rays must see).
//!
//! The PLY writer is ours: the header is a few lines, and the `ply-rs` writer would build a
//! map per vertex.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Vec3};

use super::Skip;
use super::matched::matched;
use crate::light::Light;
use crate::scene::RenderScene;
use crate::texture::Wrap;

/// What [`export`] wrote and left out.
#[derive(Debug, Clone)]
pub struct Export {
    /// The scene file (`scene.xml` in the folder).
    pub xml: PathBuf,
    /// The scene as written: what our renderer should render to compare.
    pub scene: RenderScene,
    /// Features of the input left out, with the reasons.
    pub skipped: Vec<Skip>,
}

/// An export that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{dir}: cannot write the Mitsuba scene there: {source}")]
    Io {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "scene {scene}: nothing left that Mitsuba renders as we do (no light left):\n  {}",
        .skipped.iter().map(|s| s.to_string()).collect::<Vec<_>>().join("\n  ")
    )]
    NothingMatched { scene: String, skipped: Vec<Skip> },
    #[error("{0}")]
    Texture(String),
}

/// Writes the matched form of `scene` into `dir` (created if needed) as `scene.xml` and its
/// files. An error when nothing lights the matched scene, listing every reason.
pub fn export(scene: &RenderScene, dir: &Path) -> Result<Export, ExportError> {
    let (scene, skipped) = matched(scene);
    if scene.lights.is_empty() {
        return Err(ExportError::NothingMatched {
            scene: scene.name.clone(),
            skipped,
        });
    }
    let io = |source| ExportError::Io {
        dir: dir.to_path_buf(),
        source,
    };
    std::fs::create_dir_all(dir.join("meshes")).map_err(io)?;
    let mut xml = String::new();
    let _ = writeln!(xml, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        xml,
        "<!-- Written by coherent from scene {}: the part both renderers compute alike. -->",
        escape(&scene.name)
    );
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    integrator(&mut xml, &scene);
    sensor(&mut xml, &scene);
    let bsdfs = materials(&mut xml, &scene, dir)?;
    shapes(&mut xml, &scene, dir, &bsdfs)?;
    lights(&mut xml, &scene, dir)?;
    let _ = writeln!(xml, "</scene>");
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).map_err(io)?;
    Ok(Export {
        xml: path,
        scene,
        skipped,
    })
}

/// Shadow rays our renderer traces per hit: one per light sample.
fn light_samples(scene: &RenderScene) -> u32 {
    scene.lights.iter().map(|l| l.samples()).sum::<u32>().max(1)
}

fn integrator(xml: &mut String, scene: &RenderScene) {
    let env = scene
        .lights
        .iter()
        .any(|l| matches!(l, Light::Environment(_)));
    let _ = writeln!(xml, "  <integrator type=\"direct\">");
    let _ = writeln!(
        xml,
        "    <integer name=\"emitter_samples\" value=\"{}\"/>",
        light_samples(scene)
    );
    let _ = writeln!(xml, "    <integer name=\"bsdf_samples\" value=\"0\"/>");
    let _ = writeln!(
        xml,
        "    <boolean name=\"hide_emitters\" value=\"{}\"/>",
        !env
    );
    let _ = writeln!(xml, "  </integrator>");
}

fn sensor(xml: &mut String, scene: &RenderScene) {
    let c = &scene.camera;
    let extent = scene_extent(scene);
    let _ = writeln!(xml, "  <sensor type=\"perspective\">");
    let _ = writeln!(xml, "    <float name=\"fov\" value=\"{}\"/>", c.vfov_deg);
    let _ = writeln!(xml, "    <string name=\"fov_axis\" value=\"y\"/>");
    // Ours has no near plane; Mitsuba's default (0.01) would cut small scenes.
    let _ = writeln!(
        xml,
        "    <float name=\"near_clip\" value=\"{}\"/>",
        (extent * 1e-5).max(1e-6)
    );
    let _ = writeln!(
        xml,
        "    <float name=\"far_clip\" value=\"{}\"/>",
        (extent * 1e3).max(1e4)
    );
    let _ = writeln!(xml, "    <transform name=\"to_world\">");
    let _ = writeln!(
        xml,
        "      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>",
        v3(c.position),
        v3(c.look_at),
        v3(c.up)
    );
    let _ = writeln!(xml, "    </transform>");
    let _ = writeln!(xml, "    <sampler type=\"independent\">");
    let _ = writeln!(xml, "      <integer name=\"sample_count\" value=\"1\"/>");
    let _ = writeln!(xml, "    </sampler>");
    let _ = writeln!(xml, "    <film type=\"hdrfilm\">");
    let _ = writeln!(
        xml,
        "      <integer name=\"width\" value=\"{}\"/>",
        scene.width
    );
    let _ = writeln!(
        xml,
        "      <integer name=\"height\" value=\"{}\"/>",
        scene.height
    );
    let _ = writeln!(xml, "      <string name=\"pixel_format\" value=\"rgb\"/>");
    let _ = writeln!(xml, "      <rfilter type=\"box\"/>");
    let _ = writeln!(xml, "    </film>");
    let _ = writeln!(xml, "  </sensor>");
}

/// The world-space size of the scene (the diagonal of its instances' boxes).
fn scene_extent(scene: &RenderScene) -> f32 {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for inst in &scene.instances {
        for p in &scene.meshes[inst.mesh].mesh.positions {
            let w = inst.world_from_object.transform_point3(*p);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    let d = (hi - lo).length();
    if d.is_finite() { d } else { 1.0 }
}

/// Writes one `twosided diffuse` BSDF per material (ids `m0`, `m1`, ...) and their textures.
fn materials(
    xml: &mut String,
    scene: &RenderScene,
    dir: &Path,
) -> Result<Vec<String>, ExportError> {
    let mut ids = Vec::with_capacity(scene.materials.len());
    for (k, m) in scene.materials.iter().enumerate() {
        let id = format!("m{k}");
        let _ = writeln!(xml, "  <!-- material {} -->", escape(&m.name));
        let _ = writeln!(xml, "  <bsdf type=\"twosided\" id=\"{id}\">");
        let _ = writeln!(xml, "    <bsdf type=\"diffuse\">");
        match &m.texture {
            Some(tex) => {
                let file = format!("textures/{id}.exr");
                let path = dir.join(&file);
                std::fs::create_dir_all(dir.join("textures")).map_err(|source| {
                    ExportError::Io {
                        dir: dir.to_path_buf(),
                        source,
                    }
                })?;
                let l0 = tex.levels()[0];
                let kd = m.phong.diffuse;
                let px: Vec<[f32; 3]> = (0..l0.height)
                    .flat_map(|y| (0..l0.width).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let t = tex.texel(0, x, y);
                        [t[0] * kd[0], t[1] * kd[1], t[2] * kd[2]]
                    })
                    .collect();
                crate::film::write_exr_rgb(&path, l0.width as u32, l0.height as u32, &px)
                    .map_err(|e| ExportError::Texture(format!("{}: {e}", path.display())))?;
                let wrap = match tex.wrap() {
                    Wrap::Repeat => "repeat",
                    Wrap::Clamp => "clamp",
                };
                let _ = writeln!(xml, "      <texture type=\"bitmap\" name=\"reflectance\">");
                let _ = writeln!(xml, "        <string name=\"filename\" value=\"{file}\"/>");
                let _ = writeln!(xml, "        <boolean name=\"raw\" value=\"true\"/>");
                let _ = writeln!(xml, "        <string name=\"wrap_mode\" value=\"{wrap}\"/>");
                let _ = writeln!(xml, "      </texture>");
            }
            None => {
                let _ = writeln!(
                    xml,
                    "      <rgb name=\"reflectance\" value=\"{}\"/>",
                    rgb(m.phong.diffuse)
                );
            }
        }
        let _ = writeln!(xml, "    </bsdf>");
        let _ = writeln!(xml, "  </bsdf>");
        ids.push(id);
    }
    Ok(ids)
}

/// Writes every mesh's PLY files (one per material it uses) and places them: directly for a
/// mesh with one instance, through a `shapegroup` for a mesh with several.
fn shapes(
    xml: &mut String,
    scene: &RenderScene,
    dir: &Path,
    bsdfs: &[String],
) -> Result<(), ExportError> {
    let mut uses = vec![0usize; scene.meshes.len()];
    for inst in &scene.instances {
        uses[inst.mesh] += 1;
    }
    let mut files: Vec<Vec<(String, u32)>> = Vec::with_capacity(scene.meshes.len());
    for (i, m) in scene.meshes.iter().enumerate() {
        let mut parts = Vec::new();
        if uses[i] > 0 {
            let mut mats: Vec<u32> = m.material.clone();
            mats.sort_unstable();
            mats.dedup();
            for mat in mats {
                let file = format!("meshes/mesh{i}_m{mat}.ply");
                write_ply(&dir.join(&file), m, mat).map_err(|source| ExportError::Io {
                    dir: dir.to_path_buf(),
                    source,
                })?;
                parts.push((file, mat));
            }
        }
        files.push(parts);
    }
    for (i, parts) in files.iter().enumerate() {
        if uses[i] > 1 {
            let _ = writeln!(xml, "  <shape type=\"shapegroup\" id=\"g{i}\">");
            for (file, mat) in parts {
                ply_shape(xml, "    ", file, &bsdfs[*mat as usize], None);
            }
            let _ = writeln!(xml, "  </shape>");
        }
    }
    for inst in &scene.instances {
        if uses[inst.mesh] > 1 {
            let _ = writeln!(xml, "  <shape type=\"instance\">");
            let _ = writeln!(xml, "    <ref id=\"g{}\"/>", inst.mesh);
            transform(xml, "    ", &inst.world_from_object);
            let _ = writeln!(xml, "  </shape>");
        } else {
            for (file, mat) in &files[inst.mesh] {
                ply_shape(
                    xml,
                    "  ",
                    file,
                    &bsdfs[*mat as usize],
                    Some(&inst.world_from_object),
                );
            }
        }
    }
    Ok(())
}

fn ply_shape(xml: &mut String, pad: &str, file: &str, bsdf: &str, at: Option<&Affine3A>) {
    let _ = writeln!(xml, "{pad}<shape type=\"ply\">");
    let _ = writeln!(xml, "{pad}  <string name=\"filename\" value=\"{file}\"/>");
    let _ = writeln!(xml, "{pad}  <ref id=\"{bsdf}\"/>");
    if let Some(m) = at {
        transform(xml, &format!("{pad}  "), m);
    }
    let _ = writeln!(xml, "{pad}</shape>");
}

/// `to_world` as a row-major 4x4 matrix.
fn transform(xml: &mut String, pad: &str, m: &Affine3A) {
    let a = m.matrix3;
    let t = m.translation;
    let rows = [
        [a.x_axis.x, a.y_axis.x, a.z_axis.x, t.x],
        [a.x_axis.y, a.y_axis.y, a.z_axis.y, t.y],
        [a.x_axis.z, a.y_axis.z, a.z_axis.z, t.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let values: Vec<String> = rows.iter().flatten().map(|v| v.to_string()).collect();
    let _ = writeln!(xml, "{pad}<transform name=\"to_world\">");
    let _ = writeln!(xml, "{pad}  <matrix value=\"{}\"/>", values.join(" "));
    let _ = writeln!(xml, "{pad}</transform>");
}

/// The triangles of `mesh` with material `mat`, their vertices renumbered, as binary PLY
/// (positions, normals and UVs where the mesh has them).
fn write_ply(path: &Path, mesh: &crate::scene::ShadedMesh, mat: u32) -> std::io::Result<()> {
    let mut remap = vec![u32::MAX; mesh.mesh.positions.len()];
    let mut verts: Vec<u32> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    for (tri, &m) in mesh.mesh.indices.iter().zip(&mesh.material) {
        if m != mat {
            continue;
        }
        let mut f = [0u32; 3];
        for c in 0..3 {
            let v = tri[c] as usize;
            if remap[v] == u32::MAX {
                remap[v] = verts.len() as u32;
                verts.push(v as u32);
            }
            f[c] = remap[v];
        }
        faces.push(f);
    }
    let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
    let _ = writeln!(header, "element vertex {}", verts.len());
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    if mesh.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.uvs.is_some() {
        header.push_str("property float u\nproperty float v\n");
    }
    let _ = writeln!(header, "element face {}", faces.len());
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = Vec::with_capacity(header.len() + verts.len() * 32 + faces.len() * 13);
    out.extend_from_slice(header.as_bytes());
    for &v in &verts {
        let v = v as usize;
        for c in mesh.mesh.positions[v].to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if let Some(n) = &mesh.normals {
            for c in n[v].to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(uv) = &mesh.uvs {
            for c in uv[v].to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    for f in &faces {
        out.push(3);
        for i in f {
            out.extend_from_slice(&(*i as i32).to_le_bytes());
        }
    }
    std::fs::File::create(path)?.write_all(&out)
}

/// Writes the emitters (the area lights as shapes carrying an `area` emitter).
fn lights(xml: &mut String, scene: &RenderScene, dir: &Path) -> Result<(), ExportError> {
    for light in &scene.lights {
        match light {
            Light::Omni(o) => {
                let _ = writeln!(xml, "  <emitter type=\"point\">");
                let _ = writeln!(
                    xml,
                    "    <point name=\"position\" value=\"{}\"/>",
                    v3(o.position())
                );
                let _ = writeln!(
                    xml,
                    "    <rgb name=\"intensity\" value=\"{}\"/>",
                    rgb(o.intensity())
                );
                let _ = writeln!(xml, "  </emitter>");
            }
            Light::Parallel(p) => {
                let _ = writeln!(xml, "  <emitter type=\"directional\">");
                let _ = writeln!(
                    xml,
                    "    <vector name=\"direction\" value=\"{}\"/>",
                    v3(p.direction())
                );
                let _ = writeln!(
                    xml,
                    "    <rgb name=\"irradiance\" value=\"{}\"/>",
                    rgb(p.irradiance())
                );
                let _ = writeln!(xml, "  </emitter>");
            }
            Light::Rectangular(r) => {
                let (corner, eu, ev) = r.frame();
                // Mitsuba's rectangle is [-1, 1]^2 in its xy plane, emitting towards +z.
                let m = Affine3A::from_cols(
                    (0.5 * eu).into(),
                    (0.5 * ev).into(),
                    eu.cross(ev).normalize().into(),
                    (corner + 0.5 * (eu + ev)).into(),
                );
                area_light(xml, "rectangle", &m, r.radiance());
            }
            Light::Circular(c) => {
                let (center, normal, radius) = c.disk();
                let (t, b) = normal.any_orthonormal_pair();
                // Mitsuba's disk is the unit disk in its xy plane, emitting towards +z; the
                // tangents must make a right-handed frame with the normal.
                let (t, b) = if t.cross(b).dot(normal) > 0.0 {
                    (t, b)
                } else {
                    (b, t)
                };
                let m = Affine3A::from_cols(
                    (radius * t).into(),
                    (radius * b).into(),
                    normal.into(),
                    center.into(),
                );
                area_light(xml, "disk", &m, c.radiance());
            }
            Light::Environment(e) => {
                let file = "environment.exr";
                let (w, h) = e.size();
                let s = e.scale();
                let px: Vec<[f32; 3]> = e.texels().map(|t| t.map(|v| v * s)).collect();
                crate::film::write_exr_rgb(&dir.join(file), w as u32, h as u32, &px)
                    .map_err(|err| ExportError::Texture(format!("{file}: {err}")))?;
                // Mitsuba's map: u = atan2(x, -z) / 2 pi, v = acos(y) / pi in its local
                // frame. Ours: phi from axis x towards axis y, theta from up. So local x is
                // our y axis, local y our up, local -z our x axis.
                let [ax, ay, up] = e.axes();
                let m = Affine3A::from_cols(ay.into(), up.into(), (-ax).into(), Vec3::ZERO.into());
                let _ = writeln!(xml, "  <emitter type=\"envmap\">");
                let _ = writeln!(xml, "    <string name=\"filename\" value=\"{file}\"/>");
                transform(xml, "    ", &m);
                let _ = writeln!(xml, "  </emitter>");
            }
            other => unreachable!("matched() keeps no {} light", other.kind()),
        }
    }
    Ok(())
}

fn area_light(xml: &mut String, shape: &str, m: &Affine3A, radiance: [f32; 3]) {
    let _ = writeln!(xml, "  <shape type=\"{shape}\">");
    transform(xml, "    ", m);
    let _ = writeln!(
        xml,
        "    <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf>"
    );
    let _ = writeln!(xml, "    <emitter type=\"area\">");
    let _ = writeln!(
        xml,
        "      <rgb name=\"radiance\" value=\"{}\"/>",
        rgb(radiance)
    );
    let _ = writeln!(xml, "    </emitter>");
    let _ = writeln!(xml, "  </shape>");
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

fn rgb(c: [f32; 3]) -> String {
    format!("{}, {}, {}", c[0], c[1], c[2])
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace("--", "- -")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::{Omni, Spot};

    #[test]
    fn every_left_out_feature_is_reported_and_the_rest_written() {
        let mut scene = crate::scene::load("cornell").unwrap();
        scene.lights.push(Light::Spot(
            Spot::new(
                Vec3::new(0.0, 1.5, 0.0),
                Vec3::NEG_Y,
                [5.0; 3],
                0.3,
                0.5,
                Default::default(),
            )
            .unwrap(),
        ));
        scene.lights.push(Light::Omni(
            Omni::new(Vec3::new(0.0, 1.0, 1.0), [2.0; 3]).unwrap(),
        ));
        let dir = tempfile::tempdir().unwrap();
        let ex = export(&scene, dir.path()).unwrap();
        let text: Vec<String> = ex.skipped.iter().map(|s| s.to_string()).collect();
        let has = |needle: &str| text.iter().any(|t| t.contains(needle));
        assert!(has("(spot)") && has("linearly"), "{text:?}");
        assert!(has("Phong lobe"), "{text:?}");
        assert!(has("depth 2"), "{text:?}");
        assert!(has("fixed points"), "{text:?}");
        // What stays: the area light, the omni light, every material, every instance.
        assert_eq!(ex.scene.lights.len(), 2);
        let xml = std::fs::read_to_string(&ex.xml).unwrap();
        assert_eq!(xml.matches("<emitter type=\"area\">").count(), 1);
        assert_eq!(xml.matches("<emitter type=\"point\">").count(), 1);
        assert_eq!(
            xml.matches("<bsdf type=\"twosided\"").count(),
            scene.materials.len()
        );
        assert!(xml.contains("<integer name=\"emitter_samples\" value=\"22\"/>"));
        for line in xml.lines().filter(|l| l.contains("filename")) {
            let file = line
                .split("value=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap();
            assert!(dir.path().join(file).is_file(), "{file} not written");
        }
    }

    #[test]
    fn a_scene_with_nothing_matched_is_refused_with_every_reason() {
        let mut scene = crate::scene::load("cornell").unwrap();
        scene.lights = vec![Light::Spot(
            Spot::new(
                Vec3::new(0.0, 1.5, 0.0),
                Vec3::NEG_Y,
                [5.0; 3],
                0.3,
                0.5,
                Default::default(),
            )
            .unwrap(),
        )];
        let dir = tempfile::tempdir().unwrap();
        let e = export(&scene, dir.path()).unwrap_err().to_string();
        assert!(e.contains("no light left"), "{e}");
        assert!(e.contains("(spot)") && e.contains("Phong lobe"), "{e}");
        assert!(!dir.path().join("scene.xml").exists());
    }

    #[test]
    fn a_ply_holds_one_materials_triangles_renumbered() {
        let mesh = crate::scene::ShadedMesh {
            mesh: coherent_accel::Mesh::new(
                "m",
                vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
                vec![[0, 1, 2], [1, 3, 2]],
            ),
            normals: None,
            uvs: None,
            material: vec![0, 1],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.ply");
        write_ply(&path, &mesh, 1).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let end = b"end_header\n";
        let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..at]).unwrap();
        assert!(header.contains("element vertex 3") && header.contains("element face 1"));
        // 3 vertices of 3 floats, then one face: count 3 and indices 0 1 2.
        let face = &bytes[at + 36..];
        assert_eq!(face[0], 3);
        let idx: Vec<i32> = face[1..]
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(idx, [0, 1, 2]);
        let first = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(first, 1.0, "vertex 1 (x = 1) comes first");
    }
}
