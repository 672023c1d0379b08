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
    #[error("{scene}{}: {field}: {problem}", crate::mesh_file::at_line(*.line))]
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
    /// A file the project's set-up fetches (`scripts/native.py`: named by the scene file's
    /// `[assets]` table, or anything under `.cache/`) that is missing or cannot be read:
    /// the message names the scene file, the field, the asset and the command that fetches
    /// it (again).
    #[error(
        "{path}:{line}: {field}: asset {asset} {problem}; {}",
        fetch_hint(step.as_deref(), *on_demand, *missing)
    )]
    Asset {
        /// The scene file.
        path: PathBuf,
        line: usize,
        field: Box<str>,
        /// The asset as found (the scene file's folder joined with the path it gives).
        asset: PathBuf,
        /// "is missing" or "cannot be read: ...".
        problem: Box<str>,
        /// The `scripts/native.py` step that fetches it, when the scene file names one.
        step: Option<String>,
        /// Fetched only when asked for by name (a large download the tests never make).
        on_demand: bool,
        /// Missing (not fetched), rather than present and unreadable.
        missing: bool,
    },
    /// Neither a scene or mesh file nor a built-in scene; `why` says which it is not (or
    /// which scene file was probably meant).
    #[error("no scene {spec:?}: {why} (built in: {known})")]
    Unknown {
        spec: String,
        why: String,
        known: String,
    },
}

/// How to fetch an asset (again), for [`SceneError::Asset`].
fn fetch_hint(step: Option<&str>, on_demand: bool, missing: bool) -> String {
    let cmd = match step {
        Some(s) => format!("python3 scripts/native.py {s}"),
        None => "python3 scripts/native.py".to_string(),
    };
    let mut out = if missing {
        format!(
            "it is not fetched: run `{cmd}` (the project's set-up fetches it, pinned and checked)"
        )
    } else {
        format!(
            "it is fetched by the project's set-up: run `{cmd}` to fetch it again (every file \
             is checked against its recorded sha256 and replaced when it differs)"
        )
    };
    if on_demand {
        out.push_str(
            "; a large download, fetched only when asked for by name (`scripts/reproduce.sh` \
             without --quick does)",
        );
    }
    out
}

impl SceneError {
    /// Whether this is an asset the project's set-up has not fetched: a scene that reports
    /// it is skipped by the experiments and the scene tests (with this message).
    pub fn is_missing_asset(&self) -> bool {
        matches!(self, SceneError::Asset { missing: true, .. })
    }

    /// Whether the asset at fault is fetched only when asked for by name (see
    /// [`SceneError::Asset`]).
    pub fn is_on_demand_asset(&self) -> bool {
        matches!(
            self,
            SceneError::Asset {
                on_demand: true,
                ..
            }
        )
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
