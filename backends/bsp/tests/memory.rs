//! The build's memory against the finished structure's (paper section 3's object trees and
//! the top tree over instances): the most bytes live at once during `Bsp::build`, counted by
//! this test program's allocator, over `Bsp::memory_bytes`. The build binned at every level
//! keeps within 2x on a mesh and on a scene of many tiny objects; the exact build (its event
//! lists per node) is only reported.

use std::sync::{Mutex, MutexGuard};

use coherent_accel::alloc_count::{CountingAlloc, peak_bytes};
use coherent_accel::shapes::soup;
use coherent_accel::{Accel, Instance, Mesh, Scene};
use coherent_bsp::{Bsp, BspParams, BuildPreset};
use glam::{Affine3A, Vec3};

/// One test at a time: the harness runs tests on several threads, and every thread's
/// allocations count, so each test holds this from its start (scene included) to its end.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

#[global_allocator]
static ALLOCATOR: CountingAlloc = CountingAlloc;

/// `scene` built with `preset` on `threads` threads: the structure, and the most bytes live
/// at once during the build over those live before it (the finished structure included).
/// The caller holds [`serial`].
fn build_counted(scene: &Scene, preset: BuildPreset, threads: usize) -> (Bsp, usize) {
    let mut p = BspParams::default();
    p.object.build = preset;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (bsp, peak) = peak_bytes(|| pool.install(|| Bsp::build(scene, &p)));
    (bsp.unwrap(), peak)
}

/// A mesh of 30,000 random small triangles (large enough to bin and partition across threads
/// at the top): the binned build's peak is at most twice the structure it leaves.
#[test]
fn binned_build_of_a_mesh_peaks_within_twice_the_structure() {
    let _serial = serial();
    let scene = Scene::single(soup("soup", 30_000, 20.0, 0.8, 5));
    for threads in [1, 2] {
        for preset in BuildPreset::ALL {
            let (bsp, peak) = build_counted(&scene, preset, threads);
            let bytes = bsp.memory_bytes();
            let r = peak as f64 / bytes as f64;
            eprintln!("soup, {preset}, {threads} thread(s): peak {peak} over {bytes} = {r:.2}x");
            if preset == BuildPreset::Binned {
                assert!(
                    r <= 2.0,
                    "{threads} thread(s): peak {peak}, structure {bytes}"
                );
            }
        }
    }
}

/// A million tiny objects (one triangle each, no two at one transform) under the top tree:
/// the binned build's peak is at most twice the structure.
#[test]
fn a_million_tiny_objects_build_within_twice_the_structure() {
    let _serial = serial();
    let side = 1000;
    let tiny = Mesh::new(
        "tiny",
        vec![
            Vec3::new(-0.3, -0.3, 0.0),
            Vec3::new(0.3, -0.3, 0.0),
            Vec3::new(0.0, 0.3, 0.0),
        ],
        vec![[0, 1, 2]],
    );
    let instances: Vec<Instance> = (0..side * side)
        .map(|i| {
            let at = Vec3::new((i % side) as f32, (i / side) as f32, 0.0);
            Instance::new(0, Affine3A::from_translation(at))
        })
        .collect();
    let scene = Scene::new(vec![tiny], instances);
    let (bsp, peak) = build_counted(&scene, BuildPreset::Binned, 2);
    let bytes = bsp.memory_bytes();
    let r = peak as f64 / bytes as f64;
    eprintln!(
        "{} objects: peak {peak} over {bytes} = {r:.2}x",
        side * side
    );
    assert!(r <= 2.0, "peak {peak}, structure {bytes}");
}
