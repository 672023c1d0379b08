//! Experiment `table1`: the paper's Table 1 (section 4.2), anisotropic tabulated BDF
//! evaluations on every lane backend usable here, and two measurements behind it: how
//! often a packet's lanes fall in one table cell, and how many material passes packets of
//! each width need (section 4: one material at a time).
//!
//! Protocol: the BDF is the paper's 17 x 7 x 17 x 13 anisotropic table (theta_i, phi_i,
//! theta_o, phi_o), RGB, sampled from an anisotropic Ward model (brushed metal) on the
//! non-uniform grid of `coherent::bdf::tabulate`. The calls are those a renderer makes for
//! a brushed sphere seen by a pinhole camera and lit by a point light
//! (`coherent::bdf::workload::BdfInputs::sphere`): world frames and directions of
//! neighbouring pixels in 4 x 4 tiles, so packets are coherent as the renderer's are. One
//! call = frame transform, angles (approximate acos/atan2), four N-wide binary searches and
//! a 16-corner interpolation of three channels. One *sample* is `calls` calls; samples of
//! all backends are interleaved round-robin and each row reports the median.
//! `speedup` = scalar seconds / this row's seconds, for the same calls in the same run.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use coherent::bdf::workload::{BdfCalls, BdfInputs};
use coherent::bdf::{
    Analytic, AnisotropicBdf, Bdf, Frames, PAPER_ANISOTROPIC_SHAPE, Symmetry, tabulate_anisotropic,
};
use coherent::material::{Material, Optics, ShadeHits, SplitCount, shade};
use coherent::simd::scalar::Scalar;
use coherent::simd::{Backend, Kernel, Lanes, SimdI32, Vec3s};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::is_hand_written;
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{PaperTable, fmt_num, markdown_table};
use crate::timing::{median, speedup};

