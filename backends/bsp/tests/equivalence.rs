//! The two-level BSP against brute force (paper section 3): first hit, all hits and
//! occlusion, single rays and packets of every lane backend, on random soups, random
//! instance transforms and random rays, plus the edge cases.

use coherent_accel::shapes::{Rng, icosphere, soup};
use std::sync::OnceLock;

use coherent_accel::testing::*;
use coherent_accel::{Accel, BruteForce, Mesh, Ray1, Rays, Scene};
use coherent_bsp::{Bsp, BspParams, BuildPreset, SahParams};
use coherent_simd::{Kernel, Lanes, SimdMask};
use glam::Vec3;
use proptest::prelude::*;

/// Every preset and traversal switch the tests run under.
fn param_sets(lanes: usize) -> Vec<BspParams> {
    let mut v = vec![];
    for (preset, mailbox, thr) in [
        ("default", true, None),
        ("fast", false, Some(0)),
        ("slow", true, Some(lanes.div_ceil(2) as u32)),
    ] {
        let mut p = BspParams::preset(preset).unwrap();
        p.mailbox = mailbox;
        p.single_ray_threshold = thr;
        // One set walks packets per group of equal direction signs, as the paper does.
        p.mixed_signs = preset != "fast";
        v.push(p);
    }
    // Single rays testing leaves four triangles at a time, on leaves priced per four.
    let mut p = BspParams {
        simd_leaves: true,
        ..BspParams::default()
    };
    p.object.leaf_group = 4;
    v.push(p);
    // The fast build: binning down to 16 references (the test scenes are far below the
    // default hand-over to the exact sweep), with and without perfect splits, and with a
    // reference budget tight enough to stop splits.
    for (object, sweep_below, bins, refs) in [
        (SahParams::default(), 16, 8, 16.0),
        (SahParams::fast(), 0, 32, 16.0),
        (SahParams::slow(), 4, 5, 1.2),
    ] {
        let p = BspParams {
            object: SahParams {
                build: BuildPreset::Fast,
                sweep_below,
                bins,
                max_refs_per_tri: refs,
                ..object
            },
            ..BspParams::default()
        };
        v.push(p);
    }
    // The build binned at every level: binning down to single references (no sweep), with
    // few bins and without perfect splits, and with a tight reference budget and the sweep
    // below 16 references.
    for (object, flat_sweep_below, bins, refs) in [
        (SahParams::default(), 0, 8, 16.0),
        (SahParams::fast(), 8, 3, 16.0),
        (SahParams::slow(), 16, 5, 1.2),
    ] {
        v.push(BspParams {
            object: SahParams {
                build: BuildPreset::Binned,
                flat_sweep_below,
                bins,
                max_refs_per_tri: refs,
                ..object
            },
            ..BspParams::default()
        });
    }
    v
}

/// How many sets [`param_sets`] gives.
const PARAM_SETS: usize = 10;

/// Triangles a kd-tree build finds hard, shuffled together: long thin ones (spanning the
/// scene one way, a thousandth of it across), degenerate ones (points, lines), coplanar sets
/// in axis planes, duplicates, and a fan of thin ones through one point (returned too).
fn hard_scene(seed: u64, n: usize) -> (Scene, Vec3) {
    let mut rng = Rng::new(seed);
    let mut tris: Vec<[Vec3; 3]> = vec![];
    let pt = |rng: &mut Rng| rng.vec3(Vec3::splat(-5.0), Vec3::splat(5.0));
    let hub = pt(&mut rng);
    while tris.len() < n {
        let a = pt(&mut rng);
        let t = match rng.next_u64() % 6 {
            0 => {
                let d = rng.unit_vector() * rng.range(4.0, 10.0);
                [a, a + d, a + d + rng.unit_vector() * 0.01]
            }
            1 => {
                // A point or a segment.
                let b = if rng.next_u64().is_multiple_of(2) {
                    a
                } else {
                    pt(&mut rng)
                };
                [a, b, a + (b - a) * 0.25]
            }
            2 => {
                let k = (rng.next_u64() % 3) as usize;
                let mut t = [a, pt(&mut rng), pt(&mut rng)];
                // Few distinct plane positions: many coplanar triangles per plane.
                let v = (rng.next_u64() % 3) as f32 - 1.0;
                for p in &mut t {
                    p[k] = v;
                }
                t
            }
            3 if !tris.is_empty() => tris[rng.next_u64() as usize % tris.len()],
            4 => {
                let d = rng.unit_vector() * 6.0;
                [hub, hub + d, hub + d + rng.unit_vector() * 0.02]
            }
            _ => [a, a + rng.unit_vector(), a + rng.unit_vector()],
        };
        tris.push(t);
    }
    (Scene::single(Mesh::from_triangles("hard", &tris)), hub)
}

