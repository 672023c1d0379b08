//! The one place that names every backend: the [`Backend`] enum, what is compiled in and
//! usable on this CPU, and [`Backend::run`], which runs a [`Kernel`] generic over the lane
//! type with the chosen backend's token (inside pulp's `#[target_feature]` entry point for
//! the pulp backends).

use core::fmt;
use core::str::FromStr;

use crate::lanes::Lanes;

/// A lane backend, by the names used on the command line and in results files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Backend {
    /// 1 lane, plain `f32`: the paper's non-SSE baseline.
    Scalar,
    /// 4 lanes, hand-written SSE/SSE2 intrinsics.
    Sse,
    /// 4 lanes on `wide::f32x4`.
    Wide4,
    /// 8 lanes on `wide::f32x8`.
    Wide8,
    /// 16 lanes on `wide::f32x16`.
    Wide16,
    /// 8 lanes, hand-written AVX2 + FMA intrinsics, chosen at run time.
    Avx2,
    /// 16 lanes, hand-written AVX-512 intrinsics, chosen at run time.
    Avx512,
    /// 8 lanes on pulp's portable operations, as pulp `V3` (AVX2 + FMA), chosen at run time.
    Pulp8,
    /// 16 lanes on pulp's portable operations, as pulp `V4` (AVX-512), chosen at run time.
    Pulp16,
    /// 4 lanes on pulp's portable operations, as pulp `Neon` (aarch64 only).
    Pulp4,
    /// 1 lane, the scalar backend with the SIMD backends' estimates for `rsqrt` and `recip`
    /// (x86-64 only): the arithmetic factor of Table 3 on its own. Not swept (not in
    /// [`Backend::ALL`]).
    ScalarEst,
}

/// A computation generic over the lane type, run by [`Backend::run`].
///
/// Mark `run` `#[inline(always)]`, and everything it calls per packet too: the run-time
/// dispatched backends (avx2, avx512, pulp8, pulp16)
/// run it inside a `#[target_feature]` function, and code that is not inlined into it is
/// compiled without AVX.
pub trait Kernel {
    type Output;
    /// The backends [`Backend::run`] compiles this kernel for, a set of [`Backend::bit`]s;
    /// on any other, `run` says the backend cannot run it. The build of every kernel on every
    /// backend is most of the workspace's compile time, so a kernel is compiled only where it
    /// runs: by default on [`Backend::ALL`], without [`Backend::ScalarEst`], which exists for
    /// the factor table's frames and the tests that stamp it (those kernels add its bit,
    /// [`Backend::WITH_FACTORS`]); a test that stamps one backend narrows its kernel to it
    /// with [`Only`].
    const BACKENDS: u32 = Backend::bits(&Backend::ALL);
    fn run<L: Lanes>(self, l: L) -> Self::Output;
}

/// Kernel `K` compiled for the backends of the set `BITS` alone ([`Kernel::BACKENDS`]): a
/// test stamped for backend `B` runs `B.run(Only::<_, { B.bit() }>(k))`, and the kernel is
/// compiled once instead of once per backend.
pub struct Only<K, const BITS: u32>(pub K);

impl<K: Kernel, const BITS: u32> Kernel for Only<K, BITS> {
    type Output = K::Output;
    const BACKENDS: u32 = K::BACKENDS & BITS;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> K::Output {
        self.0.run(l)
    }
}

/// A backend that cannot run here.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BackendError {
    #[error("unknown backend `{name}`; backends: {all}; usable here: {available}")]
    Unknown {
        name: String,
        all: String,
        available: String,
    },
    #[error("backend `{backend}` cannot run here: {reason}; usable here: {available}")]
    Unavailable {
        backend: Backend,
        reason: String,
        available: String,
    },
}

/// What a backend needs of the CPU beyond what its build targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Cpu {
    /// Nothing: the target's baseline (x86-64's SSE2) is enough.
    Baseline,
    /// AVX2 + FMA (pulp's `V3`).
    V3,
    /// AVX-512 F/BW/CD/DQ/VL (pulp's `V4`).
    V4,
    /// NEON (pulp's `Neon`).
    Neon,
}

