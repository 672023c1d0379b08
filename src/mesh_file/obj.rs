//! Wavefront OBJ + MTL through `tobj`: positions, normals, texture coordinates, polygons
//! (triangulated as fans), one material per group from the MTL files (Phong `Kd`/`Ks`/`Ns`/
//! `Ka`, mirrors `illum 3`, glass `illum 4/6/7` or `d < 1` with `Ni`, `map_Kd` textures).
//! Points, lines and faces of fewer than three vertices are skipped and counted.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;
use std::sync::Arc;

use coherent_accel::Mesh;
use glam::{Vec2, Vec3};

use super::{MeshFile, MeshFileError, default_material, stem};
use crate::material::Material;
use crate::scene::ShadedMesh;
use crate::texture::{InverseToneMap, Wrap};

/// Reads an OBJ file and the MTL files it names (relative to its folder). A missing or
/// broken MTL file is a warning (the default material is used); a missing texture it names
/// is an error.
pub fn read_obj(path: &Path) -> Result<MeshFile, MeshFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_obj(path, &text)
}

/// [`read_obj`] on the file's text, as if read from `path` (the MTL files it names are read
/// from `path`'s folder).
pub fn parse_obj(path: &Path, text: &str) -> Result<MeshFile, MeshFileError> {
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    check_face_indices(text).map_err(|(line, problem)| MeshFileError::Parse {
        path: path.to_path_buf(),
        line,
        problem,
    })?;
    // Why an MTL file was refused, in more words than tobj's error has.
    let mtl_problem = std::cell::RefCell::new(None);
    let (models, mtl) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &opts, |p| {
        read_mtl(&dir.join(p)).map_err(|(e, problem)| {
            *mtl_problem.borrow_mut() = Some(problem);
            e
        })
    })
    .map_err(|e| MeshFileError::Invalid {
        path: path.to_path_buf(),
        problem: format!("not a readable OBJ file: {e}"),
    })?;
    let mtl = mtl.unwrap_or_else(|e| {
        eprintln!(
            "warning: {}: cannot read its MTL file ({}); using the default material",
            path.display(),
            mtl_problem.take().unwrap_or_else(|| e.to_string())
        );
        Vec::new()
    });
    let mut materials = mtl
        .iter()
        .map(|m| material(m, path, &dir))
        .collect::<Result<Vec<_>, _>>()?;
    let default = materials.len() as u32;
    materials.push(default_material());
    let mut file = assemble(stem(path), &models, default);
    file.skipped = count_skipped(text);
    file.materials = materials;
    Ok(file)
}

