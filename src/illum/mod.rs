//! Illumination maps (paper section 2: higher-order indirect light from maps computed by
//! forward Monte-Carlo ray tracing; section 8: making those rays coherent is the next
//! problem). Particles leave the lights by their own emission ([`emit`]), deposit their power
//! in the surface cells they land in from their second hit on, and go on by sampling the
//! material until Russian roulette ends them. A cell's irradiance is its power over its area;
//! the renderer adds `albedo / pi * E` at its hits, beside the exact direct light.

pub mod emit;
pub mod error;

pub use emit::{Emitter, Particle};
pub use error::IllumError;
