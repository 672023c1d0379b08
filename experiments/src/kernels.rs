//! Experiment `kernels`: the approximations of sections 4.2, 5 and 6.1 (exp, log, pow, acos,
//! atan2), trilinear texture lookups (section 4.1) and the tone-mapping operators (section
//! 6.1, `tonemap_*`) timed on every lane backend usable here, and the approximations'
//! measured error against `std` (for tone mapping: the display value against the operator
//! computed with `std` `powf`).
//!
//! Protocol: each kernel maps a 16,384-value input (coherent, like neighbouring pixels:
//! see `coherent::kernels::approx_inputs`) through the approximation; one *sample* is
//! `passes` such maps. Samples of all backends are interleaved round-robin (so a load spike
//! hits every backend alike) and each row reports the median sample, scaled to seconds per
//! 2^20 evaluations. `speedup` = scalar seconds / this row's seconds, within this run.

use std::collections::BTreeMap;

use coherent::bdf::workload::{BdfCalls, BdfInputs};
use coherent::bdf::{Analytic, PAPER_ANISOTROPIC_SHAPE, Symmetry, tabulate_anisotropic};
use coherent::kernels::{ApproxKernel, approx_inputs};
use coherent::simd::Backend;
use coherent::simd::approx::{Approx, Bound, EvalSlices};
use coherent::simd::scalar::Scalar;
use coherent::texture::Texture;
use coherent::texture::workload::{
    LodMethod, TextureInputs, TextureLookups, lod_at, pattern_texture,
};
use coherent::tonemap::{self, Adaptation, Display, Operator, ToneMap};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::is_hand_written;
use crate::plot::{BarChart, LineChart, Series};
use crate::table::{fmt_num, markdown_table};
use crate::timing::{median, speedup};

pub const EXPERIMENT: Experiment = Experiment {
    name: "kernels",
    description: "the approximations (exp, log, pow, acos, atan2) per lane backend",
    paper: "sections 4.2, 5 and 6.1 (the SSE approximations)",
    csv: &["kernels.csv", "kernels_accuracy.csv", "texture_lod.csv"],
    plots: &[
        "kernels_speedup_vs_lanes",
        "kernels_speedup",
        "portability_exp",
        "portability_exp_poly",
        "portability_log",
        "portability_pow",
        "portability_acos",
        "portability_atan2",
        "portability_texture_trilinear",
        "portability_bdf_anisotropic",
    ],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

const HEADER: &[&str] = &["kernel", "backend", "lanes", "seconds", "speedup"];
const ACCURACY_HEADER: &[&str] = &["kernel", "backend", "max_error", "bound", "error_kind"];

/// Values per map (fits in L2 with its output: the kernels are timed, not memory).
const VALUES: usize = 16_384;
/// Evaluations the `seconds` column is scaled to.
const PER: f64 = (1u64 << 20) as f64;

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let backends = Backend::available();
    for b in Backend::ALL {
        if let Some(why) = b.unavailable_reason() {
            ctx.note(format!("kernels: backend {b} skipped: {why}"));
        }
    }
    let passes = ctx.pick(8, 64);
    let samples = ctx.pick(5, 15);
    let bar = ctx.progress((Approx::TIMED.len() * samples) as u64, "kernels");
    let timing = Rounds {
        backends: &backends,
        samples,
        bar: &bar,
    };
    // Every kernel's samples per backend, with the scale to seconds per `PER` evaluations.
    let mut timed: Vec<(String, Samples, f64)> = Vec::new();
    let scale = PER / (passes * VALUES) as f64;
    for f in Approx::TIMED {
        let s = timing.approximation(f, passes)?;
        timed.push((f.name().to_owned(), s, scale));
    }
    // The texture kernel (section 4.1): trilinear lookups of a 1024 x 1024 mipmapped texture
    // from a floor seen by a pinhole camera, the mip level by successive halving (the
    // paper's) or from ray differentials.
    let texture = pattern_texture(1024);
    let tex_inputs = TextureInputs::floor(ctx.pick(256, 512), 1024);
    for (method, name) in TEXTURE_KERNELS {
        let s = timing.run(|backend| {
            backend.run(TextureLookups {
                texture: &texture,
                inputs: &tex_inputs,
                lookups: passes * VALUES,
                lod: method,
            })
        })?;
        timed.push((name.to_owned(), s, scale));
    }
    texture_lod(ctx, &texture, &tex_inputs)?;
    // The tabulated anisotropic BDF (section 4.2, Table 1's workload): calls from a brushed
    // sphere, here so that the portability table has every kernel in one run.
    let bdf = tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )?;
    let bdf_inputs = BdfInputs::sphere(ctx.pick(256, 512));
    let bdf_calls = passes * VALUES / 4;
    let s = timing.run(|backend| {
        backend.run(BdfCalls {
            bdf: &bdf,
            inputs: &bdf_inputs,
            calls: bdf_calls,
        })
    })?;
    timed.push((BDF_KERNEL.to_owned(), s, PER / bdf_calls as f64));
    // Tone mapping (section 6.1).
    let tone = ToneWorkload::new();
    for t in &tone.maps {
        let s = timing.tone_map(&tone, t, passes)?;
        timed.push((format!("tonemap_{}", t.operator().name()), s, scale));
    }
    bar.finish_and_clear();

    let mut csv = ctx.csv("kernels.csv", HEADER)?;
    for (name, seconds, scale) in &timed {
        let scalar = median(&seconds[&Backend::Scalar]) * scale;
        for &backend in &backends {
            let s = median(&seconds[&backend]) * scale;
            csv.row(&[
                name,
                &backend.name(),
                &backend.lanes(),
                &format!("{s:.6e}"),
                &format!("{:.3}", speedup(scalar, s)),
            ])?;
        }
    }
    csv.finish()?;
    accuracy(ctx, &backends, &tone)
}