/// Face (`f`, `l`) vertex indices that refer before the first element of their kind or past
/// the last, for the kinds the file has. tobj turns such an index into a huge `usize` and
/// multiplies it, which overflows (a panic in builds with overflow checks, a wrong index
/// otherwise), so they are refused here first with the line.
fn check_face_indices(text: &str) -> Result<(), (usize, String)> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let kind = |word: Option<&str>| ["v", "vt", "vn"].iter().position(|k| word == Some(*k));
    let mut total = [0i64; 3];
    for l in text.lines() {
        if let Some(k) = kind(l.split_whitespace().next()) {
            total[k] += 1;
        }
    }
    let mut before = [0i64; 3];
    for (n, l) in text.lines().enumerate() {
        let mut words = l.split_whitespace();
        let first = words.next();
        if let Some(k) = kind(first) {
            before[k] += 1;
            continue;
        }
        if !matches!(first, Some("f" | "l")) {
            continue;
        }
        for word in words {
            for (k, index) in word.split('/').take(3).enumerate() {
                // Not a number: tobj reports it.
                let Ok(i) = index.parse::<i64>() else {
                    continue;
                };
                let (count, which) = if i < 0 {
                    (before[k], "before this line")
                } else {
                    (total[k], "in the file")
                };
                // A kind the file lacks is ignored by tobj, whatever the index.
                if total[k] > 0 && i.unsigned_abs() > count as u64 {
                    return Err((
                        n + 1,
                        format!(
                            "face index {i} is out of range: {count} {}(s) {which}",
                            KINDS[k]
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// An MTL file through tobj, or tobj's error and the problem: the file that cannot be
/// read, or a colour (`Ka`, `Kd`, `Ks`, `Ke`) of fewer than three numbers, which tobj
/// would panic on.
#[allow(clippy::type_complexity)]
fn read_mtl(
    path: &Path,
) -> Result<(Vec<tobj::Material>, HashMap<String, usize>), (tobj::LoadError, String)> {
    let bytes = std::fs::read(path).map_err(|e| {
        (
            tobj::LoadError::OpenFileFailed,
            format!("{}: {e}", path.display()),
        )
    })?;
    for (n, l) in String::from_utf8_lossy(&bytes).lines().enumerate() {
        let mut words = l.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next()
            && words.count() < 3
        {
            return Err((
                tobj::LoadError::MaterialParseError,
                format!("{}:{}: {key} needs three numbers", path.display(), n + 1),
            ));
        }
    }
    tobj::load_mtl_buf(&mut Cursor::new(bytes)).map_err(|e| {
        let problem = format!("{}: {e}", path.display());
        (e, problem)
    })
}

/// The models of an OBJ file as one mesh (material ids per triangle; models without a
/// material get `default`). Normals are kept when every model has them (normalised), and
/// computed smooth otherwise; UVs are kept when every model has them.
fn assemble(name: String, models: &[tobj::Model], default: u32) -> MeshFile {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut indices = Vec::new();
    let mut material = Vec::new();
    let (mut all_normals, mut all_uvs) = (true, true);
    let mut bad_normals = 0;
    for model in models {
        let m = &model.mesh;
        let base = positions.len() as u32;
        let n = m.positions.len() / 3;
        for v in 0..n {
            positions.push(Vec3::from_slice(&m.positions[3 * v..3 * v + 3]));
        }
        if m.normals.len() == 3 * n {
            for v in 0..n {
                let nv = Vec3::from_slice(&m.normals[3 * v..3 * v + 3]);
                match nv.try_normalize() {
                    Some(n) => normals.push(n),
                    None => bad_normals += 1,
                }
            }
        } else {
            all_normals = false;
        }
        if m.texcoords.len() == 2 * n {
            for v in 0..n {
                uvs.push(Vec2::from_slice(&m.texcoords[2 * v..2 * v + 2]));
            }
        } else {
            all_uvs = false;
        }
        let id = m.material_id.map_or(default, |i| i as u32);
        for t in m.indices.chunks_exact(3) {
            indices.push([base + t[0], base + t[1], base + t[2]]);
            material.push(id);
        }
    }
    let mesh = ShadedMesh {
        mesh: Mesh::new(name, positions, indices),
        normals: None,
        uvs: (all_uvs && !models.is_empty()).then_some(uvs),
        material,
    };
    let mesh = if all_normals && bad_normals == 0 && !models.is_empty() {
        ShadedMesh {
            normals: Some(normals),
            ..mesh
        }
    } else {
        mesh.with_smooth_normals()
    };
    MeshFile {
        mesh,
        materials: Vec::new(),
        skipped: 0,
        bad_normals,
    }
}

/// Elements with fewer than three vertices: `f` records of one or two vertices, and `p`
/// and `l` records.
fn count_skipped(text: &str) -> usize {
    text.lines()
        .filter(|l| {
            let mut w = l.split_whitespace();
            match w.next() {
                Some("f") => w.count() < 3,
                Some("l" | "p") => true,
                _ => false,
            }
        })
        .count()
}

/// An MTL material as ours: `Kd`, `Ks`, `Ns`, `Ka` for the Phong bundle; `illum 3` a mirror
/// reflecting `Ks`; `illum 4`, `6`, `7` or a dissolve `d < 1` glass of index `Ni` (1.5 when
/// absent) with Fresnel-weighted reflection and refraction; `map_Kd` the texture. A texture
/// error names the OBJ file (`obj`) and the texture.
fn material(m: &tobj::Material, obj: &Path, dir: &Path) -> Result<Material, MeshFileError> {
    let specular = m.specular.unwrap_or([0.0; 3]);
    let mut out = Material::phong(
        &m.name,
        m.diffuse.unwrap_or([0.6; 3]),
        specular,
        m.shininess.unwrap_or(0.0).max(0.0),
    );
    out.phong.ambient = m.ambient.unwrap_or([0.0; 3]);
    let illum = m.illumination_model.unwrap_or(2);
    let dissolve = m.dissolve.unwrap_or(1.0);
    if matches!(illum, 4 | 6 | 7) || dissolve < 1.0 {
        out.optics.reflectance = [1.0; 3];
        out.optics.transmittance = [1.0; 3];
        out.optics.ior = m.optical_density.filter(|&n| n > 0.0).unwrap_or(1.5);
        out.optics.fresnel = true;
        out.phong.diffuse = out.phong.diffuse.map(|d| d * dissolve.clamp(0.0, 1.0));
    } else if illum == 3 {
        out.optics.reflectance = specular;
    }
    if let Some(tex) = &m.diffuse_texture {
        let p = dir.join(tex);
        let t = crate::texture::load(&p, Wrap::Repeat, &InverseToneMap::default()).map_err(
            |source| MeshFileError::Texture {
                path: obj.to_path_buf(),
                source,
            },
        )?;
        out.texture = Some(Arc::new(t));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn polygons_negative_indices_and_two_vertex_faces() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "q.obj",
            "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2 3 4\nf -4 -3 -2\nf 1 2\nl 1 2\n",
        );
        let f = read_obj(&p).unwrap();
        assert_eq!(f.mesh.mesh.indices.len(), 3);
        assert_eq!(f.skipped, 2);
        assert_eq!(
            f.mesh.mesh.positions[f.mesh.mesh.indices[2][0] as usize],
            Vec3::ZERO
        );
        assert!(f.mesh.normals.is_some(), "smooth normals are computed");
    }

    #[test]
    fn zero_or_nan_normals_are_counted_and_replaced_by_the_faces_normals() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "n.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn nan 0 1\nvn 0 0 0\nf 1//1 2//2 3//3\n",
        );
        let f = read_obj(&p).unwrap();
        assert_eq!(f.bad_normals, 2);
        // Smooth normals of the one triangle: its face normal, +z, at every vertex.
        let n = f.mesh.normals.as_ref().unwrap();
        assert_eq!(n.len(), 3);
        assert!(n.iter().all(|v| (*v - Vec3::Z).length() < 1e-6), "{n:?}");
    }

    #[test]
    fn mtl_materials_become_ours() {
        let d = tempfile::tempdir().unwrap();
        write(
            d.path(),
            "m.mtl",
            "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 30\nnewmtl glass\nillum 7\nNi 1.45\n",
        );
        let p = write(
            d.path(),
            "m.obj",
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nvn 0 0 1\nvn 0 0 1\nusemtl red\nf 1//1 2//2 3//3\nusemtl glass\nf 1//1 3//3 2//2\n",
        );
        let f = read_obj(&p).unwrap();
        assert_eq!(f.materials.len(), 3);
        let red = &f.materials[f.mesh.material[0] as usize];
        assert_eq!(
            (red.name.as_str(), red.phong.diffuse),
            ("red", [0.8, 0.1, 0.1])
        );
        let glass = &f.materials[f.mesh.material[1] as usize];
        assert!(glass.optics.fresnel && glass.optics.ior == 1.45);
        for n in f.mesh.normals.unwrap() {
            assert!((n.length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn face_indices_out_of_range_are_errors_with_the_line() {
        let d = tempfile::tempdir().unwrap();
        let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\n";
        for (face, want) in [
            ("f 1/1/1 2/1/1 3/1/-2147483649", "face index -2147483649"),
            ("f 1 2 -4", "face index -4"),
            ("f 1 2 9223372036854775807", "3 vertex(s) in the file"),
        ] {
            let p = write(d.path(), "i.obj", &format!("{quad}{face}\n"));
            let e = read_obj(&p).unwrap_err().to_string();
            assert!(e.contains("i.obj:6") && e.contains(want), "{e}");
        }
        // An index of a kind the file lacks is ignored, as tobj does.
        let p = write(
            d.path(),
            "t.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-9 2/-9 3/-9\n",
        );
        assert_eq!(read_obj(&p).unwrap().mesh.mesh.indices.len(), 1);
    }

    #[test]
    fn a_colour_of_two_numbers_is_a_broken_mtl_file_not_a_panic() {
        let d = tempfile::tempdir().unwrap();
        write(d.path(), "c.mtl", "newmtl red\nKd 0.8 0.1\n");
        let p = write(
            d.path(),
            "c.obj",
            "mtllib c.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
        );
        let f = read_obj(&p).unwrap();
        assert_eq!(f.materials.len(), 1, "the default material only");
        let e = read_mtl(&d.path().join("c.mtl")).unwrap_err().1;
        assert!(
            e.contains("c.mtl:2") && e.contains("Kd needs three numbers"),
            "{e}"
        );
    }

    #[test]
    fn broken_files_are_named() {
        let d = tempfile::tempdir().unwrap();
        let p = write(d.path(), "bad.obj", "v 0 0 0\nf 1 2 3\n");
        let e = super::super::load(&p).unwrap_err().to_string();
        assert!(e.contains("bad.obj"), "{e}");
        let p = write(
            d.path(),
            "nan.obj",
            "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
        );
        let e = super::super::load(&p).unwrap_err().to_string();
        assert!(e.contains("nan.obj") && e.contains("not finite"), "{e}");
        write(d.path(), "t.mtl", "newmtl t\nmap_Kd missing.png\n");
        let p = write(
            d.path(),
            "t.obj",
            "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        );
        let e = super::super::load(&p).unwrap_err().to_string();
        assert!(e.contains("t.obj") && e.contains("missing.png"), "{e}");
    }
}