pub const EXPERIMENT: Experiment = Experiment {
    name: "table1",
    description: "anisotropic tabulated BDF evaluations per backend",
    paper: "Table 1 (section 4.2)",
    csv: &[
        "table1_bdf.csv",
        "table1_coherence.csv",
        "table1_splits.csv",
    ],
    plots: &["table1_speedup_vs_lanes", "table1_speedup"],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

pub(crate) const HEADER: &[&str] = &["calls", "backend", "lanes", "seconds", "speedup"];
const COHERENCE_HEADER: &[&str] = &[
    "lanes",
    "packets",
    "one_cell_fraction",
    "splat_cells_max",
    "splat_fraction",
];
const SPLITS_HEADER: &[&str] = &["backend", "lanes", "packets", "passes", "passes_per_packet"];

/// The paper's Table 1: Intel Centrino, 1.8 GHz mobile Pentium, 512 MB.
pub(crate) const PAPER: PaperTable = PaperTable {
    caption: "Table 1: anisotropic BDF (17 x 7 x 17 x 13) evaluations. Paper: Intel Centrino \
              notebook, 1.8 GHz mobile Pentium, non-SSE vs SSE; ours: the scalar and sse \
              backends on the machine of `machine.json`.",
    key: "calls",
    columns: &["non-SSE s", "SSE s", "speedup"],
    rows: &[
        ("100000", &[0.137, 0.040, 3.43]),
        ("200000", &[0.248, 0.078, 3.17]),
        ("400000", &[0.495, 0.156, 3.17]),
    ],
};

/// The project's targets for the speedup over scalar: `(lanes, target)`.
const TARGETS: &[(usize, f64)] = &[(4, 3.2), (8, 6.0), (16, 10.0)];

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let backends = Backend::available();
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            ctx.note(format!("table1: backend {b} skipped: {why}"));
        }
    }
    let bdf = tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )?;
    let inputs = BdfInputs::sphere(ctx.pick(256, 512));
    let calls: &[usize] = ctx.pick(&[10_000, 20_000, 40_000], &[100_000, 200_000, 400_000]);
    let samples = ctx.pick(5, 15);

    let bar = ctx.progress((calls.len() * samples) as u64, "table1");
    let mut seconds: BTreeMap<(usize, Backend), Vec<f64>> = BTreeMap::new();
    for &n in calls {
        let sample = |backend: Backend| -> anyhow::Result<f64> {
            let start = Instant::now();
            std::hint::black_box(backend.run(BdfCalls {
                bdf: &bdf,
                inputs: &inputs,
                calls: n,
            })?);
            Ok(start.elapsed().as_secs_f64())
        };
        for &backend in &backends {
            sample(backend)?; // warm-up
        }
        for _ in 0..samples {
            for &backend in &backends {
                let s = sample(backend)?;
                seconds.entry((n, backend)).or_default().push(s);
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    let mut csv = ctx.csv("table1_bdf.csv", HEADER)?;
    for &n in calls {
        let scalar = median(&seconds[&(n, Backend::Scalar)]);
        for &backend in &backends {
            let s = median(&seconds[&(n, backend)]);
            csv.row(&[
                &n,
                &backend.name(),
                &backend.lanes(),
                &format!("{s:.6e}"),
                &format!("{:.3}", speedup(scalar, s)),
            ])?;
        }
    }
    csv.finish()?;

    coherence(ctx, &bdf, &inputs)?;
    splits(ctx, &backends, &inputs)?;
    Ok(())
}

/// The packet of vectors `k` starting at call `i`.
#[inline(always)]
fn load3<L: Lanes>(l: L, inputs: &BdfInputs, k: usize, i: usize) -> Vec3s<L> {
    let v = &inputs.v[k];
    Vec3s::new(l.load(&v[0][i..]), l.load(&v[1][i..]), l.load(&v[2][i..]))
}

/// How often the lanes of a packet of 4, 8 and 16 calls all fall in one table cell (then
/// the interpolation reads its 16 corners once for the whole packet).
fn coherence(ctx: &Ctx, bdf: &AnisotropicBdf, inputs: &BdfInputs) -> anyhow::Result<()> {
    let l = Scalar;
    let cells: Vec<[i32; 4]> = (0..inputs.len())
        .map(|i| {
            let frames = Frames {
                tangent: load3(l, inputs, 0, i),
                bitangent: load3(l, inputs, 1, i),
                normal: load3(l, inputs, 2, i),
            };
            let wi = frames.to_local(load3(l, inputs, 3, i));
            let wo = frames.to_local(load3(l, inputs, 4, i));
            let c = bdf.grid().locate(l, bdf.coords(l, &wi, &wo));
            core::array::from_fn(|k| c[k].index.lane(0))
        })
        .collect();
    let mut csv = ctx.csv("table1_coherence.csv", COHERENCE_HEADER)?;
    for n in [4usize, 8, 16] {
        let packets = cells.len() / n;
        let distinct = |c: &[[i32; 4]]| {
            let mut d = c.to_vec();
            d.sort();
            d.dedup();
            d.len()
        };
        // `Grid::interpolate` splats the nodes of packets in at most `n / 4 + 1` cells.
        let cap = n / 4 + 1;
        let (mut one, mut few) = (0, 0);
        for c in cells.chunks_exact(n) {
            let d = distinct(c);
            one += (d == 1) as usize;
            few += (d <= cap) as usize;
        }
        let share = |k: usize| format!("{:.3}", k as f64 / packets.max(1) as f64);
        csv.row(&[&n, &packets, &share(one), &cap, &share(few)])?;
    }
    csv.finish()?;
    Ok(())
}

/// Shades the sphere image with three materials in bands of latitude on every backend and
/// counts the material passes (section 4: one material at a time).
#[derive(Clone, Copy)]
struct Splits<'a> {
    materials: &'a [Material],
    inputs: &'a BdfInputs,
}

/// The material of a hit on the unit sphere: bands of latitude 0.3 high.
fn band(normal_y: f32) -> i32 {
    (((normal_y + 1.0) / 0.3) as i32).rem_euclid(3)
}

impl Kernel for Splits<'_> {
    type Output = SplitCount;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> SplitCount {
        let mut count = SplitCount::default();
        let inputs = self.inputs;
        for i in (0..inputs.len()).step_by(L::N) {
            let frames = Frames {
                tangent: load3(l, inputs, 0, i),
                bitangent: load3(l, inputs, 1, i),
                normal: load3(l, inputs, 2, i),
            };
            let hits = ShadeHits {
                active: l.splat_mask(true),
                material: l.from_fn_i32(|k| band(inputs.v[2][1][i + k])),
                frames,
                wo: load3(l, inputs, 4, i),
                s: l.splat(0.0),
                t: l.splat(0.0),
                lod: l.splat(0.0),
            };
            let wi = load3(l, inputs, 3, i);
            // Valid ids by construction: an error here is a bug worth a loud stop.
            std::hint::black_box(shade(l, self.materials, &hits, &wi, &mut count).expect("ids"));
        }
        count
    }
}

