//! One published image of the viewer and its figures: what the page and `/frame.png` show
//! after a pass. Frames are immutable and shared (`Arc<Frame>`), so serving one never
//! touches the film being rendered.

/// An image after one pass of the current render, with the figures shown beside it.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The image (or the per-pixel map's heat map) as a PNG file.
    pub png: Vec<u8>,
    /// The PNG's size in pixels (a heat map is wider than the film: it holds a colour bar).
    pub width: u32,
    pub height: u32,
    /// Which render this frame belongs to: one more after every change of the settings.
    pub generation: u64,
    /// The pass (0: the pre-render of superpixel corners).
    pub pass: u32,
    /// Rays traced so far (primary samples, pre-render included).
    pub rays: u64,
    /// Every ray of every kind traced so far (shadow, reflection, refraction included).
    pub all_rays: u64,
    /// Seconds since this render started.
    pub seconds: f64,
    /// Rays of every kind per second since this render started.
    pub rays_per_second: f64,
    /// Active lanes per packet by kind of ray (`primary`, `shadow`, ...), of `lanes`.
    pub active_lanes: Vec<(&'static str, f64)>,
    /// Lanes per packet of the backend.
    pub lanes: usize,
    /// The estimated RMS error of the image in display units (the film's two matrices).
    pub estimate: f64,
    /// Fraction of the render done (uniform: passes; adaptive: pixels that met the accuracy).
    pub done: f64,
    /// Seconds the accelerator took to build (the last rebuild).
    pub build_seconds: f64,
    /// Seconds from the settings change that started this render to this frame.
    pub since_change: f64,
    /// Why the render stopped, once it has.
    pub stop: Option<&'static str>,
}
