//! Table 3 explained, factor by factor (part of the `table3` experiment): the paper's
//! speedup of its SSE renderer over its non-SSE one split into what each change gives on
//! its own, on the BSP, 1 thread, per scene:
//!
//! - **arithmetic**: the scalar backend with the SIMD backends' estimates for `rsqrt` and
//!   `recip` (`scalar-est`: `rsqrtss`/`rcpss` instead of a division and a square root) over
//!   the exact scalar backend;
//! - **culling**: the camera rays of a film tile traced as one beam at one lane (frustum
//!   culling and the entry-point search without SIMD) over lane packets, scalar;
//! - **lanes**: each hand-written backend's lane packets over `scalar-est` (the same
//!   arithmetic, so only the width differs);
//! - **beams**: that backend's beams over its lane packets;
//! - **all together**: that backend's beams over the exact scalar backend; by construction
//!   `arithmetic x lanes x beams`.
//!
//! and each frame against the best ordinary renderer at hand too (the scalar backend with
//! Embree's single-ray queries). Protocol: one untimed frame per configuration (its image:
//! PSNR against the exact scalar + BSP one), then 3 rounds visiting every configuration in
//! turn; `seconds` is the median.

use coherent::accel_any::{AccelKind, AnyAccel};
use coherent::render::centres::psnr;
use coherent::render::{Packets, Renderer};
use coherent::simd::Backend;

use crate::ctx::Ctx;
use crate::frames::{self, Plan};
use crate::plot::BarChart;
use crate::table::{Table, fmt_num, markdown_table};
use crate::table3::{ROUNDS, find, paper_speedup};
use crate::timing::{median, speedup};

pub(crate) const FILE: &str = "table3_factors.csv";
/// The contract's columns, then the PSNR against the exact scalar + BSP image.
pub(crate) const HEADER: &[&str] = &[
    "scene",
    "backend",
    "lanes",
    "packets",
    "arithmetic",
    "accel",
    "seconds",
    "speedup_vs_scalar",
    "speedup_vs_scalar_embree",
    "psnr_db",
];

/// One frame configuration: a backend, how camera rays travel, and the accelerator (an
/// index into the scene's renderers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Config {
    backend: Backend,
    packets: Packets,
    accel: usize,
}

/// The configurations of a scene: exact scalar (the reference, first), `scalar-est`, scalar
/// beams, each of `simd`'s lane packets and beams on the BSP (renderer 0), and exact scalar
/// on Embree when `embree` is one of the renderers.
fn configs(simd: &[Backend], embree: Option<usize>) -> Vec<Config> {
    let bsp = |backend, packets| Config {
        backend,
        packets,
        accel: 0,
    };
    let mut c = vec![bsp(Backend::Scalar, Packets::Lanes)];
    if Backend::ScalarEst.is_available() {
        c.push(bsp(Backend::ScalarEst, Packets::Lanes));
    }
    c.push(bsp(Backend::Scalar, Packets::Beam));
    for &b in simd {
        c.push(bsp(b, Packets::Lanes));
        c.push(bsp(b, Packets::Beam));
    }
    if let Some(accel) = embree {
        c.push(Config {
            backend: Backend::Scalar,
            packets: Packets::Lanes,
            accel,
        });
    }
    c
}

/// The SIMD backends the factor table measures: the hand-written (or preferred) one per
/// width of those usable here.
fn simd_backends(backends: &[Backend]) -> Vec<Backend> {
    [4, 8, 16]
        .into_iter()
        .filter_map(|n| {
            Backend::preference(n)
                .iter()
                .copied()
                .find(|b| backends.contains(b))
        })
        .collect()
}

