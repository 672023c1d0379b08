//! An experiment of `reproduce`: one paper item (a table of section 7, or a comparison of the
//! testbed), its outputs, and the functions that measure it and report it.
//!
//! An experiment is one module exporting a `const EXPERIMENT`, listed in
//! [`crate::EXPERIMENTS`]. `run` measures and writes CSV rows (under the contract's exact
//! header); `plot` draws the plots and `report` renders the README section, both from the CSV
//! alone, so that `reproduce --report-only` redraws every plot and section from CSV files
//! (edited, merged, or measured on another machine):
//!
//! ```
//! use coherent_experiments::plot::{LineChart, Series};
//! use coherent_experiments::table::PaperTable;
//! use coherent_experiments::{Ctx, Experiment, Status};
//!
//! const FILE: &str = "table1_bdf.csv";
//! const HEADER: &[&str] = &["calls", "backend", "lanes", "seconds", "speedup"];
//!
//! pub const EXPERIMENT: Experiment = Experiment {
//!     name: "table1",
//!     description: "anisotropic tabulated BDF evaluations per backend",
//!     paper: "Table 1 (section 4.2)",
//!     csv: &[FILE],
//!     plots: &["table1_speedup"],
//!     status: Status::Ready { run, plot, report },
//! };
//!
//! /// The paper's figures, as data (Pentium 4 1.8 GHz, non-SSE vs SSE).
//! const PAPER: PaperTable = PaperTable {
//!     caption: "Paper, Table 1 (Pentium 4 1.8 GHz) beside ours (scalar vs sse):",
//!     key: "calls",
//!     columns: &["scalar s", "SSE s", "speedup"],
//!     rows: &[
//!         ("100000", &[0.137, 0.040, 3.43]),
//!         ("200000", &[0.248, 0.078, 3.17]),
//!         ("400000", &[0.495, 0.156, 3.17]),
//!     ],
//! };
//!
//! fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
//!     let sizes: Vec<usize> = ctx.pick(vec![10_000], vec![100_000, 200_000, 400_000]);
//!     let mut csv = ctx.csv(FILE, HEADER)?;
//!     let bar = ctx.progress(sizes.len() as u64, "table1");
//!     for &calls in &sizes {
//!         // Real experiments loop over `coherent::simd::Backend::available()` and time a
//!         // `Kernel` through `backend.run(kernel)`.
//!         let scalar = ctx.time(|| (0..calls).map(|i| (i as f32).sqrt()).sum::<f32>());
//!         csv.row(&[&calls, &"scalar", &1, &scalar.median, &1.0])?;
//!         bar.inc(1);
//!     }
//!     bar.finish_and_clear();
//!     csv.finish()?;
//!     Ok(())
//! }
//!
//! fn plot(ctx: &Ctx) -> anyhow::Result<()> {
//!     let Some(table) = ctx.read_csv(FILE, HEADER)? else {
//!         return Ok(()); // not run into this folder yet
//!     };
//!     let mut points = Vec::new();
//!     for r in 0..table.rows.len() {
//!         points.push((table.f64(r, "lanes")?, table.f64(r, "speedup")?));
//!     }
//!     ctx.line_chart(
//!         "table1_speedup",
//!         &LineChart {
//!             title: "Table 1: BDF speedup over scalar".into(),
//!             x_label: "lanes".into(),
//!             y_label: "speedup".into(),
//!             series: vec![Series::new("bdf", points)],
//!             log2_x: true,
//!             log_y: false,
//!         },
//!     )?;
//!     Ok(())
//! }
//!
//! fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
//!     let Some(table) = ctx.read_csv(FILE, HEADER)? else {
//!         return Ok(None); // not run into this folder yet
//!     };
//!     let mut ours = Vec::new();
//!     for calls in table.distinct("calls")? {
//!         let rows = table.rows_where("calls", &calls)?;
//!         let seconds = |backend: &str| -> Option<f64> {
//!             let r = rows.iter().find(|&&r| table.get(r, "backend").ok() == Some(backend))?;
//!             table.f64(*r, "seconds").ok()
//!         };
//!         let (scalar, sse) = (seconds("scalar"), seconds("sse"));
//!         let speedup = scalar.zip(sse).map(|(a, b)| a / b);
//!         ours.push((calls, vec![scalar, sse, speedup]));
//!     }
//!     let mut md = PAPER.beside(&ours);
//!     md.push_str("\nAll backends (speedup over scalar):\n\n");
//!     md.push_str(&table.pivot("calls", "backend", "speedup")?);
//!     md.push_str(&ctx.plot_markdown("table1_speedup", "BDF speedup").unwrap_or_default());
//!     Ok(Some(md))
//! }
//!
//! // Try it in a temporary folder:
//! let dir = tempfile::tempdir()?;
//! let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
//! let Status::Ready { run, plot, report } = EXPERIMENT.status else { unreachable!() };
//! run(&mut ctx)?;
//! plot(&ctx)?;
//! assert!(dir.path().join("plots/table1_speedup.png").is_file());
//! let section = report(&ctx)?.expect("the CSV is there");
//! assert!(section.contains("| 10000 | — | "));
//! # Ok::<(), anyhow::Error>(())
//! ```