/// One backend's facts. [`INFO`] holds a row per backend, in the enum's order, and every
/// per-backend property below reads it; only [`Backend::run`] names the lane types.
struct Info {
    backend: Backend,
    name: &'static str,
    lanes: usize,
    /// The reports' group: `wide`, `pulp`, or the backend's own name.
    family: &'static str,
    /// In the sweeps ([`Backend::ALL`]); the others are [`Backend::FACTORS`].
    swept: bool,
    /// Written by hand per instruction set, as the paper's were.
    hand_written: bool,
    /// Rank among the backends of its width for [`Backend::preferred_for_lanes`] (lower
    /// first); `None`: never the one measured at its width.
    preference: Option<u8>,
    /// The cargo feature that compiles it in (`""`: none) and whether this build has it.
    feature: &'static str,
    feature_on: bool,
    /// The target architecture it needs (`""`: any) and whether this build is for it.
    arch: &'static str,
    arch_on: bool,
    cpu: Cpu,
    /// `rsqrt` and `recip` are the hardware's estimates (else exact).
    estimates: bool,
    /// The instruction set its code is compiled for, in this build.
    instructions: &'static str,
    /// The traversal tests (every accelerator against brute force, the BSP's own and its
    /// beams') run on it: [`Backend::TRAVERSAL_TESTED`]. Each backend there compiles every
    /// traversal once more, so a backend whose answers another one already gives bit for bit
    /// (the lane tests check that) is left out.
    traversal_tested: bool,
}

const X86: bool = cfg!(target_arch = "x86_64");
const ARM: bool = cfg!(target_arch = "aarch64");

/// What `wide` compiles to: the build's target features.
const WIDE_INSTRUCTIONS: &str = if ARM {
    "NEON (wide's aarch64 paths)"
} else if cfg!(target_feature = "avx512f") {
    "the build's target features: AVX-512"
} else if cfg!(target_feature = "avx2") {
    "the build's target features: AVX2"
} else {
    "the build's target features: SSE2 (the x86-64 baseline)"
};

/// Every backend's facts, in the order of [`Backend`]'s variants.
const INFO: [Info; 11] = [
    Info {
        backend: Backend::Scalar,
        name: "scalar",
        lanes: 1,
        family: "scalar",
        swept: true,
        hand_written: true,
        preference: Some(0),
        feature: "",
        feature_on: true,
        arch: "",
        arch_on: true,
        cpu: Cpu::Baseline,
        estimates: false,
        instructions: if ARM {
            "A64 scalar floating point"
        } else {
            "SSE2 scalar (the x86-64 baseline)"
        },
        traversal_tested: true,
    },
    Info {
        backend: Backend::Sse,
        name: "sse",
        lanes: 4,
        family: "sse",
        swept: true,
        hand_written: true,
        preference: Some(0),
        feature: "sse",
        feature_on: cfg!(feature = "sse"),
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::Baseline,
        estimates: true,
        instructions: "SSE2 (the x86-64 baseline)",
        traversal_tested: true,
    },
    Info {
        backend: Backend::Wide4,
        name: "wide4",
        lanes: 4,
        family: "wide",
        swept: true,
        hand_written: false,
        preference: Some(2),
        feature: "wide",
        feature_on: cfg!(feature = "wide"),
        arch: "",
        arch_on: true,
        cpu: Cpu::Baseline,
        estimates: X86,
        instructions: WIDE_INSTRUCTIONS,
        // On x86-64 sse gives its answers bit for bit; aarch64 has no other 4-lane backend
        // compiled everywhere.
        traversal_tested: !X86,
    },
    Info {
        backend: Backend::Wide8,
        name: "wide8",
        lanes: 8,
        family: "wide",
        swept: true,
        hand_written: false,
        preference: Some(2),
        feature: "wide",
        feature_on: cfg!(feature = "wide"),
        arch: "",
        arch_on: true,
        cpu: Cpu::Baseline,
        estimates: X86,
        instructions: WIDE_INSTRUCTIONS,
        // On x86-64 avx2 gives its answers bit for bit.
        traversal_tested: !X86,
    },
    Info {
        backend: Backend::Wide16,
        name: "wide16",
        lanes: 16,
        family: "wide",
        swept: true,
        hand_written: false,
        preference: Some(2),
        feature: "wide",
        feature_on: cfg!(feature = "wide"),
        arch: "",
        arch_on: true,
        cpu: Cpu::Baseline,
        estimates: X86,
        instructions: WIDE_INSTRUCTIONS,
        // 16 lanes on the machines without AVX-512 too.
        traversal_tested: true,
    },
    Info {
        backend: Backend::Avx2,
        name: "avx2",
        lanes: 8,
        family: "avx2",
        swept: true,
        hand_written: true,
        preference: Some(0),
        feature: "pulp",
        feature_on: cfg!(feature = "pulp"),
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::V3,
        estimates: true,
        instructions: "AVX2 + FMA (pulp's V3 entry point)",
        traversal_tested: true,
    },
    Info {
        backend: Backend::Avx512,
        name: "avx512",
        lanes: 16,
        family: "avx512",
        swept: true,
        hand_written: true,
        preference: Some(0),
        feature: "pulp",
        feature_on: cfg!(feature = "pulp"),
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::V4,
        estimates: true,
        instructions: "AVX-512 F/BW/CD/DQ/VL (pulp's V4 entry point)",
        traversal_tested: true,
    },
    Info {
        backend: Backend::Pulp8,
        name: "pulp8",
        lanes: 8,
        family: "pulp",
        swept: true,
        hand_written: false,
        preference: None,
        feature: "pulp",
        feature_on: cfg!(feature = "pulp"),
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::V3,
        estimates: false,
        instructions: "AVX2 + FMA (pulp V3)",
        traversal_tested: false,
    },
    Info {
        backend: Backend::Pulp16,
        name: "pulp16",
        lanes: 16,
        family: "pulp",
        swept: true,
        hand_written: false,
        preference: None,
        feature: "pulp",
        feature_on: cfg!(feature = "pulp"),
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::V4,
        estimates: false,
        instructions: "AVX-512 F/BW/CD/DQ/VL (pulp V4)",
        traversal_tested: false,
    },
    Info {
        backend: Backend::Pulp4,
        name: "pulp4",
        lanes: 4,
        family: "pulp",
        swept: true,
        hand_written: false,
        // aarch64 has no hand-written backend: pulp4 is measured there before wide4.
        preference: Some(1),
        feature: "pulp",
        feature_on: cfg!(feature = "pulp"),
        arch: "aarch64",
        arch_on: ARM,
        cpu: Cpu::Neon,
        estimates: false,
        instructions: "NEON (pulp Neon)",
        traversal_tested: false,
    },
    Info {
        backend: Backend::ScalarEst,
        name: "scalar-est",
        lanes: 1,
        family: "scalar-est",
        swept: false,
        hand_written: false,
        preference: None,
        feature: "",
        feature_on: true,
        // The estimate instructions of the SIMD backends it stands in for.
        arch: "x86-64",
        arch_on: X86,
        cpu: Cpu::Baseline,
        estimates: true,
        instructions: "SSE scalar, with rsqrtss/rcpss estimates",
        traversal_tested: false,
    },
];

