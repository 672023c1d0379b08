//! The README section of `spectral`, from its CSV files: the kernels' cost per colour form,
//! the frames and their stage shares, which bin layout wins at each width and why, the
//! images' error, and the targets.

use coherent::render::Stage;

use super::error::AGREEMENT_DB;
use super::plots::{
    COST_CHANNELS, LAYOUT_RATIO, geomean, hand_written_backends, kernel_mean, select,
};
use super::{error, frames, kernels};
use crate::ctx::Ctx;
use crate::table::{Table, fmt_num, markdown_table};
use crate::targets::{Check, condensed};

/// A hero frame over the RGB frame, at most (the widest backend).
pub const HERO_TARGET: f64 = 1.25;
/// A frame of 32 bins over the RGB frame at 16 lanes, in the faster layout, at most.
pub const BINS_TARGET: f64 = 4.0;
/// The lanes the bins target is set at.
pub const BINS_TARGET_LANES: f64 = 16.0;

pub(super) fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let k = ctx.read_csv(kernels::FILE, kernels::HEADER)?;
    let f = ctx.read_csv(frames::FILE, frames::HEADER)?;
    let e = ctx.read_csv(error::FILE, error::HEADER)?;
    if k.is_none() && f.is_none() && e.is_none() {
        return Ok(None);
    }
    let mut md = String::from(
        "Spectral colour beside RGB (beyond the paper, which carries RGB and names \"20 to 40 \
         intensities\" per ray as the alternative): `hero` carries four wavelengths per ray, \
         the first drawn per image sample and the others a quarter of the range apart \
         (Wilkie et al. 2014); `binsN` carries N fixed bins over 380-780 nm, laid out either \
         over rays (each lane a ray, one register per bin) or over wavelengths (one ray's \
         bins across the lanes, N / lanes registers per ray). RGB colour enters a path \
         (shading, light samples, background) and is upsampled where it enters (Jakob and \
         Hanika's sigmoids); each sample's spectrum goes to XYZ and linear sRGB on the film. \
         Spectral forms render on the hand-written backends alone (one per width).\n",
    );
    let mut checks = Vec::new();
    if let Some(t) = &k {
        md.push_str(&kernels_md(ctx, t)?);
    }
    if let Some(t) = &f {
        md.push_str(&frames_md(t, &mut checks)?);
        md.push_str(&layouts_md(t, k.as_ref())?);
    }
    md.push_str(
        &ctx.plot_markdown(LAYOUT_RATIO, "time over rays / over wavelengths per width")
            .unwrap_or_default(),
    );
    if let Some(t) = &e {
        md.push_str(&error_md(t, &mut checks)?);
    }
    if !checks.is_empty() {
        md.push_str(&format!(
            "\nTargets (a `hero` frame at most {HERO_TARGET}x the RGB frame at the widest \
             backend; a frame of 32 bins at most {BINS_TARGET}x the RGB frame at 16 lanes in \
             the faster layout; without dispersion, hero and bins images within \
             {AGREEMENT_DB} dB PSNR of RGB at the most samples per pixel):\n\n"
        ));
        md.push_str(&condensed("scene", &checks));
    }
    Ok(Some(md))
}

fn first(t: &Table, col: &str) -> String {
    t.get(0, col).unwrap_or("?").to_owned()
}

/// The widest hand-written backend of `t`, with its lanes.
fn widest(t: &Table) -> anyhow::Result<Option<(String, f64)>> {
    Ok(hand_written_backends(t)?.pop())
}

