//! `coherent`: coherent (SIMD packet) physically accurate ray tracing after Adinetz et al.,
//! Graphicon 2005.

pub use coherent_accel as accel;
pub use coherent_bsp as bsp;
pub use coherent_simd as simd;

#[cfg(feature = "embree")]
pub use coherent_embree as embree;
#[cfg(feature = "obvhs")]
pub use coherent_obvhs as obvhs;

pub mod accel_any;
pub mod approx;
pub mod bdf;
pub mod camera;
pub mod export;
pub mod film;
pub mod illum;
pub mod kernels;
pub mod light;
pub mod machine;
pub mod material;
pub mod median;
pub mod mesh_file;
pub mod plot_font;
pub mod render;
pub mod require;
pub mod sampler;
pub mod scene;
pub mod spectrum;
pub mod tabulated;
pub mod texture;
pub mod tonemap;
pub mod view;