// The table is in the enum's order: `Backend::info` indexes it by discriminant.
const _: () = {
    let mut i = 0;
    while i < INFO.len() {
        assert!(
            INFO[i].backend as usize == i,
            "INFO is not in Backend's order"
        );
        i += 1;
    }
};

/// How many rows of [`INFO`] are swept (`true`) or not.
const fn count(swept: bool) -> usize {
    let (mut n, mut i) = (0, 0);
    while i < INFO.len() {
        if INFO[i].swept == swept {
            n += 1;
        }
        i += 1;
    }
    n
}

/// The backends of [`INFO`] that are swept (`true`) or not, in its order.
const fn collect<const N: usize>(swept: bool) -> [Backend; N] {
    let mut out = [Backend::Scalar; N];
    let (mut n, mut i) = (0, 0);
    while i < INFO.len() {
        if INFO[i].swept == swept {
            out[n] = INFO[i].backend;
            n += 1;
        }
        i += 1;
    }
    out
}

/// The set of the swept backends written by hand ([`Backend::hand_written`]).
const fn hand_written_bits() -> u32 {
    let (mut bits, mut i) = (0, 0);
    while i < INFO.len() {
        if INFO[i].swept && INFO[i].hand_written {
            bits |= 1 << INFO[i].backend as u32;
        }
        i += 1;
    }
    bits
}

/// How many rows of [`INFO`] the traversal tests run on.
const fn count_tested() -> usize {
    let (mut n, mut i) = (0, 0);
    while i < INFO.len() {
        if INFO[i].traversal_tested {
            n += 1;
        }
        i += 1;
    }
    n
}

/// The backends the traversal tests run on, in [`INFO`]'s order.
const fn collect_tested<const N: usize>() -> [Backend; N] {
    let mut out = [Backend::Scalar; N];
    let (mut n, mut i) = (0, 0);
    while i < INFO.len() {
        if INFO[i].traversal_tested {
            out[n] = INFO[i].backend;
            n += 1;
        }
        i += 1;
    }
    out
}

impl Backend {
    /// Every swept backend, in [`INFO`]'s order (narrowest first within each family).
    pub const ALL: [Backend; count(true)] = collect(true);

