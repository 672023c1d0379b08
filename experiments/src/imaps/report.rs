//! The README section of `imaps`, from its CSV files: the particle rays' speed per mode and
//! generation, the map's error against particles, the frames with the map, and the targets.

use super::error::{REFERENCE_FACTOR, log_log_slope};
use super::plots::{ERROR_PARTICLES, ERROR_SECONDS, rays_stem, target_backend};
use super::{error, frames, speed};
use crate::ctx::Ctx;
use crate::table::{Table, fmt_num, markdown_table};
use crate::targets::{Check, condensed};

/// Sorted streams' rays per second over `packets`' from the second generation on, at least.
pub const SORTED_TARGET: f64 = 1.5;
/// The error's log-log slope against particles, and how far from it (relative) it may be.
pub const SLOPE: f64 = -0.5;
pub const SLOPE_TOLERANCE: f64 = 0.2;
/// A frame with the map's indirect light over a direct-only frame, at most.
pub const FRAME_TARGET: f64 = 1.5;
/// The map's disagreement with the path-traced reference (mean absolute difference over
/// 8 x 8 blocks) over the reference's own noise there, at most.
pub const AGREEMENT_TARGET: f64 = 2.0;

pub(super) fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let s = ctx.read_csv(speed::FILE, speed::HEADER)?;
    let e = ctx.read_csv(error::FILE, error::HEADER)?;
    let f = ctx.read_csv(frames::FILE, frames::HEADER)?;
    if s.is_none() && e.is_none() && f.is_none() {
        return Ok(None);
    }
    let mut md = String::from(
        "Illumination maps (paper section 2; section 8 names the coherence of forward rays as \
         the next problem): particles leave the lights and bounce, one generation at a time, \
         depositing their power in surface cells from their second hit on. Each \
         generation's live rays are traced one per packet (`single`), in particle order cut \
         into packets (`packets`), as sorted streams (`sorted`, after Áfra et al. 2016: \
         direction octant, Morton code of the origin, coarse direction) or grouped by \
         direction octant (`octant`, after Boulos et al. 2008). The same particles should give \
         the same map in every mode: `map vs single` below is the relative difference (the \
         error metric below) of each mode's map from `single`'s, 0 where every ray hits the \
         same triangle whichever packet carries it; a particle whose hit differs between \
         single-ray and packet traversal takes another path and moves its deposits.\n",
    );
    let mut checks = Vec::new();
    if let Some(t) = &s {
        md.push_str(&speed_md(ctx, t, &mut checks)?);
    }
    if let Some(t) = &e {
        md.push_str(&error_md(ctx, t, &mut checks)?);
    }
    if let Some(t) = &f {
        md.push_str(&frames_md(t, &mut checks)?);
    }
    if !checks.is_empty() {
        md.push_str(&format!(
            "\nTargets (sorted streams >= {SORTED_TARGET}x the rays per second of `packets` \
             from the second generation on, generation 1 in the table's numbering from 0; BSP \
             at 16 lanes; error slope {SLOPE} within \
             {:.0}%; a frame with the map <= {FRAME_TARGET}x a direct-only one; on cornell, \
             the map within {AGREEMENT_TARGET}x the path-traced reference's own noise):\n\n",
            SLOPE_TOLERANCE * 100.0
        ));
        md.push_str(&condensed("scene", &checks));
    }
    Ok(Some(md))
}

/// The rows of `t` where each `(column, value)` holds.
fn select(t: &Table, wheres: &[(&str, &str)]) -> anyhow::Result<Vec<usize>> {
    let mut out = Vec::new();
    'rows: for r in 0..t.len() {
        for (col, value) in wheres {
            if t.get(r, col)? != *value {
                continue 'rows;
            }
        }
        out.push(r);
    }
    Ok(out)
}

