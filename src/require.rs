//! The `COHERENT_REQUIRE_*` switches: a test whose fetched data (meshes, goniodiagram files,
//! HDR maps, scene assets, an accelerator's native library) is missing skips with a message, unless its switch asks for the
//! data, and then it fails. `scripts/test.sh` and CI set them.
//!
//! Also here: [`command`], which runs a test's built executable through an emulator when the
//! tests were cross-built.
//!
//! `COHERENT_REQUIRE_BACKENDS` is not one of these: it holds a list of backend names and is
//! read by `coherent_simd::Backend::required`.

/// The environment variable naming a program that runs the built binaries in tests: an
/// emulator (`qemu-aarch64-static`) when the tests were cross-built for another architecture
/// (`scripts/cross-test.sh` sets it). Unset: the binary runs directly.
pub const RUNNER_ENV: &str = "COHERENT_TEST_RUNNER";

/// A command that runs the built executable `exe` (a test's `env!("CARGO_BIN_EXE_...")`),
/// through [`RUNNER_ENV`]'s program when it is set.
pub fn command(exe: &str) -> std::process::Command {
    match std::env::var_os(RUNNER_ENV).filter(|r| !r.is_empty()) {
        Some(runner) => {
            let mut c = std::process::Command::new(runner);
            c.arg(exe);
            c
        }
        None => std::process::Command::new(exe),
    }
}

/// Whether the switch `name` (e.g. `"COHERENT_REQUIRE_MESHES"`) asks for its data: set to
/// anything but the empty string or `0`, so `=1`, `=yes` and `=true` all require, and `=0` or
/// unset skips.
pub fn required(name: &str) -> bool {
    asks(std::env::var_os(name).as_deref())
}

/// The rule `required` applies to a switch's value (apart, so that the test needs no
/// `set_var` while other tests read the environment).
fn asks(value: Option<&std::ffi::OsStr>) -> bool {
    value.is_some_and(|v| !v.is_empty() && v != "0")
}

#[cfg(test)]
mod tests {
    use super::asks;
    use std::ffi::OsStr;

    #[test]
    fn set_and_not_zero_or_empty_means_required() {
        for (value, want) in [
            (Some("1"), true),
            (Some("yes"), true),
            (Some("0"), false),
            (Some(""), false),
            (None, false),
        ] {
            assert_eq!(asks(value.map(OsStr::new)), want, "{value:?}");
        }
    }
}
