//! The goniodiagram parsers on real files (paper section 5): the IES LM-63-2002 and
//! EULUMDAT examples of the lidrs crate and six manufacturers' EULUMDAT files from the
//! eulumdat package, fetched by `python3 scripts/native.py photometry` into
//! `.cache/photometry/` (pinned, checksummed, data only). Without them the tests say so
//! and check nothing, unless `COHERENT_REQUIRE_PHOTOMETRY` is set (by `scripts/test.sh`,
//! which runs the set-up first), when they fail.

use std::path::{Path, PathBuf};

use coherent::light::photometry::PhotometricType;
use coherent::light::{GonioLookup, Goniodiagram, ies, ldt};
use glam::Vec3;

fn files() -> Option<Vec<PathBuf>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(".cache/photometry");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ies" || e == "ldt"))
        .collect();
    v.sort();
    if v.is_empty() {
        return None;
    }
    Some(v)
}

/// The files, or `None` after saying why they are absent; panics when they are required.
fn files_or_skip() -> Option<Vec<PathBuf>> {
    let f = files();
    if f.is_none() {
        let why = "no goniodiagram files in .cache/photometry (run `python3 scripts/native.py photometry`)";
        if coherent::require::required("COHERENT_REQUIRE_PHOTOMETRY") {
            panic!("{why}");
        }
        eprintln!("skipping: {why}");
    }
    f
}

#[test]
fn every_fetched_file_parses_unfolds_and_lights() {
    let Some(files) = files_or_skip() else {
        return;
    };
    assert!(files.len() >= 8, "expected 8 files, found {files:?}");
    for path in &files {
        let table = match path.extension().unwrap().to_str().unwrap() {
            "ies" => ies::load(path),
            _ => ldt::load(path),
        }
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(table.max_candela() > 0.0, "{}: all zero", path.display());
        let full = table.full(path).unwrap_or_else(|e| panic!("{e}"));
        if full.kind == PhotometricType::C {
            assert_eq!(*full.planes.last().unwrap(), 360.0, "{}", path.display());
        }
        for lookup in [GonioLookup::Search, GonioLookup::Uniform] {
            let g = Goniodiagram::load(path, Vec3::ZERO, Vec3::Z, Vec3::X, [1.0; 3], lookup)
                .unwrap_or_else(|e| panic!("{e}"));
            // The uniform grid reproduces the file's nodes to within a few percent of the
            // peak (nodes off its 0.5-degree grid are interpolated).
            let (err, max) = g.uniform_error_at_nodes();
            assert!(
                err <= 0.05 * max,
                "{}: uniform error {err} of {max}",
                path.display()
            );
        }
        eprintln!(
            "{}: {:?}, {} planes x {} angles, peak {} cd",
            path.file_name().unwrap().to_string_lossy(),
            table.kind,
            table.planes.len(),
            table.angles.len(),
            table.max_candela()
        );
    }
}

#[test]
fn the_lidrs_ies_example_has_its_documented_shape() {
    let Some(files) = files_or_skip() else {
        return;
    };
    let Some(path) = files
        .iter()
        .find(|p| p.ends_with("lidrs_iesna2002_example_typec.ies"))
    else {
        panic!("the lidrs IES example is missing from {files:?}");
    };
    let t = ies::load(path).unwrap();
    assert_eq!(t.kind, PhotometricType::C);
    assert_eq!(t.angles.first(), Some(&0.0));
    assert_eq!(t.candela.len(), t.planes.len() * t.angles.len());
}
