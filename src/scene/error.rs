//! What goes wrong loading a scene (paper section 7: the renderer's input); every variant
//! names the file or scene, and where it can the line and the field.

use std::path::PathBuf;

use coherent_accel::AccelError;

use crate::material::MaterialError;
use crate::mesh_file::MeshFileError;

/// A scene that cannot be loaded or used.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file that cannot be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A scene file whose TOML does not parse or does not fit the schema (unknown key,
    /// wrong type, missing field): `line` and `column` are 1-based.
    #[error("{path}:{line}:{column}: {problem}")]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        problem: String,
    },
    /// A value that parses but cannot be used; `field` says which (e.g. `camera.up`,
    /// `materials.red.ior`), `line` where it is when known (0 when not).
    #[error("{scene}{}: {field}: {problem}", line_suffix(*.line))]
    Invalid {
        scene: String,
        line: usize,
        field: String,
        problem: String,
    },
    /// A mesh file that cannot be read.
    #[error(transparent)]
    MeshFile(#[from] MeshFileError),
    /// A mesh or instance the accelerators would reject.
    #[error("scene {scene}: {source}")]
    Geometry {
        scene: String,
        #[source]
        source: AccelError,
    },
    /// A material with unusable attributes.
    #[error("scene {scene}: {source}")]
    Material {
        scene: String,
        #[source]
        source: MaterialError,
    },
    /// Neither a file nor a built-in scene.
    #[error("no scene {spec:?}: not a file, and not a built-in scene (built in: {known})")]
    Unknown { spec: String, known: String },
}

fn line_suffix(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

impl SceneError {
    /// An [`SceneError::Invalid`] without a line.
    pub fn invalid(
        scene: impl Into<String>,
        field: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        SceneError::Invalid {
            scene: scene.into(),
            line: 0,
            field: field.into(),
            problem: problem.into(),
        }
    }
}
