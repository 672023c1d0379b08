//! Coherent texturing (paper section 4.1): texture coordinates interpolated per lane,
//! images loaded and inverse tone mapped to linear values, a mipmap pyramid, the mip level
//! by successive halving of the hit distance (or from ray differentials), and trilinear
//! filtering over lanes with wrap or clamp addressing.

pub mod coords;
pub mod error;
pub mod load;
pub mod lod;
pub mod pyramid;
pub mod sample;
pub mod workload;

pub use coords::TexCoords;
pub use error::TextureError;
pub use load::{InverseToneMap, load};
pub use lod::{lod_by_halving, lod_from_differentials};
pub use pyramid::{LevelInfo, Texture};
pub use sample::{Footprint, Wrap};

#[cfg(test)]
mod tests;
