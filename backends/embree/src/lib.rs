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
mod packet;
mod query;
mod scene;

#[cfg(test)]
mod abi;

pub use device::Device;
pub use error::EmbreeError;
pub use packet::{COHERENT_CONE_DEGREES, PacketK};
pub use query::valid_lanes;
pub use scene::{BuildQuality, Coherence, Embree, EmbreeParams};

/// Whether Embree can be used here, or why not (cause and fix).
pub fn unavailable_reason() -> Option<String> {
    Device::shared(Some(1)).err().map(|e| e.to_string())
}

/// `rtcGetDeviceProperty(VERSION)` of the loaded library, e.g. 40400 for 4.4.0.
pub fn version() -> Result<u32, EmbreeError> {
    Device::shared(Some(1)).map(|d| d.version())
}

/// What the loaded Embree runs on this machine (for `machine.json` and reports).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmbreeInfo {
    /// `major.minor.patch`, e.g. `4.4.0`.
    pub version: String,
    /// The instruction set its kernels use here (see [`Device::isa`]).
    pub isa: &'static str,
    /// The packet widths (of 4, 8, 16) it runs natively rather than emulated.
    pub native_packets: Vec<usize>,
}

/// [`EmbreeInfo`] of the loaded library, or why there is none.
pub fn info() -> Result<EmbreeInfo, EmbreeError> {
    let d = Device::shared(Some(1))?;
    Ok(EmbreeInfo {
        version: version_string(d.version()),
        isa: d.isa(),
        native_packets: [4, 8, 16]
            .into_iter()
            .filter(|&w| d.native_packets(w))
            .collect(),
    })
}

/// 40400 -> `4.4.0`.
pub fn version_string(v: u32) -> String {
    format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
}
