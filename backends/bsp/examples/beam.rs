//! Beams against lane packets on a built-in scene: primary and shadow rays of a 1024 x 768
//! image (or WxH), traced as lane packets of each backend and as square beams of 4x4 to 32x32
//! rays on the same backend (packets as the backend's packet tiles in Morton order inside the
//! beam); Mrays/s (median of interleaved passes, thread CPU time) and the traversal counters
//! per ray. The control is the beam of one packet (`beam 1p`: a 4x4 beam at 16 lanes, a 4x2
//! at 8), which must time as the lane packets do; at 16 lanes, lane packets shaped 8 x 2 and
//! 16 x 1 show what the packets' shape alone costs. Beams of 256 rays are also timed without
//! culling a leaf's triangles against the group's frustum (`no cull`) and, for shadow rays,
//! without walking them from the light (`no rev`). The `accel` experiment of `reproduce` measures the same beside
//! Embree and obvhs; this is the quick look at the BSP alone.
//!
//! ```text
//! cargo run --release -p coherent-bsp --example beam -- [SCENE] [quick|full] [WxH] [BACKENDS]
//! SCENE: spheres terrain room blob (default room); BACKENDS: comma-separated (default: the
//! widest and scalar)
//! ```

use coherent_accel::scenes::{self, BuiltinScene, SceneSize};
use coherent_accel::workload::{self, Clock, RayKind, TimeBeams, TimePackets};
use coherent_accel::{Accel, Hits, Ray1, Rays};
use coherent_bsp::{Bsp, BspParams, TraversalStats};
use coherent_simd::{Backend, Kernel, Lanes};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("room", String::as_str);
    let size = if args.get(2).is_some_and(|s| s == "quick") {
        SceneSize::Quick
    } else {
        SceneSize::Full
    };
    let (w, h) = args
        .get(3)
        .and_then(|s| s.split_once('x'))
        .map_or((1024, 768), |(a, b)| {
            (a.parse().unwrap(), b.parse().unwrap())
        });
    let backends: Vec<Backend> = match args.get(4) {
        Some(list) => list.split(',').map(|b| b.parse().unwrap()).collect(),
        None => {
            let mut v = vec![Backend::widest()];
            if v[0] != Backend::Scalar {
                v.push(Backend::Scalar);
            }
            v
        }
    };
    let s = scenes::by_name(name, size).expect("scene: spheres terrain room blob");
    let bsp = Bsp::build(&s.scene, &BspParams::default()).unwrap();
    println!(
        "{}: {} triangles, {} instances, {w}x{h}",
        s.name,
        bsp.stats().triangles,
        bsp.stats().instances
    );
    // The same tree with the beams' leaf culling off, and with their reversal off.
    let mut no_cull = bsp.clone();
    no_cull.set_beam_params(false, true);
    let mut no_rev = bsp.clone();
    no_rev.set_beam_params(true, false);
    for kind in [RayKind::Primary, RayKind::Shadow] {
        for &b in &backends {
            run(&s, [&bsp, &no_cull, &no_rev], kind, b, w, h);
        }
    }
}

fn rays(s: &BuiltinScene, bsp: &Bsp, kind: RayKind, primary: Vec<Ray1>) -> Vec<Ray1> {
    match kind {
        RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
        _ => primary,
    }
}

