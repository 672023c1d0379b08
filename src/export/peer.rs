//! The installed peer renderer, Mitsuba 3, driven through `scripts/mitsuba_peer.py`: one
//! Python process per scene and variant, which loads the exported scene once and renders on
//! request, timing each frame itself (the process start, the import and the load are outside
//! the frame and reported apart). `python3 scripts/native.py mitsuba` installs the pinned
//! Mitsuba, Dr.Jit and LLVM.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// The versions the set-up pins (scripts/native.py): anything else is refused.
pub const MITSUBA_VERSION: &str = "3.9.1";
pub const DRJIT_VERSION: &str = "1.5.0";
/// The LLVM library Dr.Jit's `llvm_*` variants load (Debian's libllvm22).
pub const LLVM_LIBRARY: &str = "/usr/lib/x86_64-linux-gnu/libLLVM.so.22.1";

/// Mitsuba's variants the comparisons use: its scalar one (one ray at a time per thread)
/// and its vectorised JIT one (Dr.Jit's LLVM back end, as wide as the CPU allows).
pub const VARIANTS: [&str; 2] = ["scalar_rgb", "llvm_ad_rgb"];

/// Why the peer cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum PeerError {
    #[error(
        "the peer renderer Mitsuba is not installed ({0}): run `python3 scripts/native.py \
         mitsuba` (it needs root for Debian's libllvm22)"
    )]
    Missing(String),
    #[error(
        "the installed Mitsuba is {found}, not the pinned mitsuba {MITSUBA_VERSION} / drjit \
         {DRJIT_VERSION}: delete .native/mitsuba and run `python3 scripts/native.py mitsuba`"
    )]
    WrongVersion { found: String },
    #[error("Mitsuba ({variant}) on {scene}: {message}")]
    Failed {
        scene: PathBuf,
        variant: String,
        message: String,
    },
}

/// Where the set-up put the peer.
#[derive(Debug, Clone)]
pub struct Installed {
    /// The folder holding the `mitsuba` and `drjit` packages.
    pub site: PathBuf,
    /// The driver script.
    pub driver: PathBuf,
}

/// The project's `.native/mitsuba` (`COHERENT_MITSUBA` overrides it).
fn native_dir() -> PathBuf {
    match std::env::var_os("COHERENT_MITSUBA") {
        Some(d) => PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join(".native/mitsuba"),
    }
}

/// The installed peer, checked: the pinned versions, the LLVM library, the driver.
pub fn installed() -> Result<Installed, PeerError> {
    let dir = native_dir();
    let versions = dir.join("VERSIONS.json");
    let text = std::fs::read_to_string(&versions)
        .map_err(|e| PeerError::Missing(format!("{}: {e}", versions.display())))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| PeerError::Missing(format!("{}: {e}", versions.display())))?;
    let (m, d) = (v["mitsuba"].as_str(), v["drjit"].as_str());
    if m != Some(MITSUBA_VERSION) || d != Some(DRJIT_VERSION) {
        return Err(PeerError::WrongVersion {
            found: format!("mitsuba {m:?} / drjit {d:?}"),
        });
    }
    if !Path::new(LLVM_LIBRARY).exists() {
        return Err(PeerError::Missing(format!("no {LLVM_LIBRARY}")));
    }
    let driver = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/mitsuba_peer.py");
    if !driver.is_file() {
        return Err(PeerError::Missing(format!("no {}", driver.display())));
    }
    Ok(Installed {
        site: dir.join("site"),
        driver,
    })
}

/// What the peer reported when its scene was loaded.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// Seconds to import Mitsuba and Dr.Jit.
    pub import_s: f64,
    /// Seconds to load the scene (its meshes, its acceleration structure).
    pub load_s: f64,
}

/// A running peer with one scene loaded in one variant.
pub struct Peer {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    scene: PathBuf,
    variant: String,
    pub loaded: Loaded,
}

impl Peer {
    /// Starts the peer on the exported `xml` in `variant` with `threads` worker threads and
    /// waits until the scene is loaded.
    pub fn start(xml: &Path, variant: &str, threads: usize) -> Result<Peer, PeerError> {
        let inst = installed()?;
        let failed = |message: String| PeerError::Failed {
            scene: xml.to_path_buf(),
            variant: variant.to_string(),
            message,
        };
        let mut child = Command::new("python3")
            .arg(&inst.driver)
            .arg("--scene")
            .arg(xml)
            .arg("--variant")
            .arg(variant)
            .arg("--threads")
            .arg(threads.to_string())
            .env("PYTHONPATH", &inst.site)
            .env("DRJIT_LIBLLVM_PATH", LLVM_LIBRARY)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| failed(format!("cannot start python3: {e}")))?;
        let stdin = child.stdin.take().expect("piped stdin");
        let stdout = BufReader::new(child.stdout.take().expect("piped stdout"));
        let mut peer = Peer {
            child,
            stdin,
            stdout,
            scene: xml.to_path_buf(),
            variant: variant.to_string(),
            loaded: Loaded {
                import_s: 0.0,
                load_s: 0.0,
            },
        };
        let ready = peer.answer()?;
        let (m, d) = (ready["mitsuba"].as_str(), ready["drjit"].as_str());
        if m != Some(MITSUBA_VERSION) || d != Some(DRJIT_VERSION) {
            return Err(PeerError::WrongVersion {
                found: format!("mitsuba {m:?} / drjit {d:?}"),
            });
        }
        peer.loaded = Loaded {
            import_s: ready["import_s"].as_f64().unwrap_or(f64::NAN),
            load_s: ready["load_s"].as_f64().unwrap_or(f64::NAN),
        };
        Ok(peer)
    }

    /// Renders one frame of `spp` samples per pixel with `seed`, writing the EXR to `out`
    /// when given; returns the frame's seconds as the peer timed them (the write excluded).
    pub fn render(&mut self, spp: u32, seed: u32, out: Option<&Path>) -> Result<f64, PeerError> {
        let req = serde_json::json!({
            "spp": spp,
            "seed": seed,
            "out": out.map(|p| p.display().to_string()),
        });
        writeln!(self.stdin, "{req}")
            .and_then(|_| self.stdin.flush())
            .map_err(|e| self.failed(format!("the driver stopped reading: {e}")))?;
        let v = self.answer()?;
        v["seconds"]
            .as_f64()
            .ok_or_else(|| self.failed(format!("no time in its answer {v}")))
    }

    fn failed(&self, message: String) -> PeerError {
        PeerError::Failed {
            scene: self.scene.clone(),
            variant: self.variant.clone(),
            message,
        }
    }

    /// The driver's next JSON line; its `error` as an error.
    fn answer(&mut self) -> Result<serde_json::Value, PeerError> {
        let mut line = String::new();
        let n = self
            .stdout
            .read_line(&mut line)
            .map_err(|e| self.failed(format!("reading its answer: {e}")))?;
        if n == 0 {
            let status = self.child.wait().map(|s| s.to_string()).unwrap_or_default();
            return Err(self.failed(format!("the driver exited ({status}) without answering")));
        }
        let v: serde_json::Value = serde_json::from_str(&line)
            .map_err(|e| self.failed(format!("its answer {line:?} is not JSON: {e}")))?;
        if let Some(e) = v["error"].as_str() {
            return Err(self.failed(e.to_string()));
        }
        Ok(v)
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
