//! Experiment `table2`: the paper's Table 2 (section 5), lighting per light kind on every
//! lane backend usable here, with and without shadow packets, and two comparisons beside
//! it: the goniodiagram's uniform resampled table against the paper's non-uniform search,
//! and the spot's exact falloff cosine and the environment light.
//!
//! Protocol: shading points are a `side` x `side` grid on a gently curved patch of ground
//! (normals tilted by the slope), visited in tiles of 4 x 4 (so packets of 4, 8 and 16
//! lanes are neighbours, as a renderer's are), two uniform numbers per point from a fixed
//! hash. One *call* evaluates one light for one packet: every sample
//! (`Light::samples`: 1 for point lights, 7 linear, 21 circular and rectangular, 16
//! environment), `li * cos` summed per lane so that nothing is optimised away. With
//! `shadows` 1, each sample's shadow packet is also traced through the two-level BSP
//! (`Accel::occluded`) of a scene of the ground and a few spheres between it and the
//! lights. A timed sample sweeps the points `ceil(21 / samples)` times (about 21 light
//! samples per point for every kind, so that point lights too are timed over
//! milliseconds) and reports seconds per sweep. Samples of all backends are interleaved round-robin and each row reports the
//! median; `speedup` = the scalar row's seconds (one shading point at a time) / this
//! row's, same light, same `shadows`, same run.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use coherent::accel::{Accel, Mesh, Scene, shapes};
use coherent::bsp::{Bsp, BspParams};
use coherent::light::photometry::{PhotometricTable, PhotometricType};
use coherent::light::{
    Circular, Direct, Environment, GonioLookup, Goniodiagram, Light, Linear, Omni, Parallel,
    Rectangular, Spot, SpotFalloff, shadow_rays,
};
use coherent::simd::{Backend, Kernel, Lanes, Rgbs, SimdF32, SimdMask, Vec3s};
use glam::Vec3;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::is_hand_written;
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{PaperTable, fmt_num, markdown_table};
use crate::targets::{Check, condensed};
use crate::timing::{median, speedup};