/// `3` for one generation, `8-13` for several summed.
fn generation_label(t: &Table, r: usize) -> anyhow::Result<String> {
    let g = t.f64(r, "generation")? as u64;
    let n = t.f64(r, "generations")? as u64;
    Ok(if n > 1 {
        format!("{g}-{}", g + n - 1)
    } else {
        g.to_string()
    })
}

/// Rays per second over the rows `rows` together: their rays over the sum of their times.
fn pooled_rate(t: &Table, rows: &[usize], column: &str) -> anyhow::Result<f64> {
    let (mut rays, mut seconds) = (0.0, 0.0);
    for &r in rows {
        let n = t.f64(r, "rays")?;
        rays += n;
        seconds += n / t.f64(r, column)?;
    }
    Ok(rays / seconds)
}

fn speed_md(ctx: &Ctx, t: &Table, checks: &mut Vec<Check>) -> anyhow::Result<String> {
    let Some(backend) = target_backend(t)? else {
        return Ok(String::new());
    };
    let first = |col: &str| -> String { t.get(0, col).unwrap_or("?").to_owned() };
    let mut md = format!(
        "\n**Speed** (`{}`): {} particles per map, one thread, every backend measured on the \
         BSP and Embree; per scene, accelerator and backend one untimed map per mode with the \
         traversal's work counted, then {} rounds of one map per mode (the modes' order \
         rotating), medians. `Mrays/s` counts tracing only (with the sort: `sorted` \
         also pays its sort). Generations {} on are summed in one row. At {backend}, BSP:\n\n",
        speed::FILE,
        first("particles"),
        first("rounds"),
        speed::KEPT_GENERATIONS,
    );
    let modes = t.distinct("mode")?;
    let mut rows = Vec::new();
    for scene in t.distinct("scene")? {
        let base = [
            ("scene", scene.as_str()),
            ("accel", "bsp"),
            ("backend", backend.as_str()),
        ];
        let mode_rows = |mode: &str| -> anyhow::Result<Vec<usize>> {
            let mut w = base.to_vec();
            w.push(("mode", mode));
            select(t, &w)
        };
        let packets = mode_rows("packets")?;
        let sorted = mode_rows("sorted")?;
        for (i, &p) in packets.iter().enumerate() {
            let mut row = vec![
                scene.clone(),
                generation_label(t, p)?,
                t.get(p, "rays")?.to_owned(),
            ];
            for m in &modes {
                let rs = mode_rows(m)?;
                row.push(
                    rs.get(i)
                        .map(|&r| t.f64(r, "mrays_per_s").map(fmt_num))
                        .transpose()?
                        .unwrap_or_else(|| "—".into()),
                );
            }
            let cell = |rows: &[usize], col: &str| -> anyhow::Result<String> {
                Ok(rows
                    .get(i)
                    .map(|&r| t.f64(r, col).map(fmt_num))
                    .transpose()?
                    .unwrap_or_else(|| "—".into()))
            };
            row.push(format!(
                "{} / {}",
                cell(&packets, "lanes_per_packet")?,
                cell(&sorted, "lanes_per_packet")?
            ));
            row.push(format!(
                "{} / {}",
                cell(&packets, "inner_nodes_per_ray")?,
                cell(&sorted, "inner_nodes_per_ray")?
            ));
            row.push(match sorted.get(i) {
                Some(&s) => format!(
                    "{:.2}x ({:.2}x)",
                    t.f64(s, "mrays_per_s")? / t.f64(p, "mrays_per_s")?,
                    t.f64(s, "mrays_per_s_with_sort")? / t.f64(p, "mrays_per_s")?
                ),
                None => "—".into(),
            });
            row.push(cell(&sorted, "sort_share")?);
            rows.push(row);
        }
        // The target: generations after the one leaving the lights (numbered from 0), pooled.
        if packets.len() > 1 && sorted.len() > 1 {
            let p = pooled_rate(t, &packets[1..], "mrays_per_s")?;
            let s = pooled_rate(t, &sorted[1..], "mrays_per_s")?;
            let sw = pooled_rate(t, &sorted[1..], "mrays_per_s_with_sort")?;
            checks.push(Check::at_least(
                &scene,
                &format!("sorted >= {SORTED_TARGET}x packets, generation 1 on (bsp, {backend})"),
                format!(
                    "{:.2}x, {:.2}x with the sort: {} vs {} Mrays/s (>= {SORTED_TARGET}x)",
                    s / p,
                    sw / p,
                    fmt_num(s),
                    fmt_num(p)
                ),
                s / p,
                SORTED_TARGET,
            ));
        }
    }
    let mut header: Vec<String> = vec!["scene".into(), "generation".into(), "rays".into()];
    header.extend(modes.iter().map(|m| format!("{m} Mrays/s")));
    header.extend([
        "lanes per packet, packets / sorted".into(),
        "inner nodes per ray, packets / sorted".into(),
        "sorted over packets (with the sort)".into(),
        "sort share".into(),
    ]);
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));

    // Whole maps per accelerator and backend.
    md.push_str(
        "\nWhole maps, seconds per mode (median; every generation, sorting and shading \
         included), and the largest difference of any mode's map from `single`'s:\n\n",
    );
    let mut rows = Vec::new();
    for scene in t.distinct("scene")? {
        for accel in t.distinct("accel")? {
            for b in t.distinct("backend")? {
                let mut row = vec![scene.clone(), accel.clone()];
                let mut lanes = String::new();
                let mut diff = 0.0f64;
                let mut any = false;
                for m in &modes {
                    let rs = select(
                        t,
                        &[
                            ("scene", &scene),
                            ("accel", &accel),
                            ("backend", &b),
                            ("mode", m),
                        ],
                    )?;
                    match rs.first() {
                        Some(&r) => {
                            any = true;
                            lanes = t.get(r, "lanes")?.to_owned();
                            diff = diff.max(t.f64(r, "map_vs_single")?);
                            row.push(fmt_num(t.f64(r, "map_s")?));
                        }
                        None => row.push("—".into()),
                    }
                }
                if any {
                    row.insert(2, format!("{b} ({lanes})"));
                    row.push(format!("{diff:.1e}"));
                    rows.push(row);
                }
            }
        }
    }
    let mut header: Vec<String> = vec!["scene".into(), "accel".into(), "backend (lanes)".into()];
    header.extend(modes.iter().map(|m| format!("{m} s")));
    header.push("map vs single".into());
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));
    for scene in t.distinct("scene")? {
        md.push_str(
            &ctx.plot_markdown(
                &rays_stem(&scene),
                &format!("{scene}: particle rays per second per generation"),
            )
            .unwrap_or_default(),
        );
    }
    Ok(md)
}

