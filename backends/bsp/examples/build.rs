//! Times the object-tree builds of the paper's two-level BSP (section 3) per build preset
//! ([`BuildPreset::Exact`]: Wald & Havran 2006's sweep; [`BuildPreset::Fast`]: binned SAH
//! after Hunt et al. 2006 and Shevtsov et al. 2007 above a node size; [`BuildPreset::Binned`]:
//! binned at every level): the median of several whole builds (`Bsp::build`: every mesh tree
//! and the top tree) on rayon pools of 1 and 2 threads, in wall time and in process CPU time,
//! with the trees' nodes, leaf references, depth and summed SAH cost, whether the trees came
//! out identical on every thread count, and the build's peak memory: the most bytes live at
//! once during one more (untimed) build, counted by this program's allocator, over the
//! finished structure's bytes.
//!
//! `--trace` instead times each preset's tree (built on one thread) on the same rays: primary,
//! shadow and diffuse (the `accel` experiment's rays: a `WxH` image, shadow rays to the
//! scene's light, one diffuse bounce), one ray at a time and in packets of the widest backend,
//! the presets interleaved, thread CPU time, the median of `--runs` passes; and how far each
//! tree's count of hits is from the first tree's (0 when they agree).
//!
//! ```text
//! cargo run --release -p coherent-bsp --example build -- [SHAPE...] [--preset exact|fast|binned]
//!     [--runs N] [--threads 1,2] [--quick] [--trace [--size WxH]]
//! SHAPE: blob room terrain spheres (built-in scenes), terrain100k, soup100k, needles (long
//! thin triangles, 36,762 of them), fan (20,000 long thin triangles through one point),
//! bunny (the fetched real mesh), blocks (4,761 objects of 12 triangles); default all.
//! BINS, SWEEP_BELOW, FLAT_SWEEP_BELOW, REFS (max_refs_per_tri) override the preset's
//! parameters.
//! ```

use coherent_accel::alloc_count::{CountingAlloc, peak_bytes};

use coherent_accel::scenes::View;
use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::shapes::{self, Rng};
use coherent_accel::workload::{self, Clock, RayKind, TimePackets};
use coherent_accel::{Accel, Mesh, Scene};
use coherent_bsp::{Bsp, BspParams, BuildPreset};
use coherent_simd::Backend;
use glam::Vec3;

fn env<T: std::str::FromStr>(k: &str) -> Option<T> {
    std::env::var(k).ok().and_then(|v| v.parse().ok())
}

/// `n` long thin triangles at random: each spans most of a 100-unit box one way and a
/// thousandth of that across, as the faces of tessellated CAD parts do.
fn needles(n: usize, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let tris: Vec<[Vec3; 3]> = (0..n)
        .map(|_| {
            let a = rng.vec3(Vec3::splat(-50.0), Vec3::splat(50.0));
            let d = rng.unit_vector() * rng.range(40.0, 100.0);
            let w = rng.unit_vector() * 0.1;
            [a, a + d, a + d + w]
        })
        .collect();
    Mesh::from_triangles("needles", &tris)
}

/// `n` long thin triangles through the origin, in every direction: every plane near the
/// origin cuts nearly all of them.
pub fn fan(n: usize, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let tris: Vec<[Vec3; 3]> = (0..n)
        .map(|_| {
            let d = rng.unit_vector() * 100.0;
            let w = rng.unit_vector() * 0.05;
            [Vec3::ZERO, d, d + w]
        })
        .collect();
    Mesh::from_triangles("fan", &tris)
}