pub const EXPERIMENT: Experiment = Experiment {
    name: "table2",
    description: "light source evaluation per light type and backend",
    paper: "Table 2 (section 5)",
    csv: &["table2_lights.csv", "table2_variants.csv"],
    plots: &["table2_speedup", "table2_speedup_vs_lanes"],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

pub(crate) const FILE: &str = "table2_lights.csv";
pub(crate) const HEADER: &[&str] = &["light", "backend", "lanes", "shadows", "seconds", "speedup"];
/// The variants: the same columns, `light` naming the variant, plus the variant's error.
const VARIANTS_FILE: &str = "table2_variants.csv";
const VARIANTS_HEADER: &[&str] = &[
    "light",
    "backend",
    "lanes",
    "shadows",
    "seconds",
    "speedup",
    "max_rel_error",
];

/// The paper's Table 2: Pentium 4 2.8 GHz, 1 GB.
pub(crate) const PAPER: PaperTable = PaperTable {
    caption: "Table 2: lighting per light kind. Paper: Pentium 4 2.8 GHz, non-SSE vs SSE, \
              seconds of its own workload; ours: scalar vs sse, lighting only (`shadows` 0), \
              on the machine of `machine.json`. Seconds are not comparable (different \
              workloads and machines); the speedups are.",
    key: "light",
    columns: &["non-SSE s", "SSE s", "speedup"],
    rows: &[
        ("omni", &[1.137, 0.157, 7.24]),
        ("spot", &[0.816, 0.211, 3.87]),
        ("parallel", &[0.444, 0.103, 4.31]),
        ("direct", &[0.936, 0.150, 6.24]),
        ("linear", &[6.696, 1.149, 5.83]),
        ("circular", &[27.936, 4.828, 5.79]),
        ("rectangular", &[145.252, 24.375, 5.96]),
        ("goniodiagram", &[2.573, 0.588, 4.38]),
    ],
};

/// Targets for the speedup over scalar, lighting only: `(lanes, target)`.
const TARGETS: &[(usize, f64)] = &[(4, 3.5), (8, 6.0), (16, 10.0)];

/// Height of the lights above the ground.
const H: f32 = 3.0;

/// The shading points, structure of arrays, in packet order (tiles of neighbours).
pub struct Points {
    pub(crate) p: [Vec<f32>; 3],
    pub(crate) n: [Vec<f32>; 3],
    pub(crate) u: [Vec<f32>; 2],
}

impl Points {
    pub(crate) fn len(&self) -> usize {
        self.p[0].len()
    }
}

/// The ground's height and its gradient at `(x, y)`.
fn ground(x: f32, y: f32) -> (f32, Vec3) {
    let z = 0.1 * (0.7 * x).sin() * (0.5 * y).cos();
    let dx = 0.07 * (0.7 * x).cos() * (0.5 * y).cos();
    let dy = -0.05 * (0.7 * x).sin() * (0.5 * y).sin();
    (z, Vec3::new(-dx, -dy, 1.0).normalize())
}

/// A hash of `i` to `[0, 1)`.
fn hash01(i: u64) -> f32 {
    let mut x = i.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    x ^= x >> 29;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 32;
    (x >> 40) as f32 / (1u64 << 24) as f32
}

/// `side * side` points on [-2, 2]^2 in tiles of 4 x 4 (16 consecutive points are a
/// tile, so packets of 4, 8 and 16 are neighbours).
pub fn points(side: usize) -> Points {
    let side = side.div_ceil(4) * 4;
    let mut pts = Points {
        p: [vec![], vec![], vec![]],
        n: [vec![], vec![], vec![]],
        u: [vec![], vec![]],
    };
    let step = 4.0 / side as f32;
    for ty in (0..side).step_by(4) {
        for tx in (0..side).step_by(4) {
            for j in 0..4 {
                for i in 0..4 {
                    let (x, y) = (-2.0 + (tx + i) as f32 * step, -2.0 + (ty + j) as f32 * step);
                    let (z, n) = ground(x, y);
                    for (k, v) in [x, y, z].into_iter().enumerate() {
                        pts.p[k].push(v);
                    }
                    for (k, v) in n.to_array().into_iter().enumerate() {
                        pts.n[k].push(v);
                    }
                    let id = (pts.u[0].len() as u64) * 2;
                    pts.u[0].push(hash01(id));
                    pts.u[1].push(hash01(id + 1));
                }
            }
        }
    }
    pts
}

/// The ground (a grid following [`ground`]) and six spheres between it and the lights.
fn shadow_scene() -> Scene {
    let n = 32;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (
                -2.5 + 5.0 * i as f32 / n as f32,
                -2.5 + 5.0 * j as f32 / n as f32,
            );
            positions.push(Vec3::new(x, y, ground(x, y).0));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            let b = a + 1;
            let c = a + (n + 1) as u32;
            indices.push([a, b, c + 1]);
            indices.push([a, c + 1, c]);
        }
    }
    let mut meshes = vec![Mesh::new("ground", positions, indices)];
    for k in 0..6 {
        let a = k as f32 * 1.047;
        let c = Vec3::new(1.2 * a.cos(), 1.2 * a.sin(), 1.2 + 0.2 * k as f32);
        meshes.push(shapes::icosphere("ball", c, 0.3, 2));
    }
    let mut scene = Scene::new(vec![], vec![]);
    for m in meshes {
        let id = scene.add_mesh(m);
        scene.add_instance(id, glam::Affine3A::IDENTITY);
    }
    scene
}

