//! Tabulated BDFs (paper section 4.2): 3D isotropic and 4D anisotropic tables on
//! non-uniform grids, evaluated for a packet of rays by angles (approximate inverse
//! trigonometry), an N-wide binary search per axis and multilinear interpolation; our
//! file format; and the analytic models the tables are sampled from.

pub mod analytic;
pub mod angles;
pub mod error;
pub mod format;
pub mod table;
pub mod tabulate;
pub mod workload;

pub use analytic::{Analytic, Ggx, Ward};
pub use angles::Frames;
pub use error::{BdfError, BdfProblem};
pub use table::{AnisotropicBdf, Bdf, IsotropicBdf, Symmetry};
pub use tabulate::{PAPER_ANISOTROPIC_SHAPE, tabulate_anisotropic, tabulate_isotropic};

#[cfg(test)]
mod tests;
