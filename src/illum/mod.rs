//! Illumination maps (paper section 2: higher-order indirect light from maps computed by
//! forward Monte-Carlo ray tracing; section 8: making those rays coherent is the next
//! problem). Particles leave the lights by their own emission ([`emit`]), deposit their power
//! in the surface cells they land in from their second hit on, and go on by sampling the
//! material until Russian roulette ends them ([`trace`]). A cell's irradiance is its power over
//! its area ([`map`], on the cells of [`cells`]); the renderer adds `albedo / pi * E` at its
//! hits, beside the exact direct light. Maps are saved and loaded as OpenEXR ([`file`]).

pub mod cells;
pub mod emit;
pub mod error;
pub mod file;
pub mod map;
pub mod mode;
pub mod order;
pub mod stats;
#[cfg(test)]
mod tests;
pub mod trace;

pub use cells::{CellLayout, DEFAULT_CELLS, MAP_BUDGET};
pub use emit::{Emitter, Particle};
pub use error::IllumError;
pub use file::fingerprint;
pub use map::{Deposits, IllumMap};
pub use mode::Mode;
pub use stats::{GenerationStats, TraceStats};
pub use trace::{MapOptions, build_map};
