//! Meshes from files (paper section 7 renders real models; section 4's materials need their
//! normals, texture coordinates and material ids): Wavefront OBJ + MTL (through `tobj`), PLY
//! (through `ply-rs-bw`) and OFF (by hand: no maintained crate reads it) readers, and the
//! real meshes `scripts/native.py` fetches from Debian packages into `.cache/meshes/` (pinned
//! and checksummed there).

mod obj;
mod off;
mod ply;

pub use obj::{parse_obj, read_obj};
pub use off::parse_off;
pub use ply::{parse_ply, read_ply};

use std::path::{Path, PathBuf};

use coherent_accel::Mesh;

use crate::material::Material;
use crate::scene::ShadedMesh;

/// What went wrong reading a mesh file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// `line` is 1-based; 0 when the parser did not say (then not printed).
    #[error("{path}{}: {problem}", at_line(*.line))]
    Parse {
        path: PathBuf,
        line: usize,
        problem: String,
    },
    #[error("{path}: {problem}")]
    Invalid { path: PathBuf, problem: String },
    #[error("{path}: unknown mesh format (expected .obj, .ply or .off)")]
    Format { path: PathBuf },
    /// `path` is the mesh file; the texture error names the texture.
    #[error("{path}: {source}")]
    Texture {
        path: PathBuf,
        #[source]
        source: crate::texture::TextureError,
    },
    #[error(
        "mesh {name} is not fetched ({path} missing); fix: run `python3 scripts/native.py meshes` \
         (fetches it from Debian's {package} package)"
    )]
    NotFetched {
        name: &'static str,
        path: PathBuf,
        package: &'static str,
    },
}

/// A mesh of the project's real-mesh set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RealMesh {
    /// Scene name in results.
    pub name: &'static str,
    /// Debian package it comes from.
    pub package: &'static str,
    /// File name under `.cache/meshes/<package>/`.
    pub file: &'static str,
}

/// The real meshes `scripts/native.py` fetches (keep the two lists in step).
pub const REAL_MESHES: [RealMesh; 4] = [
    RealMesh {
        name: "bunny",
        package: "glmark2-data",
        file: "bunny.obj",
    },
    RealMesh {
        name: "dragon",
        package: "libcgal-demo",
        file: "ChineseDragon-10kv.off",
    },
    RealMesh {
        name: "armadillo",
        package: "libcgal-demo",
        file: "armadillo.off",
    },
    RealMesh {
        name: "elephant",
        package: "libcgal-demo",
        file: "refined_elephant.off",
    },
];

