//! The machine a measurement ran on: CPU, SIMD features found at run time, how the binary was
//! built (compiler, RUSTFLAGS, compile-time target features) and the source revision. Written
//! beside every result as `machine.json` (docs/experiments.md lists the results; paper
//! section 7 names its machines the same way) and shown by `coherent info`.

use crate::simd::Backend;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::process::Command;
use std::time::{SystemTime, UNIX_EPOCH};

/// The SIMD-relevant x86 features, in the order they are listed. The same names serve for
/// run-time detection (`is_x86_feature_detected!`) and compile time (`cfg!(target_feature)`).
macro_rules! x86_features {
    ($($feature:tt),* $(,)?) => {
        /// The listed features this CPU has (run-time detection); aarch64's own list there.
        fn detected_features() -> Vec<String> {
            #[allow(unused_mut)]
            let mut found = Vec::new();
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            {
                $(if std::arch::is_x86_feature_detected!($feature) {
                    found.push($feature.to_owned());
                })*
            }
            #[cfg(target_arch = "aarch64")]
            found.extend(aarch64_features());
            found
        }

        /// The listed features the compiler was allowed to use everywhere in this build
        /// (`-C target-cpu` / `-C target-feature`), whatever the CPU it runs on.
        fn compiled_features() -> Vec<String> {
            #[allow(unused_mut)]
            let mut enabled = Vec::new();
            $(if cfg!(target_feature = $feature) {
                enabled.push($feature.to_owned());
            })*
            enabled
        }
    };
}

/// The SIMD-relevant aarch64 features this CPU has (run-time detection).
#[cfg(target_arch = "aarch64")]
fn aarch64_features() -> Vec<String> {
    use std::arch::is_aarch64_feature_detected as has;
    let found = [
        ("neon", has!("neon")),
        ("fp16", has!("fp16")),
        ("fcma", has!("fcma")),
        ("dotprod", has!("dotprod")),
        ("sve", has!("sve")),
        ("sve2", has!("sve2")),
    ];
    found
        .into_iter()
        .filter(|&(_, yes)| yes)
        .map(|(name, _)| name.to_owned())
        .collect()
}

x86_features!(
    "sse",
    "sse2",
    "sse3",
    "ssse3",
    "sse4.1",
    "sse4.2",
    "sse4a",
    "popcnt",
    "avx",
    "avx2",
    "fma",
    "f16c",
    "bmi1",
    "bmi2",
    "lzcnt",
    "avx512f",
    "avx512bw",
    "avx512cd",
    "avx512dq",
    "avx512vl",
    "avx512ifma",
    "avx512vbmi",
    "avx512vbmi2",
    "avx512vnni",
    "avx512bitalg",
    "avx512vpopcntdq",
    "avx512bf16",
    "avx512fp16",
    "gfni",
    "vaes",
    "vpclmulqdq",
);

/// Where and how a measurement was made. Serialises to `machine.json` with the contract's
/// keys first (`cpu, cores, threads, cpu_features, rustc, rustflags, git_rev, date, os`),
/// then extra keys.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Machine {
    /// CPU model name, e.g. `AMD EPYC 9654 96-Core Processor`.
    pub cpu: String,
    /// Physical cores (from `/proc/cpuinfo`; the thread count where that is unknown).
    pub cores: usize,
    /// Hardware threads this process may use (`std::thread::available_parallelism`).
    pub threads: usize,
    /// SIMD features of this CPU, detected at run time, e.g. `["sse", ..., "avx512f"]`.
    pub cpu_features: Vec<String>,
    /// The compiler that built this binary (`rustc -V`).
    pub rustc: String,
    /// RUSTFLAGS of the build, space separated; empty when none.
    pub rustflags: String,
    /// `git rev-parse HEAD` of the source tree, `-dirty` appended when tracked files other
    /// than `results/` were modified; `unknown` without git.
    pub git_rev: String,
    /// When this description was taken: UTC, ISO-8601 (`2026-11-21T19:30:00Z`).
    pub date: String,
    /// Operating system, architecture, distribution and kernel.
    pub os: String,
    /// SIMD features enabled at compile time for the whole build (`cfg!(target_feature)`):
    /// what `wide` and the auto-vectoriser may use without run-time dispatch.
    #[serde(default)]
    pub target_features: Vec<String>,
    /// Cargo profile of the build (`release` or `debug`).
    #[serde(default)]
    pub profile: String,
    /// The lane backends compiled in and usable on this CPU (`Backend::available`).
    #[serde(default)]
    pub backends: Vec<String>,
    /// The lane backends this build or CPU cannot run, as `name: reason`
    /// (`Backend::skipped`): experiments and tests skip them.
    #[serde(default)]
    pub skipped_backends: Vec<String>,
    /// The instruction set this program was built for (`x86_64`, `aarch64`).
    #[serde(default)]
    pub arch: String,
    /// Empty when the program runs on a CPU of its own instruction set; else what runs it
    /// (an aarch64 build under user-mode emulation on an x86-64 CPU): its times are the
    /// emulator's, not measurements of the code, and reports say so instead of comparing them.
    #[serde(default)]
    pub emulated: String,
}

