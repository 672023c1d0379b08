//! `reproduce` as other tools call it: bad arguments give a clear message and a non-zero exit,
//! never a panic; a report-only run writes the README.

use std::path::Path;
use std::process::Output;

fn reproduce(args: &[&str]) -> Output {
    coherent::require::command(env!("CARGO_BIN_EXE_reproduce"))
        .args(args)
        .output()
        .expect("the reproduce binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn assert_clean_failure(out: &Output, code: i32, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for needle in needles {
        assert!(err.contains(needle), "`{needle}` missing from: {err}");
    }
}

#[test]
fn an_unknown_experiment_lists_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().to_str().unwrap();
    let out = reproduce(&["--quick", "--only", "kernels,nope", "--out", out_dir]);
    assert_clean_failure(
        &out,
        2,
        &[
            "unknown experiment `nope`",
            "kernels, accel, table1, table2, table3, table4, table5, aa",
        ],
    );
    assert!(!dir.path().join("machine.json").exists(), "nothing written");
}

#[test]
fn an_unusable_output_folder_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let below_file = file.join("results");
    // (Running as root defeats permission bits, so use a path under a regular file.)
    let out = reproduce(&["--quick", "--out", below_file.to_str().unwrap()]);
    assert_clean_failure(
        &out,
        1,
        &["cannot create output folder", below_file.to_str().unwrap()],
    );
    let out = reproduce(&["--quick", "--out", file.to_str().unwrap()]);
    assert_clean_failure(&out, 1, &["is not a folder", file.to_str().unwrap()]);
}

#[test]
fn bad_flags_are_usage_errors() {
    assert_clean_failure(&reproduce(&["--frobnicate"]), 2, &["--frobnicate"]);
    assert_clean_failure(&reproduce(&["--only"]), 2, &["--only"]);
    assert_clean_failure(
        &reproduce(&["--report-only", "--only", "kernels"]),
        2,
        &["cannot be used with"],
    );
}

#[test]
fn report_only_renders_the_readme_without_running_anything() {
    let dir = tempfile::tempdir().unwrap();
    let out = reproduce(&["--report-only", "--out", dir.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "stderr: {}", stderr(&out));
    let readme = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
    assert!(readme.starts_with("# Results"), "{readme}");
    for name in ["kernels", "accel", "table1", "aa"] {
        assert!(
            readme.contains(&format!("\n## {name} — ")),
            "section {name}"
        );
    }
    // machine.json describes the machine that measured; report-only does not write it.
    assert!(!Path::new(&dir.path().join("machine.json")).exists());
    assert!(readme.contains("Cannot read `machine.json`"));
}