/// One kernel's timed samples (seconds each) per backend.
type Samples = BTreeMap<Backend, Vec<f64>>;

/// How the kernels are timed: samples interleaved round-robin over the backends, after one
/// warm-up sample each.
struct Rounds<'a> {
    backends: &'a [Backend],
    samples: usize,
    bar: &'a indicatif::ProgressBar,
}

impl Rounds<'_> {
    /// The samples of `f`, one sample a call, its result kept from the optimiser.
    fn run<T>(
        &self,
        mut f: impl FnMut(Backend) -> Result<T, coherent::simd::BackendError>,
    ) -> anyhow::Result<Samples> {
        let mut sample = |backend: Backend| -> anyhow::Result<f64> {
            let start = std::time::Instant::now();
            std::hint::black_box(f(backend)?);
            Ok(start.elapsed().as_secs_f64())
        };
        for &backend in self.backends {
            sample(backend)?; // warm-up
        }
        let mut out = Samples::new();
        for _ in 0..self.samples {
            for &backend in self.backends {
                let s = sample(backend)?;
                out.entry(backend).or_default().push(s);
            }
        }
        Ok(out)
    }

    /// An approximation over the coherent inputs, `passes` maps a sample.
    fn approximation(&self, f: Approx, passes: usize) -> anyhow::Result<Samples> {
        let (a, b) = approx_inputs(f, VALUES);
        let mut out = vec![0.0f32; a.len()];
        let s = self.run(|backend| {
            for _ in 0..passes {
                backend.run(ApproxKernel {
                    f,
                    a: &a,
                    b: &b,
                    out: &mut out,
                })?;
            }
            Ok(())
        })?;
        self.bar.inc(self.samples as u64);
        Ok(s)
    }

    /// A tone-mapping operator over the workload's planes, `passes` times a sample.
    fn tone_map(&self, w: &ToneWorkload, t: &ToneMap, passes: usize) -> anyhow::Result<Samples> {
        let mut out_planes: [Vec<f32>; 3] = [0, 1, 2].map(|_| vec![0.0f32; VALUES]);
        self.run(|backend| {
            for _ in 0..passes {
                let [r, g, b] = std::hint::black_box(&w.planes);
                let [or, og, ob] = &mut out_planes;
                tonemap::apply_planar(
                    backend,
                    t,
                    tonemap::Planar { r, g, b },
                    tonemap::PlanarMut {
                        r: or,
                        g: og,
                        b: ob,
                    },
                )?;
            }
            std::hint::black_box(&out_planes);
            Ok(())
        })
    }
}

