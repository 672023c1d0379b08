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
pub mod plot;
pub mod readme;
pub mod table;
pub mod timing;

pub use ctx::Ctx;
pub use experiment::{Experiment, Status};
pub use plot::{BarChart, LineChart, Series};
pub use table::{PaperTable, Table};
pub use timing::{Timing, speedup};

// The experiments, one module each.
pub mod aa;
pub mod accel;
pub mod kernels;
pub mod table1;
pub mod table2;
pub mod table4;

/// Every experiment, in the order `reproduce` runs them and the README lists them. The
/// names are the results contract (`--only` takes them).
pub const EXPERIMENTS: &[Experiment] = &[
    kernels::EXPERIMENT,
    accel::EXPERIMENT,
    table1::EXPERIMENT,
    table2::EXPERIMENT,
    Experiment::planned(
        "table3",
        "rendering the test scenes per backend and accel",
        "Table 3 (section 7)",
        &["table3_scenes.csv"],
        None,
    ),
    table4::EXPERIMENT,
    Experiment::planned(
        "table5",
        "rendering with 1, 2, ... threads",
        "Table 5 (section 7)",
        &["table5_threads.csv"],
        None,
    ),
    aa::EXPERIMENT,
];
