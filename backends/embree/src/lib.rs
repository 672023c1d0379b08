//! Embree 4 behind the project's traversal interface: the BVH people use today, measured
//! against the paper's two-level BSP (section 3) across the same packet boundary.
//!
//! The library is loaded at run time ([`library`]): the pinned Embree 4.4 that
//! `scripts/native.py` fetches into `.native/`, or `EMBREE_DIR`. Without it everything
//! builds and the rest of the program runs; building an [`Embree`] then fails with
//! [`coherent_accel::AccelError::Unavailable`] naming the paths tried and the fix.

mod accel;
mod device;
mod error;
pub mod ffi;
pub mod library;
mod query;
mod scene;

#[cfg(test)]
mod abi;

pub use device::Device;
pub use error::EmbreeError;
pub use query::valid_lanes;
pub use scene::{BuildQuality, Embree, EmbreeParams};

/// Whether Embree can be used here, or why not (cause and fix).
pub fn unavailable_reason() -> Option<String> {
    Device::new(Some(1)).err().map(|e| e.to_string())
}

/// `rtcGetDeviceProperty(VERSION)` of the loaded library, e.g. 40400 for 4.4.0.
pub fn version() -> Result<u32, EmbreeError> {
    Device::new(Some(1)).map(|d| d.version())
}