fn kernels_md(ctx: &Ctx, t: &Table) -> anyhow::Result<String> {
    let mut md = format!(
        "\n**Kernels** (`{}`): table1's three materials (brushed metal's tabulated BDF, \
         Phong plastic, glass) on its calls and table2's eight light kinds on its shading \
         points, each value accumulated into a colour of the form (`add_reflected`, which \
         upsamples both factors for the spectral forms); the accumulator goes to RGB once per \
         run. About {} evaluations per timed sample, median of {} interleaved samples, one \
         thread. Nanoseconds per colour evaluation, geometric mean over the {} kernels, and \
         in brackets over the same backend's `rgb`:\n\n",
        kernels::FILE,
        first(t, "evals"),
        first(t, "samples"),
        t.distinct("kernel")?.len(),
    );
    let backends = hand_written_backends(t)?;
    let mut rows = Vec::new();
    for colour in t.distinct("colour")? {
        let mut row = vec![colour.clone(), {
            let r = t.rows_where("colour", &colour)?[0];
            t.get(r, "channels")?.to_owned()
        }];
        for (b, _) in &backends {
            let ns = kernel_mean(t, b, &colour, "ns_per_eval")?;
            let ratio = kernel_mean(t, b, &colour, "ratio")?;
            row.push(if ns.is_finite() {
                format!("{} ({:.2}x)", fmt_num(ns), ratio)
            } else {
                "—".into()
            });
        }
        rows.push(row);
    }
    let mut header = vec!["colour".to_owned(), "channels".to_owned()];
    header.extend(backends.iter().map(|(b, l)| format!("{b} ({l})")));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));

    if let Some((b, lanes)) = widest(t)? {
        md.push_str(&format!(
            "\nPer kernel at {b} ({lanes} lanes): each form's time over `rgb`'s.\n\n"
        ));
        let colours: Vec<String> = t
            .distinct("colour")?
            .into_iter()
            .filter(|c| c != "rgb")
            .collect();
        let mut rows = Vec::new();
        for kernel in t.distinct("kernel")? {
            let mut row = vec![kernel.clone()];
            let mut rgb_ns = String::from("—");
            for c in std::iter::once("rgb".to_owned()).chain(colours.iter().cloned()) {
                let rs = select(t, &[("backend", &b), ("kernel", &kernel), ("colour", &c)])?;
                match rs.first() {
                    Some(&r) if c == "rgb" => rgb_ns = fmt_num(t.f64(r, "ns_per_eval")?),
                    Some(&r) => row.push(format!("{:.2}x", t.f64(r, "ratio")?)),
                    None => row.push("—".into()),
                }
            }
            row.insert(1, rgb_ns);
            rows.push(row);
        }
        let mut header = vec!["kernel".to_owned(), "rgb ns".to_owned()];
        header.extend(colours.iter().cloned());
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        md.push_str(&markdown_table(&header, &rows));
    }
    md.push_str(
        &ctx.plot_markdown(COST_CHANNELS, "ns per colour evaluation against channels")
            .unwrap_or_default(),
    );
    Ok(md)
}

/// The row of `scene`, `backend` and `colour` in the frames.
fn frame_row(t: &Table, scene: &str, backend: &str, colour: &str) -> anyhow::Result<Option<usize>> {
    Ok(select(
        t,
        &[("scene", scene), ("backend", backend), ("colour", colour)],
    )?
    .first()
    .copied())
}

