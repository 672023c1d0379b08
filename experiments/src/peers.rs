//! Experiment `peers`: our frames beside a renderer users would pick instead, Mitsuba 3
//! (pinned, installed by `scripts/native.py mitsuba`), on the same scenes: each scene is
//! reduced to what both compute alike (`coherent::export::matched`, the exporter's skipped
//! features written to `peers_skipped.csv`), exported, and rendered by
//! - ours: the scalar and the widest backend, with the BSP and Embree;
//! - Mitsuba: `scalar_rgb` and `llvm_ad_rgb` (Dr.Jit's LLVM back end), `direct` integrator
//!   with as many emitter samples as our renderer traces shadow rays per hit;
//!
//! at 1 and 2 threads, 1 sample per pixel. Frame times are medians of interleaved rounds
//! (each contender one frame per round); the time to a first image is our accelerator's
//! build plus our first frame, and Mitsuba's scene load plus its first frame (the JIT
//! compiles its kernels there; the import of the Python modules is recorded apart). Rays per
//! second count our frame's primary samples (the film's count: the pixels' samples and the
//! pre-render's corners, no shadow rays), for both. Agreement: both at the same samples per
//! pixel, converged, as mean radiance and PSNR of the images tone-mapped alike (peak 1).

use std::collections::BTreeMap;

use anyhow::Context;
use coherent::accel_any::AccelKind;
use coherent::export::Skip;
use coherent::export::mitsuba::{ExportError, export};
use coherent::export::peer::{Peer, VARIANTS, installed};
use coherent::film::{FilmOptions, Method};
use coherent::median::median;
use coherent::render::centres::psnr;
use coherent::render::render_frame;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::frames::{self, Plan};
use crate::plot::BarChart;
use crate::table::markdown_table;

pub const EXPERIMENT: Experiment = Experiment {
    name: "peers",
    description: "our frames beside Mitsuba 3's scalar and JIT-vectorised variants on the same matched scenes",
    paper: "section 7 (Table 3's frames), against a current renderer",
    csv: &[FILE, AGREEMENT, SKIPPED],
    plots: &["peers_frames"],
    status: Status::Ready { run, plot, report },
};

pub const FILE: &str = "peers.csv";
pub const HEADER: &[&str] = &[
    "scene",
    "renderer",
    "backend",
    "accel",
    "threads",
    "width",
    "height",
    "spp",
    "frame_s",
    "first_image_s",
    "mrays_per_s",
    "rounds",
];
const AGREEMENT: &str = "peers_agreement.csv";
const AGREEMENT_HEADER: &[&str] = &[
    "scene",
    "variant",
    "spp",
    "mean_ours",
    "mean_peer",
    "mean_ratio",
    "psnr_db",
];
const SKIPPED: &str = "peers_skipped.csv";
const SKIPPED_HEADER: &[&str] = &["scene", "what", "why"];

/// Our renderer's name in the CSV; Mitsuba's rows carry its variant as the backend.
const OURS: &str = "coherent";
const MITSUBA: &str = "mitsuba";

/// The scenes: cornell, the paper's stand-ins, the real meshes as bare meshes.
fn specs(ctx: &Ctx) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = ctx
        .pick(
            vec!["cornell"],
            vec!["cornell", "spdemo", "glass1", "room2"],
        )
        .into_iter()
        .map(|s| (s.to_string(), s.to_string()))
        .collect();
    let meshes = coherent::scene::scenes_dir().join("../.cache/meshes");
    let real: Vec<(&str, &str)> = ctx.pick(
        vec![("bunny", "glmark2-data/bunny.obj")],
        vec![
            ("bunny", "glmark2-data/bunny.obj"),
            ("dragon", "libcgal-demo/ChineseDragon-10kv.off"),
            ("armadillo", "libcgal-demo/armadillo.off"),
        ],
    );
    for (name, file) in real {
        out.push((name.to_string(), meshes.join(file).display().to_string()));
    }
    out
}

