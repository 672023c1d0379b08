//! A bounded mutation fuzzer over every input parser: scene TOML, OBJ (+MTL), PLY, OFF,
//! glTF and GLB, IES and EULUMDAT, OpenEXR environment maps, tabulated BDF files, and PNG,
//! JPEG and OpenEXR textures. Each is fed mutations of its seeds (`fuzz/targets.rs`,
//! `fuzz/mutate.rs`); a case fails when it panics, runs past its deadline, allocates past
//! the memory cap, overflows its stack, or returns an error that does not name the file.
//! `Err` itself is the expected answer to a broken file.
//!
//! A failing input is saved under `tests/fuzz_regressions/<parser>/`, and
//! `replay_regressions` runs every saved input on every run. The default run is a fixed
//! seed and a small number of cases per parser, sized for CI (`scripts/test.sh`); a longer
//! one is (see docs/scene-format.md, "Broken files"):
//!
//! ```text
//! COHERENT_FUZZ_CASES=100000 COHERENT_FUZZ_SEED=7 cargo test --release --test fuzz -- --nocapture
//! ```
//!
//! Settings: `COHERENT_FUZZ_CASES` (cases per parser), `COHERENT_FUZZ_SEED`,
//! `COHERENT_FUZZ_TIMEOUT_SECS` (per case, 10), `COHERENT_FUZZ_MEMORY_MB` (the cap, 4096:
//! above the largest texture the loaders take, 16384 x 16384 RGB floats),
//! `COHERENT_FUZZ_MAX_SEED_KB` (fetched seeds larger than this are left out, 256),
//! `COHERENT_FUZZ_FETCHED=0` (no fetched seeds: the committed and generated ones only).

#[path = "fuzz/alloc.rs"]
mod alloc;
#[path = "fuzz/mutate.rs"]
mod mutate;
#[path = "fuzz/supervise.rs"]
mod supervise;
#[path = "fuzz/targets.rs"]
mod targets;

use std::collections::BTreeMap;
use std::fmt::Write;
use std::time::Instant;

use supervise::{Job, env_u64, input, regressions, save, signature, supervise};
use targets::{TARGETS, target};

#[global_allocator]
static ALLOC: alloc::Capped = alloc::Capped;

/// The run seed of CI: fixed, so that a failure there is one anybody can rerun.
const DEFAULT_SEED: u64 = 1;

/// The child process's entry (see `fuzz/supervise.rs`); nothing without its variable.
#[test]
#[ignore = "run by the other fuzz tests, in a child process"]
fn fuzz_child() {
    if let Ok(spec) = std::env::var("COHERENT_FUZZ_CHILD") {
        supervise::child(&spec);
    }
}

/// Fuzzes one parser; fails with every failing case (saved for `replay_regressions`).
fn fuzz(parser: &str) {
    let t = target(parser);
    let seed = env_u64("COHERENT_FUZZ_SEED", DEFAULT_SEED);
    // The parsers do not depend on the features: the run without the default ones (CI's
    // second) repeats a quarter of the cases, to check that the test runs there.
    let default = if cfg!(feature = "backends") {
        t.cases
    } else {
        t.cases / 4
    };
    let cases = env_u64("COHERENT_FUZZ_CASES", default);
    let (seeds, left_out) = targets::seeds(t);
    let labels: Vec<&str> = seeds.iter().map(|s| s.label.as_str()).collect();
    eprintln!(
        "fuzz {parser}: {cases} cases of seed {seed} from {} seeds: {}",
        seeds.len(),
        labels.join(", ")
    );
    if !left_out.is_empty() {
        eprintln!(
            "fuzz {parser}: fetched files left out, over COHERENT_FUZZ_MAX_SEED_KB: {}",
            left_out.join(", ")
        );
    }
    let work = tempfile::tempdir().unwrap();
    for (name, bytes) in targets::support_files() {
        std::fs::write(work.path().join(name), bytes).unwrap();
    }
    let clock = Instant::now();
    let job = Job {
        mode: "fuzz",
        target: t,
        seed,
        end: cases,
        dir: work.path(),
    };
    let out = supervise(&job);
    eprintln!(
        "fuzz {parser}: {} parsed, {} errors, {} failures in {:.1} s",
        out.ok,
        out.errors,
        out.failures.len(),
        clock.elapsed().as_secs_f64()
    );
    // One input saved per distinct failure (kind and place): the first case that found it.
    let mut distinct: BTreeMap<String, (&supervise::Failure, usize)> = BTreeMap::new();
    for f in &out.failures {
        distinct.entry(signature(f)).or_insert((f, 0)).1 += 1;
    }
    let mut report = String::new();
    for (f, n) in distinct.values() {
        let (path, bytes, how) = input("fuzz", t, &seeds, seed, f.case, work.path());
        let saved = save(t, &f.kind, &bytes);
        let _ = writeln!(
            report,
            "{parser} case {} ({}, {n} case(s) alike): {}\n  input: {how}\n  saved: {}",
            f.case,
            f.kind,
            f.message,
            saved
                .strip_prefix(targets::root())
                .unwrap_or(&saved)
                .display()
        );
        // The replay reads every saved input in the work folder.
        if !path.starts_with(work.path()) {
            let _ = writeln!(
                report,
                "  (read in {}, beside the files it names: reduce it to a file that fails \
                 alone before keeping it)",
                path.parent().unwrap().display()
            );
        }
    }
    if out.stopped {
        report.push_str("(stopped at the failure limit)\n");
    }
    assert!(
        out.failures.is_empty(),
        "fuzz {parser} (COHERENT_FUZZ_SEED={seed}): {} failing cases:\n{report}",
        out.failures.len()
    );
}

