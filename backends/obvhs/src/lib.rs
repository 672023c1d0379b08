//! obvhs BVH2 and CWBVH behind the project's traversal interface: the BVHs people use
//! today, measured against the paper's two-level BSP (section 3) across the same boundary.
//!
//! obvhs traverses one ray at a time, so a packet is served lane by lane (the results say
//! so); beams (many coherent packets at once) walk BVH2s with this crate's large-packet
//! traversal ([`packet`], Wald, Boulos & Shirley 2007); instances go through per-mesh trees and a top tree, with the rays moved into each
//! instance's space here (obvhs' own TLAS traversal does not transform rays).

mod accel;
pub mod packet;
mod scene;
mod tree;

#[cfg(test)]
mod tests;

pub use scene::{Obvhs, ObvhsParams};
pub use tree::{Count, Counts, Kind, Preset, Tree};