/// A goniodiagram like a real downlight's file: 25 C-planes over a quadrant and 37
/// gammas at 2.5 degrees below 40 and 5 degrees above, a smooth beam.
fn gonio_table() -> PhotometricTable {
    let planes: Vec<f32> = (0..=24).map(|i| i as f32 * 90.0 / 24.0).collect();
    let mut angles: Vec<f32> = (0..16).map(|i| i as f32 * 2.5).collect();
    angles.extend(
        (0..=20)
            .map(|i| 40.0 + i as f32 * 5.0)
            .filter(|&a| a <= 140.0),
    );
    let mut candela = Vec::new();
    for &c in &planes {
        for &g in &angles {
            let beam = (-(g / 35.0f32).powi(2)).exp();
            candela.push(1000.0 * beam * (1.0 + 0.2 * (2.0 * c.to_radians()).cos()) + 5.0);
        }
    }
    PhotometricTable {
        kind: PhotometricType::C,
        planes,
        angles,
        candela,
    }
}

/// The lights of the table, by name: all above the ground, facing it (the `spectral`
/// experiment times its colour forms on them too).
pub(crate) fn lights() -> anyhow::Result<Vec<(&'static str, Light)>> {
    let top = Vec3::new(0.2, 0.1, H);
    let gonio = |lookup| {
        Goniodiagram::new(
            top,
            Vec3::Z,
            Vec3::X,
            &gonio_table(),
            [1.0; 3],
            lookup,
            Path::new("table2 downlight"),
        )
    };
    let mut sky = Vec::new();
    let (w, h) = (256, 128);
    for j in 0..h {
        for i in 0..w {
            let sun = if (40..44).contains(&i) && (20..23).contains(&j) {
                500.0
            } else {
                0.0
            };
            let b = 0.3 + 0.5 * (j as f32 / h as f32);
            sky.push([b + sun, b + sun, 1.2 * b + sun]);
        }
    }
    Ok(vec![
        ("omni", Light::Omni(Omni::new(top, [10.0; 3])?)),
        (
            "spot",
            Light::Spot(Spot::new(
                top,
                -Vec3::Z,
                [10.0; 3],
                0.5,
                0.8,
                SpotFalloff::Approx,
            )?),
        ),
        (
            "parallel",
            Light::Parallel(Parallel::new(Vec3::new(0.2, 0.1, -1.0), [1.0; 3])?),
        ),
        (
            "direct",
            Light::Direct(Direct::new(top, -Vec3::Z, [10.0; 3])?),
        ),
        (
            "linear",
            Light::Linear(Linear::new(
                Vec3::new(-1.0, 0.0, H),
                Vec3::new(1.0, 0.5, H),
                [10.0; 3],
                coherent::light::linear::DEFAULT_POINTS,
                1,
                true,
            )?),
        ),
        (
            "circular",
            Light::Circular(Circular::new(
                top,
                -Vec3::Z,
                0.7,
                [5.0; 3],
                coherent::light::circular::DEFAULT_GRID,
                2,
                true,
            )?),
        ),
        (
            "rectangular",
            Light::Rectangular(Rectangular::new(
                Vec3::new(-0.6, 0.4, H),
                Vec3::new(1.2, 0.0, 0.0),
                Vec3::new(0.0, -0.8, 0.0),
                [5.0; 3],
                coherent::light::rectangular::DEFAULT_GRID,
                3,
                true,
            )?),
        ),
        (
            "goniodiagram",
            Light::Goniodiagram(gonio(GonioLookup::Search)?),
        ),
        (
            "goniodiagram_uniform",
            Light::Goniodiagram(gonio(GonioLookup::Uniform)?),
        ),
        (
            "spot_exact",
            Light::Spot(Spot::new(
                top,
                -Vec3::Z,
                [10.0; 3],
                0.5,
                0.8,
                SpotFalloff::Exact,
            )?),
        ),
        (
            "environment",
            Light::Environment(Environment::new(
                "table2 sky",
                w,
                h,
                &sky,
                1.0,
                Vec3::Z,
                Vec3::X,
                coherent::light::environment::DEFAULT_SAMPLES,
            )?),
        ),
    ])
}