fn splits(ctx: &Ctx, backends: &[Backend], inputs: &BdfInputs) -> anyhow::Result<()> {
    let brushed = Arc::new(Bdf::from(tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )?));
    let mut metal = Material::phong("brushed metal", [0.0; 3], [0.0; 3], 0.0);
    metal.bdf = Some(brushed);
    let plastic = Material::phong("plastic", [0.6, 0.1, 0.1], [0.3; 3], 30.0);
    let mut glass = Material::phong("glass", [0.0; 3], [0.05; 3], 200.0);
    glass.optics = Optics {
        reflectance: [1.0; 3],
        transmittance: [0.9; 3],
        ior: 1.5,
        fresnel: true,
        dispersion: None,
    };
    let materials = [metal, plastic, glass];
    let mut csv = ctx.csv("table1_splits.csv", SPLITS_HEADER)?;
    for &b in backends {
        let c = b.run(Splits {
            materials: &materials,
            inputs,
        })?;
        csv.row(&[
            &b.name(),
            &b.lanes(),
            &c.packets,
            &c.passes,
            &format!("{:.3}", c.passes_per_packet()),
        ])?;
    }
    csv.finish()?;
    Ok(())
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv("table1_bdf.csv", HEADER)? else {
        return Ok(());
    };
    let backends = t.distinct("backend")?;
    // Speedup against lanes for the hand-written or run-time dispatched backend of each
    // width, one line per call count, with the paper's SSE figures and the ideal.
    let mut series = Vec::new();
    for c in t.distinct("calls")? {
        let mut pts = Vec::new();
        for r in t.rows_where("calls", &c)? {
            // The hand-written backends only (the bar chart shows every backend).
            if is_hand_written(t.get(r, "backend")?) {
                pts.push((t.f64(r, "lanes")?, t.f64(r, "speedup")?));
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(Series::new(format!("{c} calls"), pts));
    }
    let paper: Vec<(f64, f64)> = PAPER.rows.iter().map(|(_, v)| (4.0, v[2])).collect();
    series.push(Series::reference("paper SSE (3.17-3.43x)", paper));
    series.push(Series::reference(
        "ideal (= lanes)",
        vec![(1.0, 1.0), (4.0, 4.0), (8.0, 8.0), (16.0, 16.0)],
    ));
    ctx.line_chart(
        "table1_speedup_vs_lanes",
        &LineChart {
            title: "Table 1: BDF evaluation speedup vs lanes (scalar, sse, avx2, avx512)".into(),
            x_label: "lanes".into(),
            y_label: "speedup over scalar".into(),
            series,
            log2_x: true,
            log_y: false,
        },
    )?;

    let calls = t.distinct("calls")?;
    let mut bars = Vec::new();
    for c in &calls {
        let mut v = Vec::new();
        for b in &backends {
            let r = t
                .rows_where("calls", c)?
                .into_iter()
                .find(|&r| t.get(r, "backend").is_ok_and(|x| x == b));
            v.push(match r {
                Some(r) => t.f64(r, "speedup")?,
                None => 0.0,
            });
        }
        bars.push((format!("{c} calls"), v));
    }
    ctx.bar_chart(
        "table1_speedup",
        &BarChart {
            title: "Table 1: BDF evaluation speedup over scalar (paper SSE: 3.17-3.43x)".into(),
            y_label: "speedup over scalar".into(),
            categories: backends,
            series: bars,
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv("table1_bdf.csv", HEADER)? else {
        return Ok(None);
    };
    let row_of = |calls: &str, backend: &str| -> anyhow::Result<Option<usize>> {
        Ok(t.rows_where("calls", calls)?
            .into_iter()
            .find(|&r| t.get(r, "backend").is_ok_and(|x| x == backend)))
    };
    let mut md = String::new();
    md.push_str(
        "The paper's 17 x 7 x 17 x 13 anisotropic table, RGB, sampled from an anisotropic Ward \
         model on a non-uniform grid; each call is what a renderer does per shaded pixel of a \
         brushed sphere lit by a point light: frame transform, angles with the approximate \
         acos/atan2, four N-wide binary searches, 16-corner interpolation of 3 channels. Calls \
         come from neighbouring pixels (4 x 4 tiles), so packets are coherent. Median of \
         interleaved samples; `speedup` = scalar seconds / row seconds in the same run. \
         `--quick` uses 10x fewer calls.\n\n",
    );
    let mut ours = Vec::new();
    for c in t.distinct("calls")? {
        let get = |b: &str, col: &str| -> anyhow::Result<Option<f64>> {
            Ok(match row_of(&c, b)? {
                Some(r) => Some(t.f64(r, col)?),
                None => None,
            })
        };
        ours.push((
            c.clone(),
            vec![
                get("scalar", "seconds")?,
                get("sse", "seconds")?,
                get("sse", "speedup")?,
            ],
        ));
    }
    md.push_str(&PAPER.beside(&ours));

    md.push_str("\nEvery backend: seconds (speedup over scalar).\n\n");
    let backends = t.distinct("backend")?;
    let mut header = vec!["calls".to_owned()];
    header.extend(backends.iter().cloned());
    let mut rows = Vec::new();
    for c in t.distinct("calls")? {
        let mut row = vec![c.clone()];
        for b in &backends {
            row.push(match row_of(&c, b)? {
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
    if let Some(m) = ctx.read_csv("manycore/table1_bdf.csv", HEADER)? {
        md.push_str(&format!(
            "\nThe same run on {}, lent for a session (`manycore/`, with its own \
             `machine.json`); speedup over scalar there:\n\n",
            crate::manycore::manycore_machine(ctx, "table1")
        ));
        md.push_str(&m.pivot("calls", "backend", "speedup")?);
    }

    // The project's targets, against the largest call count measured.
    if let Some(last) = t.distinct("calls")?.last() {
        md.push_str(&format!(
            "\nThe project's targets (speedup over scalar at {last} calls; the paper's SSE gave 3.2x):\n\n"
        ));
        let mut rows = Vec::new();
        for &(lanes, target) in TARGETS {
            for b in &backends {
                if let Some(r) = row_of(last, b)?
                    && t.f64(r, "lanes")? as usize == lanes
                {
                    let s = t.f64(r, "speedup")?;
                    let verdict = if s >= target { "met" } else { "not met" };
                    rows.push(vec![
                        b.clone(),
                        lanes.to_string(),
                        format!(">= {}x", fmt_num(target)),
                        format!("{}x", fmt_num(s)),
                        verdict.to_owned(),
                    ]);
                }
            }
        }
        md.push_str(&markdown_table(
            &["backend", "lanes", "target", "measured", ""],
            &rows,
        ));
    }
    if let Some(p) = ctx.plot_markdown("table1_speedup_vs_lanes", "BDF speedup vs lanes") {
        md.push_str(&p);
    }
    if let Some(p) = ctx.plot_markdown("table1_speedup", "BDF speedup per backend") {
        md.push_str(&p);
    }
    if let Some(c) = ctx.read_csv("table1_coherence.csv", COHERENCE_HEADER)? {
        md.push_str(
            "\nCoherence of the calls (`table1_coherence.csv`): the share of packets whose \
             lanes all fall in one table cell, and in at most `splat_cells_max` cells. Those \
             read each cell's 16 x 3 values once and splat (and select) them; the others \
             gather them lane by lane, which costs at least as much per lane as the scalar \
             loads do and bounds the speedup.\n\n",
        );
        md.push_str(&c.to_markdown());
    }
    if let Some(s) = ctx.read_csv("table1_splits.csv", SPLITS_HEADER)? {
        md.push_str(
            "\nMaterial passes (`table1_splits.csv`, section 4: one material at a time): the \
             same image shaded with three materials in bands of latitude (tabulated BDF, \
             Phong, Fresnel glass); a packet makes one pass per distinct material among its \
             lanes.\n\n",
        );
        md.push_str(&s.to_markdown());
    }
    Ok(Some(md))
}
