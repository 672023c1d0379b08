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

/// Whether the registries have an Embree 4 for this target (`scripts/native.py` fetches the
/// x86-64 `embreex` wheel): elsewhere only `EMBREE_DIR` can name one.
const TARGET_IN_REGISTRIES: bool = cfg!(target_arch = "x86_64");

fn load() -> Result<Api, EmbreeError> {
    if !TARGET_IN_REGISTRIES && std::env::var_os("EMBREE_DIR").is_none() {
        return Err(EmbreeError::NotForTarget {
            target: std::env::consts::ARCH,
        });
    }
    let mut tried = Vec::new();
    for path in candidates() {
        // A bare name goes through the system's search; a path must exist to be worth a try.
        if path.components().count() > 1 && !path.exists() {
            tried.push(format!("{}: not found", path.display()));
            continue;
        }
        if path.exists() {
            check_architecture(&path)?;
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

/// ELF `e_machine` values of the targets this project builds for.
const ELF_MACHINES: [(u16, &str); 2] = [(62, "x86_64"), (183, "aarch64")];

/// Refuses a library built for another architecture than this program's, naming the file and
/// the architecture found (loading it would fail with the loader's less telling message, or
/// not at all under an emulator that runs both).
fn check_architecture(path: &Path) -> Result<(), EmbreeError> {
    let unusable = |why: String| EmbreeError::Unusable {
        path: path.display().to_string(),
        why,
    };
    let mut head = [0u8; 20];
    let read = std::fs::File::open(path).and_then(|mut f| {
        use std::io::Read;
        f.read_exact(&mut head)
    });
    if let Err(e) = read {
        return Err(unusable(format!("cannot read its header ({e})")));
    }
    if head[..4] != *b"\x7fELF" {
        return Err(unusable("it is not an ELF shared library".to_string()));
    }
    // e_machine at offset 18, in the byte order e_ident[5] gives (1: little endian).
    let bytes = [head[18], head[19]];
    let machine = if head[5] == 2 {
        u16::from_be_bytes(bytes)
    } else {
        u16::from_le_bytes(bytes)
    };
    let ours = std::env::consts::ARCH;
    let found = ELF_MACHINES
        .iter()
        .find(|(m, _)| *m == machine)
        .map_or_else(
            || format!("ELF machine {machine}"),
            |(_, n)| (*n).to_string(),
        );
    if found != ours {
        return Err(unusable(format!(
            "it is a library for {found}, and this program is built for {ours}"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_library_for_another_architecture_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(LIBRARY);
        let mut elf = vec![0u8; 64];
        elf[..4].copy_from_slice(b"\x7fELF");
        elf[5] = 1;
        // the other architecture than this program's
        let other: u16 = if cfg!(target_arch = "aarch64") {
            62
        } else {
            183
        };
        elf[18..20].copy_from_slice(&other.to_le_bytes());
        std::fs::write(&path, &elf).unwrap();
        let e = check_architecture(&path).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
        let name = if other == 62 { "x86_64" } else { "aarch64" };
        assert!(
            e.contains(name) && e.contains(std::env::consts::ARCH),
            "{e}"
        );
        std::fs::write(&path, b"not a library at all").unwrap();
        let e = check_architecture(&path).unwrap_err().to_string();
        assert!(e.contains("not an ELF"), "{e}");
    }
}