/// Tone mapping's workload: each operator over a 16,384-pixel HDR image, with its adaptation
/// from a 1-in-16 subsample (the pre-render).
struct ToneWorkload {
    image: Vec<[f32; 3]>,
    /// The image in planar channels, as a packet renderer holds radiance.
    planes: [Vec<f32>; 3],
    maps: Vec<ToneMap>,
}

impl ToneWorkload {
    fn new() -> Self {
        let image = tonemap::workload_image(VALUES);
        let adaptation = Adaptation::from_luminances(
            image
                .iter()
                .step_by(16)
                .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]),
        );
        let maps = Operator::ALL
            .iter()
            .map(|&op| ToneMap::new(op, adaptation, Display::default()))
            .collect();
        let planes = [0, 1, 2].map(|c| image.iter().map(|p| p[c]).collect());
        Self {
            image,
            planes,
            maps,
        }
    }
}

/// `kernels_accuracy.csv`: the largest error over a dense sweep of each approximation's
/// domain, per backend; and each tone map's display values against the same operator with
/// `std` maths, over the timed image, as an absolute error in [0, 1] display units.
fn accuracy(ctx: &mut Ctx, backends: &[Backend], tone: &ToneWorkload) -> anyhow::Result<()> {
    let mut acc = ctx.csv("kernels_accuracy.csv", ACCURACY_HEADER)?;
    let n = ctx.pick(100_000, 1_000_000);
    for f in Approx::ALL {
        let (a, b) = sweep(f, n);
        for &backend in backends {
            let got = backend.run(EvalSlices { f, a: &a, b: &b })?;
            let (err, bound, kind) = max_error(f, &a, &b, &got);
            acc.row(&[
                &f.name(),
                &backend.name(),
                &format!("{err:.3e}"),
                &format!("{bound:.3e}"),
                &kind,
            ])?;
        }
    }
    for t in &tone.maps {
        let exact: Vec<[f32; 3]> = tone.image.iter().map(|c| t.apply_exact(*c)).collect();
        for &backend in backends {
            let got = tonemap::apply_image(backend, t, &tone.image)?;
            let err = got
                .iter()
                .zip(&exact)
                .flat_map(|(g, e)| (0..3).map(move |c| (g[c] - e[c]).abs() as f64))
                .fold(
                    0.0f64,
                    |m, e| if e.is_nan() { f64::INFINITY } else { m.max(e) },
                );
            acc.row(&[
                &format!("tonemap_{}", t.operator().name()),
                &backend.name(),
                &format!("{err:.3e}"),
                &format!("{:.3e}", t.max_abs_error()),
                &"absolute",
            ])?;
        }
    }
    acc.finish()?;
    Ok(())
}

/// The BDF kernel's name in `kernels.csv`: Table 1's tabulated anisotropic BDF calls.
const BDF_KERNEL: &str = "bdf_anisotropic";

/// The kernels of the portability table and plots (`portability_<kernel>`).
const PORTABILITY_KERNELS: [&str; 8] = [
    "exp",
    "exp_poly",
    "log",
    "pow",
    "acos",
    "atan2",
    "texture_trilinear",
    BDF_KERNEL,
];

/// Per width (4, 8 and 16 lanes): the hand-written, the pulp (portable) and the `wide`
/// backend, from the dispatch module's families.
fn families() -> Vec<(
    usize,
    Option<&'static str>,
    Option<&'static str>,
    &'static str,
)> {
    let name = |family, lanes| Backend::in_family(family, lanes).map(Backend::name);
    [4, 8, 16]
        .into_iter()
        .map(|lanes| {
            let hand = Backend::hand_written().find(|b| b.lanes() == lanes);
            let wide = name("wide", lanes).expect("wide has every width");
            (lanes, hand.map(Backend::name), name("pulp", lanes), wide)
        })
        .collect()
}

/// The portability target: pulp's time at most this times the hand-written one's.
const PORTABILITY_TARGET: f64 = 1.15;

/// The same experiment run on another machine, lent for a session (see `table5`).
const MANYCORE_FILE: &str = "manycore/kernels.csv";

