//! Build script of `coherent`: records how this binary was built (compiler version, RUSTFLAGS,
//! profile) for `machine.json` and `coherent info` (the results files of docs/experiments.md),
//! and optimises the RGB-to-spectrum table of `spectrum::upsample`
//! (build/rgb_to_spectrum.rs).

use std::env;
use std::path::PathBuf;
use std::process::Command;

#[path = "build/rgb_to_spectrum.rs"]
mod rgb_to_spectrum;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CARGO_ENCODED_RUSTFLAGS");

    // The compiler that builds this crate: `$RUSTC -V`.
    let rustc = env::var("RUSTC").unwrap_or_else(|_| "rustc".to_owned());
    let version = Command::new(&rustc)
        .arg("-V")
        .output()
        .ok()
        .filter(|out| out.status.success())
        .map(|out| String::from_utf8_lossy(&out.stdout).trim().to_owned())
        .unwrap_or_else(|| "unknown".to_owned());
    println!("cargo:rustc-env=COHERENT_RUSTC_VERSION={version}");

    // RUSTFLAGS as cargo passed them: arguments separated by 0x1f.
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let flags = flags
        .split('\x1f')
        .filter(|flag| !flag.is_empty())
        .collect::<Vec<_>>()
        .join(" ");
    println!("cargo:rustc-env=COHERENT_RUSTFLAGS={flags}");

    // `debug` or `release` (the profile's base: `bench` builds report `release`).
    let profile = env::var("PROFILE").unwrap_or_else(|_| "unknown".to_owned());
    println!("cargo:rustc-env=COHERENT_PROFILE={profile}");

    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    rgb_to_spectrum::write_table(&out_dir);
}
