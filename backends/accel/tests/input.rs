//! Input validation and the brute-force reference (paper section 3's two-level scene).

use coherent_accel::{Accel, AccelError, BruteForce, Instance, Mesh, Ray1, Rays, Scene};
use coherent_simd::scalar::Scalar;
use glam::{Affine3A, Mat3, Vec3};

fn tri_mesh(name: &str) -> Mesh {
    Mesh::new(name, vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])
}

#[test]
fn bad_input_is_named() {
    let mut m = tri_mesh("bad-index");
    m.indices.push([0, 1, 3]);
    let e = BruteForce::build(&Scene::single(m), &()).unwrap_err();
    assert!(matches!(
        e,
        AccelError::IndexOutOfRange {
            mesh: 0,
            tri: 1,
            index: 3,
            ..
        }
    ));
    assert!(e.to_string().contains("bad-index"), "{e}");

    let mut m = tri_mesh("nan");
    m.positions[1].y = f32::NAN;
    let e = BruteForce::build(&Scene::single(m), &()).unwrap_err();
    assert!(
        matches!(e, AccelError::NonFinitePosition { index: 1, .. }),
        "{e}"
    );

    let e = BruteForce::build(&Scene::single(Mesh::new("empty", vec![], vec![])), &()).unwrap_err();
    assert!(matches!(e, AccelError::EmptyMesh { .. }) && e.to_string().contains("empty"));

    let scene = Scene::new(vec![tri_mesh("a")], vec![Instance::identity(1)]);
    let e = BruteForce::build(&scene, &()).unwrap_err();
    assert!(matches!(
        e,
        AccelError::MeshOutOfRange {
            instance: 0,
            mesh: 1,
            meshes: 1
        }
    ));

    let flat = Affine3A::from_mat3(Mat3::from_diagonal(Vec3::new(1.0, 1.0, 0.0)));
    let scene = Scene::new(
        vec![tri_mesh("a")],
        vec![Instance::identity(0), Instance::new(0, flat)],
    );
    let e = BruteForce::build(&scene, &()).unwrap_err();
    assert!(
        matches!(e, AccelError::SingularTransform { instance: 1, .. }),
        "{e}"
    );
    let inf = Affine3A::from_translation(Vec3::new(f32::INFINITY, 0.0, 0.0));
    let e = Instance::new(0, inf).object_from_world(4, 1).unwrap_err();
    assert!(matches!(
        e,
        AccelError::SingularTransform { instance: 4, .. }
    ));
}

#[test]
fn degenerate_triangles_are_counted_and_never_hit() {
    let m = Mesh::new(
        "mixed",
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, 2.0 * Vec3::X],
        vec![[0, 1, 3], [0, 1, 2], [2, 2, 2]],
    );
    let bf = BruteForce::build(&Scene::single(m), &()).unwrap();
    assert_eq!(bf.stats().degenerate, 2);
    assert_eq!(bf.stats().triangles, 1);
    let h = bf
        .intersect1(&Ray1::infinite(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z))
        .unwrap();
    assert_eq!((h.prim, h.inst, h.t), (1, 0, 1.0));
}

#[test]
fn instances_transform_rays_and_report_world_t() {
    let scene = Scene::new(
        vec![tri_mesh("t")],
        vec![
            Instance::new(0, Affine3A::from_translation(Vec3::new(0.0, 0.0, -5.0))),
            Instance::new(
                0,
                Affine3A::from_scale_rotation_translation(
                    Vec3::splat(2.0),
                    glam::Quat::IDENTITY,
                    Vec3::new(0.0, 0.0, -3.0),
                ),
            ),
        ],
    );
    let bf = BruteForce::build(&scene, &()).unwrap();
    let ray = Ray1::infinite(Vec3::new(0.1, 0.1, 0.0), -Vec3::Z);
    let h = bf.intersect1(&ray).unwrap();
    assert_eq!((h.inst, h.t), (1, 3.0));
    assert!((h.u - 0.05).abs() < 1e-6 && (h.v - 0.05).abs() < 1e-6);
    let mut all = vec![];
    bf.intersect_all1(&ray, &mut |h| all.push((h.inst, h.t)));
    all.sort_by(|a, b| a.1.total_cmp(&b.1));
    assert_eq!(all, vec![(1, 3.0), (0, 5.0)]);
    assert!(bf.occluded1(&Ray1::new(ray.origin, ray.dir, 0.0, 3.5)));
    assert!(!bf.occluded1(&Ray1::new(ray.origin, ray.dir, 0.0, 3.0)));
    // Moving the nearer instance away.
    let mut moved = bf.clone();
    let mut inst = scene.instances.clone();
    inst[1].world_from_object = Affine3A::from_translation(Vec3::new(0.0, 0.0, 10.0));
    moved.set_instances(&inst).unwrap();
    assert_eq!(moved.intersect1(&ray).unwrap().inst, 0);
}

#[test]
fn invalid_rays_miss() {
    let bf = BruteForce::build(&Scene::single(tri_mesh("t")), &()).unwrap();
    let o = Vec3::new(0.1, 0.1, 1.0);
    for d in [
        Vec3::ZERO,
        Vec3::NAN,
        Vec3::new(0.0, 0.0, f32::NEG_INFINITY),
    ] {
        let r = Ray1::infinite(o, d);
        assert!(bf.intersect1(&r).is_none() && !bf.occluded1(&r));
        let p = Rays::from_fn(Scalar, |_| r);
        assert!(bf.intersect(Scalar, &p, true).lane(0).is_none());
    }
    let r = Ray1::new(o, -Vec3::Z, 2.0, 1.0);
    assert!(bf.intersect1(&r).is_none());
    let r = Ray1::new(o, -Vec3::Z, f32::NAN, 2.0);
    assert!(bf.intersect1(&r).is_none());
}

#[test]
fn empty_scene_misses() {
    let bf = BruteForce::build(&Scene::default(), &()).unwrap();
    assert!(
        bf.intersect1(&Ray1::infinite(Vec3::ZERO, Vec3::X))
            .is_none()
    );
}