/// Seconds of `(kernel, backend)` in a `kernels.csv` table.
fn seconds_of(t: &crate::Table, kernel: &str, backend: &str) -> anyhow::Result<Option<f64>> {
    for r in t.rows_where("kernel", kernel)? {
        if t.get(r, "backend")? == backend {
            return Ok(Some(t.f64(r, "seconds")?));
        }
    }
    Ok(None)
}

/// One bar chart per kernel: speedup over scalar of hand-written, pulp and wide at 4, 8 and
/// 16 lanes, the native build's beside it where `native/kernels.csv` exists.
fn portability_plots(ctx: &Ctx, t: &crate::Table) -> anyhow::Result<()> {
    let native = ctx.read_csv("native/kernels.csv", HEADER).ok().flatten();
    for kernel in PORTABILITY_KERNELS {
        let mut series = Vec::new();
        let builds: Vec<(&str, &crate::Table)> = std::iter::once(("", t))
            .chain(native.as_ref().map(|n| (" (native)", n)))
            .collect();
        for (suffix, table) in builds {
            let Some(scalar) = seconds_of(table, kernel, "scalar")? else {
                continue;
            };
            for (family, pick) in [("hand-written", 0), ("pulp", 1), ("wide", 2)] {
                let mut v = Vec::new();
                for &(_, hand, pulp, wide) in &families() {
                    let b = [hand, pulp, Some(wide)][pick];
                    let s = match b {
                        Some(b) => seconds_of(table, kernel, b)?,
                        None => None,
                    };
                    v.push(s.map_or(f64::NAN, |s| speedup(scalar, s)));
                }
                series.push((format!("{family}{suffix}"), v));
            }
        }
        if series.is_empty() {
            continue;
        }
        ctx.bar_chart(
            &format!("portability_{kernel}"),
            &BarChart {
                title: format!(
                    "{kernel}: hand-written (sse/avx2/avx512) vs pulp vs wide, speedup over scalar"
                ),
                y_label: "speedup over scalar".into(),
                categories: families()
                    .iter()
                    .map(|f| format!("{} lanes", f.0))
                    .collect(),
                series,
            },
        )?;
    }
    Ok(())
}

/// Which instruction set each backend of the run was built for, and what it ran on
/// (`machine.json`: the target, the CPU, and the emulator when there was one).
fn instruction_sets(ctx: &Ctx, t: &crate::Table) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(ctx.path("machine.json")).unwrap_or_default();
    let machine = coherent::machine::Machine::from_json(&text).ok();
    // The host of this experiment's run (`runs`), else the last run's.
    let run = crate::machine_keys::runs(&text)
        .into_iter()
        .find(|r| r.experiment == EXPERIMENT.name);
    let ran_on = match (&machine, run.and_then(|r| r.cpu.zip(r.os))) {
        (Some(m), _) if m.is_emulated() => {
            format!("{} under emulation ({})", m.arch, m.emulated)
        }
        (_, Some((cpu, os))) => format!("{cpu} ({os})"),
        (Some(m), None) => format!("{} ({})", m.cpu, m.os),
        (None, None) => "(no machine.json)".to_owned(),
    };
    let mut rows = Vec::new();
    for name in t.distinct("backend")? {
        let isa =
            Backend::named(&name).map_or("(not a backend of this build)", |b| b.instructions());
        rows.push(vec![name, isa.to_owned(), ran_on.clone()]);
    }
    Ok(format!(
        "Built for and run on (the instruction sets as this build compiles each backend):\n\n{}\n",
        markdown_table(&["backend", "instruction set", "ran on"], &rows)
    ))
}

