//! What the progressive film (paper section 6.2) asks the renderer for: radiance through
//! the image plane for a packet of screen samples.

use coherent_simd::{Lanes, Rgbs};

use super::batch::{PacketIn, PacketOut, trace_each};

/// A renderer as the film drives it.
pub trait SampleTracer: Sync {
    /// Per-task statistics (rays by kind, active lanes per stage, NaN count...), merged in a
    /// fixed order.
    type Stats: Default + Send;
    /// The backends the tracer is compiled for ([`coherent_simd::Kernel::BACKENDS`]): on
    /// any other the film says it cannot run it.
    const BACKENDS: u32 = coherent_simd::Backend::WITH_FACTORS;
    /// Whether a sample's RGB may be negative by design: a spectral sample carries a few
    /// wavelengths (one, past a dispersive refraction), whose colour can lie outside the
    /// display's gamut. The film then keeps negative channels, since zeroing them per sample
    /// would bias every pixel such samples reach toward brighter and redder; the average
    /// converges into the gamut, and the display clips what is left.
    const SIGNED: bool = false;
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

    /// The radiance of each lane of `packets` (a tile's samples, each packet of `l`'s width),
    /// in order. By default each packet through [`SampleTracer::trace`]; a tracer may trace
    /// the batch together (the renderer's regrouping of secondary packets), as long as each
    /// lane's radiance is what `trace` would give it up to rounding.
    #[inline(always)]
    fn trace_batch<L: Lanes>(
        &self,
        l: L,
        packets: &[PacketIn],
        stats: &mut Self::Stats,
    ) -> Vec<PacketOut> {
        trace_each(self, l, packets, stats)
    }
}
