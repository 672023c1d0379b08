//! The first screen of `results/README.md`: the paper's Tables 1-5 (section 7) against ours in
//! one line each, three plots and the machine. Every figure is computed from the CSV files
//! and `machine.json` in the output folder, as the sections below it are.

use crate::ctx::Ctx;
use crate::experiment::Experiment;
use crate::table::{PaperTable, Table, fmt_num, markdown_table};
use crate::{table1, table2, table3, table4, table5};
use coherent::machine::Machine;
use coherent::simd::Backend;

/// The plots of the first screen, one per slot: the first stem of each slot whose PNG exists.
pub const PLOTS: &[&[(&str, &str)]] = &[
    &[
        ("table3_speedup", "Table 3: whole-frame speedup over scalar"),
        ("table1_speedup", "Table 1: BDF speedup over scalar"),
    ],
    &[
        (
            "accel_primary",
            "primary rays: Mrays/s per accelerator and width",
        ),
        ("accel_mrays", "BSP: Mrays/s per scene and ray kind"),
    ],
    &[
        (
            "kernels_speedup",
            "approximation kernels: speedup over scalar",
        ),
        ("table2_speedup", "Table 2: lighting speedup over scalar"),
    ],
];

/// The CPU features the first screen names (the rest are in the machine table).
const SIMD_FEATURES: &[&str] = &[
    "sse2",
    "sse4.2",
    "avx",
    "avx2",
    "fma",
    "avx512f",
    "avx512bw",
    "avx512vl",
    "avx512fp16",
    "neon",
    "sve",
];

/// The first screen, Markdown, ending with a blank line.
pub fn render(ctx: &Ctx, registry: &[Experiment]) -> String {
    let mut md = String::from(
        "The paper's Tables 1-5 against ours at a glance, computed from the CSV files in this \
         folder. The paper's figures are its SSE renderer's (4 lanes) over its non-SSE one; \
         ours are ranges over the compared rows, per lane-backend family, each over scalar in \
         the same run (`wide` and `pulp` are the portable backends; their lane counts follow \
         the name). The sections below have every row.\n\n",
    );
    let emulated = std::fs::read_to_string(ctx.path("machine.json"))
        .ok()
        .and_then(|t| Machine::from_json(&t).ok())
        .filter(Machine::is_emulated);
    if let Some(m) = &emulated {
        md.push_str(&format!(
            "**Under emulation: these times are not measurements.** This run is {}. Every \
             time below is the emulator's, so the run is a smoke test that each experiment \
             runs on {}; this screen compares none of them with the paper.\n\n",
            m.emulated, m.arch
        ));
    }
    md.push_str(&table(ctx, registry, emulated.is_some()));
    md.push('\n');
    md.push_str(&runs_note(ctx));
    md.push_str("\n\n");

    let plots: Vec<String> = PLOTS
        .iter()
        .filter_map(|slot| {
            slot.iter()
                .find(|(stem, _)| ctx.path(&format!("plots/{stem}.png")).is_file())
        })
        .map(|(stem, alt)| {
            format!(
                "<a href=\"plots/{stem}.svg\"><img src=\"plots/{stem}.png\" width=\"32%\" \
                 alt=\"{alt}\" title=\"{alt}\"></a>"
            )
        })
        .collect();
    if !plots.is_empty() {
        md.push_str(&plots.join("\n"));
        md.push_str("\n\n");
    }
    md.push_str(&machine_line(ctx));
    md
}

