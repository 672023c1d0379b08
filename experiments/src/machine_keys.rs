//! The keys `reproduce` adds to `machine.json` after the machine's own: `build` (which build
//! measured: `native` when compiled with `-C target-cpu=native`, else `portable`) on every
//! run, and `embree` (the library the `accel` experiment timed: version, ISA, native packet
//! widths) written by `accel`. Each sits on a line of its own at the end of the object, so
//! the contract's keys keep their order.
//!
//! A run of other experiments rewrites `machine.json` but keeps the `embree` line of the
//! previous one when it was measured on the same CPU: `accel.csv` stays in the folder until
//! `accel` runs again, and its report reads which Embree it timed from that key.
//!
//! Likewise `runs`: per experiment whose results are in the folder, the source revision
//! (`git_rev`) and the date of the run that wrote them. `--only` runs replace some sections
//! and keep the others, so the machine's own `git_rev` names only the last run.

use coherent::machine::Machine;

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

/// The `machine.json` a run writes: `machine`'s own keys, `build`, and the `embree` line of
/// `previous` (the folder's earlier `machine.json`) when that was written on the same CPU.
pub fn machine_json(machine: &Machine, previous: Option<&str>) -> String {
    let mut json = set_key(&machine.to_json(), "build", build_value(machine));
    if let Some(previous) = previous {
        let same_cpu = Machine::from_json(previous).is_ok_and(|p| p.cpu == machine.cpu);
        for key in ["embree", "runs"] {
            if let (true, Some(value)) = (same_cpu, get_key(previous, key)) {
                json = set_key(&json, key, &value);
            }
        }
    }
    json
}

/// `json` with `experiment`'s entry of `runs` set to `machine`'s revision and date (the run
/// that has just written that experiment's results).
pub fn record_run(json: &str, experiment: &str, machine: &Machine) -> String {
    let mut runs: serde_json::Map<String, serde_json::Value> = get_key(json, "runs")
        .and_then(|v| serde_json::from_str(&v).ok())
        .unwrap_or_default();
    runs.insert(
        experiment.to_owned(),
        serde_json::json!({ "git_rev": machine.git_rev, "date": machine.date }),
    );
    set_key(json, "runs", &serde_json::Value::Object(runs).to_string())
}

/// `runs` of `json` as `(experiment, git_rev, date)`, by experiment name; empty without it.
pub fn runs(json: &str) -> Vec<(String, String, String)> {
    let Some(value) = get_key(json, "runs") else {
        return Vec::new();
    };
    let Ok(serde_json::Value::Object(runs)) = serde_json::from_str(&value) else {
        return Vec::new();
    };
    let text = |v: &serde_json::Value, k: &str| v[k].as_str().unwrap_or("?").to_owned();
    runs.iter()
        .map(|(name, v)| (name.clone(), text(v, "git_rev"), text(v, "date")))
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

        // A later run keeps the key on the same CPU and drops it on another.
        let kept = machine_json(&machine, Some(&with));
        assert_eq!(get_key(&kept, "embree").as_deref(), Some(embree));
        let mut other = machine.clone();
        other.cpu = "another CPU".into();
        let other_json = set_key(&other.to_json(), "embree", embree);
        assert_eq!(
            get_key(&machine_json(&machine, Some(&other_json)), "embree"),
            None
        );
        // The machine's own keys still come first, in the contract's order.
        assert!(kept.find("\"cpu\"").unwrap() < kept.find("\"build\"").unwrap());
    }

    #[test]
    fn runs_are_recorded_per_experiment_and_kept_by_later_runs() {
        let mut machine = Machine::detect();
        machine.git_rev = "aaa".into();
        machine.date = "d1".into();
        let json = record_run(&machine_json(&machine, None), "kernels", &machine);
        let json = record_run(&json, "table1", &machine);
        // A later run on the same CPU, of one experiment only.
        let mut later = machine.clone();
        later.git_rev = "bbb".into();
        later.date = "d2".into();
        let json = record_run(&machine_json(&later, Some(&json)), "table1", &later);
        let want = |n: &str, r: &str, d: &str| (n.to_owned(), r.to_owned(), d.to_owned());
        assert_eq!(
            runs(&json),
            vec![want("kernels", "aaa", "d1"), want("table1", "bbb", "d2")]
        );
        let parsed: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(parsed["runs"]["kernels"]["git_rev"], "aaa");
        assert_eq!(parsed["git_rev"], "bbb");
        // Another CPU's runs are not this one's.
        let mut other = later.clone();
        other.cpu = "another CPU".into();
        assert!(runs(&machine_json(&other, Some(&json))).is_empty());
        assert!(runs("{}").is_empty());
    }
}
