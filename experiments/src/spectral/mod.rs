//! Experiment `spectral`: what carrying colour as spectra costs the paper's packets, beside
//! RGB (`coherent::render::colour`): `hero` (four wavelengths per ray, the first drawn per
//! image sample) and `bins` (N fixed bins over 380-780 nm, the paper's "20 to 40
//! intensities"), the latter in two layouts: lanes over rays (one register per bin) and
//! lanes over wavelengths (one ray's bins across the lanes). Spectral forms render on the
//! hand-written backends alone (scalar, sse, avx2, avx512: one per width), the SIMD ones in a
//! build with the `spectral-simd` feature (`scripts/reproduce.sh` turns it on).
//!
//! Three parts, one file each:
//! - [`kernels`]: the kernels of Tables 1 and 2 (table1's three materials, table2's eight
//!   light kinds) with their RGB result accumulated in each colour form, in ns per colour
//!   evaluation (`spectral_kernels.csv`);
//! - [`frames`]: frames of the paper's four scenes per colour form at one thread, with the
//!   stage clocks' split (`spectral_frames.csv`);
//! - [`error`]: each form's image against a converged `bins` reference at several samples
//!   per pixel, and, without dispersion, hero and bins against RGB (`spectral_error.csv`).
//!
//! [`plots`] and [`report`] work from the CSV files alone.

mod error;
mod frames;
mod kernels;
mod plots;
mod report;

use coherent::render::colour::{ColourForm, Layout, spectral_refusal};
use coherent::scene::RenderScene;
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};

pub const EXPERIMENT: Experiment = Experiment {
    name: "spectral",
    description: "spectral colour (hero wavelengths, bins over rays or over wavelengths) against RGB: kernels, frames and image error",
    paper: "beyond the paper: its \"20 to 40 intensities\" per ray, in packets",
    csv: &[kernels::FILE, frames::FILE, error::FILE],
    plots: &[plots::COST_CHANNELS, plots::LAYOUT_RATIO],
    status: Status::Ready {
        run,
        plot: plots::plots,
        report: report::report,
    },
};

/// The paper's four scenes (Table 4), as built-in stand-ins.
const SCENES: [&str; 4] = ["car", "spdemo", "glass1", "room2"];

/// The bins of the frames and of the error's images (and of its reference).
pub const FRAME_BINS: u32 = 32;

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let backends = hand_written(ctx);
    kernels::run(ctx)?;
    let plan = frames::plan(ctx);
    let mut scenes = Vec::new();
    for name in SCENES {
        if let Some(scene) = crate::frames::load_or_note(ctx, "spectral", &plan, name, name) {
            scenes.push((name.to_owned(), scene));
        }
    }
    frames::run(ctx, &scenes, &backends, &plan)?;
    let widest = backends.last().copied().unwrap_or(Backend::Scalar);
    error::run(ctx, &scenes, widest)?;
    Ok(())
}

/// The hand-written backends usable here that the spectral forms are compiled for
/// (`SPECTRAL_BACKENDS`: scalar, and sse, avx2 and avx512 with the `spectral-simd` feature);
/// the others are noted.
fn hand_written(ctx: &mut Ctx) -> Vec<Backend> {
    let mut out = Vec::new();
    for b in Backend::hand_written() {
        let why = spectral_refusal(&ColourForm::Hero, b).or_else(|| b.unavailable_reason());
        match why {
            None => out.push(b),
            Some(why) => ctx.note(format!("spectral: backend {b} skipped: {why}")),
        }
    }
    out
}

/// The forms the frames and the error compare: RGB, hero, and 32 bins in both layouts.
pub fn frame_forms() -> Vec<ColourForm> {
    let mut out = vec![ColourForm::Rgb, ColourForm::Hero];
    for layout in Layout::ALL {
        out.push(ColourForm::bins(FRAME_BINS, layout).expect("32 bins are valid"));
    }
    out
}

/// The layout column of a form: `rays` or `wavelengths` for bins, empty otherwise.
pub fn layout_name(form: &ColourForm) -> &'static str {
    match form {
        ColourForm::Bins { layout, .. } => layout.name(),
        _ => "",
    }
}

/// Whether any material of `scene` disperses.
fn disperses(scene: &RenderScene) -> bool {
    scene
        .materials
        .iter()
        .any(|m| m.optics.dispersion.is_some())
}