fn error_md(ctx: &Ctx, t: &Table, checks: &mut Vec<Check>) -> anyhow::Result<String> {
    let first = |col: &str| -> String { t.get(0, col).unwrap_or("?").to_owned() };
    let mut md = format!(
        "\n**Error** (`{}`): per scene a reference map of {} particles ({REFERENCE_FACTOR}x the \
         largest budget, every thread), then per budget {} maps from other seeds ({}, BSP, \
         `{}`, one thread). The error is the root mean square over the cells, weighted by \
         area, of the irradiance difference from the reference, over the reference's mean \
         irradiance; a budget's is the RMS over its seeds (smallest and largest beside it). \
         `slope`: least squares of log error against log particles.\n\n",
        error::FILE,
        first("reference_particles"),
        first("seeds"),
        first("backend"),
        first("mode"),
    );
    let mut rows = Vec::new();
    for scene in t.distinct("scene")? {
        let rs = t.rows_where("scene", &scene)?;
        let mut pts = Vec::new();
        for &r in &rs {
            pts.push((t.f64(r, "particles")?, t.f64(r, "rel_error")?));
        }
        let slope = log_log_slope(&pts);
        for (k, &r) in rs.iter().enumerate() {
            rows.push(vec![
                scene.clone(),
                t.get(r, "particles")?.to_owned(),
                format!(
                    "{} ({} to {})",
                    fmt_num(t.f64(r, "rel_error")?),
                    fmt_num(t.f64(r, "rel_error_min")?),
                    fmt_num(t.f64(r, "rel_error_max")?)
                ),
                fmt_num(t.f64(r, "seconds")?),
                if k == 0 {
                    format!("{slope:.3}")
                } else {
                    String::new()
                },
            ]);
        }
        let off = (slope - SLOPE).abs() / SLOPE.abs();
        checks.push(Check::at_most(
            &scene,
            &format!("error slope {SLOPE} within {:.0}%", SLOPE_TOLERANCE * 100.0),
            format!("slope {slope:.3}, {:.0}% off", off * 100.0),
            off,
            SLOPE_TOLERANCE,
        ));
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "particles",
            "relative error (min to max)",
            "seconds",
            "slope",
        ],
        &rows,
    ));
    for (stem, alt) in [
        (ERROR_PARTICLES, "map error against particles"),
        (ERROR_SECONDS, "map error against seconds"),
    ] {
        md.push_str(&ctx.plot_markdown(stem, alt).unwrap_or_default());
    }
    Ok(md)
}

