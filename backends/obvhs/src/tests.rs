//! Basic answers of the obvhs scene on hand-made cases (the cross-accel equivalence against
//! brute force lives in the workspace's tests/).

use glam::{Affine3A, Vec3};

use crate::*;

fn square() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    (p, vec![[0, 1, 2], [0, 2, 3]])
}

fn two_squares(kind: Kind) -> ObvhsScene {
    let (p, i) = square();
    let meshes = [MeshRef { positions: &p, indices: &i }];
    let instances = [
        InstanceRef { mesh: 0, world_from_object: Affine3A::from_translation(Vec3::Z) },
        InstanceRef {
            mesh: 0,
            world_from_object: Affine3A::from_scale_rotation_translation(
                Vec3::new(2.0, 2.0, 1.0),
                glam::Quat::IDENTITY,
                Vec3::new(0.0, 0.0, 2.0),
            ),
        },
    ];
    let params = BuildParams { kind, ..Default::default() };
    ObvhsScene::build(&meshes, &instances, params).unwrap()
}

fn up(x: f32, y: f32) -> Ray1 {
    Ray1 { org: [x, y, -1.0], dir: [0.0, 0.0, 1.0], tmin: 0.0, tmax: f32::INFINITY }
}

#[test]
fn first_hit_all_hits_and_occlusion() {
    for kind in Kind::ALL {
        let scene = two_squares(kind);
        let h = scene.intersect1(&up(0.75, 0.25)).unwrap();
        assert_eq!((h.inst, h.prim), (0, 0), "{kind:?}");
        assert!((h.t - 2.0).abs() < 1e-6);
        // The hit point is (1 - u - v) v0 + u v1 + v v2 of triangle [0, 1, 2].
        let p = Vec3::new(1.0, 0.0, 0.0) * h.u + Vec3::new(1.0, 1.0, 0.0) * h.v;
        assert!((p - Vec3::new(0.75, 0.25, 0.0)).length() < 1e-6, "{kind:?}: {h:?}");
        let h = scene.intersect1(&up(1.5, 1.2)).unwrap();
        assert_eq!(h.inst, 1);
        assert!((h.t - 3.0).abs() < 1e-6);
        assert_eq!(scene.intersect1(&up(3.0, 0.5)), None);
        let mut all = Vec::new();
        scene.all_hits1(&up(0.75, 0.25), &mut all);
        all.sort_by(|a, b| a.t.total_cmp(&b.t));
        assert_eq!(all.iter().map(|h| h.inst).collect::<Vec<_>>(), [0, 1], "{kind:?}");
        let short = Ray1 { tmax: 1.5, ..up(0.5, 0.25) };
        assert_eq!(scene.intersect1(&short), None);
        assert!(!scene.occluded1(&short));
        assert!(scene.occluded1(&up(0.5, 0.25)));
    }
}

#[test]
fn invalid_rays_miss() {
    let scene = two_squares(Kind::Cwbvh);
    for r in [
        Ray1 { dir: [0.0; 3], ..up(0.5, 0.5) },
        Ray1 { dir: [f32::NAN, 0.0, 1.0], ..up(0.5, 0.5) },
        Ray1 { org: [f32::INFINITY, 0.5, -1.0], ..up(0.5, 0.5) },
        Ray1 { tmin: 5.0, tmax: 1.0, ..up(0.5, 0.5) },
        Ray1 { tmax: f32::NAN, ..up(0.5, 0.5) },
    ] {
        assert_eq!(scene.intersect1(&r), None, "{r:?}");
        assert!(!scene.occluded1(&r), "{r:?}");
    }
}

#[test]
fn moving_an_instance_rebuilds_the_top_level() {
    for kind in Kind::ALL {
        let mut scene = two_squares(kind);
        scene.move_instance(0, Affine3A::from_translation(Vec3::new(5.0, 0.0, 1.0))).unwrap();
        assert_eq!(scene.intersect1(&up(0.5, 0.25)).map(|h| h.inst), Some(1));
        assert_eq!(scene.intersect1(&up(5.5, 0.25)).map(|h| h.inst), Some(0));
        let singular = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
        assert!(matches!(
            scene.move_instance(0, singular),
            Err(ObvhsError::InvalidInstance { instance: 0, .. })
        ));
    }
}

#[test]
fn bad_input_names_the_mesh_or_instance() {
    let (p, _) = square();
    let bad = [[0, 1, 7]];
    let err = ObvhsScene::build(&[MeshRef { positions: &p, indices: &bad }], &[], BuildParams::default())
        .err()
        .unwrap();
    assert!(matches!(err, ObvhsError::InvalidMesh { mesh: 0, .. }), "{err}");
    let inst = [InstanceRef { mesh: 3, world_from_object: Affine3A::IDENTITY }];
    let err = ObvhsScene::build(&[], &inst, BuildParams::default()).err().unwrap();
    assert!(matches!(err, ObvhsError::InvalidInstance { instance: 0, .. }), "{err}");
}

#[test]
fn empty_scene_and_empty_mesh_miss() {
    let scene = ObvhsScene::build(&[], &[], BuildParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    let empty = MeshRef { positions: &[], indices: &[] };
    let inst = [InstanceRef { mesh: 0, world_from_object: Affine3A::IDENTITY }];
    let scene = ObvhsScene::build(&[empty], &inst, BuildParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    assert!(!scene.occluded1(&up(0.5, 0.5)));
}