fn frames_md(t: &Table, checks: &mut Vec<Check>) -> anyhow::Result<String> {
    let mut md = format!(
        "\n**Frames** (`{}`): the paper's four scenes at {} x {}, {} sample per pixel, BSP, one \
         thread, each hand-written backend; per backend and form one untimed frame with the \
         stage clocks on (the shares below, as `coherent render --stages`), then {} rounds of \
         one frame per form, the order rotating; medians. Seconds per frame, and in brackets \
         over the RGB frame of the same scene and backend:\n\n",
        frames::FILE,
        first(t, "width"),
        first(t, "height"),
        first(t, "spp"),
        first(t, "rounds"),
    );
    let colours = t.distinct("colour")?;
    let backends = hand_written_backends(t)?;
    let mut rows = Vec::new();
    for scene in t.distinct("scene")? {
        for (b, lanes) in &backends {
            let mut row = vec![scene.clone(), format!("{b} ({lanes})")];
            for c in &colours {
                row.push(match frame_row(t, &scene, b, c)? {
                    Some(r) => format!(
                        "{} ({:.2}x)",
                        fmt_num(t.f64(r, "seconds")?),
                        t.f64(r, "ratio")?
                    ),
                    None => "—".into(),
                });
            }
            rows.push(row);
        }
    }
    let mut header = vec!["scene".to_owned(), "backend (lanes)".to_owned()];
    header.extend(colours.iter().map(|c| format!("{c} s")));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));

    if let Some((b, lanes)) = widest(t)? {
        md.push_str(&format!(
            "\nWhere the time goes at {b} ({lanes} lanes): each stage's share of the timed \
             stages (colour work falls in `shading` for materials, `lights` for light \
             samples, `other` for the background, the camera's wavelengths and the film's \
             conversion), and the rays traced:\n\n"
        ));
        let mut rows = Vec::new();
        for scene in t.distinct("scene")? {
            for c in &colours {
                if let Some(r) = frame_row(t, &scene, &b, c)? {
                    let mut row = vec![scene.clone(), c.clone()];
                    for s in Stage::ALL {
                        let v = t.f64(r, &format!("share_{}", s.name()))?;
                        row.push(format!("{:.1}%", 100.0 * v));
                    }
                    row.push(t.get(r, "rays")?.to_owned());
                    rows.push(row);
                }
            }
        }
        let mut header = vec!["scene".to_owned(), "colour".to_owned()];
        header.extend(Stage::ALL.iter().map(|s| s.name().to_owned()));
        header.push("rays".into());
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        md.push_str(&markdown_table(&header, &rows));

        // Targets: hero at the widest backend; bins at 16 lanes in the faster layout.
        for scene in t.distinct("scene")? {
            if let Some(r) = frame_row(t, &scene, &b, "hero")? {
                let ratio = t.f64(r, "ratio")?;
                checks.push(Check::at_most(
                    &scene,
                    &format!("hero frame <= {HERO_TARGET}x rgb ({b}, {lanes} lanes)"),
                    format!("{ratio:.2}x"),
                    ratio,
                    HERO_TARGET,
                ));
            }
        }
    }
    let at16 = backends.iter().find(|(_, l)| *l == BINS_TARGET_LANES);
    let (bb, kind) = match (at16, backends.last()) {
        (Some((b, _)), _) => (
            Some(b.clone()),
            format!(
                "bins{} frame <= {BINS_TARGET}x rgb at 16 lanes, winning layout",
                super::FRAME_BINS
            ),
        ),
        (None, Some((b, l))) => (
            Some(b.clone()),
            format!(
                "bins{} frame <= {BINS_TARGET}x rgb, winning layout (no 16-lane backend: at {b}, {l} lanes)",
                super::FRAME_BINS
            ),
        ),
        _ => (None, String::new()),
    };
    if let Some(b) = bb {
        for scene in t.distinct("scene")? {
            let mut best: Option<(f64, &str)> = None;
            for layout in ["rays", "wavelengths"] {
                let colour = format!("bins{}-{layout}", super::FRAME_BINS);
                if let Some(r) = frame_row(t, &scene, &b, &colour)? {
                    let ratio = t.f64(r, "ratio")?;
                    if best.is_none_or(|(x, _)| ratio < x) {
                        best = Some((ratio, layout));
                    }
                }
            }
            if let Some((ratio, layout)) = best {
                checks.push(Check::at_most(
                    &scene,
                    &kind,
                    format!("{b} {ratio:.2}x ({layout})"),
                    ratio,
                    BINS_TARGET,
                ));
            }
        }
    }
    Ok(md)
}

/// Which layout wins at each width, by how much, and the stage that makes the difference.
fn layouts_md(t: &Table, k: Option<&Table>) -> anyhow::Result<String> {
    let mut md = String::new();
    let bins = super::FRAME_BINS;
    let (rays_c, wl_c) = (
        format!("bins{bins}-rays"),
        format!("bins{bins}-wavelengths"),
    );
    let mut rows = Vec::new();
    for (b, lanes) in hand_written_backends(t)? {
        let (mut r_ratio, mut w_ratio) = (Vec::new(), Vec::new());
        let mut stage_r = [0.0f64; Stage::COUNT];
        let mut stage_w = [0.0f64; Stage::COUNT];
        for scene in t.distinct("scene")? {
            let (Some(r), Some(w)) = (
                frame_row(t, &scene, &b, &rays_c)?,
                frame_row(t, &scene, &b, &wl_c)?,
            ) else {
                continue;
            };
            r_ratio.push(t.f64(r, "ratio")?);
            w_ratio.push(t.f64(w, "ratio")?);
            for s in Stage::ALL {
                let col = format!("share_{}", s.name());
                stage_r[s as usize] += t.f64(r, &col)? * t.f64(r, "seconds")?;
                stage_w[s as usize] += t.f64(w, &col)? * t.f64(w, "seconds")?;
            }
        }
        if r_ratio.is_empty() {
            continue;
        }
        let (gr, gw) = (geomean(r_ratio), geomean(w_ratio));
        let winner = if gr <= gw { "rays" } else { "wavelengths" };
        // The stage whose time differs most between the layouts.
        let s = Stage::ALL
            .into_iter()
            .max_by(|a, b| {
                let d = |s: Stage| (stage_r[s as usize] - stage_w[s as usize]).abs();
                d(*a).total_cmp(&d(*b))
            })
            .expect("stages");
        let (sr, sw) = (stage_r[s as usize], stage_w[s as usize]);
        let why = format!(
            "{}: {} s over rays, {} s over wavelengths",
            s.name(),
            fmt_num(sr),
            fmt_num(sw)
        );
        let kern = match k {
            Some(k) => {
                let r = kernel_mean(k, &b, &rays_c, "ns_per_eval")?;
                let w = kernel_mean(k, &b, &wl_c, "ns_per_eval")?;
                if (r / w).is_finite() {
                    format!("{:.2}", r / w)
                } else {
                    "—".into()
                }
            }
            None => "—".into(),
        };
        rows.push(vec![
            format!("{lanes}"),
            b.clone(),
            format!("{gr:.2}x"),
            format!("{gw:.2}x"),
            winner.to_owned(),
            kern,
            why,
        ]);
    }
    if rows.is_empty() {
        return Ok(md);
    }
    md.push_str(&format!(
        "\n**Layouts**: at each width, the frames of {bins} bins over the RGB frame (geometric \
         mean over the scenes) in each layout, the faster one, the kernels' time over rays / \
         over wavelengths ({bins} bins, geometric mean over the kernels; above 1: \
         wavelengths faster), and why: the stage whose time (share x frame seconds, summed \
         over the scenes) differs most between the layouts. Over rays, each lane is a ray \
         and a bin is one register: the work per ray is N registers whatever the width, and \
         the upsampling's per-lane coefficients load once. Over wavelengths, one ray's N \
         bins fill N / lanes registers: fewer instructions per ray as the packet widens, \
         but the same N registers per packet, and each lane's coefficients are splat lane \
         by lane.\n\n"
    ));
    md.push_str(&markdown_table(
        &[
            "lanes",
            "backend",
            "over rays x rgb",
            "over wavelengths x rgb",
            "faster",
            "kernels rays / wavelengths",
            "largest stage difference",
        ],
        &rows,
    ));
    Ok(md)
}

