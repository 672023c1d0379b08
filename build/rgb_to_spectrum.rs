//! The RGB-to-spectrum table of Jakob and Hanika (2019) for linear sRGB, optimised here by
//! the `rgb2spec` crate rather than downloaded or checked in, written to
//! `$OUT_DIR/srgb_to_spectrum.bin` (`RGB2Spec::to_writer`'s format) for
//! `src/spectrum/upsample.rs` to embed.
//!
//! The optimisation (Gauss-Newton per table entry, one thread) is the build's most
//! expensive step after compiling: the profiles in Cargo.toml build `rgb2spec` at
//! `opt-level = 3` for it. The table is kept between runs of this script (a change to
//! `build.rs` or to `RUSTFLAGS` reruns it) as long as its key file says it was made by the
//! same crate version, gamut and resolution.

use std::fs;
use std::path::Path;
use std::time::Instant;

use rgb2spec::optimize::gamut::Gamut;

/// Entries per axis of the table. pbrt-v4 uses 64; fewer entries optimise faster (one
/// thread, once per profile), and the round-trip error at this resolution is what
/// `examples/upsample_error.rs` prints (docs/architecture.md, "Spectral colour"). The table
/// holds `3 * RESOLUTION^3` coefficient triples.
pub const RESOLUTION: usize = 48;

/// The table's file name in `$OUT_DIR`.
const TABLE: &str = "srgb_to_spectrum.bin";
/// What the table in `$OUT_DIR` was made from, next to it: a table with another key is made
/// again. The crate version is the one Cargo.toml pins.
const KEY_FILE: &str = "srgb_to_spectrum.key";

/// Writes the table to `out_dir`, unless the table there has the same key.
pub fn write_table(out_dir: &Path) {
    println!("cargo:rerun-if-changed=build/rgb_to_spectrum.rs");
    let table = out_dir.join(TABLE);
    let key_file = out_dir.join(KEY_FILE);
    let key = format!("rgb2spec 0.1.1, gamut sRGB, resolution {RESOLUTION}\n");
    if table.is_file() && fs::read_to_string(&key_file).is_ok_and(|k| k == key) {
        println!("rgb2spec: {TABLE} kept ({})", key.trim());
        return;
    }

    let start = Instant::now();
    let model = rgb2spec::optimize::optimize(Gamut::SRGB, RESOLUTION)
        .unwrap_or_else(|e| panic!("optimising the sRGB-to-spectrum table: {e}"));
    let seconds = start.elapsed().as_secs_f64();
    let mut bytes = Vec::new();
    model
        .to_writer(&mut bytes)
        .expect("writing to memory cannot fail");
    // The key last: an interrupted run leaves no key, and the next run makes the table again.
    let _ = fs::remove_file(&key_file);
    fs::write(&table, &bytes).unwrap_or_else(|e| panic!("{}: {e}", table.display()));
    fs::write(&key_file, &key).unwrap_or_else(|e| panic!("{}: {e}", key_file.display()));
    // Not a `cargo:` line: kept in the script's `output` file for whoever times the build.
    println!(
        "rgb2spec: {TABLE} optimised in {seconds:.1} s ({}, {} bytes)",
        key.trim(),
        bytes.len()
    );
}