fn frames_md(t: &Table, checks: &mut Vec<Check>) -> anyhow::Result<String> {
    let first = |col: &str| -> String { t.get(0, col).unwrap_or("?").to_owned() };
    let mut md = format!(
        "\n**Frames** (`{}`): {} x {} at {} sample(s) per pixel, {}, BSP, one thread, direct \
         light only and with the map's indirect light (the map of {} particles built before, \
         every thread, without caustics: particles whose first bounce is a mirror or glass, \
         whose light the path tracer cannot find, are left out; its seconds beside), medians of {} interleaved rounds. On cornell, the \
         map's image against a path-traced reference of {} samples per pixel (two independent \
         halves): the mean absolute difference of 8 x 8 block means, and the reference's own \
         noise there (half the mean absolute difference of its halves' blocks), both relative \
         to the reference's mean.\n\n",
        frames::FILE,
        first("width"),
        first("height"),
        first("spp"),
        first("backend"),
        first("particles"),
        first("rounds"),
        first("path_spp"),
    );
    let mut rows = Vec::new();
    for r in 0..t.len() {
        let scene = t.get(r, "scene")?.to_owned();
        let ratio = t.f64(r, "ratio")?;
        let (diff, noise) = (t.f64(r, "block_diff")?, t.f64(r, "path_noise")?);
        rows.push(vec![
            scene.clone(),
            fmt_num(t.f64(r, "map_s")?),
            fmt_num(t.f64(r, "direct_s")?),
            fmt_num(t.f64(r, "imap_s")?),
            format!("{ratio:.2}x"),
            if diff.is_finite() {
                format!("{} / {}", fmt_num(diff), fmt_num(noise))
            } else {
                "—".into()
            },
        ]);
        checks.push(Check::at_most(
            &scene,
            &format!("imap frame <= {FRAME_TARGET}x direct"),
            format!("{ratio:.2}x (<= {FRAME_TARGET}x)"),
            ratio,
            FRAME_TARGET,
        ));
        if diff.is_finite() && noise.is_finite() {
            let a = diff / noise;
            checks.push(Check::at_most(
                &scene,
                &format!("imap within {AGREEMENT_TARGET}x the path reference's noise"),
                format!(
                    "{a:.2}x: {} vs {} of the mean (<= {AGREEMENT_TARGET}x)",
                    fmt_num(diff),
                    fmt_num(noise)
                ),
                a,
                AGREEMENT_TARGET,
            ));
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "map s",
            "direct s",
            "imap s",
            "imap over direct",
            "imap vs path / path noise",
        ],
        &rows,
    ));
    Ok(md)
}
