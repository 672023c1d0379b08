//! The speed of particle tracing per mode (`imaps.csv`): per scene, accelerator, backend,
//! mode and generation, the rays traced, their packets and active lanes, rays per second,
//! the traversal's work per ray and the sort's share of the generation's time.
//!
//! Protocol, per scene, accelerator and backend, in a pool of one thread: one untimed map
//! per mode with the traversal's work counted (the counts, and a warm-up), then `rounds`
//! rounds build one map per mode, the order of the modes rotating from round to round so
//! that slow phases of a shared machine fall on every mode alike. Every figure of time is
//! the median over the rounds; counting the work stays out of the timed maps, where it would
//! slow the traversal.

use std::fmt::Display;
use std::time::Instant;

use anyhow::Context;
use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::illum::{GenerationStats, IllumMap, MapOptions, Mode, build_map};
use coherent::median::median;
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use super::error::relative_error;
use crate::ctx::Ctx;

pub const FILE: &str = "imaps.csv";
pub const HEADER: &[&str] = &[
    "scene",
    "accel",
    "backend",
    "lanes",
    "mode",
    "particles",
    "generation",
    "generations",
    "rays",
    "packets",
    "lanes_per_packet",
    "mrays_per_s",
    "mrays_per_s_with_sort",
    "inner_nodes_per_ray",
    "tri_tests_per_ray",
    "sort_share",
    "map_s",
    "map_vs_single",
    "rounds",
];

/// Generations kept as rows of their own; the later ones (few rays, the tail of Russian
/// roulette) are summed into one row.
pub const KEPT_GENERATIONS: usize = 8;

/// The packet widths a full run measures, each on its preferred backend usable here
/// ([`Backend::preferred_for_lanes`]); a quick run measures the widest only.
const WIDTHS: [usize; 4] = [1, 4, 8, 16];

/// The seed of the particles of the timed maps.
const SEED: u32 = 1;

/// Generations summed: one row of the CSV.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Group {
    /// The first generation summed.
    generation: u32,
    /// How many generations are summed.
    generations: u32,
    rays: u64,
    packets: u64,
    active_lanes: u64,
    trace_ns: u64,
    sort_ns: u64,
    shade_ns: u64,
    inner_nodes: u64,
    tri_tests: u64,
}

impl Group {
    fn of(g: &GenerationStats) -> Group {
        Group {
            generation: g.generation,
            generations: 1,
            rays: g.rays,
            packets: g.packets,
            active_lanes: g.active_lanes,
            trace_ns: g.trace_ns,
            sort_ns: g.sort_ns,
            shade_ns: g.shade_ns,
            inner_nodes: g.work.inner_nodes,
            tri_tests: g.work.tri_tests,
        }
    }

    fn add(&mut self, o: &Group) {
        self.generations += o.generations;
        self.rays += o.rays;
        self.packets += o.packets;
        self.active_lanes += o.active_lanes;
        self.trace_ns += o.trace_ns;
        self.sort_ns += o.sort_ns;
        self.shade_ns += o.shade_ns;
        self.inner_nodes += o.inner_nodes;
        self.tri_tests += o.tri_tests;
    }

    /// Million rays per second of tracing alone.
    fn mrays_per_s(&self) -> f64 {
        self.rays as f64 * 1e3 / self.trace_ns as f64
    }

    /// Million rays per second of tracing and sorting.
    fn mrays_per_s_with_sort(&self) -> f64 {
        self.rays as f64 * 1e3 / (self.trace_ns + self.sort_ns) as f64
    }

    /// The sort's share of the generation's time (trace, sort and shade).
    fn sort_share(&self) -> f64 {
        let all = self.trace_ns + self.sort_ns + self.shade_ns;
        if all == 0 {
            0.0
        } else {
            self.sort_ns as f64 / all as f64
        }
    }
}

/// The first [`KEPT_GENERATIONS`] generations one row each, the rest summed into one.
fn fold(generations: &[GenerationStats]) -> Vec<Group> {
    let mut out: Vec<Group> = Vec::new();
    for (i, g) in generations.iter().enumerate() {
        let g = Group::of(g);
        if i > KEPT_GENERATIONS {
            out[KEPT_GENERATIONS].add(&g);
        } else {
            out.push(g);
        }
    }
    out
}

/// The backends measured: every width's preferred backend in a full run, the widest in a
/// quick one.
fn backends(ctx: &mut Ctx) -> Vec<Backend> {
    if ctx.quick {
        return vec![Backend::widest()];
    }
    let mut out: Vec<Backend> = Vec::new();
    for n in WIDTHS {
        match Backend::preferred_for_lanes(n) {
            Some(b) if !out.contains(&b) => out.push(b),
            Some(_) => {}
            None => ctx.note(format!("imaps: no {n}-lane backend usable here")),
        }
    }
    out
}

/// What one scene, accelerator and backend measured, per mode.
struct Measured {
    /// The untimed map's groups, with the work counted.
    counted: Vec<Group>,
    /// Per round, the timed map's groups.
    rounds: Vec<Vec<Group>>,
    /// Per round, the map's wall-clock seconds.
    seconds: Vec<f64>,
    /// The untimed map.
    map: IllumMap,
}