/// `scene` with every material's dispersion taken out.
fn without_dispersion(scene: &RenderScene) -> RenderScene {
    let mut s = scene.clone();
    for m in &mut s.materials {
        m.optics.dispersion = None;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Plan;

    fn ctx(dir: &tempfile::TempDir) -> Ctx {
        Ctx::new(dir.path(), true, coherent::machine::Machine::detect())
    }

    /// Writes `rows` under `header` into `file`.
    fn write(ctx: &Ctx, file: &str, header: &[&str], rows: &[Vec<String>]) {
        let mut csv = ctx.csv(file, header).unwrap();
        for row in rows {
            let cells: Vec<&dyn std::fmt::Display> =
                row.iter().map(|c| c as &dyn std::fmt::Display).collect();
            csv.row(&cells).unwrap();
        }
        csv.finish().unwrap();
    }

    fn strings(cells: &[&dyn std::fmt::Display]) -> Vec<String> {
        cells.iter().map(|c| c.to_string()).collect()
    }

    #[test]
    fn the_frames_header_has_a_share_per_stage() {
        let shares: Vec<String> = coherent::render::Stage::ALL
            .iter()
            .map(|s| format!("share_{}", s.name()))
            .collect();
        let header: Vec<&str> = frames::HEADER
            .iter()
            .copied()
            .filter(|h| h.starts_with("share_"))
            .collect();
        assert_eq!(header, shares);
    }

    #[test]
    fn plots_and_report_come_from_the_csv_files_alone() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = ctx(&dir);
        assert!(report::report(&ctx).unwrap().is_none());
        // Kernels: cost grows with channels; over rays cheaper at 1 lane, over wavelengths
        // at 16.
        let mut rows = Vec::new();
        for (backend, lanes) in [("scalar", 1u32), ("avx512", 16)] {
            for kernel in ["plastic", "omni"] {
                let kind = if kernel == "omni" {
                    "light"
                } else {
                    "material"
                };
                let mut forms = vec![("rgb", 3u32, ""), ("hero", 4, "")];
                for n in [8u32, 16, 32, 64] {
                    forms.push((
                        Box::leak(format!("bins{n}-rays").into_boxed_str()),
                        n,
                        "rays",
                    ));
                    forms.push((
                        Box::leak(format!("bins{n}-wavelengths").into_boxed_str()),
                        n,
                        "wavelengths",
                    ));
                }
                for (colour, channels, layout) in forms {
                    let mut ns = 10.0 + f64::from(channels);
                    if layout == "wavelengths" {
                        ns *= if lanes == 1 { 1.2 } else { 0.5 };
                    }
                    rows.push(strings(&[
                        &backend,
                        &lanes,
                        &kind,
                        &kernel,
                        &colour,
                        &channels,
                        &layout,
                        &1000,
                        &ns,
                        &13.0,
                        &(ns / 13.0),
                        &3,
                    ]));
                }
            }
        }
        write(&ctx, kernels::FILE, kernels::HEADER, &rows);
        // Frames: hero 1.2x on car, 1.3x on room2 at avx512; bins over wavelengths 3x, over
        // rays 5x at 16 lanes.
        let mut rows = Vec::new();
        for scene in ["car", "room2"] {
            for (backend, lanes) in [("scalar", 1u32), ("avx512", 16)] {
                for (colour, channels, layout, ratio) in [
                    ("rgb", 3u32, "", 1.0),
                    ("hero", 4, "", if scene == "car" { 1.2 } else { 1.3 }),
                    ("bins32-rays", 32, "rays", 5.0),
                    ("bins32-wavelengths", 32, "wavelengths", 3.0),
                ] {
                    let shading = if layout == "rays" { 0.6 } else { 0.3 };
                    rows.push(strings(&[
                        &scene,
                        &backend,
                        &lanes,
                        &colour,
                        &channels,
                        &layout,
                        &128,
                        &96,
                        &1,
                        &1,
                        &(0.1 * ratio),
                        &ratio,
                        &20_000,
                        &3,
                        &0.2,
                        &0.1,
                        &shading,
                        &0.05,
                        &(0.65 - shading),
                    ]));
                }
            }
        }
        write(&ctx, frames::FILE, frames::HEADER, &rows);
        // Error: converging on car; without dispersion hero 40 dB, bins 30 and 29 dB on
        // glass1.
        let mut rows = Vec::new();
        for (scene, dispersive) in [("car", 0u8), ("glass1", 1)] {
            for colour in ["rgb", "hero", "bins32-rays", "bins32-wavelengths"] {
                for spp in [1u32, 4] {
                    rows.push(strings(&[
                        &scene,
                        &"on",
                        &dispersive,
                        &colour,
                        &4,
                        &"",
                        &spp,
                        &64,
                        &48,
                        &"bins32-rays",
                        &16,
                        &(20.0 + f64::from(spp)),
                        &0.5,
                    ]));
                }
                let db = match (scene, colour) {
                    (_, "rgb") => continue,
                    ("car", _) | (_, "hero") => 40.0,
                    (_, "bins32-rays") => 30.0,
                    _ => 29.0,
                };
                rows.push(strings(&[
                    &scene,
                    &"off",
                    &dispersive,
                    &colour,
                    &4,
                    &"",
                    &4,
                    &64,
                    &48,
                    &"rgb",
                    &4,
                    &db,
                    &0.5,
                ]));
            }
        }
        write(&ctx, error::FILE, error::HEADER, &rows);

        plots::plots(&ctx).unwrap();
        for stem in [plots::COST_CHANNELS, plots::LAYOUT_RATIO] {
            assert!(
                dir.path().join(format!("plots/{stem}.png")).is_file(),
                "{stem}"
            );
        }
        let md = report::report(&ctx).unwrap().unwrap();
        for row in [
            "| car | hero frame <= 1.25x rgb (avx512, 16 lanes) | met | narrowest pass: 1.20x |",
            "| room2 | hero frame <= 1.25x rgb (avx512, 16 lanes) | not met | nearest miss: 1.30x |",
            "| car | bins32 frame <= 4x rgb at 16 lanes, winning layout | met | narrowest pass: avx512 3.00x (wavelengths) |",
            "| glass1 | hero and bins within 35 dB PSNR of rgb without dispersion | 1 of 3 met | nearest miss: bins32-rays 30.0 dB |",
            "| car | hero and bins within 35 dB PSNR of rgb without dispersion | met (3 of 3) |",
        ] {
            assert!(md.contains(row), "{row}\n{md}");
        }
        assert!(
            md.contains("| 16 | avx512 | 5.00x | 3.00x | wavelengths |"),
            "{md}"
        );
        assert!(md.contains("plots/spectral_cost_channels.png"), "{md}");
    }

    #[test]
    fn a_tiny_run_of_glass1_writes_every_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = ctx(&dir);
        let plan = Plan {
            builtins: true,
            scenes_dir: dir.path().join("no-scenes"),
            max_triangles: usize::MAX,
            width: 16,
            height: 8,
            spp: 1,
        };
        let scene = crate::frames::load_or_note(&mut ctx, "spectral", &plan, "glass1", "glass1")
            .expect("glass1 loads");
        assert!(disperses(&scene), "glass1 has dispersive glass");
        assert!(!disperses(&without_dispersion(&scene)));
        let scenes = vec![("glass1".to_owned(), scene)];
        let backends = [Backend::Scalar];
        kernels::run_with(&mut ctx, &[Backend::Scalar], &[8, 16], 16, 64, 1).unwrap();
        frames::run_with(&mut ctx, &scenes, &backends, &plan, 1).unwrap();
        error::run_with(&mut ctx, &scenes, Backend::Scalar, (16, 8), &[1], 2).unwrap();

        let k = ctx
            .read_csv(kernels::FILE, kernels::HEADER)
            .unwrap()
            .unwrap();
        assert_eq!(
            k.distinct("colour").unwrap(),
            [
                "rgb",
                "hero",
                "bins8-rays",
                "bins8-wavelengths",
                "bins16-rays",
                "bins16-wavelengths"
            ]
        );
        assert_eq!(k.len(), 6 * (3 + 8), "3 materials and 8 lights");
        for r in 0..k.len() {
            assert!(k.f64(r, "ns_per_eval").unwrap() > 0.0, "row {r}");
        }
        let f = ctx.read_csv(frames::FILE, frames::HEADER).unwrap().unwrap();
        assert_eq!(f.len(), 4);
        assert_eq!(f.f64(0, "ratio").unwrap(), 1.0);
        for r in 0..f.len() {
            let shares: f64 = coherent::render::Stage::ALL
                .iter()
                .map(|s| f.f64(r, &format!("share_{}", s.name())).unwrap())
                .sum();
            assert!((shares - 1.0).abs() < 1e-3, "row {r}: {shares}");
        }
        let e = ctx.read_csv(error::FILE, error::HEADER).unwrap().unwrap();
        // Four forms on the scene as it is, three without dispersion.
        assert_eq!(e.len(), 4 + 3);
        assert_eq!(e.distinct("dispersion").unwrap(), ["on", "off"]);
        for r in 0..e.len() {
            assert!(e.f64(r, "psnr_db").unwrap() > 0.0, "row {r}");
        }
        plots::plots(&ctx).unwrap();
        assert!(report::report(&ctx).unwrap().is_some());
    }
}
