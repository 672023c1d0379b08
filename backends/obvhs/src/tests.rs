//! Basic answers of the obvhs accelerator on hand-made cases (the cross-accel equivalence
//! against brute force lives in the workspace's tests/).

use coherent_accel::{Accel, AccelError, Instance, Mesh, Ray1, Scene};
use glam::{Affine3A, Vec3};

use crate::*;

fn square() -> Mesh {
    Mesh::new(
        "square",
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

fn two_squares_scene() -> Scene {
    Scene::new(
        vec![square()],
        vec![
            Instance::new(0, Affine3A::from_translation(Vec3::Z)),
            Instance::new(
                0,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(2.0, 2.0, 1.0),
                    glam::Quat::IDENTITY,
                    Vec3::new(0.0, 0.0, 2.0),
                ),
            ),
        ],
    )
}

fn params(kind: Kind) -> ObvhsParams {
    ObvhsParams {
        kind,
        beam_bvh2: true,
        ..Default::default()
    }
}

fn up(x: f32, y: f32) -> Ray1 {
    Ray1::infinite(Vec3::new(x, y, -1.0), Vec3::Z)
}

#[test]
fn first_hit_all_hits_and_occlusion() {
    for kind in Kind::ALL {
        let scene = Obvhs::build(&two_squares_scene(), &params(kind)).unwrap();
        let h = scene.intersect1(&up(0.75, 0.25)).unwrap();
        assert_eq!((h.inst, h.prim), (0, 0), "{kind:?}");
        assert!((h.t - 2.0).abs() < 1e-6);
        // The hit point is (1 - u - v) p0 + u p1 + v p2 of triangle [0, 1, 2].
        let p = Vec3::new(1.0, 0.0, 0.0) * h.u + Vec3::new(1.0, 1.0, 0.0) * h.v;
        assert!(
            (p - Vec3::new(0.75, 0.25, 0.0)).length() < 1e-6,
            "{kind:?}: {h:?}"
        );
        let h = scene.intersect1(&up(1.5, 1.2)).unwrap();
        assert_eq!(h.inst, 1);
        assert!((h.t - 3.0).abs() < 1e-6);
        assert_eq!(scene.intersect1(&up(3.0, 0.5)), None);
        let mut all = Vec::new();
        scene.intersect_all1(&up(0.75, 0.25), &mut |h| all.push(h));
        all.sort_by(|a, b| a.t.total_cmp(&b.t));
        assert_eq!(
            all.iter().map(|h| h.inst).collect::<Vec<_>>(),
            [0, 1],
            "{kind:?}"
        );
        let short = Ray1 {
            tmax: 1.5,
            ..up(0.75, 0.25)
        };
        assert_eq!(scene.intersect1(&short), None);
        assert!(!scene.occluded1(&short));
        assert!(scene.occluded1(&up(0.75, 0.25)));
    }
}

#[test]
fn every_preset_builds_and_answers() {
    for kind in Kind::ALL {
        for preset in Preset::ALL {
            let p = ObvhsParams {
                kind,
                mesh_preset: preset,
                top_preset: preset,
                beam_bvh2: false,
            };
            let scene = Obvhs::build(&two_squares_scene(), &p).unwrap();
            assert_eq!(
                scene.intersect1(&up(0.75, 0.25)).map(|h| h.inst),
                Some(0),
                "{p:?}"
            );
            assert!(scene.memory_bytes() > 0);
        }
    }
}

#[test]
fn invalid_rays_miss() {
    let scene = Obvhs::build(&two_squares_scene(), &ObvhsParams::default()).unwrap();
    for r in [
        Ray1 {
            dir: Vec3::ZERO,
            ..up(0.5, 0.5)
        },
        Ray1 {
            dir: Vec3::new(f32::NAN, 0.0, 1.0),
            ..up(0.5, 0.5)
        },
        Ray1 {
            origin: Vec3::new(f32::INFINITY, 0.5, -1.0),
            ..up(0.5, 0.5)
        },
        Ray1 {
            tmin: 5.0,
            tmax: 1.0,
            ..up(0.5, 0.5)
        },
        Ray1 {
            tmax: f32::NAN,
            ..up(0.5, 0.5)
        },
    ] {
        assert_eq!(scene.intersect1(&r), None, "{r:?}");
        assert!(!scene.occluded1(&r), "{r:?}");
    }
}

#[test]
fn negative_tmin_finds_hits_behind_the_origin() {
    let scene = Obvhs::build(&two_squares_scene(), &ObvhsParams::default()).unwrap();
    let r = Ray1::new(Vec3::new(0.75, 0.25, 5.0), Vec3::Z, -10.0, f32::INFINITY);
    let h = scene.intersect1(&r).unwrap();
    assert_eq!(h.inst, 0);
    assert!((h.t + 4.0).abs() < 1e-6, "{h:?}");
}

#[test]
fn moving_instances_rebuilds_the_top_level() {
    for kind in Kind::ALL {
        let mut scene = Obvhs::build(&two_squares_scene(), &params(kind)).unwrap();
        let mut moved = two_squares_scene();
        moved.instances[0].world_from_object = Affine3A::from_translation(Vec3::new(5.0, 0.0, 1.0));
        scene.set_instances(&moved.instances).unwrap();
        assert_eq!(scene.intersect1(&up(0.75, 0.25)).map(|h| h.inst), Some(1));
        assert_eq!(scene.intersect1(&up(5.75, 0.25)).map(|h| h.inst), Some(0));
        scene.set_instances(&moved.instances[1..]).unwrap();
        assert_eq!(scene.intersect1(&up(5.75, 0.25)), None);
        let mut bad = moved.instances.clone();
        bad[1].world_from_object = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
        let err = scene.set_instances(&bad).unwrap_err();
        assert!(
            matches!(err, AccelError::SingularTransform { instance: 1, .. }),
            "{err}"
        );
    }
}

#[test]
fn degenerate_triangles_are_counted_and_never_hit() {
    let mut m = square();
    m.positions.push(Vec3::new(0.25, 0.25, 0.0));
    m.positions.push(Vec3::new(0.75, 0.75, 0.0));
    m.indices.push([4, 5, 0]);
    let scene = Obvhs::build(&Scene::single(m), &ObvhsParams::default()).unwrap();
    assert_eq!(scene.stats().degenerate, 1);
    assert_eq!(scene.stats().triangles, 2);
    let mut all = vec![];
    scene.intersect_all1(&up(0.5, 0.5), &mut |h| all.push(h.prim));
    assert!(all.iter().all(|&p| p < 2), "{all:?}");
}

#[test]
fn bad_input_names_the_mesh_or_instance() {
    let mut m = square();
    m.indices.push([0, 1, 7]);
    let err = Obvhs::build(&Scene::single(m), &ObvhsParams::default())
        .err()
        .unwrap();
    assert!(
        matches!(err, AccelError::IndexOutOfRange { mesh: 0, .. }),
        "{err}"
    );
    let scene = Scene::new(vec![square()], vec![Instance::identity(3)]);
    let err = Obvhs::build(&scene, &ObvhsParams::default()).err().unwrap();
    assert!(
        matches!(err, AccelError::MeshOutOfRange { instance: 0, .. }),
        "{err}"
    );
}

#[test]
fn empty_scene_misses() {
    let scene = Obvhs::build(&Scene::default(), &ObvhsParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    assert!(!scene.occluded1(&up(0.5, 0.5)));
}

/// A `n` x `n` grid of unit squares in z = 0 (2 n^2 triangles).
fn grid(n: u32) -> Mesh {
    let mut p = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            p.push(Vec3::new(x as f32, y as f32, 0.0));
        }
    }
    let mut t = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let i = y * (n + 1) + x;
            t.push([i, i + 1, i + n + 2]);
            t.push([i, i + n + 2, i + n + 1]);
        }
    }
    Mesh::new("grid", p, t)
}

