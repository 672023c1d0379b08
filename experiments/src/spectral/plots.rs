//! The plots of `spectral`, from its CSV files: the cost of a colour evaluation against the
//! channels a ray carries, and the two bin layouts' time ratio against the packet width.

use crate::ctx::Ctx;
use crate::frames::is_hand_written;
use crate::plot::{LineChart, Series};
use crate::table::Table;

use super::{frames, kernels};

pub const COST_CHANNELS: &str = "spectral_cost_channels";
pub const LAYOUT_RATIO: &str = "spectral_layout_ratio";

/// The geometric mean of the positive finite values (NaN without any).
pub fn geomean(values: impl IntoIterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for v in values {
        if v > 0.0 && v.is_finite() {
            sum += v.ln();
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).exp()
    }
}

/// The rows of `t` where each `(column, value)` holds.
pub fn select(t: &Table, wheres: &[(&str, &str)]) -> anyhow::Result<Vec<usize>> {
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

/// The geometric mean over the kernels of `column` for `backend` and `colour`.
pub fn kernel_mean(t: &Table, backend: &str, colour: &str, column: &str) -> anyhow::Result<f64> {
    let rows = select(t, &[("backend", backend), ("colour", colour)])?;
    let mut v = Vec::new();
    for r in rows {
        v.push(t.f64(r, column)?);
    }
    Ok(geomean(v))
}

/// The hand-written backends of `t`'s rows, with their lanes, narrowest first.
pub fn hand_written_backends(t: &Table) -> anyhow::Result<Vec<(String, f64)>> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for b in t.distinct("backend")? {
        if is_hand_written(&b) {
            let r = t.rows_where("backend", &b)?[0];
            out.push((b, t.f64(r, "lanes")?));
        }
    }
    out.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok(out)
}

/// The bin counts in `t` (from its `binsN-LAYOUT` labels), ascending.
pub fn bin_counts(t: &Table) -> anyhow::Result<Vec<u32>> {
    let mut out: Vec<u32> = t
        .distinct("colour")?
        .iter()
        .filter_map(|c| c.strip_prefix("bins")?.split('-').next()?.parse().ok())
        .collect();
    out.sort();
    out.dedup();
    Ok(out)
}

pub(super) fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let k = ctx.read_csv(kernels::FILE, kernels::HEADER)?;
    let f = ctx.read_csv(frames::FILE, frames::HEADER)?;
    if let Some(t) = &k {
        cost_channels(ctx, t)?;
    }
    if k.is_some() || f.is_some() {
        layout_ratio(ctx, k.as_ref(), f.as_ref())?;
    }
    Ok(())
}

/// Ns per colour evaluation (geometric mean over the kernels) against channels, one line
/// per hand-written backend and layout (rgb and hero start both).
fn cost_channels(ctx: &Ctx, t: &Table) -> anyhow::Result<()> {
    let bins = bin_counts(t)?;
    let mut series = Vec::new();
    for (b, lanes) in hand_written_backends(t)? {
        for layout in ["rays", "wavelengths"] {
            let mut colours = vec![("rgb".to_owned(), 3.0), ("hero".to_owned(), 4.0)];
            colours.extend(
                bins.iter()
                    .map(|n| (format!("bins{n}-{layout}"), f64::from(*n))),
            );
            let mut points = Vec::new();
            for (c, channels) in colours {
                let ns = kernel_mean(t, &b, &c, "ns_per_eval")?;
                if ns.is_finite() {
                    points.push((channels, ns));
                }
            }
            if points.len() > 2 {
                series.push(Series::new(
                    format!("{b} ({lanes} lanes), bins over {layout}"),
                    points,
                ));
            }
        }
    }
    if series.is_empty() {
        return Ok(());
    }
    ctx.line_chart(
        COST_CHANNELS,
        &LineChart {
            title:
                "Spectral colour: ns per colour evaluation against channels (Tables 1-2 kernels)"
                    .into(),
            x_label: "channels per ray (rgb 3, hero 4, bins N)".into(),
            y_label: "ns per evaluation, geometric mean over the kernels".into(),
            series,
            log2_x: true,
            log_y: true,
        },
    )?;
    Ok(())
}

/// Time over rays / time over wavelengths against lanes: per bin count from the kernels
/// (geometric mean over them), and from the frames (geometric mean over the scenes).
fn layout_ratio(ctx: &Ctx, k: Option<&Table>, f: Option<&Table>) -> anyhow::Result<()> {
    let mut series = Vec::new();
    let mut lanes_seen: Vec<f64> = Vec::new();
    if let Some(t) = k {
        for n in bin_counts(t)? {
            let mut points = Vec::new();
            for (b, lanes) in hand_written_backends(t)? {
                let rays = kernel_mean(t, &b, &format!("bins{n}-rays"), "ns_per_eval")?;
                let wl = kernel_mean(t, &b, &format!("bins{n}-wavelengths"), "ns_per_eval")?;
                if (rays / wl).is_finite() {
                    points.push((lanes, rays / wl));
                    lanes_seen.push(lanes);
                }
            }
            if !points.is_empty() {
                series.push(Series::new(format!("kernels, {n} bins"), points));
            }
        }
    }
    if let Some(t) = f {
        for n in bin_counts(t)? {
            let mut points = Vec::new();
            for (b, lanes) in hand_written_backends(t)? {
                let mut ratios = Vec::new();
                for scene in t.distinct("scene")? {
                    let get = |layout: &str| -> anyhow::Result<Option<f64>> {
                        let colour = format!("bins{n}-{layout}");
                        let rows = select(
                            t,
                            &[("scene", &scene), ("backend", &b), ("colour", &colour)],
                        )?;
                        rows.first().map(|&r| t.f64(r, "seconds")).transpose()
                    };
                    if let (Some(r), Some(w)) = (get("rays")?, get("wavelengths")?) {
                        ratios.push(r / w);
                    }
                }
                let g = geomean(ratios);
                if g.is_finite() {
                    points.push((lanes, g));
                    lanes_seen.push(lanes);
                }
            }
            if !points.is_empty() {
                series.push(Series::new(
                    format!("frames, {n} bins (over the scenes)"),
                    points,
                ));
            }
        }
    }
    if series.is_empty() {
        return Ok(());
    }
    let lo = lanes_seen.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = lanes_seen.iter().copied().fold(0.0, f64::max);
    series.push(Series::reference("equal", vec![(lo, 1.0), (hi, 1.0)]));
    ctx.line_chart(
        LAYOUT_RATIO,
        &LineChart {
            title: "Spectral bins: time over rays / time over wavelengths, per packet width".into(),
            x_label: "lanes (scalar, sse, avx2, avx512)".into(),
            y_label: "over rays / over wavelengths (above 1: wavelengths faster)".into(),
            series,
            log2_x: true,
            log_y: false,
        },
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometric_mean_skips_what_is_not_a_positive_number() {
        assert!((geomean([1.0, 4.0, f64::NAN, 0.0]) - 2.0).abs() < 1e-12);
        assert!(geomean([]).is_nan());
    }
}