impl Machine {
    /// Describes this machine and build now. Never fails: what cannot be found is `unknown`.
    pub fn detect() -> Machine {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        Machine {
            cpu: cpu_model(&cpuinfo),
            cores: physical_cores(&cpuinfo).unwrap_or(threads),
            threads,
            cpu_features: detected_features(),
            rustc: env!("COHERENT_RUSTC_VERSION").to_owned(),
            rustflags: env!("COHERENT_RUSTFLAGS").to_owned(),
            git_rev: git_rev(),
            date: iso8601_utc(SystemTime::now()),
            os: os_description(),
            target_features: compiled_features(),
            profile: env!("COHERENT_PROFILE").to_owned(),
            backends: Backend::available()
                .iter()
                .map(|b| b.name().to_owned())
                .collect(),
            skipped_backends: Backend::skipped()
                .into_iter()
                .map(|(b, why)| format!("{b}: {why}"))
                .collect(),
            arch: std::env::consts::ARCH.to_owned(),
            emulated: emulation(&cpuinfo, std::env::consts::ARCH).unwrap_or_default(),
        }
    }

    /// Whether this program ran under emulation (see [`Machine::emulated`]).
    pub fn is_emulated(&self) -> bool {
        !self.emulated.is_empty()
    }

    /// Whether the CPU has `feature` (a name as in [`Machine::cpu_features`]).
    pub fn has(&self, feature: &str) -> bool {
        self.cpu_features.iter().any(|f| f == feature)
    }

    /// Pretty JSON, as written to `machine.json`.
    pub fn to_json(&self) -> String {
        // A struct of strings and numbers always serialises.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Reads a `machine.json` written by [`Machine::to_json`].
    pub fn from_json(text: &str) -> Result<Machine, serde_json::Error> {
        serde_json::from_str(text)
    }
}

/// `Some(description)` when `/proc/cpuinfo` describes a CPU of another instruction set than
/// `arch`, the program's: a user-mode emulator (qemu-user) runs it and passes the host's
/// description through. x86 CPUs list `vendor_id` and `flags`; ARM ones `CPU implementer` and
/// `Features`.
fn emulation(cpuinfo: &str, arch: &str) -> Option<String> {
    let x86 =
        cpuinfo_field(cpuinfo, "vendor_id").is_some() && cpuinfo_field(cpuinfo, "flags").is_some();
    let arm = cpuinfo_field(cpuinfo, "CPU implementer").is_some();
    let host = match (x86, arm) {
        (true, false) => "x86_64",
        (false, true) => "aarch64",
        _ => return None,
    };
    (host != arch).then(|| {
        format!("an {arch} program on an {host} CPU, under user-mode emulation (qemu-user)")
    })
}

/// The CPU model: `model name` of `/proc/cpuinfo`, else the CPUID brand string.
fn cpu_model(cpuinfo: &str) -> String {
    cpuinfo_field(cpuinfo, "model name")
        .map(str::to_owned)
        .or_else(cpuid_brand)
        .unwrap_or_else(|| "unknown".to_owned())
}

/// The value of the first `key : value` line of `/proc/cpuinfo` with this key.
fn cpuinfo_field<'a>(cpuinfo: &'a str, key: &str) -> Option<&'a str> {
    cpuinfo.lines().find_map(|line| {
        let (k, v) = line.split_once(':')?;
        (k.trim() == key)
            .then(|| v.trim())
            .filter(|v| !v.is_empty())
    })
}

