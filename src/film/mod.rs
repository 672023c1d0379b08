//! The progressive film (paper section 6.2): samples from the Halton sampler traced in
//! coherent groups through a [`SampleTracer`], accumulated in two screen matrices whose
//! disagreement is the accuracy measure, superpixels interpolated where their corners agree,
//! and the tone-mapped (section 6.1) and HDR image output.

mod accuracy;
mod batch;
mod heatmap;
mod matrix;
mod output;
pub use output::write_exr_rgb;
mod progressive;
mod render;
mod spare;
mod superpixel;
mod tracer;

#[cfg(test)]
mod tests;

use std::path::PathBuf;
use std::time::Duration;

pub use accuracy::display_difference;
pub use batch::{PacketIn, PacketOut, trace_each, trace_packets};
pub use heatmap::{heatmap_png, scale_top, write_heatmap_png, write_map_exr};
pub use matrix::{Film, ScreenMatrix, matrix_of};
pub use progressive::Progressive;
pub use render::render;
pub use superpixel::Superpixels;
pub use tracer::SampleTracer;

use crate::sampler::{HaltonTile, Span};
use crate::tonemap::{self, Adaptation, Display, ToneMap};
use coherent_simd::BackendError;

/// How samples are placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// The paper's progressive adaptive anti-aliasing: superpixels interpolated where their
    /// corners agree, then levels of growing span; a pixel is done when its two screen
    /// matrices agree within `accuracy` (in tone-mapped display units, 0-1) over its 3x3
    /// neighbourhood, or it has `max_samples_per_pixel` samples (a pass may overshoot the cap
    /// by less than one packet: a group traces all its lanes). Stops when every pixel is
    /// done or the time runs out.
    Adaptive {
        accuracy: f32,
        max_samples_per_pixel: u32,
        time_budget: Option<Duration>,
    },
    /// Classical supersampling: `spp` Halton samples in every pixel, one pass per sample.
    Uniform { spp: u32 },
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Adaptive { .. } => "adaptive",
            Method::Uniform { .. } => "uniform",
        }
    }
}

/// Largest accepted width or height.
pub const MAX_SIDE: u32 = 16_384;
/// Largest accepted pixel count.
pub const MAX_PIXELS: u64 = 64 << 20;

/// What to render and how.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmOptions {
    pub width: u32,
    pub height: u32,
    pub method: Method,
    pub tonemap: tonemap::Operator,
    pub display: Display,
    /// The Halton tile (`2^a x 3^b` pixels; default 16 x 9).
    pub tile: HaltonTile,
    /// Superpixel size in pixels (the pre-render grid and, for the adaptive method, the
    /// interpolation cells; the paper used sizes up to 16 x 24). Default 8 x 6.
    pub superpixel: (u32, u32),
}

impl FilmOptions {
    pub fn new(width: u32, height: u32, method: Method) -> FilmOptions {
        FilmOptions {
            width,
            height,
            method,
            tonemap: tonemap::Operator::default(),
            display: Display::default(),
            tile: HaltonTile::new(4, 2),
            superpixel: (8, 6),
        }
    }

    /// Checks the options: a clear error for a zero or huge resolution, a non-positive
    /// accuracy, zero samples or more samples than the sample ids can tell apart.
    pub fn validate(&self) -> Result<(), FilmError> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return Err(FilmError::Resolution {
                width: w,
                height: h,
                why: "width and height must be at least 1".into(),
            });
        }
        if w > MAX_SIDE || h > MAX_SIDE || w as u64 * h as u64 > MAX_PIXELS {
            return Err(FilmError::Resolution {
                width: w,
                height: h,
                why: format!(
                    "at most {MAX_SIDE} pixels a side and {} Mpixels",
                    MAX_PIXELS >> 20
                ),
            });
        }
        let (sx, sy) = self.superpixel;
        if sx == 0 || sy == 0 || sx > 64 || sy > 64 {
            return Err(FilmError::Options(format!(
                "superpixel size {sx}x{sy}: each side must be in 1..=64"
            )));
        }
        let spp = match self.method {
            Method::Uniform { spp } => spp,
            Method::Adaptive {
                accuracy,
                max_samples_per_pixel,
                ..
            } => {
                // A difference of displayed colours, whose channels lie in [0, 1]: above 1
                // every pixel would pass at once.
                if !(accuracy.is_finite() && accuracy > 0.0 && accuracy <= 1.0) {
                    return Err(FilmError::Options(format!(
                        "accuracy {accuracy}: must be in (0, 1], a difference of displayed \
                         colour (e.g. 0.02 for 2%)"
                    )));
                }
                max_samples_per_pixel
            }
        };
        if spp == 0 {
            return Err(FilmError::Options(
                "samples per pixel (--spp, --max-spp, or the scene's spp) must be at least 1"
                    .into(),
            ));
        }
        let corners = (w.div_ceil(sx) as u64 + 1) * (h.div_ceil(sy) as u64 + 1);
        // Adaptive passes may overshoot the cap by a few packets of samples per pixel.
        let ids = corners + (spp as u64 + 64) * w as u64 * h as u64;
        if ids > u32::MAX as u64 {
            return Err(FilmError::Options(format!(
                "{spp} samples per pixel at {w}x{h}: more samples than 2^32 sample ids"
            )));
        }
        Ok(())
    }
}

