//! Cases run in a child process: this test binary again, running only its `fuzz_child`
//! test. A panic is caught there (`catch_unwind`) and reported; what cannot be caught in the
//! process, a case that never ends, an allocation past the cap (see `alloc.rs`), a stack
//! overflow, kills the child, and the supervisor here reports the case it was in and starts
//! a new child at the next case. The child writes one line as each case starts and one as it
//! ends, so the case it died in is known and can be rebuilt from its number.

use std::io::{BufRead, BufReader, Read};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::mutate;
use super::targets::{self, CASE_STEM, Seed, Target};

/// A run stops after this many failures: more are likely the same few bugs again.
const MAX_FAILURES: usize = 50;

/// What a failing case did.
pub struct Failure {
    pub case: u64,
    /// `panic`, `timeout`, `memory`, `stack-overflow`, `crash`, or `unnamed-error` (an `Err`
    /// whose message does not name the file).
    pub kind: String,
    pub message: String,
}

#[derive(Default)]
pub struct Outcome {
    pub failures: Vec<Failure>,
    /// Cases that parsed, and that returned an error.
    pub ok: u64,
    pub errors: u64,
    /// Whether the run stopped at `MAX_FAILURES`.
    pub stopped: bool,
}

/// The cases a child runs: `fuzz` cases of the run `seed`, or the saved regressions
/// (`replay`), numbers `start..end`.
pub struct Job<'a> {
    pub mode: &'a str,
    pub target: &'a Target,
    pub seed: u64,
    pub end: u64,
    /// The work folder: the files scene seeds name, and the MTL cases.
    pub dir: &'a Path,
}

pub fn env_u64(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(v) => v
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("{name}={v:?} is not a whole number")),
        Err(_) => default,
    }
}

/// The per-case deadline.
fn timeout() -> Duration {
    Duration::from_secs(env_u64("COHERENT_FUZZ_TIMEOUT_SECS", 10))
}

/// Runs the job's cases in children until all are run (or `MAX_FAILURES`).
pub fn supervise(job: &Job) -> Outcome {
    let mut out = Outcome::default();
    let mut start = 0;
    while start < job.end && !out.stopped {
        start = run_child(job, start, &mut out);
        out.stopped = out.failures.len() >= MAX_FAILURES;
    }
    out
}

