//! The `reproduce` command (paper section 7, regenerated): parses the arguments, prepares the
//! output folder, runs the selected experiments and writes `machine.json` and `README.md`.

use crate::ctx::Ctx;
use crate::experiment::{self, Experiment, Status};
use crate::readme::{self, RunInfo};
use anyhow::{Context, bail};
use clap::Parser;
use coherent::machine::Machine;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Regenerates the paper's tables and the testbed's comparisons: CSV files, plots, machine.json
/// and README.md in the output folder.
#[derive(Parser, Debug)]
#[command(name = "reproduce", version, about, after_help = after_help())]
pub struct Args {
    /// Small sizes: the whole run in a few minutes (a smoke test, not the paper's sizes).
    #[arg(long)]
    pub quick: bool,
    /// Run only these experiments (comma separated); the README keeps the others' last results.
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub only: Option<Vec<String>>,
    /// Run nothing: re-render README.md from the CSV files and machine.json already in DIR.
    #[arg(long, conflicts_with_all = ["only", "quick"])]
    pub report_only: bool,
    /// Output folder. Default: `results/` at the root of the workspace this binary was built
    /// from (wherever it is run); a relative DIR is taken from the current directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Write into the repository's `results/` from a tree with uncommitted changes (refused
    /// otherwise: a figure must name the revision that produced it). Every section and the
    /// headline then say the run's tree was not committed.
    #[arg(long)]
    pub allow_dirty: bool,
}

fn after_help() -> String {
    let mut text = String::from("Experiments:\n");
    for e in crate::EXPERIMENTS {
        let status = e
            .planned_text()
            .map_or(String::new(), |t| format!(" [{t}]"));
        text.push_str(&format!("  {:<8} {}{status}\n", e.name, e.description));
    }
    text
}

/// `results/` at the workspace root (the parent of this crate's manifest folder, fixed at
/// compile time); `./results` if that folder is gone (the binary was moved).
pub fn default_out() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent();
    match root {
        Some(root) if root.is_dir() => root.join("results"),
        _ => PathBuf::from("results"),
    }
}

/// Exit code for bad arguments (as clap uses).
const USAGE: u8 = 2;

