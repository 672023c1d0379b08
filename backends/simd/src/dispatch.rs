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
    /// 8 lanes on pulp `V3` (AVX2 + FMA), chosen at run time.
    Pulp8,
    /// 16 lanes on pulp `V4` (AVX-512), chosen at run time.
    Pulp16,
}

/// A computation generic over the lane type, run by [`Backend::run`].
///
/// Mark `run` `#[inline(always)]`, and everything it calls per packet too: the pulp backends
/// run it inside a `#[target_feature]` function, and code that is not inlined into it is
/// compiled without AVX.
pub trait Kernel {
    type Output;
    fn run<L: Lanes>(self, l: L) -> Self::Output;
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

impl Backend {
    /// Every backend, narrowest first.
    pub const ALL: [Backend; 7] = [
        Backend::Scalar,
        Backend::Sse,
        Backend::Wide4,
        Backend::Wide8,
        Backend::Wide16,
        Backend::Pulp8,
        Backend::Pulp16,
    ];

    /// The name used on the command line and in results files.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Scalar => "scalar",
            Backend::Sse => "sse",
            Backend::Wide4 => "wide4",
            Backend::Wide8 => "wide8",
            Backend::Wide16 => "wide16",
            Backend::Pulp8 => "pulp8",
            Backend::Pulp16 => "pulp16",
        }
    }

    /// Lanes per packet.
    pub fn lanes(self) -> usize {
        match self {
            Backend::Scalar => 1,
            Backend::Sse | Backend::Wide4 => 4,
            Backend::Wide8 | Backend::Pulp8 => 8,
            Backend::Wide16 | Backend::Pulp16 => 16,
        }
    }

    /// Whether this build has the backend (cargo features and target architecture).
    pub fn compiled(self) -> bool {
        match self {
            Backend::Scalar => true,
            Backend::Sse => cfg!(all(feature = "sse", target_arch = "x86_64")),
            Backend::Wide4 | Backend::Wide8 | Backend::Wide16 => cfg!(feature = "wide"),
            Backend::Pulp8 | Backend::Pulp16 => {
                cfg!(all(feature = "pulp", target_arch = "x86_64"))
            }
        }
    }

    /// Why the backend cannot run here, or `None` when it can.
    pub fn unavailable_reason(self) -> Option<String> {
        if !self.compiled() {
            return Some(match self {
                Backend::Sse if cfg!(feature = "sse") => {
                    "the `sse` backend needs an x86-64 target (this build is for another architecture)"
                        .to_string()
                }
                Backend::Pulp8 | Backend::Pulp16 if cfg!(feature = "pulp") => {
                    "the pulp backends need an x86-64 target".to_string()
                }
                _ => format!(
                    "not compiled in: build with the cargo feature `{}`",
                    self.feature()
                ),
            });
        }
        match self {
            Backend::Pulp8 if !pulp8_supported() => {
                Some("this CPU lacks AVX2 or FMA (pulp V3)".to_string())
            }
            Backend::Pulp16 if !pulp16_supported() => {
                Some("this CPU lacks AVX-512 F/BW/CD/DQ/VL (pulp V4)".to_string())
            }
            _ => None,
        }
    }

    /// The cargo feature that compiles the backend in (`scalar` has none).
    pub fn feature(self) -> &'static str {
        match self {
            Backend::Scalar => "",
            Backend::Sse => "sse",
            Backend::Wide4 | Backend::Wide8 | Backend::Wide16 => "wide",
            Backend::Pulp8 | Backend::Pulp16 => "pulp",
        }
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
    /// dispatched one (scalar, sse, pulp8, pulp16) where this CPU runs it, else `wide`.
    pub fn preferred_for_lanes(lanes: usize) -> Option<Backend> {
        let prefs: &[Backend] = match lanes {
            1 => &[Backend::Scalar],
            4 => &[Backend::Sse, Backend::Wide4],
            8 => &[Backend::Pulp8, Backend::Wide8],
            16 => &[Backend::Pulp16, Backend::Wide16],
            _ => &[],
        };
        prefs.iter().copied().find(|b| b.is_available())
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
        match self {
            Backend::Scalar => Ok(k.run(crate::scalar::Scalar)),
            #[cfg(all(feature = "sse", target_arch = "x86_64"))]
            Backend::Sse => Ok(k.run(crate::sse::Sse)),
            #[cfg(feature = "wide")]
            Backend::Wide4 => Ok(k.run(crate::wide::Wide4)),
            #[cfg(feature = "wide")]
            Backend::Wide8 => Ok(k.run(crate::wide::Wide8)),
            #[cfg(feature = "wide")]
            Backend::Wide16 => Ok(k.run(crate::wide::Wide16)),
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Pulp8 => {
                let l = crate::pulp::Pulp8::try_new().expect("checked by unavailable_reason");
                Ok(l.simd().vectorize(
                    #[inline(always)]
                    move || k.run(l),
                ))
            }
            #[cfg(all(feature = "pulp", target_arch = "x86_64"))]
            Backend::Pulp16 => {
                let l = crate::pulp::Pulp16::try_new().expect("checked by unavailable_reason");
                Ok(l.simd().vectorize(
                    #[inline(always)]
                    move || k.run(l),
                ))
            }
            #[allow(unreachable_patterns)]
            _ => unreachable!("{} is not compiled in, checked above", self.name()),
        }
    }
}

#[cfg(all(feature = "pulp", target_arch = "x86_64"))]
fn pulp8_supported() -> bool {
    crate::pulp::Pulp8::try_new().is_some()
}
#[cfg(not(all(feature = "pulp", target_arch = "x86_64")))]
fn pulp8_supported() -> bool {
    false
}
#[cfg(all(feature = "pulp", target_arch = "x86_64"))]
fn pulp16_supported() -> bool {
    crate::pulp::Pulp16::try_new().is_some()
}
#[cfg(not(all(feature = "pulp", target_arch = "x86_64")))]
fn pulp16_supported() -> bool {
    false
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Backend {
    type Err = BackendError;
    fn from_str(s: &str) -> Result<Backend, BackendError> {
        Backend::ALL
            .into_iter()
            .find(|b| b.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| BackendError::Unknown {
                name: s.to_string(),
                all: Backend::ALL
                    .iter()
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
        for b in Backend::ALL {
            assert_eq!(b.name().parse::<Backend>().unwrap(), b);
            assert_eq!(b.to_string(), b.name());
        }
    }

    #[test]
    fn unknown_name_lists_backends() {
        let e = "avx9".parse::<Backend>().unwrap_err().to_string();
        assert!(
            e.contains("avx9") && e.contains("scalar") && e.contains("pulp16"),
            "{e}"
        );
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
        fn run<L: Lanes>(self, _l: L) -> usize {
            L::N
        }
    }

    #[test]
    fn run_uses_the_backend_lane_count() {
        for b in Backend::ALL {
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