/// Physical cores: distinct (`physical id`, `core id`) pairs of `/proc/cpuinfo`.
fn physical_cores(cpuinfo: &str) -> Option<usize> {
    let mut cores = std::collections::BTreeSet::new();
    for block in cpuinfo.split("\n\n") {
        let package = cpuinfo_field(block, "physical id").unwrap_or("0");
        if let Some(core) = cpuinfo_field(block, "core id") {
            cores.insert((package.to_owned(), core.to_owned()));
        }
    }
    (!cores.is_empty()).then_some(cores.len())
}

/// The CPUID brand string (leaves 0x8000_0002..=0x8000_0004), where the CPU has one.
#[cfg(target_arch = "x86_64")]
fn cpuid_brand() -> Option<String> {
    use std::arch::x86_64::__cpuid;
    // SAFETY: CPUID exists on every x86-64 CPU; leaf 0x8000_0000 says which extended leaves do.
    #[allow(unused_unsafe)]
    let max = unsafe { __cpuid(0x8000_0000) }.eax;
    if max < 0x8000_0004 {
        return None;
    }
    let mut bytes = Vec::with_capacity(48);
    for leaf in 0x8000_0002u32..=0x8000_0004 {
        // SAFETY: the leaf exists (checked above).
        #[allow(unused_unsafe)]
        let r = unsafe { __cpuid(leaf) };
        for word in [r.eax, r.ebx, r.ecx, r.edx] {
            bytes.extend_from_slice(&word.to_le_bytes());
        }
    }
    let brand = String::from_utf8_lossy(&bytes)
        .trim_matches(char::from(0))
        .trim()
        .to_owned();
    (!brand.is_empty()).then_some(brand)
}

#[cfg(not(target_arch = "x86_64"))]
fn cpuid_brand() -> Option<String> {
    None
}

/// `$COHERENT_GIT_REV` where it is set (a binary copied to another machine, beside a copy of
/// the tree whose git metadata need not match: the person who copied it says what it was
/// built from); else `git rev-parse HEAD` (+ `-dirty`) of the source tree this binary was
/// built from, or of the current directory when that tree is gone; `unknown` without git.
fn git_rev() -> String {
    if let Some(rev) = std::env::var("COHERENT_GIT_REV")
        .ok()
        .filter(|rev| !rev.trim().is_empty())
    {
        return rev.trim().to_owned();
    }
    let source = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = if source.is_dir() {
        source.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_else(|_| ".".into())
    };
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git")
            .arg("-C")
            .arg(&dir)
            .args(args)
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
    };
    let Some(rev) = git(&["rev-parse", "HEAD"]).filter(|rev| !rev.is_empty()) else {
        return "unknown".to_owned();
    };
    // `results/` is what `reproduce` writes, not what it was built from: a run after another
    // in the same tree is not "dirty" for having the first one's output beside it.
    match git(&[
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ":/",
        ":(top,exclude)results",
    ]) {
        Some(changes) if !changes.is_empty() => format!("{rev}-dirty"),
        _ => rev,
    }
}

/// `linux x86_64, Debian GNU/Linux 12 (bookworm), kernel 6.1.0`: what can be found of it.
fn os_description() -> String {
    let mut parts = vec![format!(
        "{} {}",
        std::env::consts::OS,
        std::env::consts::ARCH
    )];
    if let Ok(release) = std::fs::read_to_string("/etc/os-release")
        && let Some(name) = release
            .lines()
            .find_map(|line| line.strip_prefix("PRETTY_NAME="))
    {
        parts.push(name.trim().trim_matches('"').to_owned());
    }
    if let Ok(kernel) = std::fs::read_to_string("/proc/sys/kernel/osrelease") {
        parts.push(format!("kernel {}", kernel.trim()));
    }
    parts.join(", ")
}

