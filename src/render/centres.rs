//! The simplest image driver (paper section 7's timing setting without anti-aliasing): one
//! sample at each pixel centre, rows cut into packets of the backend's width, one thread.
//! Tests and quick measurements use it; rendering proper goes through the film's
//! progressive driver.

use coherent_accel::Accel;
use coherent_simd::{Backend, BackendError, Kernel, Lanes};

use super::{RenderStats, Renderer};

/// Radiance at each pixel centre, row-major, `y` down, and the statistics.
pub fn render_centres<A: Accel>(
    renderer: &Renderer<'_, A>,
    backend: Backend,
    width: u32,
    height: u32,
) -> Result<(Vec<[f32; 3]>, RenderStats), BackendError> {
    backend.run(Centres {
        renderer,
        width,
        height,
    })
}

struct Centres<'a, 's, A: Accel> {
    renderer: &'a Renderer<'s, A>,
    width: u32,
    height: u32,
}

impl<A: Accel> Kernel for Centres<'_, '_, A> {
    type Output = (Vec<[f32; 3]>, RenderStats);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut image = vec![[0.0f32; 3]; w * h];
        let mut stats = RenderStats::default();
        for y in 0..h {
            let mut x0 = 0;
            while x0 < w {
                let xs = l.from_fn(|i| (x0 + i) as f32 + 0.5);
                let ys = l.splat(y as f32 + 0.5);
                let ids = l.from_fn_i32(|i| (y * w + x0 + i) as i32);
                let active = l.mask_from_fn(|i| x0 + i < w);
                let c = self
                    .renderer
                    .trace_packet(l, xs, ys, ids, active, &mut stats);
                for i in 0..L::N.min(w - x0) {
                    image[y * w + x0 + i] = c.lane(i);
                }
                x0 += L::N;
            }
        }
        (image, stats)
    }
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