    /// The backends the traversal tests run on, in [`INFO`]'s order: every width on this
    /// architecture, each compiled once (see `Info::traversal_tested`).
    pub const TRAVERSAL_TESTED: [Backend; count_tested()] = collect_tested();

    /// The set of [`Backend::TRAVERSAL_TESTED`], for the tests' `Only` kernels.
    pub const TRAVERSAL_TESTED_BITS: u32 = Backend::bits(&Backend::TRAVERSAL_TESTED);

    /// The backends outside the sweeps, which the command line and the factor table of
    /// `table3` name: the scalar backend with estimated arithmetic.
    pub const FACTORS: [Backend; count(false)] = collect(false);

    /// This backend's row of [`INFO`].
    const fn info(self) -> &'static Info {
        &INFO[self as usize]
    }

    /// The set of [`Backend::hand_written`], one backend per width, for a kernel compiled
    /// only where the width comparison needs it (the renderer's spectral colour).
    pub const HAND_WRITTEN_BITS: u32 = hand_written_bits();

    /// The set of [`Backend::every`], for a kernel's [`Kernel::BACKENDS`].
    pub const WITH_FACTORS: u32 = Backend::bits(&Backend::ALL) | Backend::bits(&Backend::FACTORS);

    /// This backend's bit in a set of backends ([`Kernel::BACKENDS`]).
    pub const fn bit(self) -> u32 {
        1 << self as u32
    }

    /// The set of the backends `list`.
    pub const fn bits(list: &[Backend]) -> u32 {
        let mut bits = 0;
        let mut i = 0;
        while i < list.len() {
            bits |= list[i].bit();
            i += 1;
        }
        bits
    }

    /// Every backend the command line takes: [`Backend::ALL`], then [`Backend::FACTORS`].
    pub fn every() -> impl Iterator<Item = Backend> {
        Backend::ALL.into_iter().chain(Backend::FACTORS)
    }

    /// Whether `rsqrt` and `recip` are the hardware's estimates (`estimate`: sse, avx2,
    /// avx512, scalar-est, and wide on x86-64) or exact divisions and square roots (`exact`:
    /// scalar, the pulp backends, wide elsewhere): the `arithmetic` column of the factor table.
    pub fn arithmetic(self) -> &'static str {
        if self.info().estimates {
            "estimate"
        } else {
            "exact"
        }
    }

    /// The name used on the command line and in results files.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Lanes per packet.
    pub fn lanes(self) -> usize {
        self.info().lanes
    }

    /// Whether this build has the backend (cargo features and target architecture).
    pub fn compiled(self) -> bool {
        self.info().feature_on && self.info().arch_on
    }

    /// Why the backend cannot run here, or `None` when it can.
    pub fn unavailable_reason(self) -> Option<String> {
        let info = self.info();
        if !info.feature_on {
            return Some(format!(
                "not compiled in: build with the cargo feature `{}`",
                info.feature
            ));
        }
        if !info.arch_on {
            return Some(format!(
                "the `{}` backend needs an {} target (this build is for another architecture)",
                info.name, info.arch
            ));
        }
        if cpu_has(info.cpu) {
            None
        } else {
            Some(format!("this CPU lacks {}", cpu_needs(info.cpu)))
        }
    }

    /// The family the reports group the backend in: `wide` for wide4/8/16, `pulp` for
    /// pulp4/8/16, the backend itself for the hand-written ones.
    pub fn family(self) -> &'static str {
        self.info().family
    }

    /// The swept backends written by hand per instruction set, as the paper's were (scalar,
    /// sse, avx2, avx512): the lines of the reports' speedup-versus-lanes plots.
    pub fn hand_written() -> impl Iterator<Item = Backend> {
        Backend::ALL.into_iter().filter(|b| b.info().hand_written)
    }

    /// The families of [`Backend::ALL`] (as [`Backend::family`] names them), the hand-written
    /// ones first, each in the order of `ALL`: the order reports list them in.
    pub fn families() -> Vec<&'static str> {
        let mut out: Vec<&'static str> = Backend::hand_written().map(Backend::family).collect();
        for b in Backend::ALL {
            if !out.contains(&b.family()) {
                out.push(b.family());
            }
        }
        out
    }

    /// The backend of [`Backend::ALL`] in `family` (as [`Backend::family`] names it) with
    /// `lanes` lanes, if any.
    pub fn in_family(family: &str, lanes: usize) -> Option<Backend> {
        Backend::ALL
            .into_iter()
            .find(|&b| b.lanes() == lanes && b.family() == family)
    }

    /// The backend named `name` (any of [`Backend::every`]), if there is one.
    pub fn named(name: &str) -> Option<Backend> {
        Backend::every().find(|b| b.name() == name)
    }

    /// The instruction set the backend's code is compiled for, in this build.
    pub fn instructions(self) -> &'static str {
        self.info().instructions
    }

    /// The cargo feature that compiles the backend in (`scalar` has none).
    pub fn feature(self) -> &'static str {
        self.info().feature
    }

    /// Whether the backend can run here.
    pub fn is_available(self) -> bool {
        self.unavailable_reason().is_none()
    }

    /// The backends that can run here, narrowest first.
    pub fn available() -> Vec<Backend> {
        Backend::ALL
            .into_iter()
            .filter(|b| b.is_available())
            .collect()
    }

    /// The usable backend to measure at a packet width: the hand-written or run-time
    /// dispatched one (scalar, sse, avx2, avx512; pulp4 on aarch64, which has no hand-written
    /// backend) where this CPU runs it, else `wide`.
    pub fn preferred_for_lanes(lanes: usize) -> Option<Backend> {
        Backend::preference(lanes)
            .into_iter()
            .find(|b| b.is_available())
    }

    /// The backends of a packet width in the order [`Backend::preferred_for_lanes`] picks
    /// them, usable here or not (reports pick from the rows a results file has).
    pub fn preference(lanes: usize) -> Vec<Backend> {
        let mut v: Vec<Backend> = Backend::ALL
            .into_iter()
            .filter(|b| b.lanes() == lanes && b.info().preference.is_some())
            .collect();
        v.sort_by_key(|b| b.info().preference);
        v
    }

    /// The widest hand-written or run-time dispatched backend usable here (the default for
    /// rendering): avx512, else avx2, else sse, else the widest `wide`, else scalar.
    pub fn widest() -> Backend {
        // A machine without AVX-512 runs wide16 (two AVX2 halves per operation), but avx2 is
        // the faster and the measured one: the first choices of every width come before any
        // fallback.
        let first = |b: &Backend| b.info().preference == Some(0) && b.lanes() > 1;
        [16, 8, 4]
            .into_iter()
            .flat_map(Backend::preference)
            .find(|b| first(b) && b.is_available())
            .or_else(|| {
                [16, 8, 4]
                    .into_iter()
                    .find_map(Backend::preferred_for_lanes)
            })
            .unwrap_or(Backend::Scalar)
    }

    /// The backends this machine must run, from `COHERENT_REQUIRE_BACKENDS`: a comma-separated
    /// list of names, or `native-all` (every compiled-in backend whose instructions the CPU
    /// reports, checked with `std`'s feature detection, independently of pulp's tokens).
    /// Unset or empty: none. An unknown name is an error.
    pub fn required() -> Result<Vec<Backend>, BackendError> {
        let spec = std::env::var(REQUIRE_ENV).unwrap_or_default();
        let spec = spec.trim();
        if spec.eq_ignore_ascii_case("native-all") {
            return Ok(Backend::ALL
                .into_iter()
                .filter(|b| b.compiled() && cpu_reports(b.info().cpu))
                .collect());
        }
        spec.split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(str::parse)
            .collect()
    }

    /// The backends that cannot run here, each with the reason.
    pub fn skipped() -> Vec<(Backend, String)> {
        Backend::ALL
            .into_iter()
            .filter_map(|b| b.unavailable_reason().map(|r| (b, r)))
            .collect()
    }

    /// The backends tests stamp: those usable here. Prints each skipped backend by name, and
    /// panics (failing the test) when `COHERENT_REQUIRE_BACKENDS` names one that cannot run
    /// here, or names an unknown backend: a test cannot pass by skipping a backend CI's CPU has.
    pub fn usable() -> Vec<Backend> {
        if let Err(e) = Backend::check_required() {
            panic!("{e}");
        }
        for (b, why) in Backend::skipped() {
            eprintln!("skipping backend {b}: {why}");
        }
        Backend::available()
    }

    /// `Err` naming every backend `COHERENT_REQUIRE_BACKENDS` requires that cannot run here.
    pub fn check_required() -> Result<(), String> {
        let required = Backend::required().map_err(|e| format!("{REQUIRE_ENV}: {e}"))?;
        let missing: Vec<String> = required
            .into_iter()
            .filter_map(|b| b.unavailable_reason().map(|r| format!("{b} ({r})")))
            .collect();
        if missing.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{REQUIRE_ENV} requires backends that cannot run here: {}",
                missing.join("; ")
            ))
        }
    }

    fn available_list() -> String {
        Backend::available()
            .iter()
            .map(|b| b.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Runs `k` with this backend's lane type, or says why it cannot run here.
    pub fn run<K: Kernel>(self, k: K) -> Result<K::Output, BackendError> {
        if let Some(reason) = self.unavailable_reason() {
            return Err(BackendError::Unavailable {
                backend: self,
                reason,
                available: Backend::available_list(),
            });
        }
        // A kernel is compiled only for its backends (`Kernel::BACKENDS`): each arm's
        // condition is a constant, which the collector resolves, so an arm left out is
        // never compiled.
        macro_rules! on {
            ($b:expr, $run:expr) => {
                if const { K::BACKENDS & $b.bit() != 0 } {
                    Ok($run)
                } else {
                    Err($b.not_compiled_for())
                }
            };
        }
        match self {
            Backend::Scalar => on!(Backend::Scalar, run_on(k, crate::scalar::Scalar)),
            #[cfg(target_arch = "x86_64")]
            Backend::ScalarEst => on!(Backend::ScalarEst, run_on(k, crate::scalar_est::ScalarEst)),
            #[cfg(all(feature = "sse", target_arch = "x86_64"))]
            Backend::Sse => on!(Backend::Sse, run_on(k, crate::sse::Sse)),
            #[cfg(feature = "wide")]
            Backend::Wide4 => on!(Backend::Wide4, run_on(k, crate::wide::Wide4)),
            #[cfg(feature = "wide")]
            Backend::Wide8 => on!(Backend::Wide8, run_on(k, crate::wide::Wide8)),
            #[cfg(feature = "wide")]
            Backend::Wide16 => on!(Backend::Wide16, run_on(k, crate::wide::Wide16)),
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Avx2 => on!(Backend::Avx2, {
                let l = crate::avx2::Avx2::try_new().expect("checked by unavailable_reason");
                l.simd().vectorize(
                    #[inline(always)]
                    move || k.run(l),
                )
            }),
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Avx512 => on!(Backend::Avx512, {
                let l = crate::avx512::Avx512::try_new().expect("checked by unavailable_reason");
                l.simd().vectorize(
                    #[inline(always)]
                    move || k.run(l),
                )
            }),
            // The portable backends: pulp calls `WithKernel::with_simd` with its token inside
            // the token's `#[target_feature]` entry point.
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Pulp8 => on!(Backend::Pulp8, {
                let s = pulp::x86::V3::try_new().expect("checked by unavailable_reason");
                pulp::Simd::vectorize(s, crate::pulp::WithKernel(k))
            }),
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Pulp16 => on!(Backend::Pulp16, {
                let s = pulp::x86::V4::try_new().expect("checked by unavailable_reason");
                pulp::Simd::vectorize(s, crate::pulp::WithKernel(k))
            }),
            #[cfg(all(feature = "pulp", target_arch = "aarch64"))]
            Backend::Pulp4 => on!(Backend::Pulp4, {
                let s = pulp::aarch64::Neon::try_new().expect("checked by unavailable_reason");
                pulp::Simd::vectorize(s, crate::pulp::WithKernel(k))
            }),
            #[allow(unreachable_patterns)]
            _ => unreachable!("{} is not compiled in, checked above", self.name()),
        }
    }
}

impl Backend {
    /// Why this backend cannot run a kernel not compiled for it ([`Kernel::BACKENDS`]).
    fn not_compiled_for(self) -> BackendError {
        let reason = if self == Backend::ScalarEst {
            format!(
                "`{}` runs only the renderer's frames, tone mapping and the lane tests (the \
                 factor table's workload)",
                self.name()
            )
        } else {
            "this workload is not compiled for it".to_string()
        };
        BackendError::Unavailable {
            backend: self,
            reason,
            available: Backend::available_list(),
        }
    }
}

/// `k` on the lanes `l`, in a function of its own per backend. The kernel inlines into it as
/// into the `#[target_feature]` entry points of the run-time dispatched backends; kept out of
/// [`Backend::run`], so that one kernel's copies for every backend are not one function of
/// megabytes, which LLVM optimises in time superlinear in its size and cannot split between
/// codegen units (a frame kernel took most of the library's build time).
#[inline(never)]
fn run_on<K: Kernel, L: Lanes>(k: K, l: L) -> K::Output {
    k.run(l)
}

/// The environment variable naming the backends a test run must not skip.
pub const REQUIRE_ENV: &str = "COHERENT_REQUIRE_BACKENDS";

/// Whether the CPU reports the instructions of `cpu` (`std` detection, not pulp's).
fn cpu_reports(cpu: Cpu) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        match cpu {
            // SSE2 is part of x86-64 itself.
            Cpu::Baseline => true,
            Cpu::V3 => has!("avx2") && has!("fma"),
            Cpu::V4 => {
                has!("avx512f")
                    && has!("avx512bw")
                    && has!("avx512cd")
                    && has!("avx512dq")
                    && has!("avx512vl")
            }
            Cpu::Neon => false,
        }
    }
    #[cfg(target_arch = "aarch64")]
    {
        match cpu {
            Cpu::Baseline => true,
            Cpu::V3 | Cpu::V4 => false,
            Cpu::Neon => std::arch::is_aarch64_feature_detected!("neon"),
        }
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        cpu == Cpu::Baseline
    }
}

