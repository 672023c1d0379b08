//! The simplest image driver (paper section 7's timing setting without anti-aliasing): one
//! sample at each pixel centre, rows cut into packets of the backend's width, one thread.
//! Tests and quick measurements use it; rendering proper goes through the film's
//! progressive driver.

use coherent_accel::Accel;
use coherent_simd::{Backend, BackendError};

use super::{RenderStats, Renderer};
use crate::film::{PacketIn, trace_packets};

/// Radiance at each pixel centre, row-major, `y` down, and the statistics, with the
/// accelerator chosen at run time. Not generic, so the renderer is compiled for every backend
/// once, here, for all its callers (see [`super::render_frame`]).
#[inline(never)]
pub fn render_centres(
    renderer: &Renderer<'_, crate::accel_any::AnyAccel>,
    backend: Backend,
    width: u32,
    height: u32,
) -> Result<(Vec<[f32; 3]>, RenderStats), BackendError> {
    render_centres_with(renderer, backend, width, height)
}

/// [`render_centres`] for any accelerator type. The packets go through the film's
/// [`trace_packets`], the one kernel of every image driver.
pub fn render_centres_with<A: Accel>(
    renderer: &Renderer<'_, A>,
    backend: Backend,
    width: u32,
    height: u32,
) -> Result<(Vec<[f32; 3]>, RenderStats), BackendError> {
    let (w, h) = (width as usize, height as usize);
    let lanes = backend.lanes();
    let mut packets = Vec::with_capacity(h * w.div_ceil(lanes));
    for y in 0..h {
        for x0 in (0..w).step_by(lanes) {
            let mut p = PacketIn::default();
            for m in 0..lanes.min(w - x0) {
                p.xs[m] = (x0 + m) as f32 + 0.5;
                p.ys[m] = y as f32 + 0.5;
                p.ids[m] = (y * w + x0 + m) as i32;
                p.bits |= 1 << m;
            }
            packets.push(p);
        }
    }
    let (colours, stats) = trace_packets(backend, renderer, &packets)?;
    let mut image = Vec::with_capacity(w * h);
    for (p, c) in packets.iter().zip(&colours) {
        image.extend_from_slice(&c[..p.bits.count_ones() as usize]);
    }
    Ok((image, stats))
}

/// PSNR in dB of `a` against the reference `b` with peak `peak` (infinite when identical).
pub fn psnr(a: &[[f32; 3]], b: &[[f32; 3]], peak: f32) -> f64 {
    let mut se = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            let d = f64::from(x[c]) - f64::from(y[c]);
            se += d * d;
        }
    }
    let mse = se / (3 * a.len().max(1)) as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (f64::from(peak) * f64::from(peak) / mse).log10()
    }
}
