//! Checks of the hand-written 4.4 layouts against the loaded library: every struct the library
//! writes is followed by guard words that must stay intact, and the words the 4.2 headers
//! did not have (`instPrimID`) must be the ones written. Also the scene's basic answers.
//!
//! These tests need the library: run `python3 scripts/native.py` first (scripts/test.sh
//! does); without it they fail with the loader's message naming the fix.

use coherent_accel::{Accel, AccelError, Hit1, Instance, Mesh, Ray1, Scene};
use glam::{Affine3A, Vec3};

use crate::ffi::{self, RTCRayHitK};
use crate::*;

const SENTINEL: u32 = 0xDEAD_BEEF;

/// A unit square in z = 0 (two triangles).
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

/// Two copies of the square: instance 0 at z = 1, instance 1 at z = 2 (scaled by 2 in x, y).
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

fn two_squares() -> Embree {
    Embree::build(&two_squares_scene(), &EmbreeParams::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// A ray from below (z = -1) straight up at (x, y).
fn up(x: f32, y: f32) -> Ray1 {
    Ray1::infinite(Vec3::new(x, y, -1.0), Vec3::Z)
}

/// Writes ray `r` into lane `i` of a K-wide packet.
fn set_lane<const K: usize>(p: &mut RTCRayHitK<K>, i: usize, r: &Ray1) {
    p.org_x[i] = r.origin.x;
    p.org_y[i] = r.origin.y;
    p.org_z[i] = r.origin.z;
    p.dir_x[i] = r.dir.x;
    p.dir_y[i] = r.dir.y;
    p.dir_z[i] = r.dir.z;
    p.tnear[i] = r.tmin;
    p.tfar[i] = r.tmax;
    p.id[i] = i as u32;
}

/// The hit in lane `i` after an intersect call, if any.
fn lane_hit<const K: usize>(p: &RTCRayHitK<K>, i: usize) -> Option<Hit1> {
    (p.geomID[i] != ffi::INVALID_ID).then(|| Hit1 {
        t: p.tfar[i],
        u: p.u[i],
        v: p.v[i],
        prim: p.primID[i],
        inst: p.instID[0][i],
    })
}

#[test]
fn layouts_match_the_4_4_headers() {
    // RTCHit: 9 words (instPrimID after instID), aligned to 16.
    assert_eq!(size_of::<ffi::RTCHit>(), 48);
    assert_eq!(core::mem::offset_of!(ffi::RTCHit, instPrimID), 32);
    assert_eq!(core::mem::offset_of!(ffi::RTCRayHit, hit), 48);
    // RTCRayHitK: 12 K ray words, then the hit rows; instPrimID is row 12 + 8.
    assert_eq!(core::mem::offset_of!(RTCRayHitK<16>, Ng_x), 12 * 16 * 4);
    assert_eq!(
        core::mem::offset_of!(RTCRayHitK<16>, instPrimID),
        20 * 16 * 4
    );
    assert_eq!(core::mem::offset_of!(RTCRayHitK<8>, instPrimID), 20 * 8 * 4);
    assert_eq!(core::mem::offset_of!(RTCRayHitK<4>, instPrimID), 20 * 4 * 4);
    // Valid masks aligned to the packet (at least): 64 bytes serves 16 lanes.
    assert!(align_of::<ffi::ValidK<16>>() >= 64);
    assert!(align_of::<ffi::ValidK<8>>() >= 32);
}

#[test]
fn version_is_4() {
    let v = version().unwrap_or_else(|e| panic!("{e}"));
    assert!((40000..50000).contains(&v), "Embree version {v}");
    eprintln!("Embree version {v}");
}

/// The packet, then guard words, as one block so the guards sit right after the struct.
#[repr(C, align(64))]
struct Guarded<const K: usize> {
    packet: RTCRayHitK<K>,
    guard: [u32; 64],
}

fn guarded_packet<const K: usize>() {
    let scene = two_squares();
    let mut g = Guarded::<K> {
        packet: RTCRayHitK::default(),
        guard: [SENTINEL; 64],
    };
    g.packet.instPrimID = [[SENTINEL; K]; 1];
    // Lanes spread along a line that crosses no triangle edge.
    let ray = |i: usize| up(0.05 + 0.9 * i as f32 / K as f32, 0.3137);
    for i in 0..K {
        set_lane(&mut g.packet, i, &ray(i));
    }
    // SAFETY: every lane holds a valid ray with tnear = 0 <= tfar and an empty hit.
    unsafe { scene.intersect_k_raw(&mut g.packet, &valid_lanes::<K>(K)) };
    assert!(
        g.guard.iter().all(|&w| w == SENTINEL),
        "{K}-wide: the library wrote past the hit"
    );
    for i in 0..K {
        let h = lane_hit(&g.packet, i).expect("every lane hits the first square");
        assert_eq!(h.inst, 0, "lane {i}");
        assert!((h.t - 2.0).abs() < 1e-6, "lane {i}: t = {}", h.t);
        // The word the 4.2 struct lacked is written by the 4.4 library.
        assert_ne!(
            g.packet.instPrimID[0][i], SENTINEL,
            "lane {i}: instPrimID not written"
        );
        // The packet answer is the single-ray answer.
        assert_eq!(scene.intersect1(&ray(i)), Some(h));
    }
}

#[test]
fn packet_of_16_leaves_guard_words_intact() {
    guarded_packet::<16>();
}

#[test]
fn packet_of_8_leaves_guard_words_intact() {
    guarded_packet::<8>();
}

#[test]
fn packet_of_4_leaves_guard_words_intact() {
    guarded_packet::<4>();
}

#[test]
fn single_ray_leaves_guard_words_intact() {
    #[repr(C, align(16))]
    struct Guarded1 {
        rh: ffi::RTCRayHit,
        guard: [u32; 16],
    }
    let scene = two_squares();
    let mut g = Guarded1 {
        rh: ffi::RTCRayHit::default(),
        guard: [SENTINEL; 16],
    };
    g.rh.ray = ffi::RTCRay {
        org_x: 0.5,
        org_y: 0.25,
        org_z: -1.0,
        dir_z: 1.0,
        tfar: f32::INFINITY,
        mask: u32::MAX,
        ..Default::default()
    };
    g.rh.hit.geomID = ffi::INVALID_ID;
    g.rh.hit.instPrimID = [SENTINEL];
    let mut args = ffi::RTCIntersectArguments::new(ffi::RAY_QUERY_FLAG_INCOHERENT);
    // SAFETY: a committed scene, a ray/hit of the 4.4 layout, initialised arguments.
    unsafe { (scene.device.api.intersect1)(scene.top, &mut g.rh, &mut args) };
    assert!(g.guard.iter().all(|&w| w == SENTINEL));
    assert_eq!(g.rh.hit.instID[0], 0);
    assert_ne!(g.rh.hit.instPrimID[0], SENTINEL);
}

#[test]
fn first_hit_all_hits_and_occlusion() {
    let scene = two_squares();
    // Inside both squares: the first is instance 0 at t = 2.
    let h = scene.intersect1(&up(0.75, 0.25)).unwrap();
    assert_eq!((h.inst, h.prim), (0, 0));
    assert!((h.t - 2.0).abs() < 1e-6);
    // Barycentrics: the point is (1 - u - v) p0 + u p1 + v p2.
    let p = Vec3::new(1.0, 0.0, 0.0) * h.u + Vec3::new(1.0, 1.0, 0.0) * h.v;
    assert!((p - Vec3::new(0.75, 0.25, 0.0)).length() < 1e-6, "{h:?}");
    // Outside the first, inside the scaled second: instance 1 at t = 3.
    let h = scene.intersect1(&up(1.5, 1.2)).unwrap();
    assert_eq!(h.inst, 1);
    assert!((h.t - 3.0).abs() < 1e-6);
    assert_eq!(scene.intersect1(&up(3.0, 0.5)), None);
    // All hits: both squares, once each.
    let mut all = Vec::new();
    scene.intersect_all1(&up(0.75, 0.25), &mut |h| all.push(h));
    all.sort_by(|a, b| a.t.total_cmp(&b.t));
    assert_eq!(all.iter().map(|h| h.inst).collect::<Vec<_>>(), [0, 1]);
    // Segment ends before the first square: no hit, not occluded.
    let short = Ray1 {
        tmax: 1.5,
        ..up(0.75, 0.25)
    };
    assert_eq!(scene.intersect1(&short), None);
    assert!(!scene.occluded1(&short));
    assert!(scene.occluded1(&up(0.75, 0.25)));
}

#[test]
fn all_hits_of_a_packet_go_to_their_lanes() {
    let scene = two_squares();
    // Even lanes inside both squares, odd lanes inside the second only; lane 7 off.
    let rays: Vec<Ray1> = (0..7)
        .map(|i| {
            if i % 2 == 0 {
                up(0.75, 0.1 * i as f32 + 0.05)
            } else {
                up(1.5, 1.2)
            }
        })
        .collect();
    let mut p = PacketK::<8>::new(&scene, &rays);
    let mut hits = Vec::new();
    scene.all_hits_k(&mut p, &mut hits);
    for lane in 0..8u32 {
        let mut insts: Vec<u32> = hits
            .iter()
            .filter(|(l, _)| *l == lane)
            .map(|(_, h)| h.inst)
            .collect();
        insts.sort();
        let want: &[u32] = match lane {
            7 => &[],
            l if l % 2 == 0 => &[0, 1],
            _ => &[1],
        };
        assert_eq!(insts, want, "lane {lane}");
    }
}

#[test]
fn invalid_rays_miss() {
    let scene = two_squares();
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
fn moving_an_instance_rebuilds_the_top_level() {
    let mut scene = two_squares();
    let mut moved = two_squares_scene();
    moved.instances[0].world_from_object = Affine3A::from_translation(Vec3::new(5.0, 0.0, 1.0));
    scene.set_instances(&moved.instances).unwrap();
    // The first square has gone: the ray now meets the second.
    assert_eq!(scene.intersect1(&up(0.75, 0.25)).map(|h| h.inst), Some(1));
    assert_eq!(scene.intersect1(&up(5.75, 0.25)).map(|h| h.inst), Some(0));
    // Fewer instances.
    scene.set_instances(&moved.instances[1..]).unwrap();
    assert_eq!(scene.intersect1(&up(5.75, 0.25)), None);
    assert_eq!(scene.intersect1(&up(0.75, 0.25)).map(|h| h.inst), Some(0));
    let mut bad = moved.instances.clone();
    bad[1].world_from_object = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let err = scene.set_instances(&bad).unwrap_err();
    assert!(
        matches!(err, AccelError::SingularTransform { instance: 1, .. }),
        "{err}"
    );
}

#[test]
fn negative_tmin_finds_hits_behind_the_origin() {
    let scene = two_squares();
    let r = Ray1::new(Vec3::new(0.75, 0.25, 5.0), Vec3::Z, -10.0, f32::INFINITY);
    let h = scene
        .intersect1(&r)
        .expect("the squares lie behind the origin, within tmin");
    assert_eq!(h.inst, 0);
    assert!((h.t + 4.0).abs() < 1e-6, "{h:?}");
}

#[test]
fn degenerate_triangles_are_counted_and_never_hit() {
    let mut m = square();
    m.positions.push(Vec3::new(0.25, 0.25, 0.0));
    m.positions.push(Vec3::new(0.75, 0.75, 0.0));
    // A segment across the square, as a triangle.
    m.indices.push([4, 5, 0]);
    let scene = Embree::build(&Scene::single(m), &EmbreeParams::default()).unwrap();
    assert_eq!(scene.stats().degenerate, 1);
    assert_eq!(scene.stats().triangles, 2);
    let h = scene.intersect1(&up(0.5, 0.5)).unwrap();
    assert!(h.prim < 2, "{h:?}");
}

#[test]
fn missing_library_is_a_clear_error() {
    let e = EmbreeError::NotFound {
        tried: "x: not found".into(),
    };
    let accel: AccelError = e.into();
    let msg = accel.to_string();
    assert!(
        msg.contains("embree") && msg.contains("scripts/native.py"),
        "{msg}"
    );
}

#[test]
fn bad_input_names_the_mesh_or_instance() {
    let mut m = square();
    m.indices.push([0, 1, 7]);
    let err = Embree::build(&Scene::single(m), &EmbreeParams::default())
        .err()
        .unwrap();
    assert!(
        matches!(err, AccelError::IndexOutOfRange { mesh: 0, .. }),
        "{err}"
    );
    let mut m = square();
    m.positions[2].y = f32::NAN;
    let err = Embree::build(&Scene::single(m), &EmbreeParams::default())
        .err()
        .unwrap();
    assert!(
        matches!(err, AccelError::NonFinitePosition { mesh: 0, .. }),
        "{err}"
    );
    let scene = Scene::new(vec![square()], vec![Instance::identity(3)]);
    let err = Embree::build(&scene, &EmbreeParams::default())
        .err()
        .unwrap();
    assert!(
        matches!(err, AccelError::MeshOutOfRange { instance: 0, .. }),
        "{err}"
    );
}

#[test]
fn empty_scene_misses() {
    let scene = Embree::build(&Scene::default(), &EmbreeParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    assert!(!scene.occluded1(&up(0.5, 0.5)));
    // A mesh placed by no instance.
    let scene = Embree::build(
        &Scene::new(vec![square()], vec![]),
        &EmbreeParams::default(),
    )
    .unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
}

#[test]
fn device_reports_what_the_comparison_relies_on() {
    let d = Device::new(Some(1)).unwrap();
    assert!(
        !d.backface_culling(),
        "the library culls back faces; the other structures do not"
    );
    assert!(
        d.filter_functions(),
        "all-hits queries need filter functions"
    );
    let scene = two_squares();
    assert!(scene.memory_bytes() > 0);
    eprintln!(
        "native packets 4/8/16: {}/{}/{}",
        d.native_packets(4),
        d.native_packets(8),
        d.native_packets(16)
    );
}

#[test]
fn only_the_4_4_abi_is_accepted() {
    assert!(crate::device::check_abi(40400).is_ok());
    assert!(crate::device::check_abi(40401).is_ok());
    for v in [40300, 40500, 30000, 50000] {
        let e = crate::device::check_abi(v).unwrap_err().to_string();
        let found = crate::version_string(v);
        assert!(e.contains(&found) && e.contains("4.4"), "{e}");
    }
}

#[test]
fn packed_packets_switch_off_rays_outside_the_contract() {
    let scene = two_squares();
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    let rays = [
        up(0.75, 0.25),                                            // hits instance 0 at t = 2
        Ray1::new(nan, Vec3::Z, 0.0, f32::INFINITY),               // NaN origin
        Ray1::new(Vec3::ZERO, Vec3::ZERO, 0.0, f32::INFINITY),     // zero direction
        Ray1::new(Vec3::new(0.75, 0.25, -2.0), Vec3::Z, 5.0, 1.0), // tmin > tmax
        Ray1::new(Vec3::new(0.75, 0.25, 2.0), Vec3::Z, -9.0, f32::INFINITY), // behind: t = -1
    ];
    let mut p = PacketK::<8>::new(&scene, &rays);
    assert_eq!(p.lanes(), 0b10001);
    for round in 0..2 {
        p.reset();
        scene.intersect_k(&mut p);
        let h = p.hit(0).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6, "round {round}: {h:?}");
        for i in 1..4 {
            assert_eq!(p.hit(i), None, "lane {i}");
        }
        let behind = p.hit(4).unwrap();
        assert!((behind.t + 1.0).abs() < 1e-5, "{behind:?}");
        p.reset();
        scene.occluded_k(&mut p);
        assert_eq!(p.occluded_bits(), 0b10001);
    }
}

#[test]
fn one_untransformed_instance_has_no_instance_level_and_same_answers() {
    let mut scene = Scene::default();
    let m = scene.add_mesh(square());
    scene.add_instance(m, Affine3A::IDENTITY);
    for all_hits in [true, false] {
        let p = EmbreeParams {
            all_hits,
            ..EmbreeParams::default()
        };
        let e = Embree::build(&scene, &p).unwrap();
        assert!(e.direct);
        let r = Ray1::infinite(Vec3::new(0.75, 0.25, -2.0), Vec3::Z);
        let h = e.intersect1(&r).unwrap();
        assert_eq!((h.inst, h.prim), (0, 0));
        let mut all = Vec::new();
        e.intersect_all1(&r, &mut |h| all.push(h));
        assert_eq!(all.len(), 1);
        assert_eq!(all[0].inst, 0);
        let mut pk = PacketK::<4>::new(&e, &[r]);
        e.intersect_k(&mut pk);
        assert_eq!(pk.hit(0).map(|h| h.inst), Some(0));
    }
    // Moved: an instance level again.
    let mut e = Embree::build(&scene, &EmbreeParams::default()).unwrap();
    let moved = Instance::new(m, Affine3A::from_translation(Vec3::Z));
    e.set_instances(&[moved]).unwrap();
    assert!(!e.direct);
    let r = Ray1::infinite(Vec3::new(0.75, 0.25, -2.0), Vec3::Z);
    assert!((e.intersect1(&r).unwrap().t - 3.0).abs() < 1e-6);
}

#[test]
fn all_hits_without_the_filter_flag_use_a_copy_with_it() {
    let scene = two_squares_scene();
    let p = EmbreeParams {
        all_hits: false,
        ..EmbreeParams::default()
    };
    let mut e = Embree::build(&scene, &p).unwrap();
    let mut insts = Vec::new();
    e.intersect_all1(&up(0.75, 0.25), &mut |h| insts.push(h.inst));
    insts.sort();
    assert_eq!(insts, [0, 1]);
    assert_eq!(e.intersect1(&up(0.75, 0.25)).map(|h| h.inst), Some(0));
    // New instances drop the copy (its release must not wait on the rebuild's lock) and the
    // next all-hits query builds one of the new instances.
    e.set_instances(&scene.instances[1..]).unwrap();
    let mut insts = Vec::new();
    e.intersect_all1(&up(0.75, 0.25), &mut |h| insts.push(h.inst));
    assert_eq!(insts, [0]);
    assert!(e.memory_bytes() > 0);
}
