//! The object-tree builds of the two-level BSP (paper section 3) as trees: the fast build
//! (binned SAH, Hunt et al. 2006 / Shevtsov et al. 2007) is the same tree on 1 and 2 threads,
//! and both builds keep a fan of long thin triangles through one point (Wald & Havran 2006's
//! perfect splits multiply its references) within the reference budget; a scene of a million
//! objects builds and answers within 2 GB.

use coherent_accel::shapes::{Rng, soup, terrain};
use coherent_accel::{Accel, Instance, Mesh, Ray1, Scene};
use coherent_bsp::{Bsp, BspParams, BuildPreset, KdTree, MeshTree, PARALLEL_MIN, SahParams};
use glam::{Affine3A, Vec3};

fn fast() -> SahParams {
    SahParams::default().with_build(BuildPreset::Fast)
}

fn build_on(threads: usize, positions: &[Vec3], indices: &[[u32; 3]], p: &SahParams) -> KdTree {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| MeshTree::build(positions, indices, p).tree)
}

fn assert_same(a: &KdTree, b: &KdTree, what: &str) {
    assert_eq!(a.nodes, b.nodes, "{what}: nodes differ");
    assert_eq!(a.items, b.items, "{what}: items differ");
    assert_eq!(a.bounds, b.bounds, "{what}");
    let (mut sa, mut sb) = (a.stats.clone(), b.stats.clone());
    (sa.build_seconds, sb.build_seconds) = (0.0, 0.0);
    assert_eq!(sa, sb, "{what}");
}

#[test]
fn fast_tree_is_the_same_on_one_and_two_threads() {
    let meshes = [
        soup("soup", 40_000, 20.0, 0.8, 3),
        terrain("terrain", 100.0, 96, 12.0, 5),
    ];
    for m in &meshes {
        assert!(
            m.indices.len() > 2 * PARALLEL_MIN,
            "too small to build in parallel"
        );
        for p in [
            fast(),
            SahParams {
                sweep_below: 64,
                bins: 16,
                ..fast()
            },
            SahParams {
                max_refs_per_tri: 1.1,
                ..fast()
            },
        ] {
            let one = build_on(1, &m.positions, &m.indices, &p);
            let two = build_on(2, &m.positions, &m.indices, &p);
            assert!(one.stats.nodes > 1000, "{:?}", one.stats);
            assert_same(&one, &two, &m.name);
            assert_eq!(one.stats.leaf_refs, one.items.len());
        }
    }
}

/// The build binned at every level is the same tree on 1, 2 and 16 threads (large nodes bin
/// and partition in chunks across threads, subtrees are tasks).
#[test]
fn binned_tree_is_the_same_on_1_2_and_16_threads() {
    let meshes = [
        soup("soup", 40_000, 20.0, 0.8, 3),
        terrain("terrain", 100.0, 96, 12.0, 5),
    ];
    let binned = SahParams::default().with_build(BuildPreset::Binned);
    for m in &meshes {
        assert!(
            m.indices.len() > 4 * PARALLEL_MIN,
            "too small to build in parallel"
        );
        for p in [
            binned.clone(),
            SahParams {
                max_refs_per_tri: 1.1,
                bins: 7,
                ..binned.clone()
            },
        ] {
            let one = build_on(1, &m.positions, &m.indices, &p);
            // The tight budget stops splits early: a few hundred nodes.
            assert!(one.stats.nodes > 300, "{:?}", one.stats);
            assert_eq!(one.stats.leaf_refs, one.items.len());
            for threads in [2, 16] {
                let other = build_on(threads, &m.positions, &m.indices, &p);
                assert_same(&one, &other, &format!("{} on {threads} threads", m.name));
            }
        }
    }
}

/// The exact build's tree does not depend on the thread pool either (mesh trees are built in
/// parallel, each by itself).
#[test]
fn exact_tree_is_the_same_on_one_and_two_threads() {
    let m = soup("soup", 5_000, 20.0, 0.8, 4);
    let p = SahParams::default();
    assert_same(
        &build_on(1, &m.positions, &m.indices, &p),
        &build_on(2, &m.positions, &m.indices, &p),
        "exact",
    );
}