/// Why rendering stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// Uniform: every pass done.
    Done,
    /// Adaptive: every pixel met the accuracy.
    Accuracy,
    /// Adaptive: every pixel not meeting the accuracy reached the sample cap.
    SampleBudget,
    /// Adaptive: the time budget ran out.
    TimeBudget,
    /// Stopped from outside before its end (a cancelled or abandoned progressive render).
    Interrupted,
}

impl StopReason {
    /// Why the render stopped, in words.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Done => "every pass done",
            StopReason::Accuracy => "every pixel met the accuracy",
            StopReason::SampleBudget => "stopped at the sample cap",
            StopReason::TimeBudget => "stopped at the time budget",
            StopReason::Interrupted => "interrupted before its end",
        }
    }
}

/// One pass, as recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct PassRecord {
    /// 0 is the pre-render (superpixel corners).
    pub pass: u32,
    pub span: Span,
    /// Coherence radius of the span, in pixels.
    pub radius: f64,
    /// Rays traced so far (primary samples, pre-render included).
    pub rays: u64,
    pub rays_this_pass: u64,
    pub groups_traced: u64,
    pub groups_skipped: u64,
    /// Seconds since the render started.
    pub seconds: f64,
    /// Mean display difference of the two screen matrices over pixels sampled in both.
    pub error: f64,
    /// The estimated RMS error of the image so far in display units, per channel as the
    /// `aa` experiment measures it against a converged image: half the two matrices'
    /// difference per pixel (each holds an independent half of its samples), and 1 for a
    /// pixel not sampled in both yet.
    pub estimate: f64,
    /// Fraction of pixels done (met the accuracy or at the sample cap; uniform: sampled).
    pub done: f64,
    /// How close the samples of this pass's traced groups really are.
    pub coherence: Coherence,
}

/// What the progress callback sees after each pass: the record and the film so far.
pub struct PassReport<'a> {
    pub record: PassRecord,
    pub film: &'a Film,
}

/// Samples whose radiance was fixed up (set to 0): NaN or infinite, or negative (where the
/// tracer's samples are not signed, [`SampleTracer::SIGNED`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fixups {
    pub non_finite: u64,
    pub negative: u64,
}

/// A finished render.
pub struct Rendered<S> {
    pub film: Film,
    pub adaptation: Adaptation,
    pub tonemap: ToneMap,
    pub rays: u64,
    pub passes: Vec<PassRecord>,
    pub stats: S,
    pub fixups: Fixups,
    pub stop: StopReason,
}

/// How close the samples of traced groups really are: distances (pixels) of a group's
/// samples to the group's centroid, over the groups of a pass with two or more samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coherence {
    pub mean_distance: f64,
    pub max_distance: f64,
    pub groups: u64,
}

/// A film error: names the problem (and the path for output).
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    #[error("resolution {width}x{height}: {why}")]
    Resolution {
        width: u32,
        height: u32,
        why: String,
    },
    #[error("film options: {0}")]
    Options(String),
    #[error(transparent)]
    Backend(#[from] BackendError),
    #[error("the render was cancelled")]
    Cancelled,
    #[error("cannot write {}: {reason}", path.display())]
    Write { path: PathBuf, reason: String },
}