use crate::ctx::Ctx;

/// Measures: writes the experiment's CSV(s) into `ctx.out`.
pub type RunFn = fn(&mut Ctx) -> anyhow::Result<()>;

/// Draws the experiment's plots into `ctx.out/plots` from the CSV files in `ctx.out` (never
/// from memory), after each `run` and on `--report-only`. `Ok(())` without drawing when its
/// CSV is not there; `Err` when it is there but unreadable.
pub type PlotFn = fn(&Ctx) -> anyhow::Result<()>;

/// The [`PlotFn`] of an experiment without plots.
pub fn no_plots(_: &Ctx) -> anyhow::Result<()> {
    Ok(())
}

/// Renders the experiment's section of `README.md` from the CSV files in `ctx.out` (never
/// from memory: `--only x` re-runs x and the README still shows the others' last results).
/// `Ok(None)` when its CSV is not there yet; `Err` when it is there but unreadable.
pub type ReportFn = fn(&Ctx) -> anyhow::Result<Option<String>>;

/// Whether an experiment can run yet.
#[derive(Clone, Copy, Debug)]
pub enum Status {
    /// Implemented.
    Ready {
        run: RunFn,
        plot: PlotFn,
        report: ReportFn,
    },
    /// Registered so its name is known, but not written yet; `waits_for` says in the user's
    /// words what it needs first (e.g. "the renderer"), where that is known.
    Planned { waits_for: Option<&'static str> },
}

/// One experiment. Each module exports one as `pub const EXPERIMENT: Experiment` and the
/// registry ([`crate::EXPERIMENTS`]) lists it.
#[derive(Clone, Copy, Debug)]
pub struct Experiment {
    /// The name `--only` takes, e.g. `table1`.
    pub name: &'static str,
    /// One line: what it measures.
    pub description: &'static str,
    /// The paper item it reproduces, e.g. `Table 1 (section 4.2)`, or `—` for the testbed's own.
    pub paper: &'static str,
    /// The CSV files it writes into the output folder (the results contract).
    pub csv: &'static [&'static str],
    /// The plots it writes, as stems: `plots/{stem}.png` and `.svg`.
    pub plots: &'static [&'static str],
    pub status: Status,
}

impl Experiment {
    /// A registered experiment not written yet.
    pub const fn planned(
        name: &'static str,
        description: &'static str,
        paper: &'static str,
        csv: &'static [&'static str],
        waits_for: Option<&'static str>,
    ) -> Experiment {
        Experiment {
            name,
            description,
            paper,
            csv,
            plots: &[],
            status: Status::Planned { waits_for },
        }
    }

    /// Whether it is implemented.
    pub fn is_ready(&self) -> bool {
        matches!(self.status, Status::Ready { .. })
    }

    /// The command that re-runs only this experiment.
    pub fn command(&self) -> String {
        format!(
            "cargo run --release -p coherent-experiments --bin reproduce -- --only {}",
            self.name
        )
    }

    /// "not implemented yet (it needs the renderer)".
    pub fn planned_text(&self) -> Option<String> {
        match self.status {
            Status::Ready { .. } => None,
            Status::Planned { waits_for: Some(w) } => {
                Some(format!("not implemented yet (it needs {w})"))
            }
            Status::Planned { waits_for: None } => Some("not implemented yet".to_owned()),
        }
    }
}