/// The paper's Tables 1-5 against ours, a line each, as a Markdown table (links relative to
/// the results folder). `emulated`: the run's times are an emulator's, so none is compared.
pub fn table(ctx: &Ctx, registry: &[Experiment], emulated: bool) -> String {
    let json = std::fs::read_to_string(ctx.path("machine.json")).unwrap_or_default();
    let rows: Vec<Vec<String>> = [
        ("table1", table1_row(ctx)),
        ("table2", table2_row(ctx)),
        ("table3", table3_row(ctx)),
        ("table4", table4_row(ctx)),
        ("table5", table5_row(ctx)),
    ]
    .into_iter()
    .map(|(name, row)| {
        let experiment = registry.iter().find(|e| e.name == name);
        let title = experiment.map_or_else(
            || name.to_owned(),
            |e| {
                let table = e.paper.split(" (").next().unwrap_or(e.paper);
                format!("[{table}](#{})", crate::readme::anchor(e))
            },
        );
        let (what, paper, ours, file) = row;
        let ours = match ours {
            Ok(Some(_)) if emulated => "*emulated run: not compared*".to_owned(),
            Ok(Some(text)) => text,
            Ok(None) => format!("*not run into this folder yet (`reproduce --only {name}`)*"),
            Err(e) => format!("**cannot read:** {e:#}"),
        };
        let file = if ctx.path(file).is_file() {
            format!("[{file}]({file})")
        } else {
            file.to_owned()
        };
        let run = crate::machine_keys::run_of(&json, name)
            .map_or_else(|| "not recorded".to_owned(), |r| r.label());
        vec![title, what.to_owned(), paper, ours, file, run]
    })
    .collect();
    markdown_table(
        &["paper", "compared", "paper's figures", "ours", "CSV", "run"],
        &rows,
    )
}

/// The experiments of the headline's rows.
const HEADLINE_EXPERIMENTS: [&str; 5] = ["table1", "table2", "table3", "table4", "table5"];

/// Where the headline's rows come from: one run named, or the runs counted when the rows mix
/// revisions or CPUs (each row's `run` column then names its own), and a warning for runs
/// from a tree with uncommitted changes.
pub fn runs_note(ctx: &Ctx) -> String {
    let json = std::fs::read_to_string(ctx.path("machine.json")).unwrap_or_default();
    let runs: Vec<_> = HEADLINE_EXPERIMENTS
        .iter()
        .filter_map(|name| crate::machine_keys::run_of(&json, name))
        .collect();
    let mut distinct: Vec<(&str, Option<&str>)> = Vec::new();
    for r in &runs {
        let key = (r.git_rev.as_str(), r.cpu.as_deref());
        if !distinct.contains(&key) {
            distinct.push(key);
        }
    }
    let unrecorded = HEADLINE_EXPERIMENTS.len() - runs.len();
    let mut note = match (distinct.len(), unrecorded) {
        (0, _) => "No run of these rows is recorded in `machine.json`.".to_owned(),
        (1, 0) => format!("Every row from one run: {}.", runs[0].label()),
        (n, u) => format!(
            "**The rows do not come from one run**: {n} recorded run{}{} (the `run` column \
             names each row's). Compare rows with care, or regenerate them in one \
             `scripts/reproduce.sh`.",
            if n == 1 { "" } else { "s" },
            if u == 0 {
                String::new()
            } else {
                format!(
                    " and {u} row{} from before runs were recorded",
                    if u == 1 { "" } else { "s" }
                )
            }
        ),
    };
    if runs.iter().any(|r| r.dirty()) {
        note.push_str(
            " Rows from a tree with uncommitted changes cannot be reproduced from a revision.",
        );
    }
    note
}

/// One headline row: what is compared, the paper's figures, ours (`None`: no CSV), the CSV.
type Row = (
    &'static str,
    String,
    anyhow::Result<Option<String>>,
    &'static str,
);

fn table1_row(ctx: &Ctx) -> Row {
    const FILE: &str = "table1_bdf.csv";
    let ours = ctx.read_csv(FILE, table1::HEADER).and_then(|t| {
        t.map(|t| by_family(&t, "calls", None, |_| Ok(true), false))
            .transpose()
    });
    (
        "anisotropic BDF evaluations, speedup",
        paper_range(&table1::PAPER, 2, "x"),
        ours,
        FILE,
    )
}

fn table2_row(ctx: &Ctx) -> Row {
    let ours = ctx.read_csv(table2::FILE, table2::HEADER).and_then(|t| {
        t.map(|t| {
            let shadows = t.col("shadows")?;
            by_family(
                &t,
                "light",
                Some(&table2::PAPER),
                |r| Ok(t.rows[r][shadows] == "0"),
                false,
            )
        })
        .transpose()
    });
    (
        "lighting per light kind (no shadows), speedup",
        paper_range(&table2::PAPER, 2, "x"),
        ours,
        table2::FILE,
    )
}

