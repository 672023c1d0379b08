//! The one kernel every image driver runs: a batch of packed samples traced through a
//! [`SampleTracer`] inside the backend's `Backend::run`.
//!
//! The film's pre-render, its passes and the pixel-centre driver (`render::centres`) each pack
//! their samples first (scalar bookkeeping: Halton indices, pixels, which pixels still need
//! rays) and then hand the packets to [`trace_packets`]. The renderer is inlined into the
//! kernel's `#[target_feature]` function (it must be: code left out of line there loses the
//! backend's instructions), so every distinct kernel type that calls it is a full copy of
//! the renderer per backend. With one kernel for all drivers there is one copy per backend:
//! a third of the code and of the build time of one kernel per driver.

use coherent_simd::{Backend, BackendError, Kernel, Lanes, MAX_LANES, SimdF32};

use super::tracer::SampleTracer;

/// One packet's samples: continuous pixel coordinates, per-sample ids (see
/// [`SampleTracer::trace`]) and which lanes hold a sample (bit `m` for lane `m`).
#[derive(Clone, Copy, Debug)]
pub struct PacketIn {
    pub xs: [f32; MAX_LANES],
    pub ys: [f32; MAX_LANES],
    pub ids: [i32; MAX_LANES],
    pub bits: u32,
}

impl Default for PacketIn {
    fn default() -> Self {
        PacketIn {
            xs: [0.0; MAX_LANES],
            ys: [0.0; MAX_LANES],
            ids: [0; MAX_LANES],
            bits: 0,
        }
    }
}

/// The radiance of each lane of a packet (lanes without a sample hold what the tracer
/// returned for them; ignore them).
pub type PacketOut = [[f32; 3]; MAX_LANES];

/// Traces `packets` (each of `backend`'s width, lanes beyond it empty) in order with
/// `backend`, on the calling thread: the radiance per packet and lane, and the statistics.
pub fn trace_packets<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    packets: &[PacketIn],
) -> Result<(Vec<PacketOut>, T::Stats), BackendError> {
    backend.run(TracePackets { tracer, packets })
}

struct TracePackets<'a, T> {
    tracer: &'a T,
    packets: &'a [PacketIn],
}

impl<T: SampleTracer> Kernel for TracePackets<'_, T> {
    type Output = (Vec<PacketOut>, T::Stats);
    // The factor table renders frames with the scalar backend's estimates.
    const BACKENDS: u32 = Backend::WITH_FACTORS & T::BACKENDS;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        let mut stats = T::Stats::default();
        let out = self.tracer.trace_batch(l, self.packets, &mut stats);
        (out, stats)
    }
}

/// [`SampleTracer::trace_batch`]'s default: each packet through [`SampleTracer::trace`], in
/// order.
#[inline(always)]
pub fn trace_each<T: SampleTracer + ?Sized, L: Lanes>(
    tracer: &T,
    l: L,
    packets: &[PacketIn],
    stats: &mut T::Stats,
) -> Vec<PacketOut> {
    let mut out = Vec::with_capacity(packets.len());
    let mut r = [0.0f32; MAX_LANES];
    let mut g = [0.0f32; MAX_LANES];
    let mut b = [0.0f32; MAX_LANES];
    for p in packets {
        let rgb = tracer.trace(
            l,
            l.load(&p.xs),
            l.load(&p.ys),
            l.load_i32(&p.ids),
            l.mask_from_bits(p.bits),
            stats,
        );
        rgb.r.store(&mut r);
        rgb.g.store(&mut g);
        rgb.b.store(&mut b);
        let mut lanes = [[0.0f32; 3]; MAX_LANES];
        for (m, c) in lanes.iter_mut().enumerate().take(L::N) {
            *c = [r[m], g[m], b[m]];
        }
        out.push(lanes);
    }
    out
}