/// Lights every point with `light` (all its samples), tracing the shadow packets through
/// `shadows` when given; returns the summed reflected radiance of a white diffuse surface
/// (so the work cannot be dropped).
#[derive(Clone, Copy)]
struct Lighting<'a> {
    light: &'a Light,
    points: &'a Points,
    shadows: Option<&'a Bsp>,
    /// Sweeps over the points.
    passes: u32,
}

impl Kernel for Lighting<'_> {
    type Output = f32;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f32 {
        let pts = self.points;
        let mut acc = Rgbs::zero(l);
        let samples = self.light.samples();
        for _ in 0..self.passes {
            let mut i = 0;
            while i + L::N <= pts.len() {
                let (pp, pn) = (&pts.p, &pts.n);
                let p = Vec3s::new(
                    l.load(&pp[0][i..]),
                    l.load(&pp[1][i..]),
                    l.load(&pp[2][i..]),
                );
                let n = Vec3s::new(
                    l.load(&pn[0][i..]),
                    l.load(&pn[1][i..]),
                    l.load(&pn[2][i..]),
                );
                let (p, n) = (std::hint::black_box(p), std::hint::black_box(n));
                let u = [l.load(&pts.u[0][i..]), l.load(&pts.u[1][i..])];
                let active = l.splat_mask(true);
                for k in 0..samples {
                    let s = self.light.sample(l, &p, &n, active, k, u);
                    let mut lit = s.active;
                    if let Some(bsp) = self.shadows
                        && lit.any()
                    {
                        let rays = shadow_rays(l, &p, &n, &s);
                        lit = lit.and_not(bsp.occluded(l, &rays, lit));
                    }
                    let cos = n.dot(s.wi);
                    let w = lit.select(cos, l.splat(0.0));
                    acc = s.li.mul_add(w, acc);
                }
                i += L::N;
            }
        }
        let mut sum = 0.0;
        for k in 0..L::N {
            sum += acc.r.lane(k) + acc.g.lane(k) + acc.b.lane(k);
        }
        sum
    }
}

