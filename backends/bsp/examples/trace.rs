//! Times the BSP (paper section 3's coherent tracer) on a built-in scene: build, then
//! primary, shadow and diffuse rays one at a time and in packets of every available backend.
//! Timings are thread CPU time (best of several passes), so other work on a shared machine
//! does not count.
//!
//! ```text
//! cargo run --release -p coherent-bsp --example trace -- [SCENE] [quick|full] [WxH] [THRESHOLD]
//! SCENE: spheres terrain room blob (default blob), or `build` (object build of a 100k-triangle
//! terrain per preset) or `top` (top-level rebuild over the full sphere field's instances).
//! ONLY=single|BACKEND: time just that (on primary rays, or KIND=shadow|diffuse), and print
//! traversal counters.
//! KT, KI, BONUS, LEAF, DEPTH, PRESET, GROUP (leaves priced per group) / TOPBINS, TOPKI,
//! TOPLEAF: override build parameters; BUILD=exact|fast picks the object trees' split search.
//! SIMD_LEAVES=1: single rays test leaves 4 at a time.
//! MIXED=0: packets walk per group of equal direction signs (the paper's way).
//! ```

use coherent_accel::scenes::{self, BuiltinScene, SceneSize};
use coherent_accel::workload::{self, Clock, RayKind, TimePackets};
use coherent_accel::{Accel, Ray1, Rays};
use coherent_bsp::{Bsp, BspParams, MeshTree, SahParams, TraversalStats};
use coherent_simd::{Backend, Kernel, Lanes};

fn env<T: std::str::FromStr>(k: &str) -> Option<T> {
    std::env::var(k).ok().and_then(|v| v.parse().ok())
}

fn params(thr: Option<u32>) -> BspParams {
    let mut p = BspParams {
        single_ray_threshold: thr,
        ..Default::default()
    };
    if let Some(name) = env::<String>("PRESET") {
        p.object = SahParams::preset(&name).expect("PRESET: fast default slow");
    }
    let o = &mut p.object;
    if let Some(b) = env::<String>("BUILD") {
        o.build = b.parse().unwrap();
    }
    o.traversal_cost = env("KT").unwrap_or(o.traversal_cost);
    o.intersection_cost = env("KI").unwrap_or(o.intersection_cost);
    o.empty_bonus = env("BONUS").unwrap_or(o.empty_bonus);
    o.leaf_size = env("LEAF").unwrap_or(o.leaf_size);
    o.max_depth = env("DEPTH").unwrap_or(o.max_depth);
    o.leaf_group = env("GROUP").unwrap_or(o.leaf_group);
    p.simd_leaves = env::<u32>("SIMD_LEAVES").is_some_and(|v| v == 1);
    p.mixed_signs = env::<u32>("MIXED").is_none_or(|v| v == 1);
    let t = &mut p.top;
    t.bins = env("TOPBINS").unwrap_or(t.bins);
    t.intersection_cost = env("TOPKI").unwrap_or(t.intersection_cost);
    t.leaf_size = env("TOPLEAF").unwrap_or(t.leaf_size);
    p
}

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
    let params = params(args.get(4).map(|s| s.parse().unwrap()));
    match name {
        "build" => build(&params),
        "top" => top(&params),
        _ => {
            let s = scenes::by_name(name, size).expect("scene: spheres terrain room blob");
            trace(&s, &params, w, h);
        }
    }
}

/// Object build of a 100,352-triangle terrain, thread CPU time, best of 3, per preset.
fn build(params: &BspParams) {
    let mesh = coherent_accel::shapes::terrain("terrain", 100.0, 224, 12.0, 5);
    for preset in ["fast", "default", "slow"] {
        let p = if std::env::var("PRESET").is_ok() {
            params.object.clone()
        } else {
            SahParams::preset(preset).unwrap()
        };
        let mut best = f64::INFINITY;
        let mut tree = None;
        for _ in 0..3 {
            let t0 = Clock::ThreadCpu.now();
            tree = Some(MeshTree::build(&mesh.positions, &mesh.indices, &p));
            best = best.min(Clock::ThreadCpu.now() - t0);
        }
        let t = tree.unwrap().tree.stats;
        println!(
            "{preset}: {} tris, {:.1} ms, {} nodes, {} leaves, sah {:.1}",
            mesh.indices.len(),
            best * 1e3,
            t.nodes,
            t.leaves,
            t.sah_cost
        );
    }
}