/// One contender of a frame.
#[derive(Clone, Debug)]
enum Who {
    Ours(Backend, AccelKind),
    Mitsuba(&'static str),
}

impl Who {
    fn cells(&self) -> (&'static str, String, String) {
        match self {
            Who::Ours(b, a) => (OURS, b.name().to_string(), a.to_string()),
            Who::Mitsuba(v) => (MITSUBA, v.to_string(), "mitsuba".to_string()),
        }
    }
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    if let Err(e) = installed() {
        ctx.note(format!("peers: not run: {e}"));
        return Ok(());
    }
    let (w, h) = ctx.pick((256, 192), (1024, 768));
    let rounds = ctx.pick(3, 5);
    let converged = ctx.pick(16, 32);
    let plan = Plan {
        builtins: true,
        scenes_dir: frames::scenes_dir(),
        max_triangles: usize::MAX,
        width: w,
        height: h,
        spp: 1,
    };
    let (accels, skipped_accels) = frames::accels();
    for (what, why) in skipped_accels {
        ctx.note(format!("peers: {what} skipped: {why}"));
    }
    let accels: Vec<AccelKind> = accels
        .into_iter()
        .filter(|a| matches!(a, AccelKind::Bsp | AccelKind::Embree))
        .collect();
    let widest = frames::widest();
    let mut backends = vec![Backend::Scalar];
    if widest != Backend::Scalar {
        backends.push(widest);
    }
    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut agree = ctx.csv(AGREEMENT, AGREEMENT_HEADER)?;
    let mut skipped = ctx.csv(SKIPPED, SKIPPED_HEADER)?;
    let work = tempfile::tempdir().context("a folder for the exported scenes")?;
    let specs = specs(ctx);
    let bar = ctx.progress(specs.len() as u64, "peers");
    for (name, spec) in specs {
        bar.inc(1);
        let Some(scene) = frames::load_or_note(ctx, "peers", &plan, &name, &spec) else {
            continue;
        };
        let dir = work.path().join(&name);
        let ex = match export(&scene, &dir) {
            Ok(ex) => ex,
            Err(ExportError::NothingMatched { skipped: s, .. }) => {
                write_skips(&mut skipped, &name, &s)?;
                skipped.row(&[&name, &"the whole scene", &"no light is left to compare"])?;
                continue;
            }
            Err(e) => return Err(e).with_context(|| format!("exporting {name}")),
        };
        write_skips(&mut skipped, &name, &ex.skipped)?;
        let scene = &ex.scene;

        // Ours: one renderer per accelerator, its build timed.
        let mut ours = Vec::new();
        for &a in &accels {
            let (r, build) = frames::renderer_timed(scene, a)?;
            ours.push((a, r, build));
        }
        for threads in [1usize, 2] {
            let pool = frames::pool(threads)?;
            let mut who: Vec<Who> = Vec::new();
            let mut times: Vec<Vec<f64>> = Vec::new();
            let mut first: Vec<f64> = Vec::new();
            let mut rays = 0u64;
            for &b in &backends {
                for (a, r, build) in &ours {
                    let (out, s) = frames::frame(&pool, b, r, &plan)?;
                    rays = out.rays;
                    who.push(Who::Ours(b, *a));
                    first.push(build + s);
                    times.push(Vec::new());
                }
            }
            let mut peers = Vec::new();
            for v in VARIANTS {
                let mut p = Peer::start(&ex.xml, v, threads)?;
                let s = p.render(1, 0, None)?;
                who.push(Who::Mitsuba(v));
                first.push(p.loaded.load_s + s);
                times.push(Vec::new());
                peers.push(p);
            }
            for _ in 0..rounds {
                let mut k = 0;
                for &b in &backends {
                    for (_, r, _) in &ours {
                        times[k].push(frames::frame(&pool, b, r, &plan)?.1);
                        k += 1;
                    }
                }
                for p in &mut peers {
                    times[k].push(p.render(1, 0, None)?);
                    k += 1;
                }
            }
            for ((who, t), first) in who.iter().zip(&times).zip(&first) {
                let (renderer, backend, accel) = who.cells();
                let frame = median(t);
                csv.row(&[
                    &name,
                    &renderer,
                    &backend,
                    &accel,
                    &threads,
                    &w,
                    &h,
                    &1,
                    &format!("{frame:.6}"),
                    &format!("{first:.6}"),
                    &format!("{:.3}", rays as f64 / frame / 1e6),
                    &t.len(),
                ])?;
            }
        }

        // Agreement at `converged` samples per pixel: ours (widest, BSP) against each variant.
        let (_, r, _) = &ours[0];
        let pool = frames::pool(rayon::current_num_threads())?;
        let opts = FilmOptions::new(w, h, Method::Uniform { spp: converged });
        let mine = pool.install(|| render_frame(widest, r, &opts, &|_| {}))?;
        let img = mine.image();
        let tm = |px: &[[f32; 3]]| -> anyhow::Result<Vec<[f32; 3]>> {
            let t = coherent::tonemap::apply_image(widest, &mine.tonemap, px)?;
            Ok(t.into_iter()
                .map(|c| c.map(|v| v.clamp(0.0, 1.0)))
                .collect())
        };
        let mine_shown = tm(&img)?;
        for v in VARIANTS {
            let mut p = Peer::start(&ex.xml, v, rayon::current_num_threads())?;
            let file = dir.join(format!("{v}.exr"));
            p.render(converged, 1, Some(&file))?;
            let (pw, ph, theirs) = coherent::light::environment::read_exr(&file)
                .with_context(|| format!("reading Mitsuba's image {}", file.display()))?;
            anyhow::ensure!(
                (pw, ph) == (w as usize, h as usize),
                "Mitsuba's image is {pw}x{ph}, not {w}x{h}"
            );
            let (mo, mp) = (mean(&img), mean(&theirs));
            let db = psnr(&tm(&theirs)?, &mine_shown, 1.0);
            agree.row(&[
                &name,
                &v,
                &converged,
                &format!("{mo:.6}"),
                &format!("{mp:.6}"),
                &format!("{:.4}", mp / mo),
                &format!("{db:.2}"),
            ])?;
        }
        drop(mine);
        drop(ours);
    }
    bar.finish_and_clear();
    csv.finish()?;
    agree.finish()?;
    skipped.finish()?;
    Ok(())
}

fn write_skips(csv: &mut crate::table::CsvOut, scene: &str, skips: &[Skip]) -> anyhow::Result<()> {
    for s in skips {
        csv.row(&[&scene, &s.what, &s.why])?;
    }
    Ok(())
}

/// Mean luminance-free radiance: the mean of the three channels over the image.
fn mean(px: &[[f32; 3]]) -> f64 {
    px.iter()
        .map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0)
        .sum::<f64>()
        / px.len().max(1) as f64
}

