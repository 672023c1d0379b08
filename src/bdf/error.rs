//! What can be wrong with a tabulated BDF (paper section 4.2) or its file: every error
//! names the file and the problem.

use std::path::PathBuf;

use thiserror::Error;

use crate::tabulated::TableError;

/// A BDF table file that could not be read or written.
#[derive(Debug, Error)]
pub enum BdfError {
    #[error("BDF table {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("BDF table {}: {problem}", path.display())]
    Invalid { path: PathBuf, problem: BdfProblem },
}

/// What is wrong with a table's contents.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BdfProblem {
    #[error("not a coherent BDF table (the file does not start with \"CBDFTAB\\0\")")]
    BadMagic,
    #[error("format version {0} is not supported (this build reads version 1)")]
    BadVersion(u32),
    #[error("{0} dimensions: 3 (isotropic) or 4 (anisotropic) are supported")]
    BadDims(u32),
    #[error("symmetry code {0} is unknown (0 none, 1 quadrant)")]
    BadSymmetry(u32),
    #[error("symmetry {0} is only for anisotropic (4D) tables")]
    SymmetryOnIsotropic(u32),
    #[error("axis {axis} has {len} nodes: the table would not fit in memory")]
    HugeAxis { axis: usize, len: u32 },
    #[error("truncated: {what} needs {needed} bytes at offset {offset}, the file has {len}")]
    Truncated {
        what: &'static str,
        offset: usize,
        needed: usize,
        len: usize,
    },
    #[error("{0} bytes after the end of the table")]
    TrailingBytes(usize),
    #[error("{0}")]
    Table(#[from] TableError),
    #[error("axis {axis} ({name}) spans [{first}, {last}], outside [{lo}, {hi}]")]
    AxisRange {
        axis: usize,
        name: String,
        first: f32,
        last: f32,
        lo: f32,
        hi: f32,
    },
    #[error("value {index} is negative ({value}): a BDF is never negative")]
    NegativeValue { index: usize, value: f32 },
}

impl BdfProblem {
    /// This problem in the file at `path`.
    pub fn at(self, path: impl Into<PathBuf>) -> BdfError {
        BdfError::Invalid {
            path: path.into(),
            problem: self,
        }
    }
}
