//! The keys `reproduce` adds to `machine.json` after the machine's own: `build` (which build
//! measured: `native` when compiled with `-C target-cpu=native`, else `portable`) on every
//! run, and `embree` (the library the `accel` experiment timed: version, ISA, native packet
//! widths) written by `accel`. Each sits on a line of its own at the end of the object, so
//! the contract's keys keep their order.
//!
//! A run of other experiments rewrites `machine.json` but keeps the `embree` line of the
//! previous one: `accel.csv` stays in the folder until `accel` runs again, and its report
//! reads which Embree it timed from that key (on the host `runs` names for `accel`).
//!
//! Likewise `runs`: per experiment whose results are in the folder, the source revision
//! (`git_rev`), the date, the CPU model (`cpu`), the `os` line (its kernel build tells hosts
//! apart) and a speed probe (`probe_ms`) of the run that wrote them. `--only` runs replace some
//! sections and keep the others, so the machine's own keys describe only the last run, and a
//! folder can hold experiments from hosts of different CPU models: `runs` says which came from
//! which. Hosts that report the same CPU model differ in speed too (this workplace's hosts by up
//! to 1.77x in frame time), so the probe says whether two experiments' absolute times can be
//! compared.

use std::time::Instant;

use coherent::machine::Machine;

/// Steps of the speed probe's loop: 16.5 ms on the 2.6 GHz Zen 4 host that ran `table5` of
/// `results/` (the probe was added after the other experiments there had run).
const PROBE_STEPS: u64 = 10_000_000;

/// Milliseconds of a fixed single-thread scalar loop (a dependent chain of `f64` multiplies and
/// adds beside an integer hash: latency-bound, nothing for the vectoriser, no memory), the
/// median of 5. It follows the core's clock and any other load on it, which is what makes one
/// host's frame times differ from another's of the same CPU model.
pub fn speed_probe_ms() -> f64 {
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let start = Instant::now();
            let mut x = std::hint::black_box(1.0f64);
            let mut h = std::hint::black_box(0x9e37_79b9u64);
            for _ in 0..std::hint::black_box(PROBE_STEPS) {
                x = x * 0.999_999 + 1e-7;
                h = h.rotate_left(5) ^ h.wrapping_mul(31);
            }
            std::hint::black_box((x, h));
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// One entry of `runs`: the run that wrote an experiment's results.
#[derive(Clone, Debug, PartialEq)]
pub struct RunRecord {
    /// The experiment.
    pub experiment: String,
    /// `git_rev` of the run.
    pub git_rev: String,
    /// Its date (UTC, ISO-8601).
    pub date: String,
    /// Its host's CPU model; `None` in entries written before it was recorded.
    pub cpu: Option<String>,
    /// Its host's `os` line; `None` in entries written before it was recorded.
    pub os: Option<String>,
    /// [`speed_probe_ms`] on its host; `None` in entries written before it was recorded.
    pub probe_ms: Option<f64>,
    /// The experiment's wall time in that run (its measurements and plots, not the build);
    /// `None` in entries written before it was recorded.
    pub seconds: Option<f64>,
}

/// `build`'s value for this machine's build, as JSON text.
pub fn build_value(machine: &Machine) -> &'static str {
    if machine.rustflags.contains("target-cpu=native") {
        "\"native\""
    } else {
        "\"portable\""
    }
}

/// `json` (an object as `Machine::to_json` writes it, top-level keys indented by two spaces)
/// with `key` set to `value` (JSON text on one line): an earlier line of that key goes, the
/// new one comes last.
pub fn set_key(json: &str, key: &str, value: &str) -> String {
    let prefix = format!("  \"{key}\":");
    let kept: Vec<&str> = json
        .trim_end()
        .lines()
        .filter(|line| !line.starts_with(&prefix))
        .collect();
    let body = kept.join("\n");
    let body = body.strip_suffix('}').unwrap_or(&body).trim_end();
    let body = body.strip_suffix(',').unwrap_or(body);
    let sep = if body.trim_end().ends_with('{') {
        ""
    } else {
        ","
    };
    format!("{body}{sep}\n{prefix} {value}\n}}\n")
}

/// The value of `key` in `json` as written by [`set_key`] (one line), if there.
pub fn get_key(json: &str, key: &str) -> Option<String> {
    let prefix = format!("  \"{key}\":");
    json.lines().find_map(|line| {
        let value = line.strip_prefix(&prefix)?.trim();
        Some(value.strip_suffix(',').unwrap_or(value).to_owned())
    })
}