macro_rules! fuzz_tests {
    ($($test:ident => $parser:literal,)*) => {
        $(
            #[test]
            fn $test() {
                fuzz($parser);
            }
        )*

        /// The parsers that have a test above.
        const TESTED: &[&str] = &[$($parser),*];
    };
}

fuzz_tests! {
    fuzz_scene => "scene",
    fuzz_obj => "obj",
    fuzz_mtl => "mtl",
    fuzz_ply => "ply",
    fuzz_off => "off",
    fuzz_gltf => "gltf",
    fuzz_glb => "glb",
    fuzz_ies => "ies",
    fuzz_ldt => "ldt",
    fuzz_env_exr => "env_exr",
    fuzz_bdf => "bdf",
    fuzz_png => "png",
    fuzz_jpeg => "jpeg",
    fuzz_texture_exr => "texture_exr",
}

#[test]
fn every_parser_has_a_fuzz_test() {
    let names: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
    assert_eq!(names, TESTED);
}

/// Every committed and generated seed parses (a seed the parser refuses would fuzz only its
/// first checks), but the repository's scenes, which name fetched files that are not beside
/// the case, and the map without RGB channels.
#[test]
fn the_seeds_parse() {
    let work = tempfile::tempdir().unwrap();
    for (name, bytes) in targets::support_files() {
        std::fs::write(work.path().join(name), bytes).unwrap();
    }
    let mut report = String::new();
    for t in TARGETS {
        for s in targets::seeds(t).0 {
            let expected_err = s.label.starts_with("scenes/") || s.label.contains("grey_y_only");
            if s.dir.is_some() || s.label.starts_with(".cache") || expected_err {
                continue;
            }
            let path = work
                .path()
                .join(format!("{}.{}", targets::CASE_STEM, t.ext));
            if let Err(e) = (t.run)(&path, &s.bytes) {
                let _ = writeln!(report, "{} seed {}: {e}", t.name, s.label);
            }
        }
    }
    assert!(report.is_empty(), "seeds that do not parse:\n{report}");
}

/// Every saved failing input, through its parser: none may fail again.
#[test]
fn replay_regressions() {
    let dir = targets::root().join("tests/fuzz_regressions");
    for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        assert!(
            !e.path().is_dir() || TARGETS.iter().any(|t| t.name == name),
            "{}: no fuzz target is called {name:?}",
            dir.display()
        );
    }
    let work = tempfile::tempdir().unwrap();
    for (name, bytes) in targets::support_files() {
        std::fs::write(work.path().join(name), bytes).unwrap();
    }
    let mut report = String::new();
    let mut replayed = 0;
    for t in TARGETS {
        let files = regressions(t);
        if files.is_empty() {
            continue;
        }
        replayed += files.len();
        let out = supervise(&Job {
            mode: "replay",
            target: t,
            seed: 0,
            end: files.len() as u64,
            dir: work.path(),
        });
        for f in out.failures {
            let file = &files[f.case as usize];
            let _ = writeln!(
                report,
                "{}: {} {}",
                file.strip_prefix(targets::root()).unwrap_or(file).display(),
                f.kind,
                f.message
            );
        }
    }
    eprintln!("replayed {replayed} saved inputs");
    assert!(report.is_empty(), "saved fuzz inputs fail again:\n{report}");
}