fn error_md(t: &Table, checks: &mut Vec<Check>) -> anyhow::Result<String> {
    let mut md = format!(
        "\n**Error** (`{}`): per scene at {} x {} (every thread, the widest hand-written \
         backend), a reference of {} at {} samples per pixel; each form's image at each \
         sample count against it (`on`: the scene as built; glass1's glass disperses). PSNR: \
         both images through the reference's tone map (the scene's operator, adapted to the \
         reference), clipped to [0, 1] as displayed, peak 1. dB per samples per pixel:\n\n",
        error::FILE,
        first(t, "width"),
        first(t, "height"),
        first(t, "reference"),
        first(t, "reference_spp"),
    );
    let spps = t.distinct("spp")?;
    let table_of = |way: &str| -> anyhow::Result<String> {
        let mut rows = Vec::new();
        for scene in t.distinct("scene")? {
            for colour in t.distinct("colour")? {
                let mut row = vec![scene.clone(), colour.clone()];
                let mut any = false;
                for spp in &spps {
                    let rs = select(
                        t,
                        &[
                            ("scene", &scene),
                            ("dispersion", way),
                            ("colour", &colour),
                            ("spp", spp),
                        ],
                    )?;
                    row.push(match rs.first() {
                        Some(&r) => {
                            any = true;
                            format!("{:.1}", t.f64(r, "psnr_db")?)
                        }
                        None => "—".into(),
                    });
                }
                if any {
                    rows.push(row);
                }
            }
        }
        let mut header = vec!["scene".to_owned(), "colour".to_owned()];
        header.extend(spps.iter().map(|s| format!("{s} spp")));
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        Ok(markdown_table(&header, &rows))
    };
    md.push_str(&table_of("on")?);
    md.push_str(
        "\nWithout dispersion (`off`: every material's dispersion taken out; scenes without \
         dispersive glass reuse their images), hero and bins against the RGB image of the \
         same samples per pixel: what upsampling RGB to spectra and back changes, plus \
         hero's wavelength noise:\n\n",
    );
    md.push_str(&table_of("off")?);
    let top = spps
        .iter()
        .filter_map(|s| s.parse::<u32>().ok())
        .max()
        .unwrap_or(0)
        .to_string();
    for scene in t.distinct("scene")? {
        for r in select(
            t,
            &[("scene", &scene), ("dispersion", "off"), ("spp", &top)],
        )? {
            let colour = t.get(r, "colour")?;
            let db = t.f64(r, "psnr_db")?;
            checks.push(Check::at_least(
                &scene,
                &format!("hero and bins within {AGREEMENT_DB} dB PSNR of rgb without dispersion"),
                format!("{colour} {db:.1} dB"),
                db,
                AGREEMENT_DB,
            ));
        }
    }
    Ok(md)
}