/// Why an `--only` list was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum SelectError {
    #[error("unknown experiment `{name}`; the experiments are: {valid}")]
    Unknown { name: String, valid: String },
    #[error("experiment `{name}` is {why}")]
    Planned { name: String, why: String },
    #[error("--only needs at least one experiment name; the experiments are: {valid}")]
    Empty { valid: String },
}

/// The experiments to run, in registry order. `only = None` selects every implemented one;
/// otherwise each name must be registered and implemented (duplicates are ignored).
pub fn select<'a>(
    registry: &'a [Experiment],
    only: Option<&[String]>,
) -> Result<Vec<&'a Experiment>, SelectError> {
    let valid = || {
        registry
            .iter()
            .map(|e| e.name)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let Some(names) = only else {
        return Ok(registry.iter().filter(|e| e.is_ready()).collect());
    };
    let names: Vec<&str> = names
        .iter()
        .map(|n| n.trim())
        .filter(|n| !n.is_empty())
        .collect();
    if names.is_empty() {
        return Err(SelectError::Empty { valid: valid() });
    }
    // Unknown names first: a typo matters more than an experiment not written yet.
    if let Some(name) = names
        .iter()
        .find(|name| !registry.iter().any(|e| e.name == **name))
    {
        return Err(SelectError::Unknown {
            name: (*name).to_owned(),
            valid: valid(),
        });
    }
    for experiment in registry.iter().filter(|e| names.contains(&e.name)) {
        if let Some(why) = experiment.planned_text() {
            return Err(SelectError::Planned {
                name: experiment.name.to_owned(),
                why,
            });
        }
    }
    Ok(registry
        .iter()
        .filter(|e| names.contains(&e.name))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(_: &mut Ctx) -> anyhow::Result<()> {
        Ok(())
    }

    fn report(_: &Ctx) -> anyhow::Result<Option<String>> {
        Ok(None)
    }

    const READY: Status = Status::Ready {
        run,
        plot: no_plots,
        report,
    };

    fn registry() -> Vec<Experiment> {
        vec![
            Experiment {
                name: "a",
                description: "first",
                paper: "Table 1",
                csv: &["a.csv"],
                plots: &[],
                status: READY,
            },
            Experiment::planned("b", "second", "Table 2", &["b.csv"], Some("the lights")),
            Experiment {
                name: "c",
                description: "third",
                paper: "—",
                csv: &["c.csv"],
                plots: &[],
                status: READY,
            },
            Experiment::planned("d", "fourth", "Table 3", &[], None),
        ]
    }

    fn names(selected: &[&Experiment]) -> Vec<&'static str> {
        selected.iter().map(|e| e.name).collect()
    }

    fn only(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn no_list_selects_every_ready_experiment_in_order() {
        let registry = registry();
        assert_eq!(names(&select(&registry, None).unwrap()), ["a", "c"]);
    }

    #[test]
    fn a_list_selects_in_registry_order_without_duplicates() {
        let registry = registry();
        let list = only(&["c", " a", "c"]);
        assert_eq!(names(&select(&registry, Some(&list)).unwrap()), ["a", "c"]);
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let registry = registry();
        let e = select(&registry, Some(&only(&["b", "zzz"]))).unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown experiment `zzz`; the experiments are: a, b, c, d"
        );
        let e = select(&registry, Some(&only(&["", " "]))).unwrap_err();
        assert!(matches!(e, SelectError::Empty { .. }), "{e}");
    }

    #[test]
    fn planned_experiments_are_refused_with_what_they_need() {
        let registry = registry();
        let e = select(&registry, Some(&only(&["b"]))).unwrap_err();
        assert_eq!(
            e.to_string(),
            "experiment `b` is not implemented yet (it needs the lights)"
        );
        let e = select(&registry, Some(&only(&["d"]))).unwrap_err();
        assert_eq!(e.to_string(), "experiment `d` is not implemented yet");
    }

    #[test]
    fn the_real_registry_has_the_contract_names_in_order() {
        let names: Vec<&str> = crate::EXPERIMENTS.iter().map(|e| e.name).collect();
        assert_eq!(
            names,
            [
                "kernels", "accel", "table1", "table2", "table3", "table4", "table5", "aa",
                "regroup", "builds", "maps", "view", "peers", "imaps", "spectral"
            ]
        );
    }
}
