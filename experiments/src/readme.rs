//! `results/README.md`: a first screen (the paper's Tables 1-5 against ours in one line each,
//! three plots, the machine; see [`crate::headline`]), then the machine in full, a table of
//! contents (paper item -> command -> CSV -> plot) and one section per experiment, each
//! rendered from the CSV files in the folder (paper section 7's tables beside ours). Nothing
//! in it is typed by hand.

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::table::markdown_table;
use coherent::machine::Machine;
use std::path::PathBuf;

/// What the run that writes the README did, for its header.
#[derive(Clone, Debug, Default)]
pub struct RunInfo {
    /// The experiments this run ran (others keep their earlier CSVs).
    pub ran: Vec<String>,
    /// `reproduce` arguments as given, e.g. `--quick --only kernels`.
    pub args: String,
}

/// The README text, and the problems met while rendering it (unreadable CSVs), which the
/// README shows too.
pub fn render(ctx: &Ctx, registry: &[Experiment], run: &RunInfo) -> (String, Vec<String>) {
    let mut problems = Vec::new();
    let mut md = String::new();
    md.push_str("# Results\n\n");
    md.push_str(&crate::headline::render(ctx, registry));
    md.push_str("## About these results\n\n");
    md.push_str(
        "Written by `reproduce` (crate `coherent-experiments`): every table below is generated \
         from the CSV files in this folder and every figure from the same data; do not edit by \
         hand. Regenerate everything with\n\n\
         ```sh\n\
         cargo run --release -p coherent-experiments --bin reproduce            # the paper's sizes\n\
         cargo run --release -p coherent-experiments --bin reproduce -- --quick # small sizes, minutes\n\
         ```\n\n\
         or one experiment with `-- --only NAME` (the other sections then keep their last \
         results). Timings are medians of repeated runs and are meant as ratios within one run \
         on one machine (the `speedup` columns); absolute seconds depend on the machine below.\n\n",
    );
    let command = format!("reproduce {}", run.args);
    let command = command.trim_end();
    if run.ran.is_empty() {
        // `--report-only`: nothing was measured; say so, and where the measuring runs are.
        md.push_str(&format!(
            "Last written by `{command}`, which ran no experiment: this report and the plots \
             were redrawn from the CSV files. The runs that measured them are listed under the \
             machine table.\n\n"
        ));
    } else {
        md.push_str(&format!(
            "Last run: `{command}`, which ran: {}.\n\n",
            run.ran.join(", ")
        ));
    }

    md.push_str("## Machine\n\n");
    md.push_str(&machine_section(ctx, &mut problems));

    md.push_str("## Contents\n\n");
    md.push_str(&contents(ctx, registry));

    let runs_json = std::fs::read_to_string(ctx.path("machine.json")).unwrap_or_default();
    for experiment in registry {
        md.push_str(&format!(
            "## {} — {}\n\n",
            experiment.name, experiment.description
        ));
        md.push_str(&format!("Paper: {}. ", experiment.paper));
        md.push_str(&format!("Command: `{}`.", experiment.command()));
        if let Some(run) = crate::machine_keys::run_of(&runs_json, experiment.name) {
            md.push_str(&format!(" Run: {}.", run.label()));
        }
        md.push_str("\n\n");
        match experiment.status {
            Status::Planned { .. } => {
                let why = experiment.planned_text().unwrap_or_default();
                md.push_str(&format!("*Skipped: {why}.*\n\n"));
            }
            Status::Ready { report, .. } => match report(ctx) {
                Ok(Some(section)) => {
                    md.push_str(section.trim_end());
                    md.push_str("\n\n");
                }
                Ok(None) => md.push_str(&format!(
                    "*Not run into this folder yet: run `{}`.*\n\n",
                    experiment.command()
                )),
                Err(e) => {
                    let problem = format!("{}: {e:#}", experiment.name);
                    md.push_str(&format!("**Cannot show the results:** {e:#}\n\n"));
                    problems.push(problem);
                }
            },
        }
    }
    (md.trim_end().to_owned() + "\n", problems)
}

/// Renders and writes `ctx.out/README.md`; returns its path and the rendering problems.
pub fn write(
    ctx: &Ctx,
    registry: &[Experiment],
    run: &RunInfo,
) -> anyhow::Result<(PathBuf, Vec<String>)> {
    let (md, problems) = render(ctx, registry, run);
    let path = ctx.path("README.md");
    std::fs::write(&path, md)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    Ok((path, problems))
}