/// The `machine.json` a run writes: `machine`'s own keys, `build`, and the `embree` and `runs`
/// lines of `previous` (the folder's earlier `machine.json`), whose results stay in the folder
/// until their experiments run again. Entries of `runs` written before the CPU model was
/// recorded in them get `previous`'s own `cpu`: until then `runs` was dropped whenever the
/// CPU changed, so every entry of a file was measured on that file's CPU model.
pub fn machine_json(machine: &Machine, previous: Option<&str>) -> String {
    let mut json = set_key(&machine.to_json(), "build", build_value(machine));
    let Some(previous) = previous else {
        return json;
    };
    if let Some(value) = get_key(previous, "embree") {
        json = set_key(&json, "embree", &value);
    }
    let old_cpu = Machine::from_json(previous).ok().map(|p| p.cpu);
    let runs = get_key(previous, "runs").and_then(|v| serde_json::from_str(&v).ok());
    if let Some(serde_json::Value::Object(mut runs)) = runs {
        for entry in runs.values_mut() {
            if let (Some(e), Some(cpu)) = (entry.as_object_mut(), &old_cpu) {
                e.entry("cpu").or_insert_with(|| cpu.clone().into());
            }
        }
        json = set_key(&json, "runs", &serde_json::Value::Object(runs).to_string());
    }
    json
}

/// `json` with `experiment`'s entry of `runs` set to `machine`'s revision, date, CPU model and
/// `os`, to `probe_ms` ([`speed_probe_ms`]) and to `seconds`, the experiment's wall time: the
/// run that has just written that experiment's results.
pub fn record_run(
    json: &str,
    experiment: &str,
    machine: &Machine,
    probe_ms: f64,
    seconds: f64,
) -> String {
    let mut runs: serde_json::Map<String, serde_json::Value> = get_key(json, "runs")
        .and_then(|v| serde_json::from_str(&v).ok())
        .unwrap_or_default();
    runs.insert(
        experiment.to_owned(),
        serde_json::json!({
            "git_rev": machine.git_rev,
            "date": machine.date,
            "cpu": machine.cpu,
            "os": machine.os,
            "probe_ms": (probe_ms * 100.0).round() / 100.0,
            "seconds": seconds.round(),
        }),
    );
    set_key(json, "runs", &serde_json::Value::Object(runs).to_string())
}

impl RunRecord {
    /// Whether the run was built from a tree with uncommitted changes.
    pub fn dirty(&self) -> bool {
        self.git_rev.ends_with("-dirty")
    }

    /// What a reader needs to place the run: `` `639ea2c` on Intel Xeon, 2026-11-28 ``, with
    /// a warning for an uncommitted tree.
    pub fn label(&self) -> String {
        let rev = self.git_rev.trim_end_matches("-dirty");
        let rev = rev.get(..7).unwrap_or(rev);
        let cpu = self.cpu.as_deref().unwrap_or("a CPU not recorded");
        let day = self.date.get(..10).unwrap_or(&self.date);
        let dirty = if self.dirty() {
            " (**a tree with uncommitted changes**)"
        } else {
            ""
        };
        format!("`{rev}`{dirty} on {cpu}, {day}")
    }
}

/// The run that wrote `experiment`'s results in the `machine.json` text `json`, if recorded.
pub fn run_of(json: &str, experiment: &str) -> Option<RunRecord> {
    runs(json).into_iter().find(|r| r.experiment == experiment)
}