/// The edge cases, run for one lane backend.
pub fn edge_cases<L: Lanes>(l: L) {
    let check = |scene: &Scene, rays: &[Ray1]| {
        for p in param_sets(L::N) {
            let (bf, bsp) = build_both::<Bsp>(scene, &p);
            check_all_queries(l, &bf, &bsp, rays, 1).unwrap();
        }
    };

    // Empty scene, a scene whose only mesh is all degenerate.
    let rays = random_rays(1, &Scene::default(), 16);
    check(&Scene::default(), &rays);
    let flat = Mesh::new(
        "flat",
        vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X],
        vec![[0, 1, 2]],
    );
    check(&Scene::single(flat), &rays);

    // One triangle: axis-parallel rays through its vertices, edges and inside, and along it.
    let tri = one_triangle();
    let mut rays = vec![];
    for p in [
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::ONE,
    ] {
        rays.push(Ray1::infinite(p + Vec3::Z, -Vec3::Z));
        rays.push(Ray1::infinite(p - Vec3::Z, Vec3::Z));
        rays.push(Ray1::infinite(p - Vec3::X, Vec3::X));
        // Starting on the surface.
        rays.push(Ray1::infinite(p, Vec3::new(0.3, 0.2, 1.0)));
        rays.push(Ray1::infinite(p, Vec3::new(0.3, 0.2, -1.0)));
    }
    check(&tri, &rays);

    // Bad rays: zero, NaN and infinite directions, NaN origins and bounds: misses.
    let scene = random_scene(3, 200, 1, 2);
    let o = Vec3::new(0.5, 0.5, -20.0);
    let bad = [
        Ray1::infinite(o, Vec3::ZERO),
        Ray1::infinite(o, Vec3::new(f32::NAN, 0.0, 1.0)),
        Ray1::infinite(o, Vec3::new(0.0, f32::INFINITY, 1.0)),
        Ray1::infinite(Vec3::NAN, Vec3::Z),
        Ray1::infinite(Vec3::new(f32::NEG_INFINITY, 0.0, 0.0), Vec3::X),
        Ray1::new(o, Vec3::Z, f32::NAN, 1.0),
        Ray1::new(o, Vec3::Z, 0.0, f32::NAN),
        Ray1::new(o, Vec3::Z, 5.0, 1.0),
        Ray1::infinite(o, Vec3::splat(1e-30)),
    ];
    for p in param_sets(L::N) {
        let (bf, bsp) = build_both::<Bsp>(&scene, &p);
        for r in &bad {
            assert!(bsp.intersect1(r).is_none() && !bsp.occluded1(r));
            let mut n = 0;
            bsp.intersect_all1(r, &mut |_| n += 1);
            assert_eq!(n, 0);
        }
        check_all_queries(l, &bf, &bsp, &bad, 2).unwrap();
        // Bad lanes beside good ones.
        let good = random_rays(4, &scene, 64);
        let mixed: Vec<Ray1> = good
            .iter()
            .zip(bad.iter().cycle())
            .flat_map(|(g, b)| [*b, *g])
            .collect();
        check_all_queries(l, &bf, &bsp, &mixed, 3).unwrap();
    }

    // Rays lying in split planes of the tree (axis-parallel, origin on the plane), and
    // crossing splits exactly at vertices.
    let scene = Scene::single(soup("grid", 300, 4.0, 1.5, 9));
    let bsp = Bsp::build(&scene, &BspParams::default()).unwrap();
    let tree = &bsp.mesh_trees()[0].tree;
    let mut rng = Rng::new(5);
    let mut rays = vec![];
    for n in tree.nodes.iter().filter(|n| !n.is_leaf()).take(60) {
        let k = n.axis();
        let mut o = rng.vec3(Vec3::splat(-6.0), Vec3::splat(6.0));
        o[k] = n.split();
        let mut d = rng.unit_vector();
        d[k] = 0.0;
        rays.push(Ray1::infinite(o, d));
        rays.push(Ray1::infinite(o, -d));
        let mut e = Vec3::ZERO;
        e[(k + 1) % 3] = 1.0;
        rays.push(Ray1::infinite(o - 8.0 * e, e));
    }
    for v in scene.meshes[0].positions.iter().take(100) {
        let o = rng.vec3(Vec3::splat(-9.0), Vec3::splat(9.0));
        rays.push(Ray1::infinite(o, *v - o));
    }
    check(&scene, &rays);

    // Coplanar axis-aligned geometry (many planar events at one position).
    let mut tris = vec![];
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (i as f32, j as f32);
            tris.push([
                Vec3::new(x, y, 0.0),
                Vec3::new(x + 1.0, y, 0.0),
                Vec3::new(x, y + 1.0, 0.0),
            ]);
            tris.push([
                Vec3::new(x, 0.0, y),
                Vec3::new(x + 1.0, 0.0, y),
                Vec3::new(x, 0.0, y + 1.0),
            ]);
        }
    }
    let scene = Scene::single(Mesh::from_triangles("planes", &tris));
    let mut rays = random_rays(6, &scene, 200);
    rays.push(Ray1::infinite(Vec3::new(-1.0, 0.0, 0.5), Vec3::X)); // in the plane y = 0
    rays.push(Ray1::infinite(Vec3::new(0.5, 0.5, -1.0), Vec3::Z));
    check(&scene, &rays);

    // Long thin, degenerate, coplanar, duplicated triangles and a fan, with rays through
    // the fan's hub.
    let (scene, hub) = hard_scene(8, 1500);
    let mut rays = random_rays(9, &scene, 160);
    let mut rng = Rng::new(10);
    for _ in 0..40 {
        let o = rng.vec3(Vec3::splat(-9.0), Vec3::splat(9.0));
        rays.push(Ray1::infinite(o, hub - o));
    }
    check(&scene, &rays);

    // Huge triangles (coordinates near f32's limit, areas beyond it) beside small ones.
    let big = 3.0e38_f32;
    let mut tris = vec![
        [
            Vec3::new(-big, -big, 0.0),
            Vec3::new(big, -big, 0.0),
            Vec3::new(0.0, big, 0.0),
        ],
        [
            Vec3::new(-big, 0.0, -big),
            Vec3::new(big, 0.0, -big),
            Vec3::new(0.0, 0.0, big),
        ],
    ];
    let (small, _) = hard_scene(12, 200);
    let m = &small.meshes[0];
    tris.extend(m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])));
    let scene = Scene::single(Mesh::from_triangles("huge", &tris));
    let mut rays = random_rays(13, &scene, 100);
    rays.push(Ray1::infinite(Vec3::new(0.5, 0.5, 10.0), -Vec3::Z));
    rays.push(Ray1::infinite(Vec3::new(1e30, 0.5, -1e30), Vec3::Z));
    check(&scene, &rays);
}

