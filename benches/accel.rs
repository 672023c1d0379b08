//! Criterion benches of the two-level BSP (paper section 3): object-tree build (100k
//! triangles, each preset), top-level rebuild over 1,024 moving instances, and traversal of
//! primary, shadow and diffuse rays one at a time and in packets of every available backend.
//!
//! `cargo bench --bench accel` (add `-- build` or `-- trace` to pick a group).

use std::hint::black_box;

use coherent::simd::Backend;
use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::shapes::terrain;
use coherent_accel::workload::{self, Clock, RayKind, TimePackets};
use coherent_accel::{Accel, Scene};
use coherent_bsp::{Bsp, BspParams, MeshTree, SahParams};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Affine3A, Vec3};

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    // 224 x 224 quads: 100,352 triangles.
    let mesh = terrain("terrain", 100.0, 224, 12.0, 5);
    g.throughput(Throughput::Elements(mesh.indices.len() as u64));
    for preset in ["fast", "default", "slow"] {
        let p = SahParams::preset(preset).unwrap();
        g.bench_function(BenchmarkId::new("object_100k_tris", preset), |b| {
            b.iter(|| MeshTree::build(black_box(&mesh.positions), &mesh.indices, &p))
        });
    }
    // The top level over 1,024 instances (+ the ground), rebuilt after every instance moved.
    let s = scenes::sphere_field(SceneSize::Full);
    let mut bsp = Bsp::build(&s.scene, &BspParams::default()).unwrap();
    let moved: Vec<_> = s
        .scene
        .instances
        .iter()
        .map(|i| {
            let mut i = *i;
            i.world_from_object =
                Affine3A::from_translation(Vec3::new(0.3, -0.2, 0.1)) * i.world_from_object;
            i
        })
        .collect();
    g.throughput(Throughput::Elements(moved.len() as u64));
    g.bench_function("top_1025_instances", |b| {
        b.iter(|| bsp.set_instances(black_box(&moved)).unwrap())
    });
    g.finish();
}

fn trace(c: &mut Criterion) {
    let mut g = c.benchmark_group("trace");
    g.sample_size(10);
    let (w, h) = (256, 192);
    for s in [
        scenes::blob(SceneSize::Quick),
        scenes::room(SceneSize::Quick),
    ] {
        let bsp = Bsp::build(&s.scene, &BspParams::default()).unwrap();
        for kind in RayKind::ALL {
            let rays_for = |lanes: usize| {
                let primary = workload::primary_rays(&s.view, w, h, workload::tile_shape(lanes));
                match kind {
                    RayKind::Primary => primary,
                    RayKind::Shadow => workload::shadow_rays(&bsp, &s.scene, &primary, s.light),
                    RayKind::Diffuse => workload::diffuse_rays(&bsp, &s.scene, &primary, 1),
                }
            };
            let rays = rays_for(1);
            let name = format!("{}/{}", s.name, kind.name());
            g.throughput(Throughput::Elements(rays.len() as u64));
            g.bench_function(BenchmarkId::new(name.clone(), "single"), |b| {
                b.iter(|| {
                    workload::time_single(&bsp, black_box(&rays), kind.occlusion(), 1, Clock::Wall)
                })
            });
            for backend in Backend::available()
                .into_iter()
                .filter(|b| *b != Backend::Scalar)
            {
                let rays = rays_for(backend.lanes());
                g.throughput(Throughput::Elements(rays.len() as u64));
                g.bench_function(BenchmarkId::new(name.clone(), backend.name()), |b| {
                    b.iter(|| {
                        backend
                            .run(TimePackets {
                                accel: &bsp,
                                rays: black_box(&rays),
                                occlusion: kind.occlusion(),
                                repeats: 1,
                                clock: Clock::Wall,
                            })
                            .unwrap()
                    })
                });
            }
        }
    }
    g.finish();
    let _ = Scene::default();
}

criterion_group!(benches, build, trace);
criterion_main!(benches);