/// `runs` of `json`, by experiment name; empty without it.
pub fn runs(json: &str) -> Vec<RunRecord> {
    let Some(value) = get_key(json, "runs") else {
        return Vec::new();
    };
    let Ok(serde_json::Value::Object(runs)) = serde_json::from_str(&value) else {
        return Vec::new();
    };
    let text = |v: &serde_json::Value, k: &str| v[k].as_str().unwrap_or("?").to_owned();
    runs.iter()
        .map(|(name, v)| RunRecord {
            experiment: name.clone(),
            git_rev: text(v, "git_rev"),
            date: text(v, "date"),
            cpu: v["cpu"].as_str().map(str::to_owned),
            os: v["os"].as_str().map(str::to_owned),
            probe_ms: v["probe_ms"].as_f64(),
            seconds: v["seconds"].as_f64(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_set_replaced_and_kept_for_the_same_cpu() {
        let machine = Machine::detect();
        let json = machine_json(&machine, None);
        let want = if machine.rustflags.contains("target-cpu=native") {
            "\"native\""
        } else {
            "\"portable\""
        };
        assert_eq!(get_key(&json, "build").as_deref(), Some(want));
        let parsed: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert!(parsed["build"].is_string());
        assert!(parsed.get("embree").is_none());

        let embree = r#"{"isa":"avx2","native_packets":[4,8],"version":"4.4.0"}"#;
        let with = set_key(&json, "embree", embree);
        let again = set_key(&with, "embree", embree);
        assert_eq!(with, again, "setting a key twice keeps one line");
        let parsed: serde_json::Value = serde_json::from_str(&with).unwrap();
        assert_eq!(parsed["embree"]["isa"], "avx2");
        assert_eq!(parsed["cpu"], machine.cpu.as_str());

        // A later run keeps the key, on this CPU and on another (`accel.csv` stays in the
        // folder with it; `runs` says which host ran `accel`).
        let kept = machine_json(&machine, Some(&with));
        assert_eq!(get_key(&kept, "embree").as_deref(), Some(embree));
        let mut other = machine.clone();
        other.cpu = "another CPU".into();
        let other_json = set_key(&other.to_json(), "embree", embree);
        assert_eq!(
            get_key(&machine_json(&machine, Some(&other_json)), "embree").as_deref(),
            Some(embree)
        );
        // The machine's own keys still come first, in the contract's order.
        assert!(kept.find("\"cpu\"").unwrap() < kept.find("\"build\"").unwrap());
    }

    #[test]
    fn runs_are_recorded_per_experiment_and_kept_by_later_runs() {
        let mut machine = Machine::detect();
        machine.git_rev = "aaa".into();
        machine.date = "d1".into();
        machine.os = "host a".into();
        let json = record_run(
            &machine_json(&machine, None),
            "kernels",
            &machine,
            25.0,
            60.0,
        );
        let json = record_run(&json, "table1", &machine, 25.0, 90.0);
        // A later run on the same CPU, of one experiment only, on a slower host.
        let mut later = machine.clone();
        later.git_rev = "bbb".into();
        later.date = "d2".into();
        later.os = "host b".into();
        let json = record_run(
            &machine_json(&later, Some(&json)),
            "table1",
            &later,
            37.504,
            120.4,
        );
        let want = |n: &str, r: &str, d: &str, cpu: &str, os: &str, ms: f64, secs: f64| RunRecord {
            experiment: n.to_owned(),
            git_rev: r.to_owned(),
            date: d.to_owned(),
            cpu: Some(cpu.to_owned()),
            os: Some(os.to_owned()),
            probe_ms: Some(ms),
            seconds: Some(secs),
        };
        let cpu = machine.cpu.as_str();
        assert_eq!(
            runs(&json),
            vec![
                want("kernels", "aaa", "d1", cpu, "host a", 25.0, 60.0),
                want("table1", "bbb", "d2", cpu, "host b", 37.5, 120.0)
            ]
        );
        let parsed: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(parsed["runs"]["kernels"]["git_rev"], "aaa");
        assert_eq!(parsed["git_rev"], "bbb");
        // Entries written before `cpu`, `os`, `probe_ms` and `seconds` were recorded still read.
        let old = r#"{
  "runs": {"kernels":{"date":"d0","git_rev":"ccc"}}
}"#;
        let old_record = RunRecord {
            experiment: "kernels".into(),
            git_rev: "ccc".into(),
            date: "d0".into(),
            cpu: None,
            os: None,
            probe_ms: None,
            seconds: None,
        };
        assert_eq!(runs(old), vec![old_record.clone()]);
        // A run on another CPU keeps the earlier runs, each with the CPU it ran on, and adds
        // its own.
        let mut other = later.clone();
        other.cpu = "another CPU".into();
        other.git_rev = "ddd".into();
        let mixed = record_run(
            &machine_json(&other, Some(&json)),
            "table3",
            &other,
            30.0,
            2400.0,
        );
        assert_eq!(
            runs(&mixed),
            vec![
                want("kernels", "aaa", "d1", cpu, "host a", 25.0, 60.0),
                want("table1", "bbb", "d2", cpu, "host b", 37.5, 120.0),
                want("table3", "ddd", "d2", "another CPU", "host b", 30.0, 2400.0),
            ]
        );
        // Entries from before the CPU model was recorded get the earlier file's own CPU: they
        // were all measured on it (runs were dropped whenever the CPU changed).
        let older = set_key(
            &machine.to_json(),
            "runs",
            r#"{"kernels":{"date":"d0","git_rev":"ccc"}}"#,
        );
        assert_eq!(
            runs(&machine_json(&other, Some(&older))),
            vec![RunRecord {
                cpu: Some(machine.cpu.clone()),
                ..old_record
            }]
        );
        assert!(runs("{}").is_empty());
    }

    #[test]
    fn the_speed_probe_takes_a_positive_finite_time() {
        let ms = speed_probe_ms();
        assert!(ms.is_finite() && ms > 0.0, "{ms}");
    }
}