/// The portability table: per kernel and width, the speedups and pulp's and wide's time
/// over the hand-written backend's (in one build; the native build's columns where present).
fn portability_report(ctx: &Ctx, t: &crate::Table) -> anyhow::Result<String> {
    let native = ctx.read_csv("native/kernels.csv", HEADER).ok().flatten();
    let mut md = format!(
        "
**The cost of portability.** Per kernel and width, the speedup over scalar of the hand-written backend (sse, avx2, avx512: `core::arch` intrinsics), the pulp backend (pulp8, pulp16: one implementation on pulp's portable operations) and `wide`, and the time of pulp and of wide relative to the hand-written backend at the same width (1.00 = as fast; target for pulp: <= {PORTABILITY_TARGET:.2}). `wide` uses only the build's target features (SSE2 in the default build). pulp has no gather, rounding, conversion or move-mask: the pulp backend writes these lane by lane through arrays in plain Rust, which LLVM turns into the vector instruction for all but the gathers. At 16 lanes the gathers read 8-byte words, a loop LLVM makes a 64-bit hardware gather of on AVX-512; at 8 lanes (AVX2) LLVM makes none, and the loads stay one per lane. So the kernels that read tables (exp, log, pow, texture, BDF, Tumblin's pow) are where pulp trails, most at 8 lanes. Plots: `plots/portability_<kernel>`.

"
    );
    md.push_str(&instruction_sets(ctx, t)?);
    let manycore = ctx.read_csv(MANYCORE_FILE, HEADER).ok().flatten();
    if manycore.is_some() {
        md.push_str(&format!(
            "Rows \"default, other CPU\" are `{MANYCORE_FILE}`: the code of that run's revision, on {}.\n\n",
            crate::manycore::manycore_machine(ctx, "kernels")
        ));
    }
    let builds: Vec<(&str, &crate::Table)> = std::iter::once(("default", t))
        .chain(native.as_ref().map(|n| ("native", n)))
        .chain(manycore.as_ref().map(|m| ("default, other CPU", m)))
        .collect();
    let mut rows = Vec::new();
    for kernel in PORTABILITY_KERNELS {
        for &(lanes, hand, pulp, wide) in &families() {
            for &(build, table) in &builds {
                let Some(scalar) = seconds_of(table, kernel, "scalar")? else {
                    continue;
                };
                let sec = |b: Option<&str>| -> anyhow::Result<Option<f64>> {
                    match b {
                        Some(b) => seconds_of(table, kernel, b),
                        None => Ok(None),
                    }
                };
                let (h, p, w) = (sec(hand)?, sec(pulp)?, sec(Some(wide))?);
                if h.is_none() && p.is_none() && w.is_none() {
                    continue;
                }
                let sp = |s: Option<f64>| {
                    s.map_or("—".to_owned(), |s| format!("{:.2}x", speedup(scalar, s)))
                };
                let ratio = |s: Option<f64>| match (s, h) {
                    (Some(s), Some(h)) => format!("{:.2}", s / h),
                    _ => "—".to_owned(),
                };
                let verdict = match (p, h) {
                    (Some(p), Some(h)) if p / h <= PORTABILITY_TARGET => "met",
                    (Some(_), Some(_)) => "not met",
                    _ => "—",
                };
                rows.push(vec![
                    kernel.to_owned(),
                    lanes.to_string(),
                    build.to_owned(),
                    format!("{} {}", hand.unwrap_or("—"), sp(h)),
                    format!("{} {}", pulp.unwrap_or("—"), sp(p)),
                    format!("{wide} {}", sp(w)),
                    ratio(p),
                    verdict.to_owned(),
                    ratio(w),
                ]);
            }
        }
    }
    md.push_str(&markdown_table(
        &[
            "kernel",
            "lanes",
            "build",
            "hand-written",
            "pulp",
            "wide",
            "pulp / hand-written time",
            "pulp target",
            "wide / hand-written time",
        ],
        &rows,
    ));
    for kernel in PORTABILITY_KERNELS {
        if let Some(p) = ctx.plot_markdown(&format!("portability_{kernel}"), kernel) {
            md.push_str(&p);
        }
    }
    Ok(md)
}

/// The texture kernels: the mip level by the paper's halving, and from ray differentials.
const TEXTURE_KERNELS: [(LodMethod, &str); 2] = [
    (LodMethod::Halving, "texture_trilinear"),
    (LodMethod::Differentials, "texture_trilinear_differentials"),
];

const LOD_HEADER: &[&str] = &[
    "lookups",
    "mean_lod_halving",
    "mean_lod_differentials",
    "mean_abs_difference",
    "max_abs_difference",
    "share_halving_finer",
];

/// The two ways of choosing the mip level compared on the texture kernel's lookups
/// (`texture_lod.csv`): halving the hit distance sees only the distance, the
/// differentials also the slant of the floor.
fn texture_lod(ctx: &Ctx, texture: &Texture, inputs: &TextureInputs) -> anyhow::Result<()> {
    let l = Scalar;
    let (mut sum_h, mut sum_d, mut sum_abs, mut max_abs, mut finer) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    for i in 0..inputs.len() {
        let h = lod_at(l, texture, inputs, LodMethod::Halving, i) as f64;
        let d = lod_at(l, texture, inputs, LodMethod::Differentials, i) as f64;
        sum_h += h;
        sum_d += d;
        sum_abs += (h - d).abs();
        max_abs = max_abs.max((h - d).abs());
        finer += (h < d - 0.5) as usize;
    }
    let n = inputs.len().max(1) as f64;
    let mut csv = ctx.csv("texture_lod.csv", LOD_HEADER)?;
    csv.row(&[
        &inputs.len(),
        &format!("{:.3}", sum_h / n),
        &format!("{:.3}", sum_d / n),
        &format!("{:.3}", sum_abs / n),
        &format!("{max_abs:.3}"),
        &format!("{:.3}", finer as f64 / n),
    ])?;
    csv.finish()?;
    Ok(())
}

/// A uniform sweep of the domain (log-spaced for log, whose domain spans decades).
fn sweep(f: Approx, n: usize) -> (Vec<f32>, Vec<f32>) {
    let (lo, hi) = f.domain();
    let at = |t: f64| match f {
        Approx::Log => ((lo as f64).ln() + t * ((hi as f64).ln() - (lo as f64).ln())).exp() as f32,
        _ => (lo as f64 + t * (hi as f64 - lo as f64)) as f32,
    };
    let a = (0..n).map(|i| at(i as f64 / (n - 1) as f64)).collect();
    let b = (0..n)
        .map(|i| at(((i as f64 * 0.618_034) % 1.0).abs()))
        .collect();
    (a, b)
}

/// The largest error (relative or absolute, as the bound is stated) and the largest bound.
fn max_error(f: Approx, a: &[f32], b: &[f32], got: &[f32]) -> (f64, f64, &'static str) {
    let mut worst = 0.0f64;
    let mut bound = 0.0f64;
    let mut kind = "absolute";
    for i in 0..a.len() {
        let exact = f.reference(a[i], b[i]);
        let err = (got[i] as f64 - exact).abs();
        let (e, bd) = match f.bound(a[i]) {
            Bound::Relative(bd) => {
                kind = "relative";
                (if err == 0.0 { 0.0 } else { err / exact.abs() }, bd as f64)
            }
            Bound::Absolute(bd) => (err, bd as f64),
        };
        worst = if e.is_nan() {
            f64::INFINITY
        } else {
            worst.max(e)
        };
        bound = bound.max(bd);
    }
    (worst, bound, kind)
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv("kernels.csv", HEADER)? else {
        return Ok(());
    };
    let mut series = Vec::new();
    for kernel in t.distinct("kernel")? {
        let mut pts = Vec::new();
        for r in t.rows_where("kernel", &kernel)? {
            // The hand-written backends only (the bar chart shows every backend).
            if is_hand_written(t.get(r, "backend")?) {
                pts.push((t.f64(r, "lanes")?, t.f64(r, "speedup")?));
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() > 1 {
            series.push(Series::new(kernel.clone(), pts));
        }
    }
    series.push(Series::reference(
        "ideal (= lanes)",
        vec![(1.0, 1.0), (4.0, 4.0), (8.0, 8.0), (16.0, 16.0)],
    ));
    ctx.line_chart(
        "kernels_speedup_vs_lanes",
        &LineChart {
            title: "Approximation kernels: speedup vs lanes (scalar, sse, avx2, avx512)".into(),
            x_label: "lanes".into(),
            y_label: "speedup over scalar".into(),
            series,
            log2_x: true,
            log_y: false,
        },
    )?;

    let backends = t.distinct("backend")?;
    let kernels = t.distinct("kernel")?;
    let mut bars = Vec::new();
    for k in &kernels {
        let mut v = Vec::new();
        for b in &backends {
            let r = t
                .rows_where("kernel", k)?
                .into_iter()
                .find(|&r| t.get(r, "backend").is_ok_and(|x| x == b));
            v.push(match r {
                Some(r) => t.f64(r, "speedup")?,
                None => 0.0,
            });
        }
        bars.push((k.clone(), v));
    }
    ctx.bar_chart(
        "kernels_speedup",
        &BarChart {
            title: "Approximation kernels: speedup over scalar per backend".into(),
            y_label: "speedup over scalar".into(),
            categories: backends,
            series: bars,
        },
    )?;
    portability_plots(ctx, &t)?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv("kernels.csv", HEADER)? else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "Seconds per 2^20 evaluations (median of interleaved samples) and speedup over the \
         scalar backend in the same run. Inputs are coherent sweeps of each domain: exp on \
         [-14, 0] (73% in the table part), log on (1e-6, 1] (17% in the table part), pow on \
         [0, 64] with y = 1/2.2 through the paper's range reduction, acos on [-1, 1], atan2 on \
         [-1, 1]^2. The project's targets for exp/log/pow: sse >= 3.5x, 8 lanes >= 6x, 16 lanes >= \
         10x. `texture_trilinear` (section 4.1): trilinear lookups in a 1024 x 1024 mipmapped \
         RGB texture at the texture coordinates of a floor seen by a pinhole camera (4 x 4 pixel \
         tiles), the mip level chosen per lane by successive halving of the hit distance (the \
         paper's way); `texture_trilinear_differentials` chooses it from ray differentials \
         instead (compared below). `tonemap_tumblin`, `tonemap_reinhard`, `tonemap_ward` \
         (section 6.1): a global operator over a 16,384-pixel HDR image (four decades, planar \
         channels as packets hold them), \
         Tumblin-Rushmeier with the range-reduced Padé pow (standing in for the paper's \
         reference [22]); per pixel = per evaluation. Targets: sse >= 3.5x, 8 lanes >= 6x, \
         16 lanes >= 10x. Their error against the same operator computed with `std` is in the \
         accuracy table below (absolute, in display units [0, 1]).\n\n",
    );
    // One row per kernel, one column per backend: "seconds (speedup x)".
    let backends = t.distinct("backend")?;
    let mut header = vec!["kernel".to_owned()];
    header.extend(backends.iter().cloned());
    let mut rows = Vec::new();
    for k in t.distinct("kernel")? {
        let mut row = vec![k.clone()];
        for b in &backends {
            let r = t
                .rows_where("kernel", &k)?
                .into_iter()
                .find(|&r| t.get(r, "backend").is_ok_and(|x| x == b));
            row.push(match r {
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
    if let Some(p) = ctx.plot_markdown("kernels_speedup_vs_lanes", "speedup vs lanes") {
        md.push_str(&p);
    }
    if let Some(p) = ctx.plot_markdown("kernels_speedup", "speedup per backend") {
        md.push_str(&p);
    }
    if let Some(m) = ctx.read_csv(MANYCORE_FILE, HEADER)? {
        md.push_str(&format!(
            "\nThe same run (default build) on {}, lent for a session (`manycore/`, with its own \
             `machine.json`); speedup over scalar there:\n\n",
            crate::manycore::manycore_machine(ctx, "kernels")
        ));
        md.push_str(&m.pivot("kernel", "backend", "speedup")?);
    }
    md.push_str(&portability_report(ctx, &t)?);
    if let Some(acc) = ctx.read_csv("kernels_accuracy.csv", ACCURACY_HEADER)? {
        md.push_str(
            "\nAccuracy against `std` (f64) over a dense sweep of each domain, per backend \
             (`kernels_accuracy.csv`); `bound` is the bound stated in the code's doc comments \
             and checked by the tests.\n\n",
        );
        md.push_str(&acc.to_markdown());
    }
    if let Some(lod) = ctx.read_csv("texture_lod.csv", LOD_HEADER)? {
        md.push_str(
            "\nMip levels of the texture kernel's lookups (`texture_lod.csv`): the paper's \
             successive halving of the hit distance against the level from ray differentials. \
             Halving sees the distance only, so on a slanted floor it picks finer levels than \
             the footprint needs (`share_halving_finer`: more than half a level finer, which \
             aliases); within one octave its linear fraction differs from `log2` by at most \
             0.086 levels.\n\n",
        );
        md.push_str(&lod.to_markdown());
    }
    Ok(Some(md))
}