/// Lane packets, then beams of each size, on backend `b`: Mrays/s and counters per ray.
fn run(s: &BuiltinScene, bsps: [&Bsp; 3], kind: RayKind, b: Backend, w: u32, h: u32) {
    let [bsp, no_cull, no_rev] = bsps;
    let occlusion = kind.occlusion();
    // (label, beam rays or 0 for lane packets, rays in that order, tree)
    let packet = workload::tile_shape(b.lanes());
    let lane_tile = workload::tile_shape(b.lanes().max(16));
    let primary = |tile| workload::primary_rays(&s.view, w, h, tile);
    let mut sets = vec![(
        "lanes".to_owned(),
        0,
        rays(s, bsp, kind, primary(lane_tile)),
        bsp,
    )];
    // Lane packets of other shapes at 16 lanes (rows of a tile, as beams once cut them).
    if b.lanes() == 16 {
        for (tw, th) in [(8u32, 2u32), (16, 1)] {
            if w.is_multiple_of(tw) && h.is_multiple_of(th) {
                let r = rays(s, bsp, kind, primary((tw, th)));
                sets.push((format!("lanes {tw}x{th}"), 0, r, bsp));
            }
        }
    }
    // The control: beams of one packet, in the lane packets' own order.
    sets.push((
        "beam 1p".to_owned(),
        b.lanes(),
        rays(s, bsp, kind, primary(lane_tile)),
        bsp,
    ));
    for side in [4u32, 8, 16, 32] {
        let n = (side * side) as usize;
        if w.is_multiple_of(side) && h.is_multiple_of(side) && n > b.lanes() {
            let beam = rays(
                s,
                bsp,
                kind,
                workload::beam_rays(&s.view, w, h, side, packet),
            );
            if side == 16 {
                sets.push((format!("{n} no cull"), n, beam.clone(), no_cull));
                if occlusion {
                    sets.push((format!("{n} no rev"), n, beam.clone(), no_rev));
                }
            }
            sets.push((format!("beam {n}"), n, beam, bsp));
        }
    }
    let passes = 7;
    let mut secs = vec![Vec::new(); sets.len()];
    for _ in 0..passes {
        for (i, &(_, n, ref r, bsp)) in sets.iter().enumerate() {
            let res = if n == 0 {
                b.run(TimePackets {
                    accel: bsp,
                    rays: r,
                    occlusion,
                    repeats: 1,
                    clock: Clock::ThreadCpu,
                })
            } else {
                b.run(TimeBeams {
                    accel: bsp,
                    rays: r,
                    beam: n,
                    occlusion,
                    repeats: 1,
                    clock: Clock::ThreadCpu,
                })
            }
            .unwrap();
            secs[i].push(res.seconds);
        }
    }
    let lanes_rate = rate(&sets[0].2, &mut secs[0]);
    for (i, &(ref label, n, ref r, bsp)) in sets.iter().enumerate() {
        let mr = rate(r, &mut secs[i]);
        let c = b
            .run(Counted {
                bsp,
                rays: r,
                beam: n,
                occlusion,
            })
            .unwrap();
        let k = r.len() as f64;
        println!(
            "{:>8} {:>7} {:>9}: {:7.2} Mrays/s ({:.2}x lanes)  per ray: {:.3} inner + {:.3} group steps, {:.3} leaves, {:.3} tests x {:.2} lanes, {:.3} culled, {:.3} limit reductions, {:.3} instance entries, {:.3} packets moved; setup {:.1} ns/ray; ray by ray {} lanes, other signs {} lanes, from the far end {} lanes",
            kind.name(),
            b.name(),
            label,
            mr,
            mr / lanes_rate,
            c.inner_nodes as f64 / k,
            c.beam_steps as f64 / k,
            c.leaves as f64 / k,
            c.tri_tests as f64 / k,
            c.lanes_per_test(),
            c.tris_culled as f64 / k,
            c.limit_reductions as f64 / k,
            c.instance_lanes as f64 / k,
            c.packets_transformed as f64 / k,
            c.beam_setup_ns as f64 / k,
            c.beam_fallback_lanes,
            c.beam_mixed_lanes,
            c.beam_reversed_lanes,
        );
    }
}

/// Mrays/s from the median of `secs`.
fn rate(rays: &[Ray1], secs: &mut [f64]) -> f64 {
    secs.sort_by(f64::total_cmp);
    rays.len() as f64 / secs[secs.len() / 2] / 1e6
}

/// Traversal counters of lane packets (`beam` 0) or beams of `beam` rays.
struct Counted<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
    beam: usize,
    occlusion: bool,
}

impl Kernel for Counted<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        let per = if self.beam == 0 {
            1
        } else {
            self.beam.div_ceil(L::N)
        };
        for group in self.rays.chunks(per * L::N) {
            let (p, m): (Vec<Rays<L>>, Vec<_>) = group
                .chunks(L::N)
                .map(|ch| {
                    (
                        Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]),
                        l.mask_from_fn(|i| i < ch.len()),
                    )
                })
                .unzip();
            if self.beam == 0 {
                for (p, &m) in p.iter().zip(&m) {
                    if self.occlusion {
                        self.bsp.occluded_counted(l, p, m, &mut c);
                    } else {
                        self.bsp.intersect_counted(l, p, m, &mut c);
                    }
                }
            } else if self.occlusion {
                let mut o = vec![l.splat_mask(false); p.len()];
                self.bsp.occluded_beam_counted(l, &p, &m, &mut o, &mut c);
            } else {
                let mut hs = vec![Hits::miss(l); p.len()];
                self.bsp.intersect_beam_counted(l, &p, &m, &mut hs, &mut c);
            }
        }
        c
    }
}