/// Top-level rebuild over the full sphere field's 1,025 instances, all moved each time; wall
/// clock (sub-millisecond), best of 50.
fn top(params: &BspParams) {
    let s = scenes::sphere_field(SceneSize::Full);
    let mut bsp = Bsp::build(&s.scene, params).unwrap();
    let mut inst = s.scene.instances.clone();
    let mut best = f64::INFINITY;
    for k in 0..50 {
        for i in &mut inst {
            i.world_from_object.translation += glam::Vec3A::new(0.01, -0.02, 0.0) * (k % 3) as f32;
        }
        let t0 = Clock::Wall.now();
        bsp.set_instances(&inst).unwrap();
        best = best.min(Clock::Wall.now() - t0);
    }
    let t = &bsp.top_tree().stats;
    println!(
        "top: {} instances, best {:.3} ms, {} nodes, {} leaves, {} refs, depth {}",
        inst.len(),
        best * 1e3,
        t.nodes,
        t.leaves,
        t.leaf_refs,
        t.max_depth
    );
}

fn rays_for(s: &BuiltinScene, bsp: &Bsp, kind: RayKind, w: u32, h: u32, lanes: usize) -> Vec<Ray1> {
    // Single rays go in 4x4 tiles too: coherent order helps them as much as packets.
    let tile = workload::tile_shape(if lanes == 1 { 16 } else { lanes });
    let primary = workload::primary_rays(&s.view, w, h, tile);
    match kind {
        RayKind::Primary => primary,
        RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
        RayKind::Diffuse => workload::diffuse_rays(bsp, &s.scene, &primary, 1),
    }
}

fn trace(s: &BuiltinScene, params: &BspParams, w: u32, h: u32) {
    let bsp = Bsp::build(&s.scene, params).unwrap();
    let st = bsp.stats();
    println!(
        "{}: {} tris ({} instanced), build {:.1} ms (top {:.3} ms), {} nodes, {} leaves ({} empty, {} refs), depth {}, {:.1} MB",
        s.name,
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
    );
    if let Some(only) = env::<String>("ONLY") {
        let (lanes, backend) = if only == "single" {
            (1, None)
        } else {
            let b: Backend = only.parse().unwrap();
            (b.lanes(), Some(b))
        };
        let kind = match env::<String>("KIND").as_deref() {
            None | Some("primary") => RayKind::Primary,
            Some("shadow") => RayKind::Shadow,
            Some("diffuse") => RayKind::Diffuse,
            Some(k) => panic!("KIND: primary shadow diffuse, not {k}"),
        };
        let occlusion = kind.occlusion();
        let rays = rays_for(s, &bsp, kind, w, h, lanes);
        let r = match backend {
            None => workload::time_single(&bsp, &rays, occlusion, 20, Clock::ThreadCpu),
            Some(b) => b
                .run(TimePackets {
                    accel: &bsp,
                    rays: &rays,
                    occlusion,
                    repeats: 20,
                    clock: Clock::ThreadCpu,
                })
                .unwrap(),
        };
        println!(
            "{only} {}: {:.2} Mr/s",
            kind.name(),
            rays.len() as f64 / r.seconds / 1e6
        );
        let (c, per) = match backend {
            None => {
                let mut c = TraversalStats::default();
                for r in &rays {
                    if occlusion {
                        bsp.occluded1_counted(r, &mut c);
                    } else {
                        bsp.intersect1_counted(r, &mut c);
                    }
                }
                (c, 1.0)
            }
            Some(b) => (
                b.run(Counted {
                    bsp: &bsp,
                    rays: &rays,
                    occlusion,
                })
                .unwrap(),
                b.lanes() as f64,
            ),
        };
        let p = rays.len() as f64 / per;
        println!(
            "per packet: {:.1} inner, {:.1} leaves, {:.1} tests x {:.2} lanes, {:.2} handoffs x {:.2} lanes, {:.2} instances x {:.2} lanes; mailbox hit rate {:.1}%",
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
        return;
    }
    for kind in RayKind::ALL {
        let occ = kind.occlusion();
        let rays = rays_for(s, &bsp, kind, w, h, 1);
        let one = workload::time_single(&bsp, &rays, occ, 3, Clock::ThreadCpu);
        print!(
            "{:>8}: {} rays  single {:6.2} Mr/s",
            kind.name(),
            rays.len(),
            rays.len() as f64 / one.seconds / 1e6
        );
        for b in Backend::available()
            .into_iter()
            .filter(|b| *b != Backend::Scalar)
        {
            let rays = rays_for(s, &bsp, kind, w, h, b.lanes());
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
    rays: &'a [Ray1],
    occlusion: bool,
}

impl Kernel for Counted<'_> {
    type Output = TraversalStats;
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for ch in self.rays.chunks(L::N) {
            let p = Rays::from_fn(l, |i| ch[i.min(ch.len() - 1)]);
            let active = l.mask_from_fn(|i| i < ch.len());
            if self.occlusion {
                self.bsp.occluded_counted(l, &p, active, &mut c);
            } else {
                self.bsp.intersect_counted(l, &p, active, &mut c);
            }
        }
        c
    }
}