fn table3_row(ctx: &Ctx) -> Row {
    let ours = ctx.read_csv(table3::FILE, table3::HEADER).and_then(|t| {
        t.map(|t| {
            let accel = t.col("accel")?;
            by_family(
                &t,
                "scene",
                Some(&table3::PAPER),
                |r| Ok(t.rows[r][accel] == "bsp"),
                false,
            )
        })
        .transpose()
    });
    (
        "whole frame, the paper's scenes, 1 thread, BSP, speedup",
        paper_range(&table3::PAPER, 2, "x"),
        ours,
        table3::FILE,
    )
}

fn table4_row(ctx: &Ctx) -> Row {
    let ours = ctx
        .read_csv(table4::FILE, table4::HEADER)
        .and_then(|t| t.map(|t| scenes(&t)).transpose());
    (
        "the test scenes: triangles, lights, depth",
        paper_range(&table4::PAPER, 0, " triangles"),
        ours,
        table4::FILE,
    )
}

fn table5_row(ctx: &Ctx) -> Row {
    let ours = ctx.read_csv(table5::FILE, table5::HEADER).and_then(|t| {
        t.map(|t| {
            let threads = t.col("threads")?;
            by_family(
                &t,
                "scene",
                Some(&table5::PAPER),
                |r| Ok(t.rows[r][threads] == "2"),
                true,
            )
        })
        .transpose()
    });
    (
        "whole frame, 2 threads over 1, the paper's scenes",
        paper_range(&table5::PAPER, 2, "x"),
        ours,
        table5::FILE,
    )
}

/// `lo-hi` of the paper's column `col`, with `unit` after it.
fn paper_range(paper: &PaperTable, col: usize, unit: &str) -> String {
    range(
        paper.rows.iter().filter_map(|(_, v)| v.get(col).copied()),
        unit,
    )
    .unwrap_or_else(|| "—".to_owned())
}

/// `lo-hi` (or one figure when both print the same) with `unit` after it; `None` when empty.
fn range(values: impl Iterator<Item = f64>, unit: &str) -> Option<String> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut any = false;
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
        any = true;
    }
    if !any {
        return None;
    }
    let (l, h) = (fmt_num(lo), fmt_num(hi));
    Some(if l == h {
        format!("{l}{unit}")
    } else {
        format!("{l}-{h}{unit}")
    })
}

/// The family of a lane backend named in a results file ([`Backend::family`]); a name this
/// build does not know is its own family.
fn family(backend: &str) -> &str {
    match Backend::named(backend) {
        Some(b) => b.family(),
        None => backend,
    }
}

