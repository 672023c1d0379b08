//! Times the object-tree builds of the paper's two-level BSP (section 3) per build preset
//! ([`BuildPreset::Exact`]: Wald & Havran 2006's sweep; [`BuildPreset::Fast`]: binned SAH
//! after Hunt et al. 2006 and Shevtsov et al. 2007 above a node size): wall-clock median of
//! several whole builds (`Bsp::build`: every mesh tree and the top tree) on rayon pools of 1
//! and 2 threads, with the trees' nodes, leaf references, depth and summed SAH cost, and
//! whether the trees came out identical on both thread counts.
//!
//! ```text
//! cargo run --release -p coherent-bsp --example build -- [SHAPE...] [--preset exact|fast]
//!     [--runs N] [--threads 1,2] [--quick]
//! SHAPE: blob room terrain spheres (built-in scenes), terrain100k, soup100k, needles (long
//! thin triangles, 36,762 of them), fan (20,000 long thin triangles through one point);
//! default all. BINS, SWEEP_BELOW, REFS (max_refs_per_tri) override the preset's parameters.
//! ```

use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::shapes::{self, Rng};
use coherent_accel::{Accel, Mesh, Scene};
use coherent_bsp::{Bsp, BspParams, BuildPreset};
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

fn scene(name: &str, size: SceneSize) -> Option<Scene> {
    Some(match name {
        "terrain100k" => Scene::single(shapes::terrain("t", 100.0, 224, 12.0, 5)),
        "soup100k" => Scene::single(shapes::soup("s", 100_000, 20.0, 0.8, 11)),
        "needles" => Scene::single(needles(36_762, 3)),
        "fan" => Scene::single(fan(20_000, 4)),
        _ => scenes::by_name(name, size)?.scene,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut names = vec![];
    let mut presets = BuildPreset::ALL.to_vec();
    let mut runs = 5;
    let mut threads = vec![1, 2];
    let mut size = SceneSize::Full;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--preset" => presets = vec![it.next().expect("--preset exact|fast").parse().unwrap()],
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
    println!(
        "shape        preset threads   tris  build_s(med)   nodes   leaf_refs depth  sah_cost  same_as_1"
    );
    for name in &names {
        let s = scene(name, size).unwrap_or_else(|| panic!("unknown shape {name}"));
        for &preset in &presets {
            let mut p = BspParams::default();
            p.object.build = preset;
            p.object.bins = env("BINS").unwrap_or(p.object.bins);
            p.object.sweep_below = env("SWEEP_BELOW").unwrap_or(p.object.sweep_below);
            p.object.max_refs_per_tri = env("REFS").unwrap_or(p.object.max_refs_per_tri);
            let mut first: Option<Bsp> = None;
            for &t in &threads {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .unwrap();
                let mut secs = vec![];
                let mut bsp = None;
                for _ in 0..runs {
                    let t0 = std::time::Instant::now();
                    bsp = Some(pool.install(|| Bsp::build(&s, &p).unwrap()));
                    secs.push(t0.elapsed().as_secs_f64());
                }
                let bsp = bsp.unwrap();
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
                println!(
                    "{name:<12} {:<6} {t:>7} {:>6} {:>13.4} {:>7} {:>11} {:>5} {:>9.2}  {same}",
                    preset.name(),
                    st.triangles,
                    median(secs),
                    st.nodes,
                    st.leaf_refs,
                    st.max_depth,
                    sah,
                );
                first.get_or_insert(bsp);
            }
        }
    }
}