/// The machine table, from `machine.json` in the folder.
fn machine_section(ctx: &Ctx, problems: &mut Vec<String>) -> String {
    let path = ctx.path("machine.json");
    let machine = std::fs::read_to_string(&path)
        .map_err(|e| e.to_string())
        .and_then(|text| Machine::from_json(&text).map_err(|e| e.to_string()));
    let runs = std::fs::read_to_string(&path)
        .map(|text| crate::machine_keys::runs(&text))
        .unwrap_or_default();
    let m = match machine {
        Ok(m) => m,
        Err(e) => {
            let problem = format!("{}: {e}", path.display());
            problems.push(problem.clone());
            return format!("**Cannot read `machine.json`:** {problem}\n\n");
        }
    };
    let list = |items: &[String]| {
        if items.is_empty() {
            "(none)".to_owned()
        } else {
            items.join(" ")
        }
    };
    let rows = vec![
        vec!["cpu".to_owned(), m.cpu.clone()],
        vec![
            "cores / threads".to_owned(),
            format!("{} / {}", m.cores, m.threads),
        ],
        vec!["cpu_features".to_owned(), list(&m.cpu_features)],
        vec![
            "target_features (build)".to_owned(),
            list(&m.target_features),
        ],
        vec!["rustc".to_owned(), m.rustc.clone()],
        vec![
            "rustflags".to_owned(),
            if m.rustflags.is_empty() {
                "(none)".to_owned()
            } else {
                format!("`{}`", m.rustflags)
            },
        ],
        vec!["profile".to_owned(), m.profile.clone()],
        vec!["backends (usable)".to_owned(), list(&m.backends)],
        vec![
            "backends skipped".to_owned(),
            if m.skipped_backends.is_empty() {
                "(none)".to_owned()
            } else {
                m.skipped_backends.join("; ")
            },
        ],
        vec!["git_rev".to_owned(), m.git_rev.clone()],
        vec!["date".to_owned(), m.date.clone()],
        vec!["os".to_owned(), m.os.clone()],
    ];
    let mut md = format!(
        "From [`machine.json`](machine.json), written by the last run.\n\n{}\n",
        markdown_table(&["key", "value"], &rows)
    );
    if !runs.is_empty() {
        let unknown = || "(not recorded)".to_owned();
        let rows: Vec<Vec<String>> = runs
            .into_iter()
            .map(|r| {
                vec![
                    format!("`{}`", r.experiment),
                    r.git_rev,
                    r.date,
                    r.cpu.unwrap_or_else(unknown),
                    r.os.unwrap_or_else(unknown),
                    r.probe_ms.map_or_else(unknown, |ms| format!("{ms:.1}")),
                    r.seconds
                        .map_or_else(unknown, |s| format!("{:.1}", s / 60.0)),
                ]
            })
            .collect();
        md.push_str(&format!(
            "The run that wrote each experiment's results here (`runs` in `machine.json`; \
             sections of experiments not listed come from runs before this record was kept). \
             The table above describes the last run's machine only: experiments whose `cpu` \
             differs from it were measured on another host. Hosts of the same CPU model differ \
             in speed too: `probe_ms` is a fixed single-thread \
             scalar loop timed when the experiment finished (median of 5), and the `os` line's \
             kernel build tells hosts apart. Ratios within an experiment (speedups, BSP / \
             Embree) come from one run; absolute times of two experiments compare only where \
             their probes agree. `minutes` is the experiment's wall time in that run (its \
             measurements and plots; not the build).\n\n{}\n",
            markdown_table(
                &[
                    "experiment",
                    "git_rev",
                    "date",
                    "cpu",
                    "os",
                    "probe_ms",
                    "minutes"
                ],
                &rows
            )
        ));
    }
    md
}

/// The table of contents: paper item -> experiment -> command -> CSV -> plots.
fn contents(ctx: &Ctx, registry: &[Experiment]) -> String {
    let link = |file: &str| {
        if ctx.path(file).is_file() {
            format!("[{file}]({file})")
        } else {
            format!("{file} (not written yet)")
        }
    };
    let rows: Vec<Vec<String>> = registry
        .iter()
        .map(|e| {
            let command = if e.is_ready() {
                format!("`reproduce --only {}`", e.name)
            } else {
                e.planned_text().unwrap_or_default()
            };
            let csv = e.csv.iter().map(|f| link(f)).collect::<Vec<_>>().join(", ");
            let plots = e
                .plots
                .iter()
                .map(|stem| link(&format!("plots/{stem}.png")))
                .collect::<Vec<_>>()
                .join(", ");
            vec![
                e.paper.to_owned(),
                format!("[{}](#{})", e.name, anchor(e)),
                command,
                csv,
                plots,
            ]
        })
        .collect();
    format!(
        "{}\n",
        markdown_table(
            &["paper item", "experiment", "command", "CSV", "plots"],
            &rows
        )
    )
}

