//! `coherent info` as other tools call it: it describes the machine, the build and every
//! backend; bad subcommands fail with a message, never a panic.

use std::process::Output;

fn coherent(args: &[&str]) -> Output {
    coherent::require::command(env!("CARGO_BIN_EXE_coherent"))
        .args(args)
        .output()
        .expect("the coherent binary runs")
}

#[test]
fn info_lists_the_machine_the_build_and_every_backend() {
    let out = coherent(&["info"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for field in [
        "cpu:",
        "cpu features:",
        "rustc:",
        "RUSTFLAGS:",
        "target features:",
    ] {
        assert!(text.contains(field), "`{field}` missing from:\n{text}");
    }
    for backend in coherent::simd::Backend::every() {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{} ", backend.name())))
            .unwrap_or_else(|| panic!("no line for {backend}:\n{text}"));
        let usable = line.contains("usable here") && !line.contains("not usable");
        assert_eq!(usable, backend.is_available(), "{line}");
    }
    // Every accelerator, after the header, with what it is or why it is not here.
    let accelerators = text
        .split_once("accelerators:")
        .unwrap_or_else(|| panic!("no accelerators in:\n{text}"))
        .1;
    for k in coherent::accel_any::AccelKind::ALL {
        let line = accelerators
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{} ", k.name())))
            .unwrap_or_else(|| panic!("no line for {k}:\n{text}"));
        assert_eq!(line.contains("not compiled in"), !k.compiled(), "{line}");
    }
}

#[test]
fn info_json_is_the_machine_description() {
    let out = coherent(&["info", "--json"]);
    assert!(out.status.success());
    let machine = coherent::machine::Machine::from_json(&String::from_utf8_lossy(&out.stdout))
        .expect("valid machine JSON");
    assert!(machine.threads >= 1);
    assert!(machine.backends.iter().any(|b| b == "scalar"));
}

#[test]
fn an_unknown_subcommand_is_a_usage_error() {
    let out = coherent(&["frobnicate"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("frobnicate") && !err.contains("panicked"),
        "{err}"
    );
}