/// Random scenes that once failed (seed, triangles, meshes, instances): a vertex on the mesh
/// box's corner, a needle triangle, a vertex in two split planes behind a scaling transform.
const REGRESSIONS: [(u64, usize, usize, usize); 3] = [
    (11532196785894520903, 4, 2, 1),
    (5172459823018468742, 54, 2, 5),
    (667622533911027691, 273, 3, 1),
];

pub fn regressions<L: Lanes>(l: L) {
    for (seed, tris, meshes, instances) in REGRESSIONS {
        let scene = random_scene(seed, tris, meshes, instances);
        let rays = random_rays(seed, &scene, 96);
        for p in param_sets(L::N) {
            let (bf, bsp) = build_both::<Bsp>(&scene, &p);
            check_all_queries(l, &bf, &bsp, &rays, seed).unwrap();
        }
    }
}

/// 10^5 triangles: built once, 64 rays against brute force per backend.
pub fn large_scene<L: Lanes>(l: L) {
    static LARGE: OnceLock<(BruteForce, Bsp, Vec<Ray1>)> = OnceLock::new();
    let (bf, bsp, rays) = LARGE.get_or_init(|| {
        let scene = Scene::single(soup("big", 100_000, 20.0, 0.8, 11));
        let rays = random_rays(12, &scene, 64);
        let (bf, bsp) = build_both::<Bsp>(&scene, &BspParams::default());
        (bf, bsp, rays)
    });
    assert_eq!(bsp.stats().triangles, 100_000);
    check_all_queries(l, bf, bsp, rays, 13).unwrap();
}

