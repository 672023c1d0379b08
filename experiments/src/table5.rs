//! Experiment `table5`: the paper's Table 5 (section 7), whole-frame rendering time with 1
//! and 2 threads and every core of the machine, with the speedup over 1 thread.
//!
//! Protocol: the scenes and frames of `table3` (the same plan: quick mode renders the small
//! scenes at 160 x 120), the BSP, the widest backend of this CPU and the scalar one; the
//! threads are a rayon pool installed around the render, as `coherent render --threads T`
//! does. Per scene and backend, every thread count renders once untimed, then rounds visit
//! every thread count in turn; `seconds` is the median. There are 3 rounds, or as many as make
//! the 1-thread frames add up to `TIMED_SECONDS` (at most `MAX_ROUNDS`): a 0.1 s frame
//! varies by more, relative to its length, than a 2 s one, and 2 threads' speedup is read off it.

use std::collections::BTreeMap;
use std::fmt::Display;

use coherent::accel_any::AccelKind;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::{self, Plan};
use crate::manycore::{MANYCORE, manycore_machine};
use crate::plot::{LineChart, Series};
use crate::table::{PaperTable, fmt_num, markdown_table};
use crate::timing::{median, speedup};

pub const EXPERIMENT: Experiment = Experiment {
    name: "table5",
    description: "rendering with 1, 2, ... threads",
    paper: "Table 5 (section 7)",
    csv: &[FILE],
    plots: &["table5_threads"],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

pub(crate) const FILE: &str = "table5_threads.csv";
/// Short frames get more rounds, until the 1-thread frames add up to this many seconds.
const TIMED_SECONDS: f64 = 2.0;
/// The fewest rounds.
const MIN_ROUNDS: usize = 3;
/// The most rounds.
const MAX_ROUNDS: usize = 15;

/// Rounds for a frame whose untimed 1-thread render took `seconds`.
fn rounds_for(seconds: f64) -> usize {
    let n = (TIMED_SECONDS / seconds.max(1e-6)).ceil();
    (n.min(MAX_ROUNDS as f64) as usize).max(MIN_ROUNDS)
}
/// The contract's columns, then the lanes of the backend.
pub(crate) const HEADER: &[&str] = &["scene", "backend", "threads", "seconds", "speedup", "lanes"];

/// The paper's Table 5 (its Car scene is called Polo there).
pub(crate) const PAPER: PaperTable = PaperTable {
    caption: "Table 5: a 1024 x 768 frame with SSE on 1 and 2 CPUs. Paper: dual Pentium III \
              933 MHz, its scenes (car = its Polo/Car); ours: the widest backend of this CPU \
              with the BSP, 1 and 2 threads, our stand-ins of its scenes. Seconds are not \
              comparable; the speedups are.",
    key: "scene",
    columns: &["1 CPU s", "2 CPU s", "speedup"],
    rows: &[
        ("car", &[82.11, 41.06, 2.00]),
        ("spdemo", &[2.63, 1.39, 1.89]),
        ("glass1", &[6.18, 3.20, 1.93]),
        ("room2", &[4.77, 2.49, 1.91]),
    ],
};

/// 2 threads over 1, the target.
const TARGET: f64 = 1.9;

/// 1, 2, the powers of two between, and every core, without repeats: 1, 2 on two cores,
/// 1, 2, 4, 8, 16 on sixteen, 1, 2, 4, 8, 12 on twelve.
pub fn thread_counts(cores: usize) -> Vec<usize> {
    let mut v = vec![1, 2];
    let mut n = 4;
    while n < cores {
        v.push(n);
        n *= 2;
    }
    v.push(cores.max(1));
    v.sort_unstable();
    v.dedup();
    v
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let plan = crate::table3::plan(ctx);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut backends = vec![frames::widest()];
    if backends[0] != Backend::Scalar {
        backends.push(Backend::Scalar);
    }
    run_plan(ctx, &plan, &backends, &thread_counts(cores))
}

/// Runs the experiment over `plan` with these backends and thread counts.
pub fn run_plan(
    ctx: &mut Ctx,
    plan: &Plan,
    backends: &[Backend],
    threads: &[usize],
) -> anyhow::Result<()> {
    let pools = threads
        .iter()
        .map(|&t| frames::pool(t))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let specs = frames::scene_specs(plan);
    let bar = ctx.progress(specs.len() as u64, "table5");
    for (name, spec) in &specs {
        bar.set_message(name.clone());
        let Some(scene) = frames::load_or_note(ctx, "table5", plan, name, spec) else {
            bar.inc(1);
            continue;
        };
        let r = frames::renderer(&scene, AccelKind::Bsp)?;
        for &b in backends {
            let mut seconds: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
            let mut warm = Vec::with_capacity(pools.len());
            for pool in &pools {
                warm.push(frames::frame(pool, b, &r, plan)?.1); // untimed
            }
            for _ in 0..rounds_for(warm[0]) {
                for (i, pool) in pools.iter().enumerate() {
                    let (_, s) = frames::frame(pool, b, &r, plan)?;
                    seconds.entry(i).or_default().push(s);
                }
            }
            let one = median(&seconds[&0]);
            for (i, &t) in threads.iter().enumerate() {
                let s = median(&seconds[&i]);
                let cells: [&dyn Display; 6] = [
                    name,
                    &b.name(),
                    &t,
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(one, s)),
                    &b.lanes(),
                ];
                csv.row(&cells)?;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(());
    };
    let mut series = Vec::new();
    let mut max_threads = 1.0f64;
    for s in t.distinct("scene")? {
        for b in t.distinct("backend")? {
            let mut pts = Vec::new();
            for r in t.rows_where("scene", &s)? {
                if t.get(r, "backend")? == b {
                    let n = t.f64(r, "threads")?;
                    max_threads = max_threads.max(n);
                    pts.push((n, t.f64(r, "speedup")?));
                }
            }
            if !pts.is_empty() {
                series.push(Series::new(format!("{s} {b}"), pts));
            }
        }
    }
    if series.is_empty() {
        return Ok(());
    }
    series.push(Series::reference(
        "ideal (= threads)",
        vec![(1.0, 1.0), (max_threads, max_threads)],
    ));
    ctx.line_chart(
        "table5_threads",
        &LineChart {
            title: "Table 5: whole-frame speedup over 1 thread (BSP)".into(),
            x_label: "threads".into(),
            y_label: "speedup over 1 thread".into(),
            series,
            log2_x: true,
            log_y: false,
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut md = format!(
        "The frames of `table3` (same scenes, size and samples; BSP) on a rayon pool of 1, 2, \
         4, ... and every core of the machine (`machine.json`), with the widest backend of this CPU \
         and the scalar one; every thread count renders once untimed, then rounds visit \
         them in turn and `seconds` is the median ({MIN_ROUNDS} rounds, more for short frames: \
         as many as make the 1-thread frames add up to {TIMED_SECONDS} s, at most {MAX_ROUNDS}); \
         `speedup` = 1-thread seconds / this row's. \
         On a machine shared with other work, the speedup reads low.\n\n",
    );
    let find = |s: &str, b: &str, n: &str| -> anyhow::Result<Option<usize>> {
        for r in t.rows_where("scene", s)? {
            if t.get(r, "backend")? == b && t.get(r, "threads")? == n {
                return Ok(Some(r));
            }
        }
        Ok(None)
    };
    // The widest backend in the file (the one beside the paper's SSE).
    let mut simd: Option<(usize, String)> = None;
    for r in 0..t.rows.len() {
        let lanes = t.f64(r, "lanes")? as usize;
        if simd.as_ref().is_none_or(|(l, _)| lanes > *l) {
            simd = Some((lanes, t.get(r, "backend")?.to_owned()));
        }
    }
    let simd = simd.map(|(_, b)| b).unwrap_or_else(|| "scalar".to_owned());
    let mut ours = Vec::new();
    for s in t.distinct("scene")? {
        let get = |n: &str, c: &str| -> anyhow::Result<Option<f64>> {
            Ok(match find(&s, &simd, n)? {
                Some(r) => Some(t.f64(r, c)?),
                None => None,
            })
        };
        ours.push((
            s.clone(),
            vec![
                get("1", "seconds")?,
                get("2", "seconds")?,
                get("2", "speedup")?,
            ],
        ));
    }
    md.push_str(&PAPER.beside(&ours));
    md.push_str(&format!("\n(ours: backend `{simd}`.) Every row:\n\n"));
    md.push_str(&every_row(&t)?);
    if let Some(p) = ctx.plot_markdown("table5_threads", "speedup over 1 thread") {
        md.push_str(&p);
    }
    if let Some(more) = manycore_report(ctx)? {
        md.push_str(&more);
    }
    Ok(Some(md))
}

/// Every row of `t`: per scene and backend, seconds and speedup at each thread count, and
/// whether 2 threads reach the target.
fn every_row(t: &crate::Table) -> anyhow::Result<String> {
    let find = |s: &str, b: &str, n: &str| -> anyhow::Result<Option<usize>> {
        for r in t.rows_where("scene", s)? {
            if t.get(r, "backend")? == b && t.get(r, "threads")? == n {
                return Ok(Some(r));
            }
        }
        Ok(None)
    };
    let threads = t.distinct("threads")?;
    let mut header = vec!["scene".to_owned(), "backend".to_owned()];
    header.extend(threads.iter().map(|n| format!("{n} threads")));
    header.push("2 threads >= 1.9x".to_owned());
    let mut rows = Vec::new();
    for s in t.distinct("scene")? {
        for b in t.distinct("backend")? {
            let mut row = vec![s.clone(), b.clone()];
            for n in &threads {
                row.push(match find(&s, &b, n)? {
                    Some(r) => format!(
                        "{} s ({}x)",
                        fmt_num(t.f64(r, "seconds")?),
                        fmt_num(t.f64(r, "speedup")?)
                    ),
                    None => "—".into(),
                });
            }
            row.push(match find(&s, &b, "2")? {
                Some(r) if t.f64(r, "speedup")? >= TARGET => "met".into(),
                Some(_) => "not met".into(),
                None => "— (one core)".into(),
            });
            rows.push(row);
        }
    }
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    Ok(markdown_table(&h, &rows))
}

/// The same experiment run on a machine with more cores, into `manycore/` beside these
/// results (`scripts/reproduce.sh --only table5 --out results/manycore` there), if it exists:
/// its machine and every row.
fn manycore_report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(&format!("{MANYCORE}/{FILE}"), HEADER)? else {
        return Ok(None);
    };
    let about = manycore_machine(ctx, "table5");
    let mut md = format!(
        "\n### On a machine with more cores\n\nThe same frames, backends and protocol on {about} \
         (`{MANYCORE}/`: its own [README]({MANYCORE}/README.md), `machine.json` and CSV). A \
         machine of this project has 2 cores; this one was lent for a session, so its rows are \
         from another CPU and another build date than the rest of this report.\n\n"
    );
    md.push_str(&every_row(&t)?);
    if ctx
        .path(&format!("{MANYCORE}/plots/table5_threads.png"))
        .is_file()
    {
        md.push_str(&format!(
            "\n![speedup over 1 thread, more cores]({MANYCORE}/plots/table5_threads.png)\n"
        ));
    }
    Ok(Some(md))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_frames_get_more_rounds() {
        assert_eq!(rounds_for(2.5), 3);
        assert_eq!(rounds_for(0.5), 4);
        assert_eq!(rounds_for(0.09), 15);
        assert_eq!(rounds_for(0.2), 10);
        assert_eq!(rounds_for(0.0), 15);
    }

    #[test]
    fn thread_counts_are_deduplicated() {
        assert_eq!(thread_counts(1), [1, 2]);
        assert_eq!(thread_counts(2), [1, 2]);
        assert_eq!(thread_counts(16), [1, 2, 4, 8, 16]);
        assert_eq!(thread_counts(12), [1, 2, 4, 8, 12]);
    }

    #[test]
    fn rows_per_thread_count_and_a_report() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        let plan = Plan {
            builtins: true,
            scenes_dir: dir.path().join("no-scenes"),
            max_triangles: 1_000,
            width: 16,
            height: 12,
            spp: 1,
        };
        run_plan(&mut ctx, &plan, &[Backend::Scalar], &[1, 2]).unwrap();
        let t = ctx.read_csv(FILE, HEADER).unwrap().unwrap();
        // spdemo (988 triangles) is the only built-in under 1,000.
        assert_eq!(t.distinct("scene").unwrap(), ["spdemo"]);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.f64(0, "speedup").unwrap(), 1.0);
        let md = report(&ctx).unwrap().unwrap();
        assert!(md.contains("| spdemo | 2.63 |"), "{md}");
        assert!(!md.contains("more cores"), "{md}");
        // A run from another machine in `manycore/` is shown with that machine.
        std::fs::create_dir(dir.path().join(MANYCORE)).unwrap();
        std::fs::copy(ctx.path(FILE), ctx.path(&format!("{MANYCORE}/{FILE}"))).unwrap();
        std::fs::write(
            ctx.path(&format!("{MANYCORE}/machine.json")),
            r#"{"cpu": "Big CPU", "cores": 16, "threads": 32, "git_rev": "abc", "date": "d"}"#,
        )
        .unwrap();
        let md = report(&ctx).unwrap().unwrap();
        assert!(md.contains("### On a machine with more cores"), "{md}");
        assert!(
            md.contains("Big CPU with 16 cores (32 hardware threads), git revision `abc`, d"),
            "{md}"
        );
        // A later run of another experiment there: the rows keep their own run's revision.
        std::fs::write(
            ctx.path(&format!("{MANYCORE}/machine.json")),
            r#"{"cpu": "Big CPU", "cores": 16, "threads": 32, "git_rev": "new", "date": "now",
                "runs": {"table5": {"git_rev": "old", "date": "then"}}}"#,
        )
        .unwrap();
        let md = report(&ctx).unwrap().unwrap();
        assert!(md.contains("git revision `old`, then"), "{md}");
    }
}
