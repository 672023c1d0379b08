//! Real meshes from files (the test scenes of paper section 7 are stand-ins; these are the
//! measured real ones): Wavefront OBJ and OFF readers, and the meshes `scripts/native.py`
//! fetches from Debian packages into `.cache/meshes/` (pinned and checksummed there).

use std::path::{Path, PathBuf};

use coherent_accel::scenes::{BuiltinScene, View};
use coherent_accel::{Mesh, Scene};
use glam::Vec3;

/// What went wrong reading a mesh file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}: {problem}")]
    Parse {
        path: PathBuf,
        line: usize,
        problem: String,
    },
    #[error("{path}: unknown mesh format (expected .obj or .off)")]
    Format { path: PathBuf },
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

    /// The mesh as a scene for the comparisons: placed once, seen from the front-right and
    /// a little above (+y up) so that it fills most of the view, lit from above the eye.
    pub fn scene(&self) -> Result<BuiltinScene, MeshFileError> {
        let mesh = self.load()?;
        let b = mesh.bounds();
        let (center, radius) = (b.center(), 0.5 * b.extent().length());
        let eye = center + Vec3::new(0.35, 0.25, 1.0).normalize() * (2.6 * radius);
        Ok(BuiltinScene {
            name: self.name,
            scene: Scene::single(mesh),
            view: View {
                eye,
                target: center,
                up: Vec3::Y,
                fov_y_degrees: 45.0,
            },
            light: center + Vec3::new(-0.5, 2.0, 1.5) * radius,
        })
    }

    /// The real mesh called `name`.
    pub fn named(name: &str) -> Option<RealMesh> {
        REAL_MESHES.into_iter().find(|m| m.name == name)
    }
}

/// Reads an OBJ or OFF file (by extension).
pub fn load(path: &Path) -> Result<Mesh, MeshFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let name = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let parsed = match ext.as_deref() {
        Some("obj") => parse_obj(&text),
        Some("off") => parse_off(&text),
        _ => {
            return Err(MeshFileError::Format {
                path: path.to_path_buf(),
            });
        }
    };
    let (positions, indices) = parsed.map_err(|(line, problem)| MeshFileError::Parse {
        path: path.to_path_buf(),
        line,
        problem,
    })?;
    Ok(Mesh::new(name, positions, indices))
}

type Parsed = Result<(Vec<Vec3>, Vec<[u32; 3]>), (usize, String)>;

fn number<T: std::str::FromStr>(
    word: Option<&str>,
    what: &str,
    line: usize,
) -> Result<T, (usize, String)> {
    let w = word.ok_or_else(|| (line, format!("missing {what}")))?;
    w.parse()
        .map_err(|_| (line, format!("{what} {w:?} is not a number")))
}

/// Triangulates a polygon of vertex indices as a fan.
fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

/// Wavefront OBJ: `v x y z` and `f a b c ...` (1-based or negative indices, `a/t/n` forms,
/// polygons as fans); other records are ignored.
pub fn parse_obj(text: &str) -> Parsed {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let x = number(w.next(), "x", line_no)?;
                let y = number(w.next(), "y", line_no)?;
                let z = number(w.next(), "z", line_no)?;
                positions.push(Vec3::new(x, y, z));
            }
            Some("f") => {
                let poly = w
                    .map(|v| {
                        let i: i64 = number(v.split('/').next(), "vertex index", line_no)?;
                        let len = positions.len() as i64;
                        let i = if i < 0 { len + i } else { i - 1 };
                        if !(0..len).contains(&i) {
                            return Err((
                                line_no,
                                format!("vertex index {v} out of range ({len} vertices so far)"),
                            ));
                        }
                        Ok(i as u32)
                    })
                    .collect::<Result<Vec<u32>, _>>()?;
                if poly.len() < 3 {
                    return Err((line_no, format!("face with {} vertices", poly.len())));
                }
                fan(&poly, &mut indices);
            }
            _ => {}
        }
    }
    Ok((positions, indices))
}

