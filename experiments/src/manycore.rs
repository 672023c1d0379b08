//! Runs on a lent machine with more cores, kept in `manycore/` beside the results: where they
//! are and which machine made them. The reports of `table5`, `accel`, `kernels` and `table1`
//! show them beside this machine's.

use crate::ctx::Ctx;

/// The folder, beside these results, of a run on a machine with more cores (its own
/// `machine.json`, README, CSV files and plots).
pub(crate) const MANYCORE: &str = "manycore";

/// The machine of the run in `manycore/` (its `machine.json`), in words, with the git revision
/// and date of the run that wrote `experiment`'s results there (its entry under `runs`; the
/// file's own, written by the last run, for results older than that record).
pub fn manycore_machine(ctx: &Ctx, experiment: &str) -> String {
    let machine = std::fs::read_to_string(ctx.path(&format!("{MANYCORE}/machine.json")))
        .ok()
        .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).ok());
    match &machine {
        Some(m) => {
            let run = m["runs"].get(experiment).unwrap_or(m);
            format!(
                "{} with {} cores ({} hardware threads), git revision `{}`, {}",
                m["cpu"].as_str().unwrap_or("?"),
                m["cores"],
                m["threads"],
                run["git_rev"].as_str().unwrap_or("?"),
                run["date"].as_str().unwrap_or("?"),
            )
        }
        None => "a machine whose `machine.json` is missing".to_owned(),
    }
}
