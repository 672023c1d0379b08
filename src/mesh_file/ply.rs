//! PLY meshes (ASCII and binary) through `ply-rs-bw`, the maintained fork of `ply-rs`:
//! `vertex` elements with `x y z`, optional `nx ny nz` and `u v` (or `s t`, `texture_u
//! texture_v`), and `face` elements with a `vertex_indices` (or `vertex_index`) list,
//! polygons triangulated as fans. Faces of fewer than three vertices are skipped and counted.

use std::path::Path;

use coherent_accel::Mesh;
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};

use super::{MeshFile, MeshFileError, default_material, fan, stem};
use crate::scene::ShadedMesh;

/// Reads a PLY file.
pub fn read_ply(path: &Path) -> Result<MeshFile, MeshFileError> {
    let bytes = std::fs::read(path).map_err(|source| MeshFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_ply(path, &bytes)
}

/// [`read_ply`] on the file's bytes, as if read from `path` (which errors name).
pub fn parse_ply(path: &Path, bytes: &[u8]) -> Result<MeshFile, MeshFileError> {
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut &bytes[..])
        .map_err(|e| MeshFileError::Parse {
            path: path.to_path_buf(),
            line: e.line().unwrap_or(0),
            problem: format!("not a readable PLY file: {e}"),
        })?;
    let invalid = |problem: String| MeshFileError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| invalid("no `vertex` element".to_string()))?;
    let scalar = |e: &DefaultElement, k: &str| e.get(k).and_then(Property::to_f32_lossy);
    let mut positions = Vec::with_capacity(vertices.len());
    let mut normals = Vec::with_capacity(vertices.len());
    let mut uvs = Vec::with_capacity(vertices.len());
    let mut bad_normals = 0;
    for (i, v) in vertices.iter().enumerate() {
        let p = ["x", "y", "z"].map(|k| scalar(v, k));
        let [Some(x), Some(y), Some(z)] = p else {
            return Err(invalid(format!("vertex {i} lacks a numeric x, y or z")));
        };
        positions.push(Vec3::new(x, y, z));
        if let [Some(x), Some(y), Some(z)] = ["nx", "ny", "nz"].map(|k| scalar(v, k)) {
            match Vec3::new(x, y, z).try_normalize() {
                Some(n) => normals.push(n),
                None => bad_normals += 1,
            }
        }
        let uv = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")]
            .iter()
            .find_map(|(a, b)| Some(Vec2::new(scalar(v, a)?, scalar(v, b)?)));
        if let Some(uv) = uv {
            uvs.push(uv);
        }
    }
    let mut indices = Vec::new();
    let mut skipped = 0;
    for (i, f) in ply.payload.get("face").into_iter().flatten().enumerate() {
        let list = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .ok_or_else(|| invalid(format!("face {i} has no vertex_indices list")))?;
        let poly: Vec<i64> = match list {
            Property::ListChar(v) => v.iter().map(|&x| x.into()).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| x.into()).collect(),
            Property::ListShort(v) => v.iter().map(|&x| x.into()).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| x.into()).collect(),
            Property::ListInt(v) => v.iter().map(|&x| x.into()).collect(),
            Property::ListUInt(v) => v.iter().map(|&x| x.into()).collect(),
            _ => {
                return Err(invalid(format!(
                    "face {i}: vertex_indices is not an integer list"
                )));
            }
        };
        if poly.len() < 3 {
            skipped += 1;
            continue;
        }
        if let Some(&bad) = poly
            .iter()
            .find(|&&k| k < 0 || k as usize >= positions.len())
        {
            return Err(invalid(format!(
                "face {i} refers to vertex {bad}, but the file has {} vertices",
                positions.len()
            )));
        }
        let poly: Vec<u32> = poly.iter().map(|&k| k as u32).collect();
        fan(&poly, &mut indices);
    }
    let n = positions.len();
    let mesh = ShadedMesh::flat(Mesh::new(stem(path), positions, indices), 0);
    let mesh = if normals.len() == n && bad_normals == 0 {
        ShadedMesh {
            normals: Some(normals),
            ..mesh
        }
    } else {
        mesh.with_smooth_normals()
    };
    let mesh = if uvs.len() == n {
        mesh.with_uvs(uvs)
    } else {
        mesh
    };
    Ok(MeshFile {
        mesh,
        materials: vec![default_material()],
        skipped,
        bad_normals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_ply_with_normals_uvs_and_a_quad() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("q.ply");
        std::fs::write(
            &p,
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
             property float u\nproperty float v\nelement face 2\n\
             property list uchar int vertex_indices\nend_header\n\
             0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n2 0 1\n",
        )
        .unwrap();
        let f = read_ply(&p).unwrap();
        assert_eq!(f.mesh.mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(f.skipped, 1);
        assert_eq!(f.mesh.uvs.as_ref().unwrap()[2], Vec2::ONE);
        assert_eq!(f.mesh.normals.as_ref().unwrap()[0], Vec3::Z);
    }

    #[test]
    fn broken_ply_is_named() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("b.ply");
        std::fs::write(
            &p,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
        )
        .unwrap();
        let e = read_ply(&p).unwrap_err().to_string();
        assert!(e.contains("b.ply") && e.contains("vertex 7"), "{e}");
        std::fs::write(&p, "ply\nformat ascii 1.0\nelement vertex 1\nend\n").unwrap();
        let e = read_ply(&p).unwrap_err().to_string();
        assert!(e.contains("b.ply"), "{e}");
    }
}