/// `speedup` per backend family as `label lo-hix`, joined by `; `: over the rows that pass
/// `keep`, and, with `paper`, whose column `key` is one of the paper's keys (all kept rows
/// when none is). The scalar rows are left out unless `with_scalar`.
fn by_family(
    t: &Table,
    key: &str,
    paper: Option<&PaperTable>,
    keep: impl Fn(usize) -> anyhow::Result<bool>,
    with_scalar: bool,
) -> anyhow::Result<String> {
    let (key, backend) = (t.col(key)?, t.col("backend")?);
    let mut kept = Vec::new();
    for r in 0..t.rows.len() {
        if keep(r)? && (with_scalar || t.rows[r][backend] != "scalar") {
            kept.push(r);
        }
    }
    if let Some(paper) = paper {
        let in_paper: Vec<usize> = kept
            .iter()
            .copied()
            .filter(|&r| paper.rows.iter().any(|(k, _)| *k == t.rows[r][key]))
            .collect();
        if !in_paper.is_empty() {
            kept = in_paper;
        }
    }
    // (family, its backends in order of appearance, the speedups)
    let mut families: Vec<(String, Vec<String>, Vec<f64>)> = Vec::new();
    for r in kept {
        let b = &t.rows[r][backend];
        let f = family(b).to_owned();
        let s = t.f64(r, "speedup")?;
        match families.iter_mut().find(|(name, _, _)| *name == f) {
            Some((_, members, values)) => {
                if !members.contains(b) {
                    members.push(b.clone());
                }
                values.push(s);
            }
            None => families.push((f, vec![b.clone()], vec![s])),
        }
    }
    // The dispatch module's order of families; others follow in order of appearance.
    let order = Backend::families();
    let rank = |f: &str| order.iter().position(|x| *x == f).unwrap_or(order.len());
    families.sort_by_key(|(f, _, _)| rank(f.as_str()));
    let cells: Vec<String> = families
        .iter()
        .map(|(f, members, values)| {
            let label = if members.len() == 1 {
                members[0].clone()
            } else {
                let widths: Vec<&str> = members
                    .iter()
                    .map(|m| m.strip_prefix(f.as_str()).unwrap_or(m.as_str()))
                    .collect();
                format!("{f}{}", widths.join("/"))
            };
            let figure = range(values.iter().copied(), "x").unwrap_or_default();
            format!("{label} {figure}")
        })
        .collect();
    Ok(if cells.is_empty() {
        "(no rows)".to_owned()
    } else {
        cells.join("; ")
    })
}

/// Table 4: our stand-ins' triangles beside the paper's, and their lights and depth.
fn scenes(t: &Table) -> anyhow::Result<String> {
    let paper = &table4::PAPER;
    let mut triangles = Vec::new();
    let mut worst: f64 = 0.0;
    let (mut same, mut compared) = (0, 0);
    for r in 0..t.rows.len() {
        let scene = t.get(r, "scene")?;
        let Some((_, p)) = paper.rows.iter().find(|(k, _)| *k == scene) else {
            continue;
        };
        let tri = t.f64(r, "triangles")?;
        triangles.push(tri);
        worst = worst.max((tri / p[0] - 1.0).abs());
        compared += 1;
        if t.f64(r, "lights")? == p[1] && t.f64(r, "depth")? == p[2] {
            same += 1;
        }
    }
    let Some(tri) = range(triangles.into_iter(), " triangles") else {
        return Ok("(none of the paper's scenes)".to_owned());
    };
    Ok(format!(
        "{tri}, each within {:.1} % of the paper's; lights and depth as the paper's in {same} \
         of {compared} scenes",
        100.0 * worst
    ))
}

