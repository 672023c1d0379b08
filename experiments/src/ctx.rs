//! What an experiment gets to work with (paper section 7 is the set of experiments): the output
//! folder, the quick/full switch, the machine description, and helpers for CSVs, plots,
//! timing and progress bars.

use crate::plot::{self, BarChart, LineChart, PlotFiles};
use crate::table::{CsvOut, Table};
use crate::timing::{self, Timing};
use coherent::machine::Machine;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

/// The context of one `reproduce` run, passed to every experiment.
pub struct Ctx {
    /// The output folder (`results/` by default); CSVs at its top, plots under `plots/`.
    pub out: PathBuf,
    /// `--quick`: small sizes, the whole run under 3 minutes on 2 cores.
    pub quick: bool,
    /// The machine and build this run measures.
    pub machine: Machine,
    /// Draw progress bars (stderr is a terminal).
    progress: bool,
    /// Remarks gathered during the run, printed at its end.
    notes: Vec<String>,
}

impl Ctx {
    /// A context writing into `out` (which must exist).
    pub fn new(out: impl Into<PathBuf>, quick: bool, machine: Machine) -> Ctx {
        Ctx {
            out: out.into(),
            quick,
            machine,
            progress: std::io::stderr().is_terminal(),
            notes: Vec::new(),
        }
    }

    /// `quick` under `--quick`, else `full`: `ctx.pick(100_000, 10_000_000)`.
    pub fn pick<T>(&self, quick: T, full: T) -> T {
        if self.quick { quick } else { full }
    }

    /// `out/file`.
    pub fn path(&self, file: &str) -> PathBuf {
        self.out.join(file)
    }

    /// Starts writing `out/file` with this exact header (see [`CsvOut`]; call `finish`).
    pub fn csv(&self, file: &str, header: &[&str]) -> anyhow::Result<CsvOut> {
        CsvOut::create(&self.path(file), header)
    }

    /// Reads `out/file` against this exact header; `Ok(None)` when the file does not exist
    /// (the experiment has not been run into this folder yet).
    pub fn read_csv(&self, file: &str, header: &[&str]) -> anyhow::Result<Option<Table>> {
        let path = self.path(file);
        if !path.exists() {
            return Ok(None);
        }
        Table::read(&path, header).map(Some)
    }

    /// Writes a line chart as `plots/{stem}.png` and `.svg`.
    pub fn line_chart(&self, stem: &str, chart: &LineChart) -> anyhow::Result<PlotFiles> {
        plot::line_chart(&self.out, stem, chart)
    }

    /// Writes a grouped bar chart as `plots/{stem}.png` and `.svg`.
    pub fn bar_chart(&self, stem: &str, chart: &BarChart) -> anyhow::Result<PlotFiles> {
        plot::bar_chart(&self.out, stem, chart)
    }

    /// Writes a stacked bar chart (series stacked per category) as `plots/{stem}.png` and
    /// `.svg`.
    pub fn stacked_bar_chart(&self, stem: &str, chart: &BarChart) -> anyhow::Result<PlotFiles> {
        plot::stacked_bar_chart(&self.out, stem, chart)
    }

    /// Markdown showing `plots/{stem}.png` with a link to the SVG, if the PNG exists (it
    /// starts with a blank line, so it may follow a table).
    pub fn plot_markdown(&self, stem: &str, alt: &str) -> Option<String> {
        let png = format!("plots/{stem}.png");
        self.path(&png)
            .is_file()
            .then(|| format!("\n![{alt}]({png})\n\n([SVG](plots/{stem}.svg))\n"))
    }

    /// Times `f`: 1 warm-up run, then 3 (quick) or 7 (full) timed runs; see [`timing::time`].
    pub fn time<R>(&self, f: impl FnMut() -> R) -> Timing {
        timing::time(1, self.pick(3, 7), f)
    }

    /// A progress bar of `len` steps labelled `what`, drawn on stderr only when it is a
    /// terminal (hidden in CI). Call `inc(1)` per step and `finish_and_clear()` at the end.
    pub fn progress(&self, len: u64, what: &str) -> ProgressBar {
        let target = if self.progress {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(Some(len), target);
        if let Ok(style) =
            ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(what.to_owned());
        bar
    }

    /// Records a remark (a skipped mesh, a backend this CPU lacks): printed to stderr now and
    /// repeated in the run's summary.
    pub fn note(&mut self, text: impl Into<String>) {
        let text = text.into();
        eprintln!("note: {text}");
        self.notes.push(text);
    }

    /// The remarks of this run so far.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }
}
