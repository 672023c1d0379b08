//! Finding and loading the Embree 4 library at run time, so that a machine without it still
//! builds and runs everything else (the comparison of section 3's traversal with Embree).
//!
//! Search order: `$EMBREE_DIR` when set (an Embree 4 install: `lib/`, `lib64/` or the folder
//! itself), else the project's `.native/embree/lib/` that `scripts/native.py` fills with the
//! pinned Embree 4.4 wheel, else the system's `libembree4.so.4`.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use crate::EmbreeError;
use crate::ffi::Api;

/// The library file name Embree 4 installs under.
const LIBRARY: &str = "libembree4.so.4";

/// Where `scripts/native.py` puts the library, relative to this crate's folder.
const NATIVE_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../.native/embree/lib");

/// The loaded library, or why there is none (the same answer for the whole process).
pub fn api() -> Result<&'static Api, EmbreeError> {
    static API: OnceLock<Result<Api, EmbreeError>> = OnceLock::new();
    API.get_or_init(load).as_ref().map_err(Clone::clone)
}

/// The paths tried, in order.
fn candidates() -> Vec<PathBuf> {
    if let Some(dir) = std::env::var_os("EMBREE_DIR") {
        let dir = PathBuf::from(dir);
        return ["lib", "lib64", "."]
            .iter()
            .map(|sub| dir.join(sub).join(LIBRARY))
            .collect();
    }
    vec![Path::new(NATIVE_DIR).join(LIBRARY), PathBuf::from(LIBRARY)]
}

fn load() -> Result<Api, EmbreeError> {
    let mut tried = Vec::new();
    for path in candidates() {
        // A bare name goes through the system's search; a path must exist to be worth a try.
        if path.components().count() > 1 && !path.exists() {
            tried.push(format!("{}: not found", path.display()));
            continue;
        }
        // SAFETY: loading Embree runs its static initialisers only, which have no
        // preconditions; a library of the right name but the wrong kind fails to resolve.
        match unsafe { libloading::Library::new(&path) } {
            Ok(library) => {
                // SAFETY: the file is an Embree 4 library by name; `resolve` checks the symbols.
                return unsafe { Api::resolve(library) }.map_err(|why| EmbreeError::Unusable {
                    path: path.display().to_string(),
                    why,
                });
            }
            Err(e) => tried.push(format!("{}: {e}", path.display())),
        }
    }
    Err(EmbreeError::NotFound {
        tried: tried.join("; "),
    })
}