/// `n` long thin triangles through the origin, in every direction: every plane near the
/// origin cuts nearly all of them, so each split there clips (and copies) nearly all.
fn fan(n: usize) -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(4);
    (0..n)
        .map(|_| {
            let d = rng.unit_vector() * 100.0;
            [Vec3::ZERO, d, d + rng.unit_vector() * 0.05]
        })
        .collect()
}

/// A fan of 20,000 thin triangles through one point builds, with either preset, within its
/// reference budget (`max_refs_per_tri` references per triangle: at most 16 x 20,000 leaf
/// references, 1.3 MB of items) and in seconds, leaves taking the place of further splits.
#[test]
fn fan_through_one_point_stays_within_the_reference_budget() {
    let tris = fan(20_000);
    for build in BuildPreset::ALL {
        for refs in [16.0, 2.0] {
            let p = SahParams {
                max_refs_per_tri: refs,
                ..SahParams::default().with_build(build)
            };
            let t0 = std::time::Instant::now();
            let t = coherent_bsp::build_sah(&tris, &p);
            let secs = t0.elapsed().as_secs_f64();
            let budget = p.ref_budget(tris.len());
            assert_eq!(budget, (refs * 20_000.0) as usize);
            assert_eq!(t.items.len(), t.stats.leaf_refs);
            assert!(
                t.stats.leaf_refs <= budget,
                "{build:?} {refs}: {} references, budget {budget}",
                t.stats.leaf_refs
            );
            // Generous for unoptimized test builds on a loaded machine.
            assert!(secs < 60.0, "{build:?} {refs}: {secs} s");
            eprintln!("fan {build:?} refs {refs}: {:?} in {secs:.2} s", t.stats);
        }
    }
}

/// The process's peak resident memory (Linux's `VmHWM`), in bytes, where the system says.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A million objects, each a small triangle at its own place on a 1000 x 1000 grid (no two at
/// one transform, so nothing merges): the top tree over a million boxes builds within 2 GB
/// (the structure's bytes, and the whole process's peak), and rays find the right object.
#[test]
fn a_million_tiny_objects_build_and_answer_within_2_gb() {
    const SIDE: usize = 1000;
    const LIMIT: u64 = 2 << 30;
    let tiny = Mesh::new(
        "tiny",
        vec![
            Vec3::new(-0.3, -0.3, 0.0),
            Vec3::new(0.3, -0.3, 0.0),
            Vec3::new(0.0, 0.3, 0.0),
        ],
        vec![[0, 1, 2]],
    );
    let at = |i: usize| Vec3::new((i % SIDE) as f32, (i / SIDE) as f32, 0.0);
    let instances: Vec<Instance> = (0..SIDE * SIDE)
        .map(|i| Instance::new(0, Affine3A::from_translation(at(i))))
        .collect();
    let scene = Scene::new(vec![tiny], instances);
    for build in BuildPreset::ALL {
        let mut p = BspParams::default();
        p.object.build = build;
        let bsp = Bsp::build(&scene, &p).unwrap();
        let bytes = bsp.memory_bytes() as u64;
        assert!(bytes < LIMIT, "{build:?}: {bytes} bytes");
        eprintln!(
            "a million objects, {build:?}: {bytes} bytes, {:?}",
            bsp.stats()
        );
        let mut rng = Rng::new(9);
        for _ in 0..2000 {
            let i = rng.next_u64() as usize % (SIDE * SIDE);
            let down = |o: Vec3| Ray1::new(o + Vec3::new(0.0, -0.05, 5.0), -Vec3::Z, 0.0, 100.0);
            let hit = bsp
                .intersect1(&down(at(i)))
                .expect("a ray onto an object hits it");
            assert_eq!(hit.inst as usize, i);
            assert!((hit.t - 5.0).abs() < 1e-4, "{hit:?}");
            // Between four objects there is nothing.
            let gap = at(i) + Vec3::new(0.5, 0.5, 0.0);
            assert!(!bsp.occluded1(&down(gap)), "{gap}");
        }
    }
    if let Some(peak) = peak_rss_bytes() {
        assert!(peak < LIMIT, "peak resident memory {peak} bytes");
    }
}