/// The machine in one paragraph, from `machine.json` (its table is further down), and the
/// hosts of experiments measured on another CPU.
fn machine_line(ctx: &Ctx) -> String {
    let Ok(text) = std::fs::read_to_string(ctx.path("machine.json")) else {
        return "**Machine:** `machine.json` is missing.\n\n".to_owned();
    };
    let Ok(m) = Machine::from_json(&text) else {
        return "**Machine:** `machine.json` cannot be read (see below).\n\n".to_owned();
    };
    let simd: Vec<&str> = SIMD_FEATURES
        .iter()
        .copied()
        .filter(|f| m.cpu_features.iter().any(|c| c == f))
        .collect();
    let more = m.cpu_features.len().saturating_sub(simd.len());
    let mut features = if simd.is_empty() {
        "(none recorded)".to_owned()
    } else {
        simd.join(" ")
    };
    if more > 0 {
        features.push_str(&format!(" (+{more} more)"));
    }
    let build = crate::machine_keys::get_key(&text, "build")
        .unwrap_or_else(|| crate::machine_keys::build_value(&m).to_owned());
    let build = build.trim_matches('"');
    let target = if m.target_features.is_empty() {
        "(none)".to_owned()
    } else {
        m.target_features.join(" ")
    };
    let rustflags = if m.rustflags.is_empty() {
        "no RUSTFLAGS".to_owned()
    } else {
        format!("RUSTFLAGS `{}`", m.rustflags)
    };
    let mut md = format!(
        "**Machine** (the last run's, [`machine.json`](machine.json)): {}, {} cores / {} \
         threads; features {features}; build: {} {build}{} (target features {target}, \
         {rustflags}), {}.",
        m.cpu,
        m.cores,
        m.threads,
        m.profile,
        if m.arch.is_empty() {
            String::new()
        } else {
            format!(" for {}", m.arch)
        },
        m.rustc
    );
    // Experiments measured on another CPU model, grouped by it.
    let mut elsewhere: Vec<(String, Vec<String>)> = Vec::new();
    for run in crate::machine_keys::runs(&text) {
        let Some(cpu) = run.cpu.filter(|c| *c != m.cpu) else {
            continue;
        };
        match elsewhere.iter_mut().find(|(c, _)| *c == cpu) {
            Some((_, names)) => names.push(run.experiment),
            None => elsewhere.push((cpu, vec![run.experiment])),
        }
    }
    if !elsewhere.is_empty() {
        let hosts: Vec<String> = elsewhere
            .iter()
            .map(|(cpu, names)| format!("{} on {cpu}", names.join(", ")))
            .collect();
        md.push_str(&format!(
            " Measured on another host: {} (see the runs table below).",
            hosts.join("; ")
        ));
    }
    md.push_str("\n\n");
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(ctx: &Ctx, file: &str, text: &str) {
        std::fs::write(ctx.path(file), text).unwrap();
    }

    /// A small output folder: one or two rows per table, a plot, a machine.json.
    fn folder(ctx: &Ctx) {
        write(
            ctx,
            "table1_bdf.csv",
            "calls,backend,lanes,seconds,speedup\n\
             10000,scalar,1,1.0,1.0\n10000,sse,4,0.4,2.5\n20000,sse,4,0.35,2.857\n\
             10000,wide4,4,0.5,2.0\n10000,wide8,8,0.25,4.0\n10000,avx2,8,0.2,5.0\n",
        );
        write(
            ctx,
            table2::FILE,
            "light,backend,lanes,shadows,seconds,speedup\n\
             omni,scalar,1,0,1.0,1.0\nomni,sse,4,0,0.125,8.0\nomni,sse,4,1,0.5,2.0\n\
             spot,sse,4,0,0.25,4.0\n",
        );
        write(
            ctx,
            table3::FILE,
            "scene,backend,lanes,accel,seconds,speedup,psnr_db,mrays_s,rays,width,height,spp\n\
             car,scalar,1,bsp,2,1,inf,1,1,8,8,1\ncar,avx512,16,bsp,0.5,4,inf,1,1,8,8,1\n\
             car,avx512,16,embree,0.1,20,50,1,1,8,8,1\nbunny,avx512,16,bsp,0.1,30,inf,1,1,8,8,1\n\
             room2,pulp8,8,bsp,1,2,inf,1,1,8,8,1\nroom2,pulp16,16,bsp,0.5,3,inf,1,1,8,8,1\n",
        );
        write(
            ctx,
            table4::FILE,
            "scene,triangles,objects,lights,depth,materials,light_kinds\n\
             car,230000,9,4,2,4,spot\nspdemo,988,7,3,2,4,omni\nbunny,5000,1,1,1,1,omni\n",
        );
        write(
            ctx,
            table5::FILE,
            "scene,backend,threads,seconds,speedup,lanes\n\
             car,avx512,1,1,1,16\ncar,avx512,2,0.52,1.923,16\ncar,scalar,2,0.5,2.0,1\n",
        );
        std::fs::create_dir_all(ctx.path("plots")).unwrap();
        write(ctx, "plots/accel_mrays.png", "png");
        write(ctx, "plots/kernels_speedup.png", "png");
        let mut m = ctx.machine.clone();
        m.cpu = "Test CPU 9000".into();
        m.cores = 2;
        m.threads = 4;
        m.cpu_features = vec!["sse2".into(), "avx2".into(), "popcnt".into()];
        m.target_features = vec!["sse".into(), "sse2".into()];
        m.rustflags = String::new();
        m.profile = "release".into();
        m.arch = "x86_64".into();
        m.emulated = String::new();
        let json = m.to_json();
        let json = crate::machine_keys::set_key(&json, "build", "\"portable\"");
        let json = crate::machine_keys::set_key(
            &json,
            "runs",
            concat!(
                r#"{"accel": {"git_rev": "a", "date": "d", "cpu": "Other CPU"}, "#,
                r#""table1": {"git_rev": "a", "date": "d", "cpu": "Test CPU 9000"}}"#
            ),
        );
        write(ctx, "machine.json", &json);
    }

    #[test]
    fn the_headline_is_computed_from_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, Machine::detect());
        folder(&ctx);
        let md = render(&ctx, crate::EXPERIMENTS);
        let line = |table: &str| {
            md.lines()
                .find(|l| l.starts_with(&format!("| [{table}](#")))
                .unwrap_or_else(|| panic!("no line for {table}: {md}"))
                .to_owned()
        };
        // Table 1: every call count, scalar left out, wide4/wide8 as one family.
        let t1 = line("Table 1");
        assert!(t1.contains("| 3.17-3.43x |"), "{t1}");
        assert!(
            t1.contains("| sse 2.50-2.86x; avx2 5.00x; wide4/8 2.00-4.00x |"),
            "{t1}"
        );
        assert!(t1.contains("[table1_bdf.csv](table1_bdf.csv)"), "{t1}");
        // Table 2: lighting only (shadows 0).
        let t2 = line("Table 2");
        assert!(t2.contains("| 3.87-7.24x | sse 4.00-8.00x |"), "{t2}");
        // Table 3: the BSP rows of the paper's scenes only.
        let t3 = line("Table 3");
        assert!(
            t3.contains("| 5.97-16.5x | avx512 4.00x; pulp8/16 2.00-3.00x |"),
            "{t3}"
        );
        // Table 4: triangles and the match with the paper.
        let t4 = line("Table 4");
        assert!(t4.contains("| 988-233000 triangles |"), "{t4}");
        assert!(
            t4.contains(
                "988-230000 triangles, each within 1.3 % of the paper's; lights and depth as \
                 the paper's in 2 of 2 scenes"
            ),
            "{t4}"
        );
        // Table 5: 2 threads, scalar kept.
        let t5 = line("Table 5");
        assert!(
            t5.contains("| 1.89-2.00x | scalar 2.00x; avx512 1.92x |"),
            "{t5}"
        );
        // The plots: the first existing stem of each slot.
        assert!(!md.contains("table3_speedup.png"), "{md}");
        assert!(md.contains("<img src=\"plots/accel_mrays.png\""), "{md}");
        assert!(
            md.contains("<img src=\"plots/kernels_speedup.png\""),
            "{md}"
        );
        // The machine.
        assert!(
            md.contains(
                "Test CPU 9000, 2 cores / 4 threads; features sse2 avx2 (+1 more); build: \
                 release portable for x86_64 (target features sse sse2, no RUSTFLAGS)"
            ),
            "{md}"
        );
        assert!(
            md.contains("Measured on another host: accel on Other CPU"),
            "{md}"
        );
    }

    /// `folder`'s machine.json with `runs` set to one entry per headline experiment, the
    /// revision of each given.
    fn with_runs(ctx: &Ctx, revs: [&str; 5]) {
        let text = std::fs::read_to_string(ctx.path("machine.json")).unwrap();
        let runs: Vec<String> = HEADLINE_EXPERIMENTS
            .iter()
            .zip(revs)
            .map(|(name, rev)| {
                format!(r#""{name}": {{"git_rev": "{rev}", "date": "2026-11-29T08:00:00Z", "cpu": "Test CPU 9000"}}"#)
            })
            .collect();
        let json = crate::machine_keys::set_key(&text, "runs", &format!("{{{}}}", runs.join(", ")));
        write(ctx, "machine.json", &json);
    }

    #[test]
    fn each_row_names_its_run_and_a_mixed_table_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, Machine::detect());
        folder(&ctx);
        let one = "0123456789abcdef";
        with_runs(&ctx, [one; 5]);
        let md = render(&ctx, crate::EXPERIMENTS);
        assert!(
            md.contains("Every row from one run: `0123456` on Test CPU 9000, 2026-11-29."),
            "{md}"
        );
        assert_eq!(
            md.matches("| `0123456` on Test CPU 9000, 2026-11-29 |")
                .count(),
            5,
            "{md}"
        );
        assert!(!md.contains("do not come from one run"), "{md}");
        // One row from another revision, one from an uncommitted tree.
        with_runs(
            &ctx,
            [one, one, "fedcba9876543210", one, "0123456789abcdef-dirty"],
        );
        let md = render(&ctx, crate::EXPERIMENTS);
        assert!(
            md.contains("**The rows do not come from one run**: 3 recorded runs"),
            "{md}"
        );
        assert!(
            md.contains("| `fedcba9` on Test CPU 9000, 2026-11-29 |"),
            "{md}"
        );
        assert!(
            md.contains("`0123456` (**a tree with uncommitted changes**)"),
            "{md}"
        );
        assert!(md.contains("cannot be reproduced from a revision"), "{md}");
        // Rows with no record are counted as such.
        let md = {
            let text = std::fs::read_to_string(ctx.path("machine.json")).unwrap();
            let json = crate::machine_keys::set_key(
                &text,
                "runs",
                &format!(r#"{{"table1": {{"git_rev": "{one}", "date": "d", "cpu": "C"}}}}"#),
            );
            write(&ctx, "machine.json", &json);
            render(&ctx, crate::EXPERIMENTS)
        };
        assert!(
            md.contains("1 recorded run and 4 rows from before runs were recorded"),
            "{md}"
        );
        assert_eq!(md.matches("| not recorded |").count(), 4, "{md}");
    }

    #[test]
    fn an_emulated_run_says_so_and_compares_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, Machine::detect());
        folder(&ctx);
        let text = std::fs::read_to_string(ctx.path("machine.json")).unwrap();
        let mut m = Machine::from_json(&text).unwrap();
        m.arch = "aarch64".into();
        m.emulated = "an aarch64 program on an x86_64 CPU, under user-mode emulation".into();
        write(&ctx, "machine.json", &m.to_json());
        let md = render(&ctx, crate::EXPERIMENTS);
        assert!(md.contains("these times are not measurements"), "{md}");
        assert!(md.contains("an aarch64 program on an x86_64 CPU"), "{md}");
        assert!(md.contains("for aarch64"), "{md}");
        // No measured range on the first screen: every row that has a CSV says it is not compared.
        assert_eq!(
            md.matches("*emulated run: not compared*").count(),
            5,
            "{md}"
        );
    }

    #[test]
    fn missing_and_damaged_csv_files_are_said_in_their_line() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = Ctx::new(dir.path(), true, Machine::detect());
        write(&ctx, table5::FILE, "wrong,header\n");
        let md = render(&ctx, crate::EXPERIMENTS);
        assert!(
            md.contains("*not run into this folder yet (`reproduce --only table1`)*"),
            "{md}"
        );
        assert!(md.contains("**cannot read:**"), "{md}");
        assert!(md.contains("`machine.json` is missing"), "{md}");
        assert!(!md.contains("<img"), "{md}");
    }

    #[test]
    fn the_current_results_folder_renders() {
        // Prints the headline of the repository's `results/` when it is there (for review).
        let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../results");
        if !out.join("machine.json").is_file() {
            return;
        }
        let ctx = Ctx::new(out, true, Machine::detect());
        let md = render(&ctx, crate::EXPERIMENTS);
        println!("{md}");
        assert!(md.contains("| [Table 3](#"), "{md}");
        // The whole README, for a look before a `reproduce --report-only` run rewrites it.
        if let Ok(to) = std::env::var("COHERENT_README_PREVIEW") {
            let run = crate::readme::RunInfo {
                ran: Vec::new(),
                args: "--report-only --out results".into(),
            };
            let (full, _) = crate::readme::render(&ctx, crate::EXPERIMENTS, &run);
            std::fs::write(to, full).unwrap();
        }
    }
}