/// OFF: `OFF`, `nv nf ne`, `nv` lines `x y z`, `nf` lines `n i0 .. i(n-1) [colour]`;
/// `#` comments and blank lines are skipped.
pub fn parse_off(text: &str) -> Parsed {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let (n, header) = lines.next().ok_or((1, "empty file".to_string()))?;
    let mut counts_line = if header == "OFF" {
        lines
            .next()
            .ok_or((n, "missing the counts line".to_string()))?
    } else if let Some(rest) = header.strip_prefix("OFF") {
        (n, rest.trim())
    } else {
        return Err((n, format!("expected the OFF header, found {header:?}")));
    };
    let mut c = counts_line.1.split_whitespace();
    let nv: usize = number(c.next(), "vertex count", counts_line.0)?;
    let nf: usize = number(c.next(), "face count", counts_line.0)?;
    counts_line.1 = "";
    let mut positions = Vec::with_capacity(nv);
    for k in 0..nv {
        let (n, l) = lines
            .next()
            .ok_or((counts_line.0, format!("file ends at vertex {k} of {nv}")))?;
        let mut w = l.split_whitespace();
        let x = number(w.next(), "x", n)?;
        let y = number(w.next(), "y", n)?;
        let z = number(w.next(), "z", n)?;
        positions.push(Vec3::new(x, y, z));
    }
    let mut indices = Vec::with_capacity(nf);
    for k in 0..nf {
        let (n, l) = lines
            .next()
            .ok_or((counts_line.0, format!("file ends at face {k} of {nf}")))?;
        let mut w = l.split_whitespace();
        let count: usize = number(w.next(), "face size", n)?;
        let poly = (0..count)
            .map(|_| {
                let i: usize = number(w.next(), "vertex index", n)?;
                if i >= nv {
                    return Err((n, format!("vertex index {i} out of range ({nv} vertices)")));
                }
                Ok(i as u32)
            })
            .collect::<Result<Vec<u32>, _>>()?;
        if poly.len() < 3 {
            return Err((n, format!("face with {} vertices", poly.len())));
        }
        fan(&poly, &mut indices);
    }
    Ok((positions, indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_with_polygons_slashes_and_negative_indices() {
        let (p, i) = parse_obj(
            "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2/2/2 3/3/3 4\nf -4 -3 -2\n",
        )
        .unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(i, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn obj_errors_name_the_line() {
        assert_eq!(parse_obj("v 0 0 0\nv 1 x 0\n").unwrap_err().0, 2);
        let e = parse_obj("v 0 0 0\nf 1 2 3\n").unwrap_err();
        assert!(e.0 == 2 && e.1.contains("out of range"), "{e:?}");
    }

    #[test]
    fn off_with_comments_and_quads() {
        let text = "OFF\n# a quad\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n";
        let (p, i) = parse_off(text).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(i, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn off_errors_name_the_line() {
        assert!(parse_off("PLY\n").unwrap_err().1.contains("OFF header"));
        let e = parse_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n").unwrap_err();
        assert_eq!(e.0, 6, "{e:?}");
        let e = parse_off("OFF\n3 1 0\n0 0 0\n").unwrap_err();
        assert!(e.1.contains("file ends"), "{e:?}");
    }

    #[test]
    fn fetched_meshes_load_as_scenes() {
        for m in REAL_MESHES {
            match m.scene() {
                Ok(s) => {
                    s.scene.validate().unwrap();
                    assert!(s.scene.meshes[0].indices.len() > 10_000, "{}", m.name);
                    // The view looks at the mesh: the central primary ray hits its box.
                    let r = s.view.ray_at(0.5, 0.5, 4.0 / 3.0);
                    let b = s.scene.meshes[0].bounds();
                    assert!(
                        b.clip1(r.origin, r.dir.recip(), 0.0, f32::INFINITY)
                            .is_some()
                    );
                }
                Err(e @ MeshFileError::NotFetched { .. })
                    if std::env::var_os("COHERENT_REQUIRE_MESHES").is_none() =>
                {
                    eprintln!("skipping {}: {e}", m.name)
                }
                Err(e) => panic!("{e}"),
            }
        }
    }

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