/// Moving instances and rebuilding the top level answers as a fresh build does.
pub fn moving_instances<L: Lanes>(l: L, seed: u64) {
    let scene = random_scene(seed, 120, 2, 5);
    let mut moved = random_scene(seed ^ 77, 120, 2, 6);
    moved.meshes = scene.meshes.clone();
    for i in &mut moved.instances {
        i.mesh %= scene.meshes.len();
    }
    let p = BspParams::default();
    let mut bsp = Bsp::build(&scene, &p).unwrap();
    bsp.set_instances(&moved.instances).unwrap();
    let fresh = Bsp::build(&moved, &p).unwrap();
    let rays = random_rays(seed, &moved, 256);
    for r in &rays {
        assert_eq!(bsp.intersect1(r), fresh.intersect1(r), "{r:?}");
        assert_eq!(bsp.occluded1(r), fresh.occluded1(r));
    }
    for c in rays.chunks(L::N) {
        let p = Rays::from_fn(l, |i| c[i % c.len()]);
        let all = l.splat_mask(true);
        let (a, b) = (
            Apart(&bsp).intersect(l, &p, all),
            Apart(&fresh).intersect(l, &p, all),
        );
        for i in 0..L::N {
            assert_eq!(a.lane(i), b.lane(i));
        }
    }
    let (bf, _) = build_both::<Bsp>(&moved, &p);
    check_all_queries(l, &bf, &bsp, &rays, seed).unwrap();
    // A bad instance list is refused and names the instance.
    let mut bad = moved.instances.clone();
    bad[2].mesh = 9;
    let e = bsp.set_instances(&bad).unwrap_err().to_string();
    assert!(e.contains("instance 2"), "{e}");
}

struct EdgeCases;
impl Kernel for EdgeCases {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        edge_cases(l)
    }
}

struct Regressions;
impl Kernel for Regressions {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        regressions(l)
    }
}

struct LargeScene;
impl Kernel for LargeScene {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        large_scene(l)
    }
}

struct MovingInstances;
impl Kernel for MovingInstances {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        for seed in 0..4 {
            moving_instances(l, seed);
        }
    }
}

/// One random scene, random rays, one parameter set.
struct RandomScene {
    seed: u64,
    tris: usize,
    meshes: usize,
    instances: usize,
    preset: usize,
    /// [`hard_scene`] instead of a random soup.
    hard: bool,
}
impl Kernel for RandomScene {
    type Output = Result<(), String>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Result<(), String> {
        let scene = if self.hard {
            hard_scene(self.seed, self.tris).0
        } else {
            random_scene(self.seed, self.tris, self.meshes, self.instances)
        };
        let rays = random_rays(self.seed, &scene, 96);
        let p = param_sets(L::N).swap_remove(self.preset);
        let (bf, bsp) = build_both::<Bsp>(&scene, &p);
        check_all_queries(l, &bf, &bsp, &rays, self.seed)?;
        same_unordered_answers(l, &scene, &p, &rays)
    }
}

