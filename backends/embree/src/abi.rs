//! Checks of the hand-written 4.4 layouts against the loaded library: every struct the library
//! writes is followed by guard words that must stay intact, and the words the 4.2 headers
//! did not have (`instPrimID`) must be the ones written. Also the scene's basic answers.
//!
//! These tests need the library: run `python3 scripts/native.py` first (scripts/test.sh
//! does); without it they fail with the loader's message naming the fix.

use glam::{Affine3A, Vec3};

use crate::ffi::{self, RTCRayHitK};
use crate::*;

const SENTINEL: u32 = 0xDEAD_BEEF;

/// A unit square in z = 0 (two triangles), as a mesh.
fn square() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    (p, vec![[0, 1, 2], [0, 2, 3]])
}

/// Two copies of the square: instance 0 at z = 1, instance 1 at z = 2 (scaled by 2 in x, y).
fn two_squares() -> EmbreeScene {
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
    EmbreeScene::build(&meshes, &instances, BuildParams::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A ray from below (z = -1) straight up at (x, y).
fn up(x: f32, y: f32) -> Ray1 {
    Ray1 { org: [x, y, -1.0], dir: [0.0, 0.0, 1.0], tmin: 0.0, tmax: f32::INFINITY }
}

#[test]
fn layouts_match_the_4_4_headers() {
    // RTCHit: 9 words (instPrimID after instID), aligned to 16.
    assert_eq!(core::mem::size_of::<ffi::RTCHit>(), 48);
    assert_eq!(core::mem::offset_of!(ffi::RTCHit, instPrimID), 32);
    assert_eq!(core::mem::offset_of!(ffi::RTCRayHit, hit), 48);
    // RTCRayHitK: 12 K ray words, then the hit rows; instPrimID is row 12 + 8.
    assert_eq!(core::mem::offset_of!(RTCRayHitK<16>, Ng_x), 12 * 16 * 4);
    assert_eq!(core::mem::offset_of!(RTCRayHitK<16>, instPrimID), 20 * 16 * 4);
    assert_eq!(core::mem::offset_of!(RTCRayHitK<8>, instPrimID), 20 * 8 * 4);
    assert_eq!(core::mem::offset_of!(RTCRayHitK<4>, instPrimID), 20 * 4 * 4);
    // Valid masks aligned to the packet (at least): 64 bytes serves 16 lanes.
    assert!(core::mem::align_of::<ffi::ValidK<16>>() >= 64);
    assert!(core::mem::align_of::<ffi::ValidK<8>>() >= 32);
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
    let mut g = Guarded::<K> { packet: RTCRayHitK::default(), guard: [SENTINEL; 64] };
    g.packet.instPrimID = [[SENTINEL; K]; 1];
    for i in 0..K {
        let x = 0.05 + 0.9 * i as f32 / K as f32;
        set_lane(&mut g.packet, i, &up(x, 0.3137));
    }
    scene.intersect_k(&mut g.packet, &valid_lanes::<K>(K), true);
    assert!(g.guard.iter().all(|&w| w == SENTINEL), "{K}-wide: the library wrote past the hit");
    for i in 0..K {
        let h = lane_hit(&g.packet, i).expect("every lane hits the first square");
        assert_eq!(h.inst, 0, "lane {i}");
        assert!((h.t - 2.0).abs() < 1e-6, "lane {i}: t = {}", h.t);
        // The word the 4.2 struct lacked is written by the 4.4 library.
        assert_ne!(g.packet.instPrimID[0][i], SENTINEL, "lane {i}: instPrimID not written");
        // It matches the single-ray answer.
        assert_eq!(scene.intersect1(&up(0.05 + 0.9 * i as f32 / K as f32, 0.3137)), Some(h));
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
    let mut g = Guarded1 { rh: ffi::RTCRayHit::default(), guard: [SENTINEL; 16] };
    let r = up(0.5, 0.25);
    g.rh.ray = ffi::RTCRay {
        org_x: r.org[0],
        org_y: r.org[1],
        org_z: r.org[2],
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
    let h = scene.intersect1(&up(0.5, 0.25)).unwrap();
    assert_eq!((h.inst, h.prim), (0, 0));
    assert!((h.t - 2.0).abs() < 1e-6);
    // Outside the first, inside the scaled second: instance 1 at t = 3.
    let h = scene.intersect1(&up(1.5, 1.5)).unwrap();
    assert_eq!(h.inst, 1);
    assert!((h.t - 3.0).abs() < 1e-6);
    assert_eq!(scene.intersect1(&up(3.0, 0.5)), None);
    // All hits: both squares, once each.
    let mut all = Vec::new();
    scene.all_hits1(&up(0.5, 0.25), &mut all);
    all.sort_by(|a, b| a.t.total_cmp(&b.t));
    assert_eq!(all.iter().map(|h| h.inst).collect::<Vec<_>>(), [0, 1]);
    // Segment ends before the first square: no hit, not occluded.
    let short = Ray1 { tmax: 1.5, ..up(0.5, 0.25) };
    assert_eq!(scene.intersect1(&short), None);
    assert!(!scene.occluded1(&short));
    assert!(scene.occluded1(&up(0.5, 0.25)));
}

#[test]
fn all_hits_of_a_packet_go_to_their_lanes() {
    let scene = two_squares();
    let mut p = RTCRayHitK::<8>::default();
    // Even lanes inside both squares, odd lanes inside the second only.
    for i in 0..8 {
        let r = if i % 2 == 0 { up(0.5, 0.1 * i as f32 + 0.05) } else { up(1.5, 1.2) };
        set_lane(&mut p, i, &r);
    }
    let mut hits = Vec::new();
    scene.all_hits_k(&mut p, &valid_lanes::<8>(7), true, &mut hits);
    for lane in 0..8u32 {
        let mut insts: Vec<u32> =
            hits.iter().filter(|(l, _)| *l == lane).map(|(_, h)| h.inst).collect();
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
    let mut scene = two_squares();
    scene.move_instance(0, Affine3A::from_translation(Vec3::new(5.0, 0.0, 1.0))).unwrap();
    // The first square has gone: the ray now meets the second.
    assert_eq!(scene.intersect1(&up(0.5, 0.25)).map(|h| h.inst), Some(1));
    assert_eq!(scene.intersect1(&up(5.5, 0.25)).map(|h| h.inst), Some(0));
    let singular = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert!(matches!(
        scene.move_instance(0, singular),
        Err(EmbreeError::InvalidInstance { instance: 0, .. })
    ));
    assert!(matches!(
        scene.move_instance(9, Affine3A::IDENTITY),
        Err(EmbreeError::InvalidInstance { instance: 9, .. })
    ));
}

#[test]
fn bad_input_names_the_mesh_or_instance() {
    let (p, _) = square();
    let bad = [[0, 1, 7]];
    let err = EmbreeScene::build(&[MeshRef { positions: &p, indices: &bad }], &[], BuildParams::default())
        .err()
        .unwrap();
    assert!(matches!(err, EmbreeError::InvalidMesh { mesh: 0, .. }), "{err}");
    assert!(err.to_string().contains("out of range"), "{err}");
    let mut nan = p.clone();
    nan[2].y = f32::NAN;
    let tris = [[0, 1, 2]];
    let err = EmbreeScene::build(&[MeshRef { positions: &nan, indices: &tris }], &[], BuildParams::default())
        .err()
        .unwrap();
    assert!(err.to_string().contains("not finite"), "{err}");
    let inst = [InstanceRef { mesh: 3, world_from_object: Affine3A::IDENTITY }];
    let err = EmbreeScene::build(&[MeshRef { positions: &p, indices: &tris }], &inst, BuildParams::default())
        .err()
        .unwrap();
    assert!(matches!(err, EmbreeError::InvalidInstance { instance: 0, .. }), "{err}");
}

#[test]
fn empty_scene_and_empty_mesh_miss() {
    let scene = EmbreeScene::build(&[], &[], BuildParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    let empty = MeshRef { positions: &[], indices: &[] };
    let inst = [InstanceRef { mesh: 0, world_from_object: Affine3A::IDENTITY }];
    let scene = EmbreeScene::build(&[empty], &inst, BuildParams::default()).unwrap();
    assert_eq!(scene.intersect1(&up(0.5, 0.5)), None);
    assert!(!scene.occluded1(&up(0.5, 0.5)));
}

#[test]
fn device_reports_what_the_comparison_relies_on() {
    let d = Device::new(Some(1)).unwrap();
    assert!(!d.backface_culling(), "the library culls back faces; the other structures do not");
    assert!(d.filter_functions(), "all-hits queries need filter functions");
    let scene = two_squares();
    assert!(scene.memory_bytes() > 0);
    eprintln!(
        "native packets 4/8/16: {}/{}/{}",
        d.native_packets(4),
        d.native_packets(8),
        d.native_packets(16)
    );
}
