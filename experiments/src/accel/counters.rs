//! Traversal counters (`accel_traversal.csv`): the BSP's inner nodes, leaves, triangle tests,
//! lanes per test and mailbox hit rate per ray, at width 1, the widest width and per beam;
//! beside them obvhs' own counts of its CWBVH's tests and nodes per single ray.

use coherent::accel::{Ray1, Rays};
#[cfg(feature = "obvhs")]
use coherent::accel_any::AnyAccel;
use coherent::bsp::{Bsp, TraversalStats};
use coherent::simd::{Backend, Kernel, Lanes};

use super::measure::{KindRun, Other};
use crate::table::CsvOut;

/// The rows of one scene and ray kind.
#[cfg_attr(not(feature = "obvhs"), allow(unused_variables))]
pub(super) fn rows(trav: &mut CsvOut, k: &KindRun, others: &[Other]) -> anyhow::Result<()> {
    let widths = &k.setup.widths;
    let occ = k.kind.occlusion();
    for (i, &(wd, b)) in widths.iter().enumerate() {
        if wd != 1 && i != widths.len() - 1 {
            continue;
        }
        let rays = &k.sets[i];
        let c = match b {
            None => {
                let mut c = TraversalStats::default();
                for r in rays {
                    if occ {
                        k.bsp.occluded1_counted(r, &mut c);
                    } else {
                        k.bsp.intersect1_counted(r, &mut c);
                    }
                }
                c
            }
            Some(b) => b.run(Counted {
                bsp: k.bsp,
                rays,
                occlusion: occ,
            })?,
        };
        let n = rays.len() as f64;
        // The BVH's side: obvhs' (CWBVH) triangle tests and 8-wide nodes per single ray.
        #[cfg_attr(not(feature = "obvhs"), allow(unused_mut))]
        let (mut bvh_tests, mut bvh_nodes) = (String::from("-"), String::from("-"));
        #[cfg(feature = "obvhs")]
        if wd == 1 {
            for o in others {
                if let AnyAccel::Obvhs(o) = &o.accel {
                    let (t, nodes) = rays
                        .iter()
                        .map(|r| o.counts1(r, occ))
                        .fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
                    bvh_tests = format!("{:.3}", t as f64 / n);
                    bvh_nodes = format!("{:.3}", nodes as f64 / n);
                }
            }
        }
        trav.row(&[
            &k.s.name,
            &k.kind.name(),
            &wd,
            &format!("{:.3}", c.inner_nodes as f64 / n),
            &format!("{:.3}", c.leaves as f64 / n),
            &format!("{:.3}", c.tri_tests as f64 / n),
            &format!("{:.3}", if wd == 1 { 1.0 } else { c.lanes_per_test() }),
            &format!("{:.4}", c.mailbox_hit_rate()),
            &bvh_tests,
            &bvh_nodes,
            &"lanes",
            &b.map_or("single", Backend::name),
            &"-",
            &"-",
            &format!("{:.3}", c.instance_lanes as f64 / n),
            &format!("{:.3}", c.packets_transformed as f64 / n),
            &"-",
            &"-",
            &"-",
            &"-",
            &"-",
        ])?;
    }
    // The beams' counters: inner nodes count the groups' steps with the packets' (a beam of
    // one packet takes the lane walk's), and the beams' own counters follow.
    for (rays, &(n_beam, backend)) in k.beam_sets.iter().zip(&k.setup.beams) {
        let c = backend.run(CountedBeam {
            bsp: k.bsp,
            rays,
            beam: n_beam,
            occlusion: occ,
        })?;
        let n = rays.len() as f64;
        trav.row(&[
            &k.s.name,
            &k.kind.name(),
            &n_beam,
            &format!("{:.3}", (c.inner_nodes + c.beam_steps) as f64 / n),
            &format!("{:.3}", c.leaves as f64 / n),
            &format!("{:.3}", c.tri_tests as f64 / n),
            &format!("{:.3}", c.lanes_per_test()),
            &format!("{:.4}", c.mailbox_hit_rate()),
            &"-",
            &"-",
            &"beam",
            &backend.name(),
            &format!("{:.3}", c.beam_steps as f64 / n),
            &format!("{:.3}", c.limit_reductions as f64 / n),
            &format!("{:.3}", c.instance_lanes as f64 / n),
            &format!("{:.3}", c.packets_transformed as f64 / n),
            &format!("{:.2}", c.beam_setup_ns as f64 / n),
            &c.beam_fallback_lanes,
            &c.beam_mixed_lanes,
            &format!("{:.3}", c.tris_culled as f64 / n),
            &c.beam_reversed_lanes,
        ])?;
    }
    Ok(())
}

/// Traversal counters over packets of the backend's width.
struct Counted<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
    occlusion: bool,
}

impl Kernel for Counted<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for ch in self.rays.chunks(L::N) {
            let p = Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]);
            let m = l.mask_from_fn(|i| i < ch.len());
            if self.occlusion {
                self.bsp.occluded_counted(l, &p, m, &mut c);
            } else {
                self.bsp.intersect_counted(l, &p, m, &mut c);
            }
        }
        c
    }
}

/// Traversal counters over beams of `beam` rays in packets of the backend's width.
struct CountedBeam<'a> {
    bsp: &'a Bsp,
    rays: &'a [Ray1],
    beam: usize,
    occlusion: bool,
}

impl Kernel for CountedBeam<'_> {
    type Output = TraversalStats;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        let per_beam = self.beam.div_ceil(L::N).max(1);
        for group in self.rays.chunks(per_beam * L::N) {
            // Loops, not iterator adaptors: those stay out of line, outside the kernel.
            let mut p: Vec<Rays<L>> = Vec::new();
            let mut m: Vec<L::Mask> = Vec::new();
            for ch in group.chunks(L::N) {
                p.push(Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]));
                m.push(l.mask_from_fn(|i| i < ch.len()));
            }
            if self.occlusion {
                let mut o = vec![l.splat_mask(false); p.len()];
                self.bsp.occluded_beam_counted(l, &p, &m, &mut o, &mut c);
            } else {
                let mut h = vec![coherent::accel::Hits::miss(l); p.len()];
                self.bsp.intersect_beam_counted(l, &p, &m, &mut h, &mut c);
            }
        }
        c
    }
}