/// Whether this CPU runs the code of `cpu` (pulp's tokens, which the run-time dispatched
/// backends run under).
fn cpu_has(cpu: Cpu) -> bool {
    match cpu {
        Cpu::Baseline => true,
        #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
        Cpu::V3 => pulp::x86::V3::try_new().is_some(),
        #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
        Cpu::V4 => pulp::x86::V4::try_new().is_some(),
        #[cfg(all(feature = "pulp", target_arch = "aarch64"))]
        Cpu::Neon => pulp::aarch64::Neon::try_new().is_some(),
        #[allow(unreachable_patterns)]
        _ => false,
    }
}

/// What `cpu` needs, for an error message.
fn cpu_needs(cpu: Cpu) -> &'static str {
    match cpu {
        Cpu::Baseline => "nothing",
        Cpu::V3 => "AVX2 or FMA (pulp V3)",
        Cpu::V4 => "AVX-512 F/BW/CD/DQ/VL (pulp V4)",
        Cpu::Neon => "NEON",
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Backend {
    type Err = BackendError;
    fn from_str(s: &str) -> Result<Backend, BackendError> {
        Backend::every()
            .find(|b| b.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| BackendError::Unknown {
                name: s.to_string(),
                all: Backend::every()
                    .map(|b| b.name())
                    .collect::<Vec<_>>()
                    .join(", "),
                available: Backend::available_list(),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for b in Backend::every() {
            assert_eq!(b.name().parse::<Backend>().unwrap(), b);
            assert_eq!(b.to_string(), b.name());
        }
    }

    #[test]
    fn unknown_name_lists_backends() {
        let e = "avx9".parse::<Backend>().unwrap_err().to_string();
        assert!(
            e.contains("avx9")
                && e.contains("scalar")
                && e.contains("avx512")
                && e.contains("pulp16"),
            "{e}"
        );
    }

    #[test]
    fn required_backends_run_here() {
        // Fails when COHERENT_REQUIRE_BACKENDS names a backend this machine skips.
        let usable = Backend::usable();
        for b in Backend::required().unwrap() {
            assert!(usable.contains(&b), "{b} required but not usable");
        }
    }

    #[test]
    fn native_all_matches_the_tokens() {
        // std's feature detection and pulp's tokens agree on what this CPU runs.
        for b in Backend::every() {
            if b.compiled() {
                assert_eq!(cpu_reports(b.info().cpu), b.is_available(), "{b}");
            }
        }
    }

    #[test]
    fn the_widest_is_the_first_choice_of_the_widest_width_that_has_one_here() {
        let w = Backend::widest();
        assert!(w.is_available(), "{w}");
        for b in [Backend::Avx512, Backend::Avx2, Backend::Sse] {
            if b.is_available() {
                assert_eq!(w, b);
                return;
            }
        }
        assert!(!w.info().hand_written || w == Backend::Scalar, "{w}");
    }

    #[test]
    fn the_table_gives_the_lists() {
        assert_eq!(Backend::ALL.len() + Backend::FACTORS.len(), INFO.len());
        assert_eq!(Backend::FACTORS, [Backend::ScalarEst]);
        assert_eq!(Backend::preference(1), [Backend::Scalar]);
        assert_eq!(
            Backend::preference(4),
            [Backend::Sse, Backend::Pulp4, Backend::Wide4]
        );
        assert_eq!(Backend::preference(8), [Backend::Avx2, Backend::Wide8]);
        assert_eq!(Backend::preference(16), [Backend::Avx512, Backend::Wide16]);
        assert!(Backend::preference(3).is_empty());
        // Estimates where the hardware's are used: the factor table's `arithmetic`.
        assert_eq!(Backend::Avx2.arithmetic(), "estimate");
        assert_eq!(Backend::Pulp8.arithmetic(), "exact");
        assert_eq!(Backend::Scalar.arithmetic(), "exact");
    }

    #[test]
    fn scalar_always_available() {
        assert!(Backend::available().contains(&Backend::Scalar));
    }

    #[test]
    fn preferred_backend_has_the_width_and_runs_here() {
        assert_eq!(Backend::preferred_for_lanes(1), Some(Backend::Scalar));
        for n in [4, 8, 16] {
            if let Some(b) = Backend::preferred_for_lanes(n) {
                assert!(b.lanes() == n && b.is_available());
            }
        }
        assert_eq!(Backend::preferred_for_lanes(3), None);
    }

    struct Lanes_;
    impl Kernel for Lanes_ {
        type Output = usize;
        const BACKENDS: u32 = Backend::WITH_FACTORS;
        fn run<L: Lanes>(self, _l: L) -> usize {
            L::N
        }
    }

    /// Sums lane ids inside the kernel and apart from it (`Lanes::apart`).
    struct Apart;
    impl Kernel for Apart {
        type Output = (i32, i32);
        fn run<L: Lanes>(self, l: L) -> (i32, i32) {
            use crate::SimdI32;
            let sum = |v: L::I32s| (0..L::N).map(|i| v.lane(i)).sum::<i32>();
            let inside = sum(l.lane_ids() + l.splat_i32(1));
            let apart = l.apart(|l| sum(l.lane_ids() + l.splat_i32(1)));
            (inside, apart)
        }
    }

    #[test]
    fn apart_runs_on_the_same_lanes() {
        for b in Backend::available() {
            let n = b.lanes() as i32;
            assert_eq!(b.run(Apart), Ok((n * (n + 1) / 2, n * (n + 1) / 2)), "{b}");
        }
    }

    struct NotOptedIn;
    impl Kernel for NotOptedIn {
        type Output = ();
        fn run<L: Lanes>(self, _l: L) {}
    }

    #[test]
    fn scalar_est_runs_only_the_kernels_that_opt_in() {
        if Backend::ScalarEst.is_available() {
            assert_eq!(Backend::ScalarEst.run(Lanes_), Ok(1));
            let e = Backend::ScalarEst.run(NotOptedIn).unwrap_err();
            assert!(e.to_string().contains("scalar-est"), "{e}");
        }
    }

    #[test]
    fn only_runs_a_kernel_on_its_backends() {
        let scalar = Backend::Scalar.run(Only::<_, { Backend::Scalar.bit() }>(Lanes_));
        assert_eq!(scalar, Ok(1));
        for b in Backend::available()
            .into_iter()
            .filter(|b| *b != Backend::Scalar)
        {
            let e = b
                .run(Only::<_, { Backend::Scalar.bit() }>(Lanes_))
                .unwrap_err();
            assert!(e.to_string().contains("not compiled for it"), "{e}");
            assert_eq!(b.run(Lanes_), Ok(b.lanes()), "{b}");
        }
        // Narrowing never widens: scalar-est stays out of a kernel that left it out.
        let wide = Only::<_, { Backend::WITH_FACTORS }>(NotOptedIn);
        if Backend::ScalarEst.is_available() {
            assert!(Backend::ScalarEst.run(wide).is_err());
        }
    }

    #[test]
    fn names_families_and_the_hand_written_ones() {
        for b in Backend::every() {
            assert_eq!(Backend::named(b.name()), Some(b));
            assert!(b.name().starts_with(b.family()), "{b}");
        }
        assert_eq!(Backend::named("avx1024"), None);
        assert_eq!(Backend::Wide8.family(), "wide");
        assert_eq!(Backend::Pulp4.family(), "pulp");
        let hand: Vec<&str> = Backend::hand_written().map(Backend::name).collect();
        assert_eq!(hand, ["scalar", "sse", "avx2", "avx512"]);
        for b in Backend::every() {
            assert!(!b.instructions().is_empty(), "{b}");
        }
        assert!(Backend::Pulp4.instructions().contains("NEON"));
    }

    #[test]
    fn run_uses_the_backend_lane_count() {
        for b in Backend::every() {
            match b.run(Lanes_) {
                Ok(n) => assert_eq!(n, b.lanes()),
                Err(e) => {
                    assert!(!b.is_available());
                    assert!(e.to_string().contains(b.name()));
                }
            }
        }
    }
}
