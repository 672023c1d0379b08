//! What the progressive film (paper section 6.2) asks the renderer for: radiance through
//! the image plane for a packet of screen samples.

use coherent_simd::{Lanes, Rgbs};

/// A renderer as the film drives it.
pub trait SampleTracer: Sync {
    /// Per-task statistics (rays by kind, active lanes per stage, NaN count...), merged in a
    /// fixed order.
    type Stats: Default + Send;
    fn merge_stats(into: &mut Self::Stats, from: Self::Stats);
    /// Radiance arriving through the image plane at continuous pixel coordinates `(xs, ys)`
    /// (pixel `(i, j)` covers `[i, i+1) x [j, j+1)`, y down) for the active lanes (inactive
    /// lanes are ignored). `ids` is a per-lane sample id, unique within the render and the
    /// same whatever the thread count and packet width (use it to derive random numbers).
    /// Called from rayon tasks, inside `Backend::run`.
    fn trace<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut Self::Stats,
    ) -> Rgbs<L>;
}