#[test]
fn counted_traversals_answer_like_the_timed_ones_and_count_nodes() {
    let one = Scene::new(vec![grid(16)], vec![Instance::new(0, Affine3A::IDENTITY)]);
    let two = Scene::new(
        vec![grid(16)],
        vec![
            Instance::new(0, Affine3A::IDENTITY),
            Instance::new(0, Affine3A::from_translation(Vec3::new(20.0, 0.0, 1.0))),
        ],
    );
    for (name, scene) in [("one mesh", one), ("two instances", two)] {
        for kind in Kind::ALL {
            let acc = Obvhs::build(&scene, &params(kind)).unwrap();
            let mut nodes = 0;
            for i in 0..200u32 {
                let (x, y) = ((i % 20) as f32 * 1.9 + 0.13, (i / 20) as f32 * 1.7 + 0.31);
                let r = Ray1::infinite(Vec3::new(x, y, -1.0), Vec3::new(0.01, 0.02, 1.0));
                let c = Counts::default();
                assert_eq!(
                    acc.first_hit1_c(&r, &c),
                    acc.intersect1(&r),
                    "{name} {kind:?}"
                );
                if acc.intersect1(&r).is_some() {
                    assert!(c.prims.get() >= 1, "{name} {kind:?}: a hit without a test");
                }
                assert_eq!(acc.counts1(&r, false), (c.prims.get(), c.nodes.get()));
                let c = Counts::default();
                assert_eq!(acc.any_hit1_c(&r, &c), acc.occluded1(&r), "{name} {kind:?}");
                if !acc.occluded1(&r) {
                    // A miss tests what the ray's boxes hold, whichever query it is.
                    assert_eq!(c.prims.get(), acc.counts1(&r, false).0, "{name} {kind:?}");
                }
                nodes += c.nodes.get();
            }
            match kind {
                // A CWBVH of 512 triangles has several nodes below the root.
                Kind::Cwbvh => assert!(nodes > 200, "{name}: {nodes} CWBVH nodes for 200 rays"),
                // obvhs' BVH2 traversal has no node hook.
                Kind::Bvh2 => assert_eq!(nodes, 0, "{name}"),
            }
        }
    }
}