/// Occlusion and all-hits packets answer the same, bit for bit, whether lanes of mixed
/// direction signs walk together or per sign group: only the order of the leaves changes.
fn same_unordered_answers<L: Lanes>(
    l: L,
    scene: &Scene,
    p: &BspParams,
    rays: &[Ray1],
) -> Result<(), String> {
    let build = |mixed_signs| {
        let p = BspParams {
            mixed_signs,
            ..p.clone()
        };
        Bsp::build(scene, &p).unwrap()
    };
    let (together, split) = (build(true), build(false));
    for chunk in rays.chunks(L::N) {
        let pk = Rays::from_fn(l, |i| chunk[i % chunk.len()]);
        let active = l.mask_from_fn(|i| i < chunk.len());
        let (a, b) = (
            Apart(&together).occluded(l, &pk, active).bitmask(),
            Apart(&split).occluded(l, &pk, active).bitmask(),
        );
        if a != b {
            return Err(format!("occlusion together {a:#b}, per sign group {b:#b}"));
        }
        let all = |bsp: &Bsp| {
            let mut v: Vec<_> = Apart(bsp)
                .intersect_all(l, &pk, active)
                .into_iter()
                .enumerate()
                .flat_map(|(i, hs)| {
                    hs.into_iter()
                        .map(move |h| (i, h.inst, h.prim, h.t.to_bits()))
                })
                .collect();
            v.sort_unstable();
            v
        };
        if all(&together) != all(&split) {
            return Err("all hits differ between together and per sign group".into());
        }
    }
    Ok(())
}

/// Random scenes per backend: 24, or `PROPTEST_CASES` when set (for longer hunts).
fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24)
}

/// Every traversal check on every backend the traversal tests cover.
mod on_backends {
    use super::*;

    #[test]
    fn edge_cases() {
        on_tested_backends(|| EdgeCases).unwrap();
    }

    #[test]
    fn large_scene() {
        on_tested_backends(|| LargeScene).unwrap();
    }

    #[test]
    fn regressions() {
        on_tested_backends(|| Regressions).unwrap();
    }

    #[test]
    fn moving_instances() {
        on_tested_backends(|| MovingInstances).unwrap();
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

        #[test]
        fn random_scenes_match_brute_force(
            seed in any::<u64>(),
            tris in 1usize..400,
            meshes in 1usize..4,
            instances in 0usize..7,
            preset in 0usize..PARAM_SETS,
        ) {
            on_tested_backends(|| RandomScene { seed, tris, meshes, instances, preset, hard: false })
                .map_err(TestCaseError::fail)?;
        }

        #[test]
        fn hard_scenes_match_brute_force(
            seed in any::<u64>(),
            tris in 1usize..600,
            preset in 0usize..PARAM_SETS,
        ) {
            on_tested_backends(|| RandomScene { seed, tris, meshes: 1, instances: 0, preset, hard: true })
                .map_err(TestCaseError::fail)?;
        }
    }
}

#[test]
fn param_sets_are_counted() {
    assert_eq!(param_sets(4).len(), PARAM_SETS);
}

#[test]
fn object_presets_differ() {
    let s = Scene::single(icosphere("ico", Vec3::ZERO, 1.0, 4));
    let fast = Bsp::build(
        &s,
        &BspParams {
            object: SahParams::fast(),
            ..Default::default()
        },
    )
    .unwrap();
    let slow = Bsp::build(
        &s,
        &BspParams {
            object: SahParams::slow(),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        fast.stats().nodes < slow.stats().nodes,
        "{:?} {:?}",
        fast.stats(),
        slow.stats()
    );
}