/// Measures the factor table's frames of scene `name` and writes its rows. `renderers` are
/// the scene's, the BSP first; `backends` those usable here; `reference` the exact scalar +
/// BSP image as displayed.
pub(crate) fn measure(
    out: &mut crate::table::CsvOut,
    pool: &rayon::ThreadPool,
    name: &str,
    renderers: &mut [(AccelKind, Renderer<'_, AnyAccel>)],
    backends: &[Backend],
    plan: &Plan,
    reference: &[[f32; 3]],
) -> anyhow::Result<()> {
    let embree = renderers.iter().position(|(k, _)| *k == AccelKind::Embree);
    let configs = configs(&simd_backends(backends), embree);
    let mut psnrs = Vec::new();
    for &c in &configs {
        let r = &mut renderers[c.accel].1;
        r.packets = c.packets;
        let (rendered, _) = frames::frame(pool, c.backend, r, plan)?;
        psnrs.push(psnr(&rendered.displayed(Backend::Scalar)?, reference, 1.0));
    }
    let mut seconds = vec![Vec::new(); configs.len()];
    for _ in 0..ROUNDS {
        for (i, &c) in configs.iter().enumerate() {
            let r = &mut renderers[c.accel].1;
            r.packets = c.packets;
            let (_, s) = frames::frame(pool, c.backend, r, plan)?;
            seconds[i].push(s);
        }
    }
    for (_, r) in renderers.iter_mut() {
        r.packets = Packets::Lanes;
    }
    let scalar = median(&seconds[0]);
    // Exact scalar on Embree: the last configuration when Embree is here.
    let ordinary = embree.map(|_| median(&seconds[configs.len() - 1]));
    for (i, c) in configs.iter().enumerate() {
        let s = median(&seconds[i]);
        let kind = renderers[c.accel].0;
        // scalar-est is the scalar backend with other arithmetic: the `arithmetic` column
        // tells the two apart.
        let backend = if c.backend == Backend::ScalarEst {
            Backend::Scalar
        } else {
            c.backend
        };
        out.row(&[
            &name,
            &backend.name(),
            &c.backend.lanes(),
            &c.packets.name(),
            &c.backend.arithmetic(),
            &kind,
            &format!("{s:.6e}"),
            &format!("{:.3}", speedup(scalar, s)),
            &ordinary.map_or("NaN".to_owned(), |o| format!("{:.3}", speedup(o, s))),
            &format!("{:.2}", psnrs[i]),
        ])?;
    }
    Ok(())
}

/// Seconds of a factor-table row, if the run has it.
fn seconds(
    t: &Table,
    scene: &str,
    backend: &str,
    packets: &str,
    arithmetic: &str,
    accel: &str,
) -> anyhow::Result<Option<f64>> {
    let keys = [
        ("scene", scene),
        ("backend", backend),
        ("packets", packets),
        ("arithmetic", arithmetic),
        ("accel", accel),
    ];
    match find(t, &keys)? {
        Some(r) => Ok(Some(t.f64(r, "seconds")?)),
        None => Ok(None),
    }
}

/// A scene's factors at one SIMD backend, each a speedup (`None` where the run lacks a frame).
struct Factors {
    arithmetic: Option<f64>,
    culling: Option<f64>,
    lanes: Option<f64>,
    beams: Option<f64>,
    all: Option<f64>,
    vs_embree: Option<f64>,
}

fn factors(t: &Table, scene: &str, backend: &str) -> anyhow::Result<Factors> {
    let est = match find(
        t,
        &[("scene", scene), ("backend", backend), ("accel", "bsp")],
    )? {
        Some(r) => t.get(r, "arithmetic")?.to_owned(),
        None => "estimate".to_owned(),
    };
    let est = est.as_str();
    let scalar = seconds(t, scene, "scalar", "lanes", "exact", "bsp")?;
    let scalar_est = seconds(t, scene, "scalar", "lanes", "estimate", "bsp")?;
    let scalar_beam = seconds(t, scene, "scalar", "beam", "exact", "bsp")?;
    let lanes = seconds(t, scene, backend, "lanes", est, "bsp")?;
    let beams = seconds(t, scene, backend, "beam", est, "bsp")?;
    let embree = seconds(t, scene, "scalar", "lanes", "exact", "embree")?;
    let ratio = |a: Option<f64>, b: Option<f64>| Some(speedup(a?, b?));
    // The lanes factor compares arithmetic alike: over scalar-est for an estimating backend,
    // over exact scalar for an exact one (pulp).
    let lanes_base = if est == "estimate" {
        scalar_est
    } else {
        scalar
    };
    Ok(Factors {
        arithmetic: ratio(scalar, scalar_est),
        culling: ratio(scalar, scalar_beam),
        lanes: ratio(lanes_base, lanes),
        beams: ratio(lanes, beams),
        all: ratio(scalar, beams),
        vs_embree: ratio(embree, beams),
    })
}

/// The SIMD backends of the run, narrowest first.
fn simd_in(t: &Table) -> anyhow::Result<Vec<String>> {
    let mut b: Vec<(usize, String)> = Vec::new();
    for name in t.distinct("backend")? {
        if name != "scalar" {
            let r = t.rows_where("backend", &name)?[0];
            b.push((t.f64(r, "lanes")? as usize, name));
        }
    }
    b.sort();
    Ok(b.into_iter().map(|(_, n)| n).collect())
}

fn opt(v: Option<f64>) -> String {
    v.map_or("—".to_owned(), |v| format!("{}x", fmt_num(v)))
}

/// The plot: per scene, each factor at the widest SIMD backend of the run, beside the
/// paper's speedup.
pub(crate) fn plot(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(());
    };
    if t.rows.is_empty() {
        return Ok(());
    }
    let scenes = t.distinct("scene")?;
    let widest = simd_in(&t)?.pop();
    let mut series: Vec<(String, Vec<f64>)> = Vec::new();
    let names: Vec<String> = match &widest {
        Some(w) => vec![
            "arithmetic (scalar-est)".into(),
            "culling (scalar beams)".into(),
            format!("lanes ({w})"),
            format!("beams ({w})"),
            format!("all ({w} beams)"),
        ],
        None => vec![
            "arithmetic (scalar-est)".into(),
            "culling (scalar beams)".into(),
        ],
    };
    let mut values = vec![Vec::new(); names.len()];
    for s in &scenes {
        let f = factors(&t, s, widest.as_deref().unwrap_or("scalar"))?;
        let all = [f.arithmetic, f.culling, f.lanes, f.beams, f.all];
        for (v, x) in values.iter_mut().zip(all) {
            v.push(x.unwrap_or(f64::NAN));
        }
    }
    series.extend(names.into_iter().zip(values));
    series.push((
        "paper SSE".to_owned(),
        scenes
            .iter()
            .map(|s| paper_speedup(s).unwrap_or(f64::NAN))
            .collect(),
    ));
    ctx.bar_chart(
        "table3_factors",
        &BarChart {
            title: "Table 3 explained: each factor's speedup (BSP, 1 thread)".into(),
            y_label: "speedup".into(),
            categories: scenes,
            series,
        },
    )?;
    Ok(())
}

/// The report's section: the factors per scene and SIMD backend, beside the paper's figure.
pub(crate) fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    if t.rows.is_empty() {
        return Ok(None);
    }
    let mut md = String::from(
        "\n### Table 3 explained, factor by factor\n\nThe paper's speedup of its SSE renderer \
         over its non-SSE one, split into what each change gives alone (`table3_factors.csv`; \
         BSP, 1 thread, the frames above; 3 rounds, medians). **arithmetic**: the scalar \
         backend with the SIMD backends' estimates for `rsqrt`/`recip` (`scalar-est`) over the \
         exact scalar backend; **culling**: a film tile's camera rays as one beam at one lane \
         over lane packets (scalar); **lanes**: the backend's lane packets over the scalar \
         backend of the same arithmetic; **beams**: its beams over its lane packets; **all**: \
         its beams over exact scalar (= arithmetic x lanes x beams for the estimating \
         backends); **vs scalar + Embree**: its beams over the scalar backend on Embree's \
         single-ray queries, the best ordinary renderer at hand.\n\n",
    );
    let mut rows = Vec::new();
    for s in t.distinct("scene")? {
        let paper = paper_speedup(&s).map_or("—".to_owned(), |v| format!("{}x", fmt_num(v)));
        for b in simd_in(&t)? {
            let f = factors(&t, &s, &b)?;
            rows.push(vec![
                s.clone(),
                b.clone(),
                opt(f.arithmetic),
                opt(f.culling),
                opt(f.lanes),
                opt(f.beams),
                opt(f.all),
                opt(f.vs_embree),
                paper.clone(),
            ]);
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "backend",
            "arithmetic",
            "culling (1 lane)",
            "lanes",
            "beams",
            "all",
            "vs scalar + Embree",
            "paper",
        ],
        &rows,
    ));
    if let Some(p) = ctx.plot_markdown("table3_factors", "each factor of the speedup per scene") {
        md.push_str(&p);
    }
    Ok(Some(md))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configs_start_with_the_reference_and_cover_every_factor() {
        let c = configs(&[Backend::Scalar], Some(2));
        assert_eq!(c[0].backend, Backend::Scalar);
        assert_eq!(c[0].packets, Packets::Lanes);
        assert_eq!(c[0].accel, 0);
        assert!(
            c.iter()
                .any(|c| c.packets == Packets::Beam && c.backend == Backend::Scalar)
        );
        assert_eq!(c.last().unwrap().accel, 2);
        assert_eq!(
            c.iter().any(|c| c.backend == Backend::ScalarEst),
            Backend::ScalarEst.is_available()
        );
    }

    #[test]
    fn factors_multiply_to_the_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE);
        let mut out = crate::table::CsvOut::create(&path, HEADER).unwrap();
        let rows: [(&str, usize, &str, &str, &str, f64); 6] = [
            ("scalar", 1, "lanes", "exact", "bsp", 12.0),
            ("scalar", 1, "lanes", "estimate", "bsp", 10.0),
            ("scalar", 1, "beam", "exact", "bsp", 8.0),
            ("sse", 4, "lanes", "estimate", "bsp", 4.0),
            ("sse", 4, "beam", "estimate", "bsp", 2.0),
            ("scalar", 1, "lanes", "exact", "embree", 6.0),
        ];
        for (b, lanes, p, a, accel, s) in rows {
            out.row(&[&"room2", &b, &lanes, &p, &a, &accel, &s, &1.0, &1.0, &"inf"])
                .unwrap();
        }
        out.finish().unwrap();
        let t = Table::read(&path, HEADER).unwrap();
        let f = factors(&t, "room2", "sse").unwrap();
        assert_eq!(f.arithmetic, Some(1.2));
        assert_eq!(f.culling, Some(1.5));
        assert_eq!(f.lanes, Some(2.5));
        assert_eq!(f.beams, Some(2.0));
        assert_eq!(f.all, Some(6.0));
        assert_eq!(f.vs_embree, Some(3.0));
        let product = f.arithmetic.unwrap() * f.lanes.unwrap() * f.beams.unwrap();
        assert!((product - f.all.unwrap()).abs() < 1e-12);
        assert_eq!(simd_in(&t).unwrap(), vec!["sse".to_owned()]);
    }
}