/// Every triangle is in every leaf whose voxel holds a part of it (its part clipped to the
/// voxel reaching inside in every axis where the voxel has extent), for the build binned at
/// every level on a mesh large enough to bin and partition across threads.
#[test]
fn binned_leaves_hold_every_triangle_that_reaches_them() {
    let m = soup("soup", 3 * PARALLEL_MIN, 20.0, 0.8, 7);
    let p = SahParams::default().with_build(BuildPreset::Binned);
    let tris: Vec<[Vec3; 3]> = m
        .indices
        .iter()
        .map(|t| t.map(|i| m.positions[i as usize]))
        .collect();
    let t = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| coherent_bsp::build_sah(&tris, &p));
    assert!(t.stats.leaves > 1000, "{:?}", t.stats);
    for (j, tri) in tris.iter().enumerate() {
        let mut todo = vec![(0usize, t.bounds)];
        while let Some((i, v)) = todo.pop() {
            let reaches = coherent_bsp::clipped_bounds(tri, &v)
                .is_some_and(|b| (0..3).all(|k| b.max[k] > b.min[k] || v.max[k] == v.min[k]));
            if !reaches {
                continue;
            }
            let n = t.nodes[i];
            if n.is_leaf() {
                assert!(
                    t.items[n.items()].contains(&(j as u32)),
                    "triangle {j} missing from leaf {i}"
                );
            } else {
                let (k, s) = (n.axis(), n.split());
                let (mut l, mut r) = (v, v);
                l.max[k] = s;
                r.min[k] = s;
                todo.push((n.left(), l));
                todo.push((n.left() + 1, r));
            }
        }
    }
}

/// Bad input, every build: no triangles and non-finite vertices are refused with an error;
/// only degenerate triangles, or all in one plane, build.
#[test]
fn bad_meshes_are_refused_or_built() {
    let tri = |a: Vec3| vec![a, a + Vec3::X, a + Vec3::Y];
    for build in BuildPreset::ALL {
        let mut p = BspParams::default();
        p.object.build = build;
        let empty = Mesh::new("empty", tri(Vec3::ZERO), vec![]);
        assert!(Bsp::build(&Scene::single(empty), &p).is_err(), "{build}");
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let m = Mesh::new("bad", tri(Vec3::new(0.0, bad, 0.0)), vec![[0, 1, 2]]);
            let e = Bsp::build(&Scene::single(m), &p).unwrap_err();
            assert!(e.to_string().contains("bad"), "{build}: {e}");
        }
        // Only degenerate triangles: points and segments.
        let m = Mesh::new(
            "degenerate",
            vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X],
            vec![[0, 0, 0], [0, 1, 2], [1, 1, 2]],
        );
        let b = Bsp::build(&Scene::single(m), &p).unwrap();
        assert_eq!(b.stats().degenerate, 3, "{build}");
        // 20,000 triangles in the plane z = 1: built, and answering as brute force does.
        let flat = flat(&soup("plane", 20_000, 20.0, 0.8, 2));
        let scene = Scene::single(flat);
        let b = Bsp::build(&scene, &p).unwrap();
        let bf = coherent_accel::BruteForce::build(&scene, &()).unwrap();
        let mut rng = Rng::new(3);
        for _ in 0..200 {
            let o = rng.vec3(Vec3::new(-25.0, -25.0, 3.0), Vec3::new(25.0, 25.0, 6.0));
            let ray = Ray1::new(
                o,
                rng.vec3(Vec3::splat(-0.3), Vec3::splat(0.3)) - Vec3::Z,
                0.0,
                100.0,
            );
            assert_eq!(
                b.intersect1(&ray).map(|h| h.t),
                bf.intersect1(&ray).map(|h| h.t),
                "{build}: {ray:?}"
            );
        }
    }
}

/// `m` flattened into the plane z = 1.
fn flat(m: &Mesh) -> Mesh {
    Mesh::new(
        "plane",
        m.positions
            .iter()
            .map(|v| Vec3::new(v.x, v.y, 1.0))
            .collect(),
        m.indices.clone(),
    )
}