/// Runs one child from case `start`; returns the case to go on from.
fn run_child(job: &Job, start: u64, out: &mut Outcome) -> u64 {
    let spec = format!(
        "{} {} {} {start} {}",
        job.mode, job.target.name, job.seed, job.end
    );
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "fuzz_child",
            "--exact",
            "--include-ignored",
            "--nocapture",
            "--test-threads=1",
            "--quiet",
        ])
        .env("COHERENT_FUZZ_CHILD", &spec)
        .env("COHERENT_FUZZ_DIR", job.dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start the fuzz child (this test binary)");
    let (tx, rx) = channel();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // The end of stderr: the panic or abort message of a child that died (parsers' warnings
    // go there too, so only the tail is kept).
    let tail = Arc::new(Mutex::new(Vec::<u8>::new()));
    let stderr = child.stderr.take().unwrap();
    let keep = tail.clone();
    let drain = std::thread::spawn(move || {
        let mut r = BufReader::new(stderr);
        let mut buf = [0u8; 4096];
        while let Ok(n) = r.read(&mut buf) {
            if n == 0 {
                break;
            }
            let mut t = keep.lock().unwrap();
            t.extend_from_slice(&buf[..n]);
            let excess = t.len().saturating_sub(8192);
            t.drain(..excess);
        }
    });
    let stderr_tail = |tail: &Arc<Mutex<Vec<u8>>>| {
        String::from_utf8_lossy(&tail.lock().unwrap())
            .trim()
            .to_string()
    };
    // The child loads its seeds before its first case: slower than a case.
    let startup = Duration::from_secs(120).max(timeout());
    let mut current: Option<u64> = None;
    let mut ended = false;
    loop {
        let wait = if current.is_some() {
            timeout()
        } else {
            startup
        };
        match rx.recv_timeout(wait) {
            Ok(line) => {
                let mut w = line.splitn(4, ' ');
                match (w.next(), w.next().and_then(|i| i.parse().ok())) {
                    (Some("fuzz-case"), Some(i)) => current = Some(i),
                    (Some("fuzz-done"), Some(_)) => match w.next() {
                        Some("ok") => out.ok += 1,
                        _ => out.errors += 1,
                    },
                    (Some("fuzz-fail"), Some(i)) => {
                        out.failures.push(Failure {
                            case: i,
                            kind: w.next().unwrap_or("panic").to_string(),
                            message: w.next().unwrap_or("").replace("\\n", "\n"),
                        });
                        if out.failures.len() >= MAX_FAILURES {
                            let _ = child.kill();
                            let _ = child.wait();
                            return job.end;
                        }
                    }
                    (Some("fuzz-end"), _) => ended = true,
                    _ => {}
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                let Some(i) = current else {
                    panic!(
                        "the fuzz child ({spec}) started no case in {startup:?}; its stderr:\n{}",
                        stderr_tail(&tail)
                    );
                };
                out.failures.push(Failure {
                    case: i,
                    kind: "timeout".into(),
                    message: format!("no result after {:?}: stuck or far too slow", timeout()),
                });
                return i + 1;
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = child.wait().unwrap();
                let _ = drain.join();
                if ended {
                    return job.end;
                }
                let err = stderr_tail(&tail);
                let Some(i) = current else {
                    panic!(
                        "the fuzz child ({spec}) ended ({status}) before its first case; its \
                         stderr:\n{err}"
                    );
                };
                let kind = if err.contains("fuzz-oom") {
                    "memory"
                } else if err.contains("overflowed its stack") {
                    "stack-overflow"
                } else {
                    "crash"
                };
                let last = err.lines().rev().take(3).collect::<Vec<_>>();
                out.failures.push(Failure {
                    case: i,
                    kind: kind.into(),
                    message: format!("the process died ({status}): {}", last.join(" / ")),
                });
                return i + 1;
            }
        }
    }
}

/// Case `i` of a job: the path it is read as, its bytes, and how it was made.
pub fn input(
    job_mode: &str,
    t: &Target,
    seeds: &[Seed],
    seed: u64,
    i: u64,
    dir: &Path,
) -> (PathBuf, Vec<u8>, String) {
    match job_mode {
        "fuzz" => {
            let all: Vec<&[u8]> = seeds.iter().map(|s| s.bytes.as_slice()).collect();
            let (k, bytes, steps) = mutate::case(&all, t.name, seed, i);
            let s = &seeds[k];
            let at = s.dir.as_deref().unwrap_or(dir);
            let how = format!("seed {}, then: {}", s.label, steps.join("; "));
            (at.join(format!("{CASE_STEM}.{}", t.ext)), bytes, how)
        }
        _ => {
            let file = &regressions(t)[i as usize];
            let bytes = std::fs::read(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            let how = file
                .strip_prefix(targets::root())
                .unwrap_or(file)
                .display()
                .to_string();
            (dir.join(format!("{CASE_STEM}.{}", t.ext)), bytes, how)
        }
    }
}

/// The folder of `t`'s saved failing inputs.
pub fn regression_dir(t: &Target) -> PathBuf {
    targets::root().join("tests/fuzz_regressions").join(t.name)
}

/// `t`'s saved failing inputs, sorted.
pub fn regressions(t: &Target) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(regression_dir(t))
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    v.sort();
    v
}

/// What makes failures the same bug: the kind and, for a panic, the file it panicked in and
/// its message, numbers left out (a decoder overflows on many lines of one function, and an
/// index is out of bounds by many values).
pub fn signature(f: &Failure) -> String {
    let mut lines = f.message.lines();
    let text = match f.kind.as_str() {
        "panic" => {
            let at = lines.next().unwrap_or("");
            let file = at.rsplit_once(".rs:").map_or(at, |(file, _)| file);
            format!("{file} {}", lines.next().unwrap_or(""))
        }
        "unnamed-error" => f.message.clone(),
        _ => String::new(),
    };
    let text: String = text
        .chars()
        .map(|c| if c.is_ascii_digit() { '#' } else { c })
        .collect();
    format!("{} {text}", f.kind)
}

/// Saves a failing input as `<kind>-<hash>.<ext>` in `t`'s regression folder.
pub fn save(t: &Target, kind: &str, bytes: &[u8]) -> PathBuf {
    let dir = regression_dir(t);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{kind}-{:016x}.{}", mutate::fnv(bytes), t.ext));
    if !path.exists() {
        std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    path
}

thread_local! {
    static PANIC: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// The child: runs the cases `spec` names, one line per start and end of a case.
pub fn child(spec: &str) {
    let w: Vec<&str> = spec.split(' ').collect();
    let [mode, parser, seed, start, end] = w[..] else {
        panic!("bad COHERENT_FUZZ_CHILD {spec:?}");
    };
    let (seed, start, end): (u64, u64, u64) = (
        seed.parse().unwrap(),
        start.parse().unwrap(),
        end.parse().unwrap(),
    );
    let dir = PathBuf::from(std::env::var_os("COHERENT_FUZZ_DIR").expect("COHERENT_FUZZ_DIR"));
    let t = targets::target(parser);
    // The message and place of a panic, and the functions it came through (the place is
    // often in a library), kept for the report instead of printed.
    std::panic::set_hook(Box::new(|info| {
        let trace = std::backtrace::Backtrace::force_capture().to_string();
        let frames: Vec<&str> = trace
            .lines()
            .filter_map(|l| l.trim().split_once(": ").map(|(_, f)| f))
            .skip_while(|f| !f.contains("rust_begin_unwind"))
            .filter(|f| {
                ![
                    "std::",
                    "core::",
                    "alloc::",
                    "__rustc",
                    "rust_begin",
                    "<alloc::",
                ]
                .iter()
                .any(|p| f.starts_with(p))
            })
            .take_while(|f| !f.starts_with("fuzz::"))
            .take(6)
            .collect();
        let m = format!("{info}\n  in: {}", frames.join(" < "));
        PANIC.with(|p| *p.borrow_mut() = Some(m));
    }));
    let seeds = if mode == "fuzz" {
        targets::seeds(t).0
    } else {
        Vec::new()
    };
    super::alloc::set_cap((env_u64("COHERENT_FUZZ_MEMORY_MB", 4096) as usize) << 20);
    for i in start..end {
        println!("fuzz-case {i}");
        let (path, bytes, _) = input(mode, t, &seeds, seed, i, &dir);
        let r = std::panic::catch_unwind(AssertUnwindSafe(|| (t.run)(&path, &bytes)));
        let folder = path.parent().unwrap().display().to_string();
        let (fail, done) = match r {
            Ok(Ok(())) => (None, "ok"),
            // The error must say which file is wrong: the case's, or one beside it.
            Ok(Err(e)) if e.contains(CASE_STEM) || e.contains(&folder) => (None, "err"),
            Ok(Err(e)) => (Some(("unnamed-error", e)), "err"),
            Err(_) => {
                let m = PANIC.with(|p| p.borrow_mut().take()).unwrap_or_default();
                (Some(("panic", m)), "panic")
            }
        };
        if let Some((kind, m)) = fail {
            println!("fuzz-fail {i} {kind} {}", m.replace('\n', "\\n"));
        }
        println!("fuzz-done {i} {done}");
    }
    println!("fuzz-end");
}
