//! An experiment of `reproduce`: one paper item (a table of section 7, or a comparison of the
//! testbed), its outputs, and the functions that measure it and report it.

use crate::ctx::Ctx;

/// Measures: writes the experiment's CSV(s) and plots into `ctx.out`.
pub type RunFn = fn(&mut Ctx) -> anyhow::Result<()>;

/// Renders the experiment's section of `README.md` from the CSV files in `ctx.out` (never
/// from memory: `--only x` re-runs x and the README still shows the others' last results).
/// `Ok(None)` when its CSV is not there yet; `Err` when it is there but unreadable.
pub type ReportFn = fn(&Ctx) -> anyhow::Result<Option<String>>;

/// Whether an experiment can run yet.
#[derive(Clone, Copy, Debug)]
pub enum Status {
    /// Implemented.
    Ready { run: RunFn, report: ReportFn },
    /// Registered so its name is known, but not written yet; `issue` is the issue that
    /// brings it, where one is filed.
    Planned { issue: Option<u32> },
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
        issue: Option<u32>,
    ) -> Experiment {
        Experiment {
            name,
            description,
            paper,
            csv,
            plots: &[],
            status: Status::Planned { issue },
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

    /// "not implemented yet (issue N)".
    pub fn planned_text(&self) -> Option<String> {
        match self.status {
            Status::Ready { .. } => None,
            Status::Planned { issue: Some(n) } => Some(format!("not implemented yet (issue {n})")),
            Status::Planned { issue: None } => {
                Some("not implemented yet (no issue filed yet)".to_owned())
            }
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

    const READY: Status = Status::Ready { run, report };

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
            Experiment::planned("b", "second", "Table 2", &["b.csv"], Some(7)),
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
    fn planned_experiments_are_refused_with_their_issue() {
        let registry = registry();
        let e = select(&registry, Some(&only(&["b"]))).unwrap_err();
        assert_eq!(
            e.to_string(),
            "experiment `b` is not implemented yet (issue 7)"
        );
        let e = select(&registry, Some(&only(&["d"]))).unwrap_err();
        assert!(e.to_string().contains("no issue filed yet"), "{e}");
    }

    #[test]
    fn the_real_registry_has_the_contract_names_in_order() {
        let names: Vec<&str> = crate::EXPERIMENTS.iter().map(|e| e.name).collect();
        assert_eq!(
            names,
            [
                "kernels", "accel", "table1", "table2", "table3", "table4", "table5", "aa"
            ]
        );
    }
}