/// A Wavefront OBJ file's triangles (`v` and `f` lines; faces fanned), for real meshes such
/// as the bunny the experiments fetch (`.cache/meshes/glmark2-data/bunny.obj`).
fn obj(path: &str) -> Option<Mesh> {
    let text = std::fs::read_to_string(path).ok()?;
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<f32> = w.take(3).filter_map(|x| x.parse().ok()).collect();
                positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let v: Vec<u32> = w
                    .filter_map(|x| x.split('/').next()?.parse::<u32>().ok())
                    .map(|i| i - 1)
                    .collect();
                for k in 1..v.len().saturating_sub(1) {
                    indices.push([v[0], v[k], v[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Some(Mesh::new(path, positions, indices))
}

/// Many objects, as a city is: a `side` x `side` grid of boxes of random heights, each its
/// own mesh (12 triangles) placed by an instance.
fn blocks(side: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut meshes = Vec::new();
    let mut instances = Vec::new();
    for i in 0..side * side {
        let h = rng.range(1.0, 12.0);
        meshes.push(shapes::cuboid("block", Vec3::ZERO, Vec3::new(0.8, h, 0.8)));
        let at = Vec3::new((i % side) as f32, 0.0, (i / side) as f32);
        instances.push(coherent_accel::Instance::new(
            i,
            glam::Affine3A::from_translation(at),
        ));
    }
    Scene::new(meshes, instances)
}

/// The shape `name`, and for the built-in scenes their view and light (the others get one
/// from their bounds in `--trace`).
fn scene(name: &str, size: SceneSize) -> Option<(Scene, Option<(View, Vec3)>)> {
    let only = |s: Scene| Some((s, None));
    match name {
        "bunny" => only(Scene::single(obj(&format!(
            "{}/../../.cache/meshes/glmark2-data/bunny.obj",
            env!("CARGO_MANIFEST_DIR")
        ))?)),
        "blocks" => only(blocks(69, 6)),
        "terrain100k" => only(Scene::single(shapes::terrain("t", 100.0, 224, 12.0, 5))),
        "soup100k" => only(Scene::single(shapes::soup("s", 100_000, 20.0, 0.8, 11))),
        "needles" => only(Scene::single(needles(36_762, 3))),
        "fan" => only(Scene::single(fan(20_000, 4))),
        _ => {
            let b = scenes::by_name(name, size)?;
            Some((b.scene, Some((b.view, b.light))))
        }
    }
}

/// A view of the whole of `bsp`'s bounds from above and to one side, and a light above it.
fn view_of(bsp: &Bsp) -> (View, Vec3) {
    let b = bsp.top_tree().bounds;
    let (c, r) = ((b.min + b.max) * 0.5, (b.max - b.min).length() * 0.5);
    let view = View {
        eye: c + Vec3::new(0.45, 0.5, 1.0).normalize() * 2.2 * r,
        target: c,
        up: Vec3::Y,
        fov_y_degrees: 45.0,
    };
    (view, c + Vec3::new(0.6, 1.5, 0.4) * r)
}

#[global_allocator]
static ALLOCATOR: CountingAlloc = CountingAlloc;

/// The process's CPU time so far (every thread's, from `/proc/self/task/*/schedstat`), in
/// seconds: on a shared machine, what a one-thread build costs regardless of waiting.
fn cpu_seconds() -> f64 {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return f64::NAN;
    };
    dir.filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        / 1e9
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The default parameters with the object trees built by `preset`, and the overrides the
/// environment gives.
fn params(preset: BuildPreset) -> BspParams {
    let mut p = BspParams::default();
    p.object.build = preset;
    p.object.bins = env("BINS").unwrap_or(p.object.bins);
    p.object.sweep_below = env("SWEEP_BELOW").unwrap_or(p.object.sweep_below);
    p.object.flat_sweep_below = env("FLAT_SWEEP_BELOW").unwrap_or(p.object.flat_sweep_below);
    p.object.max_refs_per_tri = env("REFS").unwrap_or(p.object.max_refs_per_tri);
    p
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut names = vec![];
    let mut presets = BuildPreset::ALL.to_vec();
    let mut runs = 5;
    let mut threads = vec![1, 2];
    let mut size = SceneSize::Full;
    let mut trace_size = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--preset" => {
                presets = vec![
                    it.next()
                        .expect("--preset exact|fast|binned")
                        .parse()
                        .unwrap(),
                ]
            }
            "--runs" => runs = it.next().expect("--runs N").parse().unwrap(),
            "--threads" => {
                threads = it
                    .next()
                    .expect("--threads 1,2")
                    .split(',')
                    .map(|t| t.parse().unwrap())
                    .collect()
            }
            "--quick" => size = SceneSize::Quick,
            "--trace" => trace_size = Some(trace_size.unwrap_or((512, 384))),
            "--size" => {
                let v = it.next().expect("--size WxH");
                let (w, h) = v.split_once('x').expect("--size WxH");
                trace_size = Some((w.parse().unwrap(), h.parse().unwrap()));
            }
            _ => names.push(a.clone()),
        }
    }
    if names.is_empty() {
        names = [
            "blob",
            "room",
            "terrain",
            "spheres",
            "terrain100k",
            "soup100k",
            "needles",
            "fan",
        ]
        .map(String::from)
        .to_vec();
    }
    if let Some((w, h)) = trace_size {
        for name in &names {
            trace(name, size, &presets, (w, h), runs);
        }
        return;
    }
    println!(
        "shape        preset threads   tris  build_s(med)   nodes   leaf_refs depth  sah_cost  same_as_1  cpu_s(med)  tree_mb  peak_mb  peak/tree"
    );
    for name in &names {
        let (s, _) = scene(name, size).unwrap_or_else(|| panic!("unknown shape {name}"));
        for &preset in &presets {
            let p = params(preset);
            let mut first: Option<Bsp> = None;
            for &t in &threads {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .unwrap();
                let (mut secs, mut cpu) = (vec![], vec![]);
                let mut bsp = None;
                for _ in 0..runs {
                    let (t0, c0) = (std::time::Instant::now(), cpu_seconds());
                    bsp = Some(pool.install(|| Bsp::build(&s, &p).unwrap()));
                    secs.push(t0.elapsed().as_secs_f64());
                    cpu.push(cpu_seconds() - c0);
                }
                drop(bsp.take());
                let (bsp, peak) = peak_bytes(|| pool.install(|| Bsp::build(&s, &p).unwrap()));
                let st = bsp.stats();
                let sah: f64 = bsp.mesh_trees().iter().map(|m| m.tree.stats.sah_cost).sum();
                let same = first.as_ref().map_or("-".to_string(), |f| {
                    let eq = f.mesh_trees().iter().zip(bsp.mesh_trees()).all(|(a, b)| {
                        a.tree.nodes == b.tree.nodes
                            && a.tree.items == b.tree.items
                            && a.tree.stats.sah_cost == b.tree.stats.sah_cost
                    });
                    eq.to_string()
                });
                let tree = bsp.memory_bytes();
                println!(
                    "{name:<12} {:<6} {t:>7} {:>6} {:>13.4} {:>7} {:>11} {:>5} {:>9.2}  {same:<9}  {:>10.4} {:>8.2} {:>8.2} {:>9.2}",
                    preset.name(),
                    st.triangles,
                    median(secs),
                    st.nodes,
                    st.leaf_refs,
                    st.max_depth,
                    sah,
                    median(cpu),
                    tree as f64 / 1e6,
                    peak as f64 / 1e6,
                    peak as f64 / tree as f64,
                );
                first.get_or_insert(bsp);
            }
        }
    }
}

/// `--trace`: each preset's tree (one thread) on the same rays of every kind, single rays and
/// packets of the widest backend, interleaved; the median of `runs` passes in thread CPU time,
/// and each preset's rate over the first preset's (`exact` unless `--preset` says otherwise).
fn trace(name: &str, size: SceneSize, presets: &[BuildPreset], (w, h): (u32, u32), runs: usize) {
    let (s, view) = scene(name, size).unwrap_or_else(|| panic!("unknown shape {name}"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let trees: Vec<Bsp> = presets
        .iter()
        .map(|&p| pool.install(|| Bsp::build(&s, &params(p)).unwrap()))
        .collect();
    let (view, light) = view.unwrap_or_else(|| view_of(&trees[0]));
    let widest = Backend::widest();
    let mut widths = vec![None];
    if widest != Backend::Scalar {
        widths.push(Some(widest));
    }
    for kind in RayKind::ALL {
        for &backend in &widths {
            let lanes = backend.map_or(1, Backend::lanes);
            let tile = workload::tile_shape(if lanes == 1 { 16 } else { lanes });
            let primary = workload::primary_rays(&view, w, h, tile);
            let rays = match kind {
                RayKind::Primary => primary,
                RayKind::Shadow => workload::shadow_rays(&trees[0], &s, &primary, light),
                RayKind::Diffuse => workload::diffuse_rays(&trees[0], &s, &primary, 7),
            };
            let occlusion = kind.occlusion();
            let mut secs = vec![Vec::with_capacity(runs); trees.len()];
            let mut hits = vec![0; trees.len()];
            for _ in 0..runs.max(1) {
                for (i, b) in trees.iter().enumerate() {
                    let r = match backend {
                        None => workload::time_single(b, &rays, occlusion, 1, Clock::ThreadCpu),
                        Some(k) => k
                            .run(TimePackets {
                                accel: b,
                                rays: &rays,
                                occlusion,
                                repeats: 1,
                                clock: Clock::ThreadCpu,
                            })
                            .unwrap(),
                    };
                    secs[i].push(r.seconds);
                    hits[i] = r.hits;
                }
            }
            let rate = |i: usize| rays.len() as f64 / median(secs[i].clone()) / 1e6;
            let mut line = format!(
                "{name:<12} {:<8} {:<7} {:>8} rays",
                kind.name(),
                backend.map_or("single", Backend::name),
                rays.len()
            );
            for (i, p) in presets.iter().enumerate() {
                line.push_str(&format!(
                    "  {} {:.3} Mr/s ({:.3}x)",
                    p.name(),
                    rate(i),
                    rate(i) / rate(0)
                ));
            }
            let differ: Vec<u64> = hits.iter().map(|&x| x.abs_diff(hits[0])).collect();
            line.push_str(&format!("  hits {} (differ by {differ:?})", hits[0]));
            println!("{line}");
        }
    }
}