/// Frame seconds by (scene, threads): (contender label, seconds) per contender.
type FramesBy = BTreeMap<(String, u32), Vec<(String, f64)>>;

/// [`FramesBy`] from `peers.csv` (`None` before `peers` ran).
fn frames_by(ctx: &Ctx) -> anyhow::Result<Option<FramesBy>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut out = FramesBy::new();
    for r in 0..t.len() {
        let label = if t.get(r, "renderer")? == MITSUBA {
            format!("Mitsuba {}", t.get(r, "backend")?)
        } else {
            format!("{} {}", t.get(r, "backend")?, t.get(r, "accel")?)
        };
        out.entry((t.get(r, "scene")?.to_string(), t.f64(r, "threads")? as u32))
            .or_default()
            .push((label, t.f64(r, "frame_s")?));
    }
    Ok(Some(out))
}

/// Table 3's peer column: per scene of `peers.csv`, at 1 thread, our widest backend with
/// the BSP and Mitsuba's two variants on the matched scene (`None` before `peers` ran).
pub fn table3_peer(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(by) = frames_by(ctx)? else {
        return Ok(None);
    };
    let mut rows = Vec::new();
    for ((scene, threads), r) in &by {
        if *threads != 1 {
            continue;
        }
        let ours = r
            .iter()
            .filter(|(l, _)| l.ends_with(" bsp") && !l.starts_with("scalar"))
            .map(|x| x.1)
            .fold(f64::INFINITY, f64::min);
        let get = |label: &str| r.iter().find(|(l, _)| l == label).map(|x| x.1);
        let cell = |v: Option<f64>| v.map_or("—".to_string(), |s| format!("{:.1} ms", s * 1e3));
        rows.push(vec![
            scene.clone(),
            cell(ours.is_finite().then_some(ours)),
            cell(get("Mitsuba llvm_ad_rgb")),
            cell(get("Mitsuba scalar_rgb")),
        ]);
    }
    let mut md = String::from(
        "\nThe peer: each scene reduced to what Mitsuba 3 renders the same way (`peers`, its \
         own resolution, 1 sample per pixel, 1 thread): our widest backend with the BSP beside \
         Mitsuba's two variants.\n\n",
    );
    md.push_str(&markdown_table(
        &[
            "scene (matched)",
            "ours, widest + BSP",
            "Mitsuba llvm_ad_rgb",
            "Mitsuba scalar_rgb",
        ],
        &rows,
    ));
    Ok(Some(md))
}

