//! `coherent-simd`: the lane trait and its backends (paper sections 3-6: every stage of the
//! renderer works on packets of rays under masks).
//!
//! Kernels are written once, generic over [`Lanes`], and run on any backend through
//! [`Backend::run`]. The backends are sibling modules; [`dispatch`] is the only place that
//! names them all.
//!
//! A kernel is a struct holding its inputs, whose `run` is generic over the lanes:
//!
//! ```
//! use coherent_simd::{Backend, Kernel, Lanes, SimdF32};
//!
//! /// `y = a x + y` over slices whose length is a multiple of every lane count.
//! struct Axpy<'a> {
//!     a: f32,
//!     x: &'a [f32],
//!     y: &'a mut [f32],
//! }
//!
//! impl Kernel for Axpy<'_> {
//!     type Output = ();
//!     // Inlined into each backend's entry point (its `#[target_feature]` function).
//!     #[inline(always)]
//!     fn run<L: Lanes>(self, l: L) {
//!         let a = l.splat(self.a);
//!         for (x, y) in self.x.chunks_exact(L::N).zip(self.y.chunks_exact_mut(L::N)) {
//!             a.mul_add(l.load(x), l.load(y)).store(y);
//!         }
//!     }
//! }
//!
//! let x: Vec<f32> = (0..64).map(|i| i as f32).collect();
//! // Every backend this CPU runs (named on the command line as `--backend NAME`).
//! for b in Backend::usable() {
//!     let mut y = vec![1.0; 64];
//!     b.run(Axpy { a: 2.0, x: &x, y: &mut y })?;
//!     assert!(y.iter().zip(&x).all(|(y, x)| *y == 2.0 * x + 1.0), "{b}");
//! }
//! # Ok::<(), coherent_simd::BackendError>(())
//! ```

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

pub use dispatch::{Backend, BackendError, Kernel, Only};