/// The GitHub anchor of an experiment's section heading `name — description`.
pub(crate) fn anchor(e: &Experiment) -> String {
    let heading = format!("{} — {}", e.name, e.description);
    heading
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{LineChart, Series};

    const HEADER: &[&str] = &["kernel", "backend", "lanes", "seconds", "speedup"];

    fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
        let mut csv = ctx.csv("demo.csv", HEADER)?;
        csv.row(&[&"exp", &"scalar", &1, &0.5, &1.0])?;
        csv.row(&[&"exp", &"wide8", &8, &0.0666, &7.5])?;
        csv.finish()?;
        let chart = LineChart {
            title: "demo".into(),
            x_label: "lanes".into(),
            y_label: "speedup".into(),
            series: vec![Series::new("exp", vec![(1.0, 1.0), (8.0, 8.0)])],
            log2_x: true,
            log_y: false,
        };
        ctx.line_chart("demo", &chart)?;
        Ok(())
    }

    fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
        let Some(table) = ctx.read_csv("demo.csv", HEADER)? else {
            return Ok(None);
        };
        let mut md = table.to_markdown();
        if let Some(plot) = ctx.plot_markdown("demo", "speedup") {
            md.push_str(&plot);
        }
        Ok(Some(md))
    }

    fn registry() -> Vec<Experiment> {
        vec![
            Experiment {
                name: "demo",
                description: "a demonstration",
                paper: "Table 9",
                csv: &["demo.csv"],
                plots: &["demo"],
                status: Status::Ready {
                    run,
                    plot: crate::experiment::no_plots,
                    report,
                },
            },
            Experiment::planned(
                "later",
                "comes later",
                "Table 10",
                &["later.csv"],
                Some("the renderer"),
            ),
        ]
    }

    fn write_machine(ctx: &Ctx) {
        std::fs::write(ctx.path("machine.json"), ctx.machine.to_json()).unwrap();
    }

    #[test]
    fn readme_is_rendered_from_the_files_in_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = Ctx::new(dir.path(), true, Machine::detect());
        write_machine(&ctx);
        let registry = registry();

        // Before the experiment ran: the section says how to run it.
        let (md, problems) = render(&ctx, &registry, &RunInfo::default());
        assert!(problems.is_empty(), "{problems:?}");
        assert!(md.contains("*Not run into this folder yet"), "{md}");
        assert!(md.contains("demo.csv (not written yet)"), "{md}");
        assert!(
            md.contains("*Skipped: not implemented yet (it needs the renderer).*"),
            "{md}"
        );
        assert!(md.contains(&ctx.machine.cpu), "{md}");
        // The first screen comes first, before the details.
        let first = md.find("| paper | compared | paper's figures | ours | CSV |");
        let details = md.find("## About these results");
        assert!(first.is_some() && first < details, "{md}");
        assert!(details < md.find("## Machine"), "{md}");

        // After: the table comes from the CSV, the plot is linked.
        run(&mut ctx).unwrap();
        let info = RunInfo {
            ran: vec!["demo".into()],
            args: "--quick".into(),
        };
        let (path, problems) = write(&ctx, &registry, &info).unwrap();
        assert!(problems.is_empty(), "{problems:?}");
        let md = std::fs::read_to_string(path).unwrap();
        assert!(md.contains("| exp | wide8 | 8 | 0.0666 | 7.50 |"), "{md}");
        assert!(md.contains("| exp | scalar | 1 | 0.500 | 1.00 |"), "{md}");
        assert!(md.contains("[demo.csv](demo.csv)"), "{md}");
        assert!(md.contains("![speedup](plots/demo.png)"), "{md}");
        assert!(md.contains("`reproduce --quick`, which ran: demo."), "{md}");
        assert!(md.contains("[demo](#demo--a-demonstration)"), "{md}");
        // The section names the run behind it once one is recorded.
        assert!(!md.contains(" Run: `"), "{md}");
        let json = std::fs::read_to_string(ctx.path("machine.json")).unwrap();
        let json = crate::machine_keys::record_run(&json, "demo", &ctx.machine, 1.0, 2.0);
        std::fs::write(ctx.path("machine.json"), json).unwrap();
        let (md, _) = render(&ctx, &registry, &info);
        let rev = ctx.machine.git_rev.trim_end_matches("-dirty");
        let rev = rev.get(..7).unwrap_or(rev);
        assert!(md.contains(&format!("Run: `{rev}`")), "{md}");
        assert!(dir.path().join("plots/demo.png").is_file());
        assert!(dir.path().join("plots/demo.svg").is_file());

        // Redrawn without running anything (`--report-only`): said as such.
        let redrawn = RunInfo {
            ran: Vec::new(),
            args: "--report-only".into(),
        };
        let (md, _) = render(&ctx, &registry, &redrawn);
        assert!(
            md.contains("Last written by `reproduce --report-only`, which ran no experiment"),
            "{md}"
        );
        assert!(md.contains("| exp | wide8 | 8 | 0.0666 | 7.50 |"), "{md}");

        // A damaged CSV is reported in the README, not hidden.
        std::fs::write(ctx.path("demo.csv"), "wrong,header\n").unwrap();
        let (md, problems) = render(&ctx, &registry, &info);
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(md.contains("**Cannot show the results:**"), "{md}");
    }

    #[test]
    fn a_missing_machine_json_is_reported() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, Machine::detect());
        let (md, problems) = render(&ctx, &registry(), &RunInfo::default());
        assert_eq!(problems.len(), 1);
        assert!(md.contains("Cannot read `machine.json`"), "{md}");
    }
}
