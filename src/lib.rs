//! `coherent`: coherent (SIMD packet) physically accurate ray tracing after Adinetz et al.,
//! Graphicon 2005.

pub use coherent_accel as accel;
pub use coherent_bsp as bsp;
pub use coherent_simd as simd;

pub mod approx;
pub mod bdf;
pub mod kernels;
pub mod machine;
pub mod material;
pub mod tabulated;
pub mod texture;