/// The folder the meshes are fetched into: `$COHERENT_MESH_DIR`, else the workspace's
/// `.cache/meshes`.
pub fn mesh_dir() -> PathBuf {
    std::env::var_os("COHERENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join(".cache/meshes"))
}

impl RealMesh {
    /// Where the fetched file lies.
    pub fn path(&self) -> PathBuf {
        mesh_dir().join(self.package).join(self.file)
    }

    /// Reads the fetched mesh; [`MeshFileError::NotFetched`] names the fix when it is absent.
    pub fn load(&self) -> Result<Mesh, MeshFileError> {
        let path = self.path();
        if !path.exists() {
            return Err(MeshFileError::NotFetched {
                name: self.name,
                path,
                package: self.package,
            });
        }
        let mut mesh = load(&path)?;
        mesh.name = self.name.to_string();
        Ok(mesh)
    }

    /// The real mesh called `name`.
    pub fn named(name: &str) -> Option<RealMesh> {
        REAL_MESHES.into_iter().find(|m| m.name == name)
    }
}

/// `:line`, or nothing for line 0 (unknown): the line part of an error message (mesh files
/// and scene files alike).
pub(crate) fn at_line(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

/// A mesh file read with its shading data.
#[derive(Debug, Clone)]
pub struct MeshFile {
    /// Material ids index `materials`.
    pub mesh: ShadedMesh,
    /// The file's materials (OBJ: from its MTL files); at least one (a grey Phong default).
    pub materials: Vec<Material>,
    /// Elements with fewer than three vertices (points, lines, two-vertex faces), skipped.
    pub skipped: usize,
    /// Vertex normals in the file that are zero or not finite. When there are any, none of
    /// the file's normals are used: the mesh gets smooth normals computed from its faces.
    pub bad_normals: usize,
}

/// The default material of a mesh file that names none.
pub fn default_material() -> Material {
    Material::phong("default", [0.6; 3], [0.2; 3], 20.0)
}

/// Reads an OBJ (+MTL), PLY or OFF file (by extension) with its shading data, and checks
/// the mesh (indices in range, finite positions and normals; errors name the file). Skipped
/// elements are reported on stderr as a warning.
pub fn load_shaded(path: &Path) -> Result<MeshFile, MeshFileError> {
    let bytes = std::fs::read(path).map_err(|source| MeshFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_shaded(path, &bytes)
}

/// [`load_shaded`] on the file's bytes, as if read from `path` (its extension picks the
/// format, its folder holds an OBJ's MTL files, and errors name it).
pub fn parse_shaded(path: &Path, bytes: &[u8]) -> Result<MeshFile, MeshFileError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let file = match ext.as_deref() {
        Some("obj") => parse_obj(path, text(path, bytes)?)?,
        Some("ply") => parse_ply(path, bytes)?,
        Some("off") => {
            let (positions, indices) =
                parse_off(text(path, bytes)?).map_err(|(line, problem)| MeshFileError::Parse {
                    path: path.to_path_buf(),
                    line,
                    problem,
                })?;
            MeshFile {
                mesh: ShadedMesh::flat(Mesh::new(stem(path), positions, indices), 0),
                materials: vec![default_material()],
                skipped: 0,
                bad_normals: 0,
            }
        }
        _ => {
            return Err(MeshFileError::Format {
                path: path.to_path_buf(),
            });
        }
    };
    let invalid = |problem: String| MeshFileError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    file.mesh
        .mesh
        .validate(0)
        .map_err(|e| invalid(e.to_string()))?;
    if let Some(p) = file.mesh.problem(file.materials.len()) {
        return Err(invalid(p));
    }
    if file.skipped > 0 {
        eprintln!(
            "warning: {}: skipped {} element(s) with fewer than 3 vertices",
            path.display(),
            file.skipped
        );
    }
    if file.bad_normals > 0 {
        eprintln!(
            "warning: {}: {} vertex normal(s) are zero or not finite; the mesh's normals were \
             computed from its faces instead",
            path.display(),
            file.bad_normals
        );
    }
    Ok(file)
}

/// Reads the positions and triangles of an OBJ, PLY or OFF file (see [`load_shaded`]).
pub fn load(path: &Path) -> Result<Mesh, MeshFileError> {
    load_shaded(path).map(|f| f.mesh.mesh)
}

/// A text format's bytes as text; an error naming the file when they are not UTF-8.
fn text<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str, MeshFileError> {
    std::str::from_utf8(bytes).map_err(|e| MeshFileError::Invalid {
        path: path.to_path_buf(),
        problem: format!("not UTF-8 text: {e}"),
    })
}

/// The file name without its extension: the mesh's name.
fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
}

/// Triangulates a polygon of vertex indices as a fan.
fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

fn number<T: std::str::FromStr>(
    word: Option<&str>,
    what: &str,
    line: usize,
) -> Result<T, (usize, String)> {
    let w = word.ok_or_else(|| (line, format!("missing {what}")))?;
    w.parse()
        .map_err(|_| (line, format!("{what} {w:?} is not a number")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unfetched_mesh_names_the_fix() {
        let m = RealMesh {
            name: "nothing",
            package: "no-such-package",
            file: "x.off",
        };
        let e = m.load().unwrap_err().to_string();
        assert!(e.contains("scripts/native.py meshes"), "{e}");
    }
}