/// One map of `particles` particles in `mode`, in `pool`: the map, its statistics and its
/// wall-clock seconds.
fn map(
    pool: &rayon::ThreadPool,
    backend: Backend,
    scene: &RenderScene,
    accel: &AnyAccel,
    opts: &MapOptions,
) -> anyhow::Result<(IllumMap, Vec<Group>, f64)> {
    let start = Instant::now();
    let (map, stats) = pool
        .install(|| build_map(backend, scene, accel, opts, &|_| {}))
        .with_context(|| {
            format!(
                "the illumination map of {} ({}, {})",
                scene.name,
                opts.mode.name(),
                backend.name()
            )
        })?;
    let seconds = start.elapsed().as_secs_f64();
    Ok((map, fold(&stats.generations), seconds))
}

/// Measures every mode of one scene, accelerator and backend.
fn measure(
    pool: &rayon::ThreadPool,
    backend: Backend,
    scene: &RenderScene,
    accel: &AnyAccel,
    particles: u64,
    rounds: usize,
) -> anyhow::Result<Vec<Measured>> {
    let opts = |mode: Mode, count_work: bool| MapOptions {
        particles,
        mode,
        seed: SEED,
        count_work,
        ..MapOptions::default()
    };
    let mut out = Vec::new();
    for mode in Mode::ALL {
        let (m, counted, _) = map(pool, backend, scene, accel, &opts(mode, true))?;
        out.push(Measured {
            counted,
            rounds: Vec::new(),
            seconds: Vec::new(),
            map: m,
        });
    }
    let n = Mode::ALL.len();
    for round in 0..rounds {
        for k in 0..n {
            let i = (k + round) % n;
            let (_, groups, seconds) =
                map(pool, backend, scene, accel, &opts(Mode::ALL[i], false))?;
            out[i].rounds.push(groups);
            out[i].seconds.push(seconds);
        }
    }
    Ok(out)
}

pub(super) fn run(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    accels: &[AccelKind],
) -> anyhow::Result<()> {
    let particles: u64 = ctx.pick(20_000, 200_000);
    let rounds = ctx.pick(2, 5);
    let backends = backends(ctx);
    run_with(ctx, scenes, accels, &backends, particles, rounds)
}

/// Measures `scenes` with these accelerators and backends, `particles` per map, `rounds`
/// timed rounds.
pub(super) fn run_with(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    accels: &[AccelKind],
    backends: &[Backend],
    particles: u64,
    rounds: usize,
) -> anyhow::Result<()> {
    let pool = crate::frames::pool(1)?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress(
        (scenes.len() * accels.len() * backends.len()) as u64,
        "imaps",
    );
    for (name, scene) in scenes {
        for &kind in accels {
            let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(kind))
                .with_context(|| format!("building the {kind} accelerator for {name}"))?;
            for &b in backends {
                bar.set_message(format!("{name} {kind} {}", b.name()));
                let measured = measure(&pool, b, scene, &accel, particles, rounds)?;
                let single = Mode::ALL
                    .iter()
                    .position(|&m| m == Mode::Single)
                    .unwrap_or(0);
                for (mode, m) in Mode::ALL.iter().zip(&measured) {
                    let vs_single = relative_error(&m.map, &measured[single].map)?;
                    let map_s = median(&m.seconds);
                    for (i, c) in m.counted.iter().enumerate() {
                        let timed: Vec<&Group> = m.rounds.iter().filter_map(|r| r.get(i)).collect();
                        let per = |f: fn(&Group) -> f64| {
                            median(&timed.iter().map(|g| f(g)).collect::<Vec<_>>())
                        };
                        let rays = c.rays.max(1) as f64;
                        let cells: [&dyn Display; 19] = [
                            name,
                            &kind.name(),
                            &b.name(),
                            &b.lanes(),
                            &mode.name(),
                            &particles,
                            &c.generation,
                            &c.generations,
                            &c.rays,
                            &c.packets,
                            &format!("{:.3}", c.active_lanes as f64 / c.packets.max(1) as f64),
                            &format!("{:.4}", per(Group::mrays_per_s)),
                            &format!("{:.4}", per(Group::mrays_per_s_with_sort)),
                            &format!("{:.3}", c.inner_nodes as f64 / rays),
                            &format!("{:.3}", c.tri_tests as f64 / rays),
                            &format!("{:.4}", per(Group::sort_share)),
                            &format!("{map_s:.6}"),
                            &format!("{vs_single:.3e}"),
                            &timed.len(),
                        ];
                        csv.row(&cells)?;
                    }
                }
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_accel::Work;

    fn generation(k: u32, rays: u64) -> GenerationStats {
        GenerationStats {
            generation: k,
            rays,
            packets: rays / 4,
            active_lanes: rays,
            trace_ns: 1000 * rays,
            sort_ns: 10 * rays,
            shade_ns: 100 * rays,
            work: Work {
                inner_nodes: 20 * rays,
                tri_tests: 5 * rays,
            },
        }
    }

    #[test]
    fn generations_past_the_kept_ones_fold_into_one_row() {
        let gens: Vec<GenerationStats> = (0..12).map(|k| generation(k, 1000 >> k)).collect();
        let groups = fold(&gens);
        assert_eq!(groups.len(), KEPT_GENERATIONS + 1);
        let tail = groups[KEPT_GENERATIONS];
        assert_eq!((tail.generation, tail.generations), (8, 4));
        assert_eq!(tail.rays, (8..12).map(|k| 1000u64 >> k).sum::<u64>());
        assert_eq!(groups[3], Group::of(&gens[3]));
        // 1000 ns per ray: one million rays per second.
        assert!((groups[0].mrays_per_s() - 1.0).abs() < 1e-12);
        assert!((groups[0].sort_share() - 10.0 / 1110.0).abs() < 1e-12);
        assert_eq!(fold(&gens[..3]).len(), 3);
    }
}