fn plot(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(by) = frames_by(ctx)? else {
        return Ok(());
    };
    // One bar group per scene at 1 thread: every contender's frame relative to Mitsuba's
    // llvm variant (below 1: faster than the peer).
    let mut categories = Vec::new();
    let mut series: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let one: Vec<_> = by.iter().filter(|((_, t), _)| *t == 1).collect();
    for (i, ((scene, _), rows)) in one.iter().enumerate() {
        categories.push(scene.clone());
        let peer = rows
            .iter()
            .find(|(l, _)| l == "Mitsuba llvm_ad_rgb")
            .map(|r| r.1);
        for (label, s) in rows.iter() {
            let v = series
                .entry(label.clone())
                .or_insert_with(|| vec![f64::NAN; one.len()]);
            v[i] = peer.map_or(f64::NAN, |p| s / p);
        }
    }
    if categories.is_empty() {
        return Ok(());
    }
    ctx.bar_chart(
        "peers_frames",
        &BarChart {
            title: "Frame time relative to Mitsuba llvm_ad_rgb (1 thread)".into(),
            y_label: "frame / Mitsuba llvm frame".into(),
            categories,
            series: series.into_iter().collect(),
        },
    )?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(by) = frames_by(ctx)? else {
        return Ok(None);
    };
    let mut rows = Vec::new();
    for ((scene, threads), r) in &by {
        let get = |label: &str| r.iter().find(|(l, _)| l == label).map(|x| x.1);
        let (Some(llvm), Some(scalar)) = (get("Mitsuba llvm_ad_rgb"), get("Mitsuba scalar_rgb"))
        else {
            continue;
        };
        let Some((best_label, best)) = r
            .iter()
            .filter(|(l, _)| !l.starts_with("Mitsuba"))
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            continue;
        };
        let widest = r
            .iter()
            .filter(|(l, _)| !l.starts_with("Mitsuba") && !l.starts_with("scalar"))
            .map(|x| x.1)
            .fold(f64::INFINITY, f64::min);
        let verdict = |ok: bool| if ok { "met" } else { "missed" };
        rows.push(vec![
            scene.clone(),
            threads.to_string(),
            format!("{:.1} ms ({best_label})", *best * 1e3),
            format!("{:.1} ms", llvm * 1e3),
            format!("{:.1} ms", scalar * 1e3),
            format!("{:.2}x: {}", best / llvm, verdict(*best <= 0.8 * llvm)),
            if widest.is_finite() {
                format!(
                    "{:.2}x: {}",
                    scalar / widest,
                    verdict(scalar >= 3.0 * widest)
                )
            } else {
                "no SIMD backend".to_string()
            },
        ]);
    }
    let mut md = String::from(
        "Each scene reduced to what both renderers compute alike (what was left out is in \
         `peers_skipped.csv`), 1 sample per pixel, medians of interleaved rounds. Targets: our \
         best frame at most 0.8x Mitsuba `llvm_ad_rgb`'s; Mitsuba `scalar_rgb`'s frame at \
         least 3x ours at the widest backend.\n\n",
    );
    md.push_str(&markdown_table(
        &[
            "scene",
            "threads",
            "our best frame",
            "Mitsuba llvm_ad_rgb",
            "Mitsuba scalar_rgb",
            "ours / llvm",
            "scalar_rgb / our widest",
        ],
        &rows,
    ));
    if let Some(t) = ctx.read_csv(AGREEMENT, AGREEMENT_HEADER)? {
        let mut rows = Vec::new();
        for r in 0..t.len() {
            let ratio = t.f64(r, "mean_ratio")?;
            let db = t.f64(r, "psnr_db")?;
            let ok = (ratio - 1.0).abs() <= 0.01 && db >= 35.0;
            rows.push(vec![
                t.get(r, "scene")?.to_string(),
                t.get(r, "variant")?.to_string(),
                t.get(r, "spp")?.to_string(),
                format!("{ratio:.4}"),
                format!("{db:.1} dB"),
                if ok { "met" } else { "missed" }.to_string(),
            ]);
        }
        md.push_str(
            "\n\nAgreement at equal samples (ours: widest backend, BSP), both images \
             tone-mapped by our operator: mean radiance within 1% and PSNR at least 35 dB.\n\n",
        );
        md.push_str(&markdown_table(
            &[
                "scene",
                "variant",
                "spp",
                "Mitsuba mean / ours",
                "PSNR",
                "target",
            ],
            &rows,
        ));
    }
    Ok(Some(md))
}
