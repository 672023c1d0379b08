//! Criterion benches of the two-level BSP (paper section 3): object-tree build (100k
//! triangles, each preset), top-level rebuild over 1,024 moving instances, and traversal of
//! primary, shadow and diffuse rays one at a time and in packets of every available backend;
//! the same builds (Embree's qualities, obvhs' BVH2 and CWBVH presets) where compiled in, and
//! the same traversals for every compared accelerator of `AccelKind` that runs here (single
//! rays only for those without packets of their own).
//!
//! `cargo bench --bench accel` (add `-- build` or `-- trace` to pick a group).

use std::hint::black_box;

use coherent::accel_any::{AccelKind, AccelVisitor, AnyAccel, AnyParams};
use coherent::simd::Backend;
use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::shapes::terrain;
use coherent_accel::workload::{self, Clock, RayKind, TimePackets};
use coherent_accel::{Accel, Mesh, Scene};
use coherent_bsp::{Bsp, BspParams, MeshTree, SahParams};
use criterion::measurement::WallTime;
use criterion::{
    BenchmarkGroup, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main,
};
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
    build_others(&mut g, &mesh, &s.scene, &moved);
    g.finish();
}

/// Embree and obvhs: the 100k-triangle mesh, and the top level after the instances moved.
fn build_others(
    g: &mut BenchmarkGroup<'_, WallTime>,
    mesh: &Mesh,
    field: &Scene,
    moved: &[coherent_accel::Instance],
) {
    let single = Scene::single(mesh.clone());
    #[cfg(feature = "embree")]
    {
        use coherent::embree::{BuildQuality, Embree, EmbreeParams};
        match Embree::build(field, &EmbreeParams::default()) {
            Err(e) => eprintln!("skipping the Embree benches: {e}"),
            Ok(mut embree) => {
                g.throughput(Throughput::Elements(mesh.indices.len() as u64));
                for q in BuildQuality::ALL {
                    let p = EmbreeParams {
                        mesh_quality: q,
                        ..EmbreeParams::default()
                    };
                    g.bench_function(BenchmarkId::new("embree_100k_tris", q.name()), |b| {
                        b.iter(|| Embree::build(black_box(&single), &p).unwrap())
                    });
                }
                g.throughput(Throughput::Elements(moved.len() as u64));
                g.bench_function("embree_top_1025_instances", |b| {
                    b.iter(|| embree.set_instances(black_box(moved)).unwrap())
                });
            }
        }
    }
    #[cfg(feature = "obvhs")]
    {
        use coherent::obvhs::{Kind, Obvhs, ObvhsParams, Preset};
        for kind in Kind::ALL {
            g.throughput(Throughput::Elements(mesh.indices.len() as u64));
            for preset in [Preset::FastBuild, Preset::MediumBuild, Preset::SlowBuild] {
                let p = ObvhsParams {
                    kind,
                    mesh_preset: preset,
                    ..ObvhsParams::default()
                };
                let id =
                    BenchmarkId::new(format!("obvhs_{}_100k_tris", kind.name()), preset.name());
                g.bench_function(id, |b| {
                    b.iter(|| Obvhs::build(black_box(&single), &p).unwrap())
                });
            }
            let mut o = Obvhs::build(
                field,
                &ObvhsParams {
                    kind,
                    ..ObvhsParams::default()
                },
            )
            .unwrap();
            g.throughput(Throughput::Elements(moved.len() as u64));
            g.bench_function(format!("obvhs_{}_top_1025_instances", kind.name()), |b| {
                b.iter(|| o.set_instances(black_box(moved)).unwrap())
            });
        }
    }
    let _ = (g, single, field, moved);
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
        trace_accel(&mut g, &bsp, &s, &bsp, (w, h), true);
        for kind in AccelKind::compared().filter(|&k| k != AccelKind::Bsp) {
            if let Some(why) = kind.unavailable_reason() {
                eprintln!("skipping the {kind} benches: {why}");
                continue;
            }
            match AnyAccel::build(&s.scene, &AnyParams::of(kind)) {
                // A structure without packets of its own would time its lane loop: single
                // rays only.
                Ok(a) => a.visit(Trace {
                    g: &mut g,
                    s: &s,
                    bsp: &bsp,
                    size: (w, h),
                    packets: kind.has_packets(),
                }),
                Err(e) => eprintln!("skipping the {kind} benches: {e}"),
            }
        }
    }
    g.finish();
}

/// [`trace_accel`] on the concrete structure inside an [`AnyAccel`] (no `match` per query).
struct Trace<'a, 'g> {
    g: &'a mut BenchmarkGroup<'g, WallTime>,
    s: &'a scenes::BuiltinScene,
    bsp: &'a Bsp,
    size: (u32, u32),
    packets: bool,
}

impl AccelVisitor for Trace<'_, '_> {
    type Output = ();
    fn visit<A: Accel>(self, a: &A) {
        trace_accel(self.g, a, self.s, self.bsp, self.size, self.packets)
    }
}

/// Primary, shadow and diffuse rays through `accel`, one at a time and (with `packets`) in
/// packets of every available backend; the secondary rays come from the BSP's hits, so every
/// accelerator traces the same rays.
fn trace_accel<A: Accel>(
    g: &mut BenchmarkGroup<'_, WallTime>,
    accel: &A,
    s: &scenes::BuiltinScene,
    bsp: &Bsp,
    (w, h): (u32, u32),
    packets: bool,
) {
    for kind in RayKind::ALL {
        let rays_for = |lanes: usize| {
            let primary = workload::primary_rays(&s.view, w, h, workload::tile_shape(lanes));
            match kind {
                RayKind::Primary => primary,
                RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
                RayKind::Diffuse => workload::diffuse_rays(bsp, &s.scene, &primary, 1),
            }
        };
        let rays = rays_for(1);
        let name = format!("{}/{}/{}", accel.name(), s.name, kind.name());
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(BenchmarkId::new(name.clone(), "single"), |b| {
            b.iter(|| {
                workload::time_single(accel, black_box(&rays), kind.occlusion(), 1, Clock::Wall)
            })
        });
        if !packets {
            continue;
        }
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
                            accel,
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

criterion_group!(benches, build, trace);
criterion_main!(benches);
