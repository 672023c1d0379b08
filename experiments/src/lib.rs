//! `coherent-experiments`: the experiments of `reproduce`, one module per paper table or
//! comparison (paper section 7), and the infrastructure they share: the run context
//! ([`Ctx`]), CSV tables, timing, plots and the generated `README.md`.
//!
//! Adding an experiment: write a module exporting `pub const EXPERIMENT: Experiment`
//! (see [`experiment`] for a complete example), declare it below and put it in
//! [`EXPERIMENTS`] in place of its `Experiment::planned` line.

pub mod cli;
pub mod ctx;
pub mod experiment;
pub mod frames;
pub mod headline;
pub mod machine_keys;
mod manycore;
pub mod plot;
pub mod readme;
pub mod root_readme;
pub mod table;
pub mod targets;
pub mod timing;

pub use ctx::Ctx;
pub use experiment::{Experiment, Status};
pub use plot::{BarChart, LineChart, Series};
pub use table::{PaperTable, Table};
pub use timing::{Timing, speedup};

// The experiments, one module each.
pub mod aa;
pub mod accel;
pub mod builds;
mod factors;
pub mod imaps;
pub mod kernels;
pub mod maps;
pub mod peers;
pub mod regroup;
pub mod spectral;
pub mod table1;
pub mod table2;
pub mod table3;
pub mod table4;
pub mod table5;
pub mod view;

/// Every experiment, in the order `reproduce` runs them and the README lists them. The
/// names are the results contract (`--only` takes them).
pub const EXPERIMENTS: &[Experiment] = &[
    kernels::EXPERIMENT,
    accel::EXPERIMENT,
    table1::EXPERIMENT,
    table2::EXPERIMENT,
    table3::EXPERIMENT,
    table4::EXPERIMENT,
    table5::EXPERIMENT,
    aa::EXPERIMENT,
    // Beyond the contract's names (which keep their order).
    regroup::EXPERIMENT,
    builds::EXPERIMENT,
    maps::EXPERIMENT,
    view::EXPERIMENT,
    peers::EXPERIMENT,
    imaps::EXPERIMENT,
    spectral::EXPERIMENT,
];