/// The whole program over a given registry: returns the process exit code. Errors go to
/// stderr; nothing here panics on bad input.
pub fn main(args: impl IntoIterator<Item = OsString>, registry: &[Experiment]) -> ExitCode {
    let argv: Vec<OsString> = args.into_iter().collect();
    let args = match Args::try_parse_from(&argv) {
        Ok(args) => args,
        Err(e) => {
            // Help and version go to stdout with success; usage errors to stderr.
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(USAGE)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let selected = match experiment::select(registry, args.only.as_deref()) {
        Ok(selected) => selected,
        Err(e) => {
            eprintln!("reproduce: error: {e}");
            return ExitCode::from(USAGE);
        }
    };
    let given = argv
        .iter()
        .skip(1)
        .map(|a| a.to_string_lossy())
        .collect::<Vec<_>>()
        .join(" ");
    match run(&args, &given, registry, &selected) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reproduce: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Refuses a run into the repository's own `results/` (or a folder in it) from a revision
/// with uncommitted changes (`git_rev` ends in `-dirty`) unless `allow` (`--allow-dirty`);
/// other folders take any run.
fn refuse_dirty(out: &Path, git_rev: &str, allow: bool) -> anyhow::Result<()> {
    if git_rev.ends_with("-dirty") && !allow && crate::root_readme::is_in_repository_results(out) {
        bail!(
            "refusing to write {} from a tree with uncommitted changes (revision {git_rev}): \
             commit them first, write elsewhere with --out DIR, or pass --allow-dirty (the \
             report and the headline then say the run was not committed)",
            out.display()
        );
    }
    Ok(())
}

/// Creates the output folder and checks it is a writable folder.
pub fn prepare_out(out: &Path) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        bail!("output folder {} exists and is not a folder", out.display());
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output folder {}", out.display()))?;
    let probe = out.join(".reproduce-write-test");
    std::fs::write(&probe, b"")
        .with_context(|| format!("output folder {} is not writable", out.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

fn run(
    args: &Args,
    given: &str,
    registry: &[Experiment],
    selected: &[&Experiment],
) -> anyhow::Result<()> {
    let out = args.out.clone().unwrap_or_else(default_out);
    prepare_out(&out)?;
    let machine_json = out.join("machine.json");
    if args.report_only {
        // machine.json describes the machine that measured: keep it.
        let machine = std::fs::read_to_string(&machine_json)
            .ok()
            .and_then(|text| Machine::from_json(&text).ok())
            .unwrap_or_else(Machine::detect);
        let ctx = Ctx::new(&out, false, machine);
        // Every plot is redrawn from the CSV files, as the report is.
        let mut failed = Vec::new();
        for experiment in registry {
            if let Status::Ready { plot, .. } = experiment.status
                && let Err(e) = plot(&ctx)
            {
                eprintln!(
                    "reproduce: cannot draw the plots of {}: {e:#}",
                    experiment.name
                );
                failed.push(experiment.name);
            }
        }
        let info = RunInfo {
            ran: Vec::new(),
            args: given.to_owned(),
        };
        write_readme(&ctx, registry, info)?;
        if !failed.is_empty() {
            anyhow::bail!("plots not drawn: {}", failed.join(", "));
        }
        return Ok(());
    }
    let machine = Machine::detect();
    refuse_dirty(&out, &machine.git_rev, args.allow_dirty)?;
    let previous = std::fs::read_to_string(&machine_json).ok();
    std::fs::write(
        &machine_json,
        crate::machine_keys::machine_json(&machine, previous.as_deref()),
    )
    .with_context(|| format!("cannot write {}", machine_json.display()))?;
    let mut ctx = Ctx::new(&out, args.quick, machine);
    eprintln!(
        "reproduce: {} run into {} ({} experiment{})",
        if args.quick { "quick" } else { "full" },
        out.display(),
        selected.len(),
        if selected.len() == 1 { "" } else { "s" }
    );

    let mut failed = Vec::new();
    let mut ran = Vec::new();
    for experiment in selected {
        let Status::Ready { run, plot, .. } = experiment.status else {
            continue; // `select` refuses planned ones
        };
        eprintln!("== {}: {}", experiment.name, experiment.description);
        let start = Instant::now();
        // A panic is a bug of that experiment: report it and go on with the others.
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            run(&mut ctx)?;
            plot(&ctx).context("cannot draw its plots")
        }))
        .unwrap_or_else(|_| Err(anyhow::anyhow!("panicked (a bug: please report it)")));
        match result {
            Ok(()) => {
                let seconds = start.elapsed().as_secs_f64();
                eprintln!("   {} done in {seconds:.1} s", experiment.name);
                ran.push(experiment.name.to_owned());
                // Which revision wrote this experiment's results (`runs` in machine.json).
                let json = std::fs::read_to_string(&machine_json)
                    .with_context(|| format!("cannot read {}", machine_json.display()))?;
                let probe = crate::machine_keys::speed_probe_ms();
                let json = crate::machine_keys::record_run(
                    &json,
                    experiment.name,
                    &ctx.machine,
                    probe,
                    seconds,
                );
                std::fs::write(&machine_json, json)
                    .with_context(|| format!("cannot write {}", machine_json.display()))?;
            }
            Err(e) => {
                eprintln!("reproduce: experiment {} failed: {e:#}", experiment.name);
                failed.push(experiment.name);
            }
        }
    }
    if args.only.is_none() {
        for e in registry.iter().filter(|e| !e.is_ready()) {
            eprintln!(
                "   skipped {}: {}",
                e.name,
                e.planned_text().unwrap_or_default()
            );
        }
    }

    for note in ctx.notes() {
        eprintln!("   note: {note}");
    }
    let info = RunInfo {
        ran,
        args: given.to_owned(),
    };
    write_readme(&ctx, registry, info)?;
    if !failed.is_empty() {
        bail!("experiments failed: {}", failed.join(", "));
    }
    Ok(())
}

fn write_readme(ctx: &Ctx, registry: &[Experiment], info: RunInfo) -> anyhow::Result<()> {
    let (readme, problems) = readme::write(ctx, registry, &info)?;
    for problem in &problems {
        eprintln!("reproduce: warning: README: {problem}");
    }
    eprintln!("reproduce: wrote {}", readme.display());
    if let Some(root) = crate::root_readme::update(ctx, registry)? {
        eprintln!("reproduce: wrote the headline of {}", root.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dirty_tree_may_not_write_the_repositorys_results() {
        let results = default_out();
        if !results.is_dir() {
            // A binary moved away from its tree has no repository results to protect.
            eprintln!("skipping: no repository results/ at {}", results.display());
            return;
        }
        let err = refuse_dirty(&results, "0123abc-dirty", false).unwrap_err();
        assert!(err.to_string().contains("--allow-dirty"), "{err}");
        assert!(err.to_string().contains("0123abc-dirty"), "{err}");
        // Allowed when asked, from a committed tree, and into any other folder.
        refuse_dirty(&results, "0123abc-dirty", true).unwrap();
        refuse_dirty(&results, "0123abc", false).unwrap();
        // Folders inside it are published too.
        assert!(refuse_dirty(&results.join("manycore"), "0123abc-dirty", false).is_err());
        let elsewhere = tempfile::tempdir().unwrap();
        refuse_dirty(elsewhere.path(), "0123abc-dirty", false).unwrap();
    }

    #[test]
    fn the_output_folder_is_created_or_refused_with_its_path() {
        let dir = tempfile::tempdir().unwrap();
        let nested = dir.path().join("a/b");
        prepare_out(&nested).unwrap();
        assert!(nested.is_dir());

        let file = dir.path().join("file");
        std::fs::write(&file, "x").unwrap();
        let e = prepare_out(&file).unwrap_err();
        assert!(e.to_string().contains("is not a folder"), "{e}");
        let e = prepare_out(&file.join("sub")).unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("cannot create output folder") && msg.contains("file/sub"),
            "{msg}"
        );
    }

    const HEADER: &[&str] = &["a"];

    fn good(ctx: &mut Ctx) -> anyhow::Result<()> {
        let mut csv = ctx.csv("good.csv", HEADER)?;
        csv.row(&[&1])?;
        csv.finish()?;
        Ok(())
    }

    fn failing(_: &mut Ctx) -> anyhow::Result<()> {
        bail!("the mesh is malformed")
    }

    fn panicking(_: &mut Ctx) -> anyhow::Result<()> {
        panic!("a bug in an experiment")
    }

    fn report_good(ctx: &Ctx) -> anyhow::Result<Option<String>> {
        Ok(ctx
            .read_csv("good.csv", HEADER)?
            .map(|t| format!("good rows: {}", t.rows.len())))
    }

    fn report_none(_: &Ctx) -> anyhow::Result<Option<String>> {
        Ok(None)
    }

    fn experiment(name: &'static str, run: crate::experiment::RunFn) -> Experiment {
        let report = if name == "good" {
            report_good
        } else {
            report_none
        };
        Experiment {
            name,
            description: name,
            paper: "—",
            csv: &[],
            plots: &[],
            status: Status::Ready {
                run,
                plot: crate::experiment::no_plots,
                report,
            },
        }
    }

    #[test]
    fn a_failing_experiment_fails_the_run_but_not_the_others() {
        let registry = [
            experiment("bad", failing),
            experiment("buggy", panicking),
            experiment("good", good),
        ];
        let dir = tempfile::tempdir().unwrap();
        let args = [
            "reproduce",
            "--quick",
            "--out",
            dir.path().to_str().unwrap(),
        ];
        let code = main(args.iter().map(OsString::from), &registry);
        assert_eq!(code, ExitCode::FAILURE);
        let readme = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
        assert!(readme.contains("good rows: 1"), "{readme}");
        assert!(readme.contains("which ran: good."), "{readme}");
        assert!(dir.path().join("machine.json").is_file());

        let args = [
            "reproduce",
            "--only",
            "good",
            "--out",
            dir.path().to_str().unwrap(),
        ];
        assert_eq!(
            main(args.iter().map(OsString::from), &registry),
            ExitCode::SUCCESS
        );
    }

    /// A plot from `good.csv`: one point per row (the row count as x).
    fn plot_good(ctx: &Ctx) -> anyhow::Result<()> {
        let Some(t) = ctx.read_csv("good.csv", HEADER)? else {
            return Ok(());
        };
        let points = vec![(t.rows.len() as f64, 1.0), (2.0, 2.0)];
        ctx.line_chart(
            "good",
            &crate::plot::LineChart {
                title: "good".into(),
                x_label: "x".into(),
                y_label: "y".into(),
                series: vec![crate::plot::Series::new("good", points)],
                log2_x: false,
                log_y: false,
            },
        )?;
        Ok(())
    }

    #[test]
    fn plots_are_drawn_after_a_run_and_redrawn_from_the_csv_by_report_only() {
        let mut good = experiment("good", good);
        if let Status::Ready { plot, .. } = &mut good.status {
            *plot = plot_good;
        }
        let registry = [good];
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().to_str().unwrap();
        let run = ["reproduce", "--quick", "--out", out];
        assert_eq!(
            main(run.iter().map(OsString::from), &registry),
            ExitCode::SUCCESS
        );
        let png = dir.path().join("plots/good.png");
        assert!(png.is_file());

        // Gone (or measured elsewhere and copied in): --report-only draws it again from the CSV.
        std::fs::remove_file(&png).unwrap();
        let report = ["reproduce", "--report-only", "--out", out];
        assert_eq!(
            main(report.iter().map(OsString::from), &registry),
            ExitCode::SUCCESS
        );
        assert!(png.is_file());

        // A CSV that cannot be read fails the command, naming the experiment's plots.
        std::fs::write(dir.path().join("good.csv"), "not,the,header\n").unwrap();
        assert_eq!(
            main(report.iter().map(OsString::from), &registry),
            ExitCode::FAILURE
        );
    }

    #[test]
    fn the_default_output_is_the_workspace_results_folder() {
        let out = default_out();
        assert!(out.ends_with("results"));
        assert!(
            out.parent().unwrap().join("Cargo.toml").is_file(),
            "{out:?}"
        );
    }
}
