//! Times the BSP on a built-in scene: build, then primary/shadow/diffuse rays one at a time
//! and in packets of every available backend (paper section 3's coherent tracer).
//!
//! `cargo run --release -p coherent-bsp --example trace -- [scene] [quick|full] [WxH] [threshold]`

use coherent_accel::Accel;
use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::workload::{self, Clock, RayKind, TimePackets};
use coherent_bsp::{Bsp, BspParams, TraversalStats};
use coherent_simd::Backend;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("blob", String::as_str);
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
    let thr: Option<u32> = args.get(4).map(|s| s.parse().unwrap());
    if name == "build" {
        // Object build of a 100,352-triangle terrain, thread CPU time, best of 3, per preset.
        let mesh = coherent_accel::shapes::terrain("terrain", 100.0, 224, 12.0, 5);
        for preset in ["fast", "default", "slow"] {
            let p = coherent_bsp::SahParams::preset(preset).unwrap();
            let mut best = f64::INFINITY;
            let mut tree = None;
            for _ in 0..3 {
                let t0 = Clock::ThreadCpu.now();
                tree = Some(coherent_bsp::MeshTree::build(
                    &mesh.positions,
                    &mesh.indices,
                    &p,
                ));
                best = best.min(Clock::ThreadCpu.now() - t0);
            }
            let t = tree.unwrap().tree.stats;
            println!(
                "{preset}: {:.1} ms, {} nodes, {} leaves, sah {:.1}",
                best * 1e3,
                t.nodes,
                t.leaves,
                t.sah_cost
            );
        }
        return;
    }
    let s = scenes::by_name(name, size).expect("scene: spheres terrain room blob");
    let mut params = BspParams {
        single_ray_threshold: thr,
        ..Default::default()
    };
    // SAH overrides for experiments: KT, KI, BONUS, LEAF, DEPTH, PRESET.
    let env = |k: &str| std::env::var(k).ok();
    if let Some(p) = env("PRESET") {
        params.object = coherent_bsp::SahParams::preset(&p).unwrap();
    }
    let o = &mut params.object;
    if let Some(v) = env("KT") {
        o.traversal_cost = v.parse().unwrap();
    }
    if let Some(v) = env("KI") {
        o.intersection_cost = v.parse().unwrap();
    }
    if let Some(v) = env("BONUS") {
        o.empty_bonus = v.parse().unwrap();
    }
    if let Some(v) = env("LEAF") {
        o.leaf_size = v.parse().unwrap();
    }
    if let Some(v) = env("DEPTH") {
        o.max_depth = v.parse().unwrap();
    }
    let bsp = Bsp::build(&s.scene, &params).unwrap();
    let st = bsp.stats();
    println!(
        "{name}: {} tris ({} instanced), build {:.1} ms (top {:.3} ms), {} nodes, {} leaves ({} empty, {} refs), depth {}, {:.1} MB, sah {:.1}",
        st.triangles,
        s.scene.instanced_triangles(),
        st.build_seconds * 1e3,
        st.top_build_seconds * 1e3,
        st.nodes,
        st.leaves,
        st.empty_leaves,
        st.leaf_refs,
        st.max_depth,
        st.memory_bytes as f64 / 1e6,
        st.extra[0].1
    );
    // ONLY=single|<backend>: time just that, primary rays, 20 passes (for profilers).
    if let Ok(only) = std::env::var("ONLY") {
        let lanes = if only == "single" {
            1
        } else {
            only.parse::<Backend>().unwrap().lanes()
        };
        let rays = workload::primary_rays(&s.view, w, h, workload::tile_shape(lanes));
        let r = if only == "single" {
            workload::time_single(&bsp, &rays, false, 20, Clock::ThreadCpu)
        } else {
            let b: Backend = only.parse().unwrap();
            b.run(TimePackets {
                accel: &bsp,
                rays: &rays,
                occlusion: false,
                repeats: 20,
                clock: Clock::ThreadCpu,
            })
            .unwrap()
        };
        println!("{only}: {:.2} Mr/s", rays.len() as f64 / r.seconds / 1e6);
        if only != "single" {
            let b: Backend = only.parse().unwrap();
            let c = b
                .run(Counted {
                    bsp: &bsp,
                    rays: &rays,
                })
                .unwrap();
            let p = rays.len() as f64 / b.lanes() as f64;
            println!(
                "per packet: {:.1} inner, {:.1} leaves, {:.1} tests x {:.2} lanes, {:.2} handoffs x {:.2} lanes, {:.2} instances x {:.2} lanes; mailbox {:.1}%",
                c.inner_nodes as f64 / p,
                c.leaves as f64 / p,
                c.tri_tests as f64 / p,
                c.lanes_per_test(),
                c.handoffs as f64 / p,
                c.handoff_lanes as f64 / c.handoffs.max(1) as f64,
                c.instances as f64 / p,
                c.instance_lanes as f64 / c.instances.max(1) as f64,
                100.0 * c.mailbox_hit_rate()
            );
        }
        return;
    }
    for kind in RayKind::ALL {
        let primary = workload::primary_rays(&s.view, w, h, (4, 4));
        let rays = match kind {
            RayKind::Primary => primary,
            RayKind::Shadow => workload::shadow_rays(&bsp, &s.scene, &primary, s.light),
            RayKind::Diffuse => workload::diffuse_rays(&bsp, &s.scene, &primary, 1),
        };
        let occ = kind.occlusion();
        let one = workload::time_single(&bsp, &rays, occ, 3, Clock::ThreadCpu);
        let mut c = TraversalStats::default();
        if !occ {
            for r in &rays {
                bsp.intersect1_counted(r, &mut c);
            }
        }
        let n = rays.len() as f64;
        print!(
            "{:>8}: {} rays  single {:6.2} Mr/s (per ray: {:.1} inner, {:.1} leaves, {:.1} tests; mailbox hit rate {:.1}%)",
            kind.name(),
            rays.len(),
            rays.len() as f64 / one.seconds / 1e6,
            c.inner_nodes as f64 / n,
            c.leaves as f64 / n,
            c.tri_tests as f64 / n,
            100.0 * c.mailbox_hit_rate()
        );
        for b in Backend::available()
            .into_iter()
            .filter(|b| *b != Backend::Scalar)
        {
            let primary = workload::primary_rays(&s.view, w, h, workload::tile_shape(b.lanes()));
            let rays = match kind {
                RayKind::Primary => primary,
                RayKind::Shadow => workload::shadow_rays(&bsp, &s.scene, &primary, s.light),
                RayKind::Diffuse => workload::diffuse_rays(&bsp, &s.scene, &primary, 1),
            };
            let r = b
                .run(TimePackets {
                    accel: &bsp,
                    rays: &rays,
                    occlusion: occ,
                    repeats: 3,
                    clock: Clock::ThreadCpu,
                })
                .unwrap();
            print!("  {} {:6.2}", b.name(), rays.len() as f64 / r.seconds / 1e6);
            if kind != RayKind::Diffuse {
                assert_eq!(r.hits, one.hits, "{} hit count", b.name());
            }
        }
        println!();
    }
}

/// Traversal counters over packets of the backend's width.
struct Counted<'a> {
    bsp: &'a Bsp,
    rays: &'a [coherent_accel::Ray1],
}

impl coherent_simd::Kernel for Counted<'_> {
    type Output = TraversalStats;
    fn run<L: coherent_simd::Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for ch in self.rays.chunks(L::N) {
            let p = coherent_accel::Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]);
            self.bsp
                .intersect_counted(l, &p, l.mask_from_fn(|i| i < ch.len()), &mut c);
        }
        c
    }
}
