//! `coherent-simd`: the lane trait and its backends (paper sections 3-6: every stage of the
//! renderer works on packets of rays under masks).
//!
//! Kernels are written once, generic over [`Lanes`], and run on any backend through
//! [`Backend::run`]. The backends are sibling modules; [`dispatch`] is the only place that
//! names them all.

pub mod approx;
pub mod lanes;
pub mod scalar;
#[cfg(target_arch = "x86_64")]
pub mod scalar_est;
pub mod slices;
pub mod vec3;

pub use lanes::{Lanes, MAX_LANES, SimdF32, SimdI32, SimdMask};
pub use vec3::{Rgbs, Vec3s};
#[cfg(all(feature = "pulp", target_arch = "x86_64"))]
pub mod avx2;
#[cfg(all(feature = "pulp", target_arch = "x86_64"))]
pub mod avx512;
#[cfg(feature = "pulp")]
pub mod pulp;
#[cfg(all(feature = "sse", target_arch = "x86_64"))]
pub mod sse;
#[cfg(feature = "wide")]
pub mod wide;
#[cfg(all(feature = "pulp", target_arch = "x86_64"))]
mod x86;

pub mod dispatch;

pub use dispatch::{Backend, BackendError, Kernel};