/// Lighting with the scalar backend (for the goniodiagram variants' error).
fn max_rel_gonio_error(g: &Goniodiagram) -> f64 {
    let (err, max) = g.uniform_error_at_nodes();
    err as f64 / max.max(f32::MIN_POSITIVE) as f64
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let backends = Backend::available();
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            ctx.note(format!("table2: backend {b} skipped: {why}"));
        }
    }
    let pts = points(ctx.pick(128, 256));
    let scene = shadow_scene();
    let bsp = Bsp::build(&scene, &BspParams::default())?;
    let lights = lights()?;
    let samples = ctx.pick(3, 9);

    let bar = ctx.progress((lights.len() * 2 * samples) as u64, "table2");
    let mut seconds: BTreeMap<(usize, u32, Backend), Vec<f64>> = BTreeMap::new();
    for (li, (_, light)) in lights.iter().enumerate() {
        for shadows in [0u32, 1] {
            // Each timed sample sweeps the points until about 21 light samples per point
            // were evaluated (so that point lights are timed over several milliseconds too);
            // the reported seconds are per sweep.
            let passes = 21u32.div_ceil(light.samples());
            let work = Lighting {
                light,
                points: &pts,
                shadows: (shadows == 1).then_some(&bsp),
                passes,
            };
            let sample = |backend: Backend| -> anyhow::Result<f64> {
                let start = Instant::now();
                std::hint::black_box(backend.run(work)?);
                Ok(start.elapsed().as_secs_f64() / passes as f64)
            };
            for &backend in &backends {
                sample(backend)?; // warm-up
            }
            for _ in 0..samples {
                for &backend in &backends {
                    let s = sample(backend)?;
                    seconds.entry((li, shadows, backend)).or_default().push(s);
                }
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();

    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut variants = ctx.csv(VARIANTS_FILE, VARIANTS_HEADER)?;
    for (li, (name, light)) in lights.iter().enumerate() {
        let error = match (name, light) {
            (&"goniodiagram_uniform", Light::Goniodiagram(g)) => {
                format!("{:.3e}", max_rel_gonio_error(g))
            }
            (&"goniodiagram", _) | (&"spot", _) => "0".to_owned(),
            _ => String::new(),
        };
        for shadows in [0u32, 1] {
            let scalar = median(&seconds[&(li, shadows, Backend::Scalar)]);
            for &backend in &backends {
                let s = median(&seconds[&(li, shadows, backend)]);
                let cells: [&dyn std::fmt::Display; 6] = [
                    name,
                    &backend.name(),
                    &backend.lanes(),
                    &shadows,
                    &format!("{s:.6e}"),
                    &format!("{:.3}", speedup(scalar, s)),
                ];
                if PAPER.rows.iter().any(|(k, _)| k == name) {
                    csv.row(&cells)?;
                }
                if !PAPER.rows.iter().any(|(k, _)| k == name)
                    || *name == "goniodiagram"
                    || *name == "spot"
                {
                    let mut row: Vec<&dyn std::fmt::Display> = cells.to_vec();
                    let err: &dyn std::fmt::Display = &error;
                    row.push(err);
                    variants.row(&row)?;
                }
            }
        }
    }
    csv.finish()?;
    variants.finish()?;
    Ok(())
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(());
    };
    let backends = t.distinct("backend")?;
    let lights = t.distinct("light")?;
    let find = |light: &str, backend: &str, shadows: &str| -> anyhow::Result<Option<f64>> {
        for r in t.rows_where("light", light)? {
            if t.get(r, "backend")? == backend && t.get(r, "shadows")? == shadows {
                return Ok(Some(t.f64(r, "speedup")?));
            }
        }
        Ok(None)
    };
    let mut bars = Vec::new();
    for b in &backends {
        let mut v = Vec::new();
        for light in &lights {
            v.push(find(light, b, "0")?.unwrap_or(f64::NAN));
        }
        bars.push((b.clone(), v));
    }
    bars.push((
        "paper SSE".to_owned(),
        lights
            .iter()
            .map(|l| {
                PAPER
                    .rows
                    .iter()
                    .find(|(k, _)| k == l)
                    .map_or(f64::NAN, |(_, v)| v[2])
            })
            .collect(),
    ));
    ctx.bar_chart(
        "table2_speedup",
        &BarChart {
            title: "Table 2: lighting speedup over scalar per light (no shadow rays)".into(),
            y_label: "speedup over scalar".into(),
            categories: lights.clone(),
            series: bars,
        },
    )?;
    let mut series = Vec::new();
    for light in &lights {
        for shadows in ["0", "1"] {
            let mut pts = Vec::new();
            for b in Backend::hand_written() {
                if let Some(s) = find(light, b.name(), shadows)? {
                    pts.push((b.lanes() as f64, s));
                }
            }
            if shadows == "0" {
                series.push(Series::new(light.clone(), pts));
            }
        }
    }
    series.push(Series::reference(
        "ideal (= lanes)",
        vec![(1.0, 1.0), (4.0, 4.0), (8.0, 8.0), (16.0, 16.0)],
    ));
    ctx.line_chart(
        "table2_speedup_vs_lanes",
        &LineChart {
            title: "Table 2: lighting speedup vs lanes (scalar, sse, avx2, avx512; no shadows)"
                .into(),
            x_label: "lanes".into(),
            y_label: "speedup over scalar".into(),
            series,
            log2_x: true,
            log_y: false,
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let row_of = |light: &str, backend: &str, shadows: &str| -> anyhow::Result<Option<usize>> {
        for r in t.rows_where("light", light)? {
            if t.get(r, "backend")? == backend && t.get(r, "shadows")? == shadows {
                return Ok(Some(r));
            }
        }
        Ok(None)
    };
    let mut md = String::new();
    md.push_str(
        "Shading points on a gently curved patch of ground, in packets of neighbours (4 x 4 \
         tiles); one light at a time, every sample of it per point (1 for point lights, 7 \
         linear, 21 circular and rectangular, 16 environment), `li cos` accumulated. \
         `shadows` 1 also traces each sample's shadow packet through the two-level BSP of \
         the ground and six spheres. Median of interleaved samples; `speedup` = scalar \
         seconds / row seconds, same light and `shadows`, same run. The goniodiagram is a \
         made-up downlight table of 25 C-planes (quadrant symmetry) x 37 non-uniform \
         gammas. Seconds are per sweep over the points (each timed sample makes \
         `ceil(21 / samples)` sweeps). `--quick` uses a 128 x 128 grid instead of 256 x \
         256.\n\n",
    );
    let mut ours = Vec::new();
    for light in t.distinct("light")? {
        let get = |b: &str, col: &str| -> anyhow::Result<Option<f64>> {
            Ok(match row_of(&light, b, "0")? {
                Some(r) => Some(t.f64(r, col)?),
                None => None,
            })
        };
        ours.push((
            light.clone(),
            vec![
                get("scalar", "seconds")?,
                get("sse", "seconds")?,
                get("sse", "speedup")?,
            ],
        ));
    }
    md.push_str(&PAPER.beside(&ours));

    let backends = t.distinct("backend")?;
    for shadows in ["0", "1"] {
        md.push_str(if shadows == "0" {
            "\nEvery backend, lighting only: seconds (speedup over scalar).\n\n"
        } else {
            "\nEvery backend, with shadow packets through the BSP: seconds (speedup over scalar).\n\n"
        });
        let mut header = vec!["light".to_owned()];
        header.extend(backends.iter().cloned());
        let mut rows = Vec::new();
        for light in t.distinct("light")? {
            let mut row = vec![light.clone()];
            for b in &backends {
                row.push(match row_of(&light, b, shadows)? {
                    Some(r) => format!(
                        "{} s ({}x)",
                        fmt_num(t.f64(r, "seconds")?),
                        fmt_num(t.f64(r, "speedup")?)
                    ),
                    None => "—".into(),
                });
            }
            rows.push(row);
        }
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        md.push_str(&markdown_table(&header, &rows));
    }

    md.push_str(
        "\nTargets (lighting only: >= 3.5x with 4 lanes, >= 6x with 8, >= 10x with 16), one \
         row per light over the hand-written backends (sse, avx2, avx512): how many are met, and \
         the figure closest to its target (the nearest miss, or the narrowest pass when all \
         are met):\n\n",
    );
    let mut checks = Vec::new();
    for light in t.distinct("light")? {
        for &(lanes, target) in TARGETS {
            for b in &backends {
                if let Some(r) = row_of(&light, b, "0")?
                    && t.f64(r, "lanes")? as usize == lanes
                    && is_hand_written(b)
                {
                    let s = t.f64(r, "speedup")?;
                    checks.push(Check::at_least(
                        &light,
                        "speedup over scalar, lighting only",
                        format!("{b} {}x (>= {}x)", fmt_num(s), fmt_num(target)),
                        s,
                        target,
                    ));
                }
            }
        }
    }
    md.push_str(&condensed("light", &checks));
    if let Some(p) = ctx.plot_markdown("table2_speedup", "lighting speedup per light and backend") {
        md.push_str(&p);
    }
    if let Some(p) = ctx.plot_markdown("table2_speedup_vs_lanes", "lighting speedup vs lanes") {
        md.push_str(&p);
    }
    if let Some(v) = ctx.read_csv(VARIANTS_FILE, VARIANTS_HEADER)? {
        md.push_str(
            "\nVariants (`table2_variants.csv`): the goniodiagram resampled once onto a uniform \
             0.5-degree grid (`goniodiagram_uniform`: O(1) cell lookup; `max_rel_error` = its \
             largest error at the table's own nodes over the largest candela) beside the \
             paper's non-uniform search; the spot with the exact falloff cosine \
             (`spot_exact`) beside the paper's `1 - x^2/2`; the environment light (a 256 x 128 \
             sky with a sun, 16 importance samples per point).\n\n",
        );
        md.push_str(&v.to_markdown());
    }
    Ok(Some(md))
}
