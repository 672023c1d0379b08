//! A packet of camera rays traced through any accelerator: the built-in `room2` scene, the
//! accelerator named on the command line (`bsp`, `embree`, `obvhs` or `brute`), one 4 x 4
//! tile of rays on the widest backend of this CPU, checked ray by ray against the same
//! accelerator's single-ray query.
//!
//! `cargo run --release --example trace_packet -- embree`
//!
//! Every accelerator answers through the `Accel` trait: `intersect` and `occluded` for a
//! packet under a mask of active lanes, `intersect1` and `occluded1` for one ray.

use coherent::accel::{Accel, Ray1, Rays};
use coherent::accel_any::AnyAccel;
use coherent::camera::PinholeCamera;
use coherent::simd::{Backend, Kernel, Lanes};

/// The rays of one packet, traced as a packet; the hits' distances, lane by lane.
struct TracePacket<'a> {
    accel: &'a AnyAccel,
    rays: &'a [Ray1],
}

impl Kernel for TracePacket<'_> {
    type Output = Vec<Option<f32>>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<Option<f32>> {
        let mut out = Vec::new();
        for chunk in self.rays.chunks(L::N) {
            let packet = Rays::from_fn(l, |i| chunk[i.min(chunk.len() - 1)]);
            let active = l.mask_from_fn(|i| i < chunk.len());
            let hits = self.accel.intersect(l, &packet, active);
            out.extend((0..chunk.len()).map(|i| hits.lane(i).map(|h| h.t)));
        }
        out
    }
}

fn main() -> anyhow::Result<()> {
    let name = std::env::args().nth(1).unwrap_or_else(|| "bsp".to_owned());
    let scene = coherent::scene::load("room2")?;
    let accel = AnyAccel::build_named(&scene.accel_scene(), &name)?;
    let c = scene.camera;
    let camera = PinholeCamera::new(c.position, c.look_at, c.up, c.vfov_deg, 64, 48)?;
    // A 4 x 4 tile in the middle of a 64 x 48 image, through the pixel centres.
    let rays: Vec<Ray1> = (0..16)
        .map(|i| {
            let (x, y) = (30 + i % 4, 22 + i / 4);
            let dir = camera.direction1(x as f32 + 0.5, y as f32 + 0.5);
            Ray1::new(camera.position, dir, 0.0, f32::INFINITY)
        })
        .collect();
    let backend = Backend::widest();
    let packet = backend.run(TracePacket {
        accel: &accel,
        rays: &rays,
    })?;
    println!(
        "{} on {} ({} lanes): {} rays in packets, distances to the first hit:",
        accel.name(),
        backend.name(),
        backend.lanes(),
        rays.len()
    );
    for (r, t) in rays.iter().zip(&packet) {
        let single = accel.intersect1(r).map(|h| h.t);
        let show = |t: Option<f32>| t.map_or("miss".to_owned(), |t| format!("{t:.4}"));
        println!("  packet {:>8}   single ray {:>8}", show(*t), show(single));
        // The same answer, up to the edge tolerance every accelerator documents.
        anyhow::ensure!(
            t.is_some() == single.is_some(),
            "packet and single ray disagree"
        );
    }
    let blocked = rays
        .iter()
        .filter(|r| accel.occluded1(&Ray1::new(r.origin, r.dir, 0.0, 1.0)))
        .count();
    println!("{blocked} of the rays meet something within 1 unit of the eye");
    Ok(())
}