/// `time` as UTC ISO-8601 with seconds, e.g. `2026-11-21T19:30:00Z` (times before 1970 give
/// the epoch).
pub fn iso8601_utc(time: SystemTime) -> String {
    let secs = time.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (year, month, day) = civil_from_days(days as i64);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The proleptic Gregorian date `days` after 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097); // day of the 400-year era, [0, 146096]
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // [0, 399]
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of the year from March 1
    let mp = (5 * doy + 2) / 153; // month from March, [0, 11]
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn dates_format_as_utc_iso8601() {
        let at = |secs| iso8601_utc(UNIX_EPOCH + Duration::from_secs(secs));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z"); // a 400-year leap day
        assert_eq!(at(1_709_210_096), "2024-02-29T12:34:56Z");
        assert_eq!(at(4_102_444_799), "2099-12-31T23:59:59Z");
        assert_eq!(at(4_107_542_400), "2100-03-01T00:00:00Z"); // 2100 is not a leap year
    }

    #[test]
    fn cpuinfo_fields_and_cores_are_parsed() {
        let info = "processor\t: 0\nmodel name\t: Test CPU @ 3GHz\nphysical id\t: 0\ncore id\t\t: 0\n\n\
                    processor\t: 1\nmodel name\t: Test CPU @ 3GHz\nphysical id\t: 0\ncore id\t\t: 0\n\n\
                    processor\t: 2\nmodel name\t: Test CPU @ 3GHz\nphysical id\t: 1\ncore id\t\t: 0\n";
        assert_eq!(cpu_model(info), "Test CPU @ 3GHz");
        assert_eq!(physical_cores(info), Some(2)); // two packages, one core each, SMT twin
        assert_eq!(physical_cores("processor : 0\n"), None);
    }

    #[test]
    fn a_cpu_of_another_instruction_set_means_emulation() {
        let x86 = "processor\t: 0\nvendor_id\t: GenuineIntel\nflags\t\t: fpu sse sse2\n";
        let arm =
            "processor\t: 0\nBogoMIPS\t: 50.00\nFeatures\t: fp asimd\nCPU implementer\t: 0x41\n";
        assert_eq!(emulation(x86, "x86_64"), None);
        assert_eq!(emulation(arm, "aarch64"), None);
        let e = emulation(x86, "aarch64").unwrap();
        assert!(
            e.contains("aarch64 program") && e.contains("x86_64 CPU"),
            "{e}"
        );
        assert!(emulation(arm, "x86_64").is_some());
        assert_eq!(emulation("", "aarch64"), None);
        assert_eq!(Machine::detect().arch, std::env::consts::ARCH);
    }

    #[test]
    fn json_has_the_contract_keys_in_order_and_round_trips() {
        let machine = Machine::detect();
        let json = machine.to_json();
        let keys = [
            "cpu",
            "cores",
            "threads",
            "cpu_features",
            "rustc",
            "rustflags",
            "git_rev",
            "date",
            "os",
        ];
        let positions: Vec<usize> = keys
            .iter()
            .map(|k| json.find(&format!("\"{k}\":")).expect(k))
            .collect();
        assert!(positions.windows(2).all(|w| w[0] < w[1]), "{json}");
        assert_eq!(Machine::from_json(&json).unwrap(), machine);
    }

    #[test]
    fn detect_describes_this_build() {
        let machine = Machine::detect();
        assert!(machine.threads >= 1 && machine.cores >= 1);
        assert!(machine.rustc.starts_with("rustc "), "{}", machine.rustc);
        assert!(!machine.cpu.is_empty() && !machine.os.is_empty());
        assert_eq!(machine.backends.first().map(String::as_str), Some("scalar"));
        // Every feature the build assumes must be present on the CPU running it.
        for feature in &machine.target_features {
            if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
                assert!(machine.has(feature), "built with {feature}, CPU lacks it");
            }
        }
        #[cfg(target_arch = "x86_64")]
        assert!(machine.has("sse2"), "every x86-64 CPU has SSE2");
    }
}
