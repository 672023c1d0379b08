//! The BSP's sweeps after the comparison: the packet-to-single-ray switch threshold
//! (`accel_threshold.csv`) and packets of mixed direction signs walked together or per sign
//! group (`accel_mixed_signs.csv`).

use coherent::accel::{Accel, Ray1};
use coherent::bsp::{Bsp, BspParams};
use coherent_accel::scenes::BuiltinScene;
use coherent_accel::workload::RayKind;
use indicatif::ProgressBar;

use super::measure::{Setup, disagreement, interleaved, pass_any};
use super::rays::rays;
use crate::ctx::Ctx;

/// The switch threshold: packet subtrees with at most `t` active lanes continue ray by ray
/// (on two scenes).
pub(super) fn threshold(
    ctx: &Ctx,
    setup: &Setup,
    all: &[BuiltinScene],
    built: &mut [Bsp],
    bar: &ProgressBar,
) -> anyhow::Result<()> {
    let mut thr = ctx.csv("accel_threshold.csv", super::THRESHOLD_HEADER)?;
    for (s, bsp) in all.iter().zip(built) {
        if s.name != "blob" && s.name != "room" {
            bar.inc(1);
            continue;
        }
        for kind in RayKind::ALL {
            for &(wd, b) in setup.widths.iter().filter(|(wd, _)| *wd > 1) {
                let rays = rays(s, bsp, kind, setup.w, setup.h, wd);
                let ts: Vec<u32> = [0, 1, 2, 3, 4, 6, 8]
                    .into_iter()
                    .filter(|&t| t as usize <= wd / 2)
                    .collect();
                let secs = interleaved(ts.len(), setup.samples, |i| {
                    bsp.set_traversal_params(true, Some(ts[i]));
                    pass_any(bsp, &rays, kind.occlusion(), b)
                })?;
                for (i, t) in ts.iter().enumerate() {
                    thr.row(&[
                        &s.name,
                        &kind.name(),
                        &wd,
                        &b.map_or("scalar", |b| b.name()),
                        t,
                        &format!("{:.3}", rays.len() as f64 / secs[i].0 / 1e6),
                    ])?;
                }
            }
        }
        bsp.set_traversal_params(true, None);
        bar.inc(1);
    }
    thr.finish()?;
    Ok(())
}

/// Packets whose lanes differ in direction signs: walked together (the default) against
/// one walk per group of equal signs (the paper's way), on the same rays, interleaved.
pub(super) fn mixed_signs(
    ctx: &Ctx,
    setup: &Setup,
    all: &[BuiltinScene],
    built: &[Bsp],
    bar: &ProgressBar,
) -> anyhow::Result<()> {
    let mut mixed = ctx.csv("accel_mixed_signs.csv", super::MIXED_HEADER)?;
    let mut disagreements = Vec::new();
    for (s, bsp) in all.iter().zip(built) {
        let split = Bsp::build(
            &s.scene,
            &BspParams {
                mixed_signs: false,
                ..BspParams::default()
            },
        )?;
        for kind in RayKind::ALL {
            for &(wd, b) in setup.widths.iter().filter(|(wd, _)| *wd > 1) {
                let rays = rays(s, bsp, kind, setup.w, setup.h, wd);
                let res = interleaved(2, setup.samples, |i| {
                    let a = if i == 0 { &split } else { bsp };
                    pass_any(a, &rays, kind.occlusion(), b)
                })?;
                if let Some(why) = disagreement(&res[0].1, &res[1].1, rays.len()) {
                    disagreements.push(format!(
                        "{} {} rays at width {wd}: together against per sign group: {why}",
                        s.name,
                        kind.name()
                    ));
                }
                let rate = |i: usize| rays.len() as f64 / res[i].0 / 1e6;
                mixed.row(&[
                    &s.name,
                    &kind.name(),
                    &wd,
                    &b.map_or("scalar", |b| b.name()),
                    &format!("{:.3}", rate(0)),
                    &format!("{:.3}", rate(1)),
                    &format!("{:.3}", rate(1) / rate(0)),
                    &format!("{:.3}", sign_groups_per_packet(&rays, wd)),
                ])?;
            }
        }
        bar.inc(1);
    }
    mixed.finish()?;
    if !disagreements.is_empty() {
        anyhow::bail!(
            "accel: the BSP's packets answer differently together and per sign group:\n  {}",
            disagreements.join("\n  ")
        );
    }
    Ok(())
}

/// The average number of groups of equal direction signs in the packets of `width`
/// consecutive rays (what a walk per sign group walks per packet).
fn sign_groups_per_packet(rays: &[Ray1], width: usize) -> f64 {
    let packets = rays.chunks(width);
    let n = packets.len().max(1) as f64;
    let groups: usize = packets
        .map(|p| {
            let mut seen = [false; 8];
            for r in p {
                let d = r.dir.to_array();
                let k = (0..3).fold(0, |k, a| k | (usize::from(d[a].is_sign_negative()) << a));
                seen[k] = true;
            }
            seen.iter().filter(|&&x| x).count()
        })
        .sum();
    groups as f64 / n
}
