//! What can stop an illumination map from being built, loaded or used: each names the
//! problem (and the file, where there is one) before any work starts.

use std::path::PathBuf;

use thiserror::Error;

/// An illumination map that cannot be built, loaded or used.
#[derive(Debug, Error)]
pub enum IllumError {
    #[error("scene {scene}: no light emits power, so there is nothing to trace particles from")]
    NoLight { scene: String },
    #[error("scene {scene}: light {light} ({kind}) cannot emit particles: {problem}")]
    Light {
        scene: String,
        light: usize,
        kind: &'static str,
        problem: String,
    },
    #[error("{what}: {problem}")]
    Options { what: &'static str, problem: String },
    #[error("illumination map {}: {problem}", path.display())]
    File { path: PathBuf, problem: String },
    /// The lane backend asked for cannot run here.
    #[error(transparent)]
    Backend(#[from] coherent_simd::BackendError),
}
