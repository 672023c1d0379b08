//! The report's table3 section: Table 3 beside the paper's, the targets, the builds, where
//! the time goes, coherence by depth and the tile-shared light samples.

use coherent::simd::Backend;

use super::*;
use crate::ctx::Ctx;
use crate::factors;
use crate::table::{Table, fmt_num, markdown_table};
use crate::targets::{Check, condensed};

/// The built-in scene of many objects, whose targets compare the BSP with Embree per width.
const MANY_OBJECTS: &str = "city";

/// The report's builds section: per scene, each build's seconds and the time to a first
/// image (build plus one frame at the widest backend) with every BSP preset the file has, the
/// presets' SAH costs against `exact`'s, which preset gives the shortest time to a first image
/// and each preset's total over the scenes, and the many-object scene's targets against
/// Embree.
fn builds_md(b: &Table, frames: &Table) -> anyhow::Result<String> {
    let default = coherent::bsp::BuildPreset::default().name();
    let mut md = format!(
        "\nBuilds and the time to a first image (`table3_builds.csv`): each structure built \
         over the scene's objects once the static instances are merged per transform (as \
         `coherent render` does unless told `--no-merge`), then one frame on it at the widest \
         backend, one thread (median of the rounds). The BSP builds on every core with every \
         preset (the frames above use `{default}`), Embree on one thread, as the renderer asks. \
         SAH: each BSP object tree's cost relative to its root box, summed.\n\n",
    );
    let bsp_presets: Vec<&str> = coherent::bsp::BuildPreset::ALL
        .iter()
        .map(|p| p.name())
        .filter(|p| find(b, &[("accel", "bsp"), ("preset", p)]).is_ok_and(|r| r.is_some()))
        .collect();
    let mut rows = Vec::new();
    // Per preset: the scenes where it gives the shortest time to a first image, and its sum
    // of those times over the scenes that have every preset.
    let mut wins = vec![0usize; bsp_presets.len()];
    let mut totals = vec![0.0f64; bsp_presets.len()];
    let mut complete = 0usize;
    let mut checks = Vec::new();
    for scene in b.distinct("scene")? {
        let get = |accel: &str, preset: &str| -> anyhow::Result<Option<(f64, f64, f64)>> {
            Ok(
                match find(
                    b,
                    &[("scene", &scene), ("accel", accel), ("preset", preset)],
                )? {
                    Some(r) => Some((
                        b.f64(r, "build_s")?,
                        b.f64(r, "frame_s")?,
                        b.f64(r, "sah_cost").unwrap_or(f64::NAN),
                    )),
                    None => None,
                },
            )
        };
        let bsp = bsp_presets
            .iter()
            .map(|p| get("bsp", p))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let embree = get("embree", "default")?;
        let exact = get("bsp", "exact")?;
        let r0 = b.rows_where("scene", &scene)?[0];
        let both = |v: Option<(f64, f64, f64)>| {
            v.map_or("—".to_owned(), |(bs, fs, _)| {
                format!("{} + {} s", fmt_num(bs), fmt_num(fs))
            })
        };
        let firsts: Option<Vec<f64>> = bsp.iter().map(|v| v.map(|(bs, fs, _)| bs + fs)).collect();
        if let Some(firsts) = firsts.filter(|f| !f.is_empty()) {
            complete += 1;
            let best = (0..firsts.len())
                .min_by(|&i, &j| firsts[i].total_cmp(&firsts[j]))
                .expect("a preset");
            wins[best] += 1;
            for (t, f) in totals.iter_mut().zip(&firsts) {
                *t += f;
            }
        }
        let mut row = vec![
            scene.clone(),
            b.get(r0, "objects")?.to_owned(),
            b.get(r0, "triangles")?.to_owned(),
        ];
        row.extend(bsp.iter().map(|&v| both(v)));
        row.push(both(embree));
        for (p, v) in bsp_presets.iter().zip(&bsp) {
            if *p == "exact" {
                continue;
            }
            row.push(match (exact, v) {
                (Some(x), Some(f)) if x.2 > 0.0 => format!("{:+.1} %", 100.0 * (f.2 / x.2 - 1.0)),
                _ => "—".to_owned(),
            });
        }
        rows.push(row);
        if scene == MANY_OBJECTS {
            if let (Some(x), Some(e)) = (get("bsp", default)?, embree) {
                checks.push(Check::at_most(
                    &scene,
                    "bsp build <= 1.5x embree's",
                    format!("{:.2}x", x.0 / e.0),
                    x.0 / e.0,
                    1.5,
                ));
            }
            for r in frames.rows_where("scene", &scene)? {
                if frames.get(r, "accel")? != "bsp" {
                    continue;
                }
                let backend = frames.get(r, "backend")?;
                if let Some(e) = find(
                    frames,
                    &[("scene", &scene), ("backend", backend), ("accel", "embree")],
                )? {
                    let (bs, es) = (frames.f64(r, "seconds")?, frames.f64(e, "seconds")?);
                    checks.push(Check::at_most(
                        &scene,
                        "bsp frame <= embree's, every backend",
                        format!("{backend} {:.2}x", bs / es),
                        bs / es,
                        1.0,
                    ));
                }
            }
        }
    }
    let mut header = vec!["scene".to_owned(), "objects".into(), "triangles".into()];
    header.extend(
        bsp_presets
            .iter()
            .map(|p| format!("bsp {p}: build + frame")),
    );
    header.push("embree: build + frame".into());
    header.extend(
        bsp_presets
            .iter()
            .filter(|&&p| p != "exact")
            .map(|p| format!("SAH {p} vs exact")),
    );
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&header, &rows));
    if complete > 0 {
        let each: Vec<String> = bsp_presets
            .iter()
            .zip(wins.iter().zip(&totals))
            .map(|(p, (w, t))| format!("`{p}` on {w} ({} s in all)", fmt_num(*t)))
            .collect();
        md.push_str(&format!(
            "\nThe shortest time to a first image, of the {complete} scenes with every preset: {}.\n",
            each.join(", ")
        ));
    }
    if !checks.is_empty() {
        md.push_str("\nThe many-object scene against Embree:\n\n");
        md.push_str(&condensed("scene", &checks));
    }
    Ok(md)
}

pub(super) fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut md = String::new();
    let size = if t.rows.is_empty() {
        "no scene rendered".to_owned()
    } else {
        format!(
            "{} x {} pixels, {} sample(s) per pixel",
            t.get(0, "width")?,
            t.get(0, "height")?,
            t.get(0, "spp")?
        )
    };
    md.push_str(&format!(
        "Whole frames ({size}) through the progressive film, as `coherent render --spp N \
         --threads 1` renders them, 1 thread; every (accel, backend) pair renders once \
         untimed, then 3 rounds visit every pair in turn and `seconds` is the median. \
         `speedup` = the scalar row's seconds (same scene, same accel) / this row's; \
         `psnr_db` compares the image as displayed (tone-mapped, each channel clipped to [0, 1] \
         as the PNG encodes it) with the scalar + BSP one (peak 1). Quick \
         mode renders only the scenes up to 20,000 triangles, at 160 x 120.\n\n"
    ));
    let mut ours = Vec::new();
    for s in t.distinct("scene")? {
        let get = |b: &str, c: &str| -> anyhow::Result<Option<f64>> {
            Ok(
                match find(&t, &[("scene", &s), ("backend", b), ("accel", "bsp")])? {
                    Some(r) => Some(t.f64(r, c)?),
                    None => None,
                },
            )
        };
        ours.push((
            s.clone(),
            vec![
                get("scalar", "seconds")?,
                get("sse", "seconds")?,
                get("sse", "speedup")?,
            ],
        ));
    }
    md.push_str(&PAPER.beside(&ours));

    md.push_str(
        "\nEvery backend and accelerator: seconds (speedup over scalar with the same \
         accelerator; PSNR in dB against scalar + BSP).\n\n",
    );
    let backends = t.distinct("backend")?;
    let mut header = vec!["scene".to_owned(), "accel".to_owned()];
    header.extend(backends.iter().cloned());
    let mut rows = Vec::new();
    for s in t.distinct("scene")? {
        for a in t.distinct("accel")? {
            let mut row = vec![s.clone(), a.clone()];
            let mut any = false;
            for b in &backends {
                row.push(
                    match find(&t, &[("scene", &s), ("backend", b), ("accel", &a)])? {
                        Some(r) => {
                            any = true;
                            format!(
                                "{} s ({}x, {} dB)",
                                fmt_num(t.f64(r, "seconds")?),
                                fmt_num(t.f64(r, "speedup")?),
                                fmt_num(t.f64(r, "psnr_db")?)
                            )
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&h, &rows));
    if let Some(peer) = crate::peers::table3_peer(ctx)? {
        md.push_str(&peer);
    }

    md.push_str(&targets(&t)?);
    if let Some(p) = ctx.plot_markdown("table3_speedup", "whole-frame speedup per scene") {
        md.push_str(&p);
    }
    if let Some(f) = factors::report(ctx)? {
        md.push_str(&f);
    }
    if let Some(b) = ctx.read_csv(BUILDS_FILE, BUILDS_HEADER)?
        && !b.rows.is_empty()
    {
        md.push_str(&builds_md(&b, &t)?);
    }

    let scenes = t.distinct("scene")?;
    let images: Vec<String> = scenes
        .iter()
        .filter(|s| ctx.path(&format!("images/table3_{s}.png")).is_file())
        .map(|s| format!("![{s}](images/table3_{s}.png)"))
        .collect();
    if !images.is_empty() {
        md.push_str("\nThe scalar + BSP images:\n\n");
        md.push_str(&images.join("\n"));
        md.push('\n');
        md.push_str(&exposure_md(ctx, &scenes));
    }
    if let Some(sk) = ctx.read_csv(SKIPPED_FILE, SKIPPED_HEADER)?
        && !sk.rows.is_empty()
    {
        md.push_str("\nLeft out of this run:\n\n");
        md.push_str(&sk.to_markdown());
    }
    if let Some(b) = ctx.read_csv(BREAKDOWN_FILE, BREAKDOWN_HEADER)? {
        md.push_str(&breakdown_md(ctx, &b)?);
    }
    if let Some(c) = ctx.read_csv(COHERENCE_FILE, COHERENCE_HEADER)? {
        md.push_str(&coherence_md(ctx, &c)?);
    }
    if let Some(x) = ctx.read_csv(LIGHT_SAMPLES_FILE, LIGHT_SAMPLES_HEADER)?
        && !x.rows.is_empty()
    {
        md.push_str(&light_samples_md(ctx, &x)?);
    }
    Ok(Some(md))
}

fn light_samples_md(ctx: &Ctx, x: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nLight samples shared per 4 x 4 pixel tile (`table3_light_samples.csv`, `coherent \
         render --light-samples tile`): the scenes whose lights take random numbers (jittered \
         area lights, the environment) rendered again with the BSP, every sample of a tile using \
         the same light sample points and environment directions, as the paper's surface \
         lights use one fixed set of points; the shadow packets of an environment light then \
         run parallel. Same protocol as above, on scalar and the hand-written backends. `speedup` = over scalar with shared samples; \
         `vs pixel` = the same backend's per-pixel frame (the table above) / this one; \
         `psnr_db` against scalar with shared samples (every backend must give that image); \
         `vs pixel dB` against the scalar per-pixel image (the two differ in their noise \
         only: each pixel's estimate is unbiased either way, but a tile's noise is \
         correlated).\n\n",
    );
    let mut rows = Vec::new();
    for s in x.distinct("scene")? {
        for b in x.distinct("backend")? {
            if let Some(r) = find(x, &[("scene", &s), ("backend", &b)])? {
                rows.push(vec![
                    s.clone(),
                    b.clone(),
                    fmt_num(x.f64(r, "seconds")?),
                    fmt_num(x.f64(r, "speedup")?),
                    fmt_num(x.f64(r, "speedup_vs_pixel")?),
                    fmt_num(x.f64(r, "psnr_db")?),
                    fmt_num(x.f64(r, "psnr_vs_pixel_db")?),
                ]);
            }
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "backend",
            "seconds",
            "speedup",
            "vs pixel",
            "psnr_db",
            "vs pixel dB",
        ],
        &rows,
    ));
    if let Some(p) = ctx.plot_markdown(
        "table3_light_samples",
        "speedup over scalar, light samples per pixel and per tile",
    ) {
        md.push_str(&p);
    }
    Ok(md)
}

/// The targets: speedup over scalar per lane count (BSP), PSNR, BSP no slower than Embree;
/// one row per scene and kind of target (see [`crate::targets`]).
fn targets(t: &Table) -> anyhow::Result<String> {
    const SPEEDUP: &str = "speedup over scalar, bsp";
    const EMBREE: &str = "bsp seconds <= embree's, same backend";
    let mut checks = Vec::new();
    for r in 0..t.rows.len() {
        let lanes = t.f64(r, "lanes")? as usize;
        let (scene, backend, accel) =
            (t.get(r, "scene")?, t.get(r, "backend")?, t.get(r, "accel")?);
        if accel == "bsp"
            && let Some((_, target)) = TARGETS.iter().find(|(l, _)| *l == lanes)
        {
            let s = t.f64(r, "speedup")?;
            checks.push(Check::at_least(
                scene,
                SPEEDUP,
                format!("{backend} {}x (>= {}x)", fmt_num(s), fmt_num(*target)),
                s,
                *target,
            ));
        }
        if accel == "embree"
            && let Some(b) = find(
                t,
                &[("scene", scene), ("backend", backend), ("accel", "bsp")],
            )?
        {
            let (bsp, embree) = (t.f64(b, "seconds")?, t.f64(r, "seconds")?);
            checks.push(Check::at_most(
                scene,
                EMBREE,
                format!("{backend} {} s vs {} s", fmt_num(bsp), fmt_num(embree)),
                bsp,
                embree,
            ));
        }
    }
    for s in t.distinct("scene")? {
        let mut worst = f64::INFINITY;
        let mut which = String::new();
        for r in t.rows_where("scene", &s)? {
            let db = t.f64(r, "psnr_db")?;
            if db < worst {
                worst = db;
                which = format!("{} + {}", t.get(r, "backend")?, t.get(r, "accel")?);
            }
        }
        checks.push(Check::at_least(
            &s,
            &format!("PSNR >= {PSNR_TARGET} dB, every backend and accel"),
            format!("lowest {} dB ({which})", fmt_num(worst)),
            worst,
            PSNR_TARGET,
        ));
    }
    let mut md = String::from(
        "\nTargets (sse >= 4x, 8 lanes >= 6x, 16 lanes >= 8x over scalar; PSNR >= 40 dB; BSP \
         frame time <= Embree's at the same width), one row per scene and kind of target: how \
         many of its checks (one per backend) are met, and the figure closest to its target \
         (the nearest miss, or the narrowest pass when all are met); every figure is in the \
         table above:\n\n",
    );
    md.push_str(&condensed("scene", &checks));
    Ok(md)
}

fn breakdown_md(ctx: &Ctx, b: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nWhere the time goes (`table3_breakdown.csv`): one more frame per backend with the \
         BSP and the renderer's stage clocks on. They read the clock several times per packet, \
         which makes these frames slower than the timed ones above; each stage's time has that \
         cost taken out (an empty lap of the clock, measured on this machine, per lap), and so \
         has the film's. `traversal` = first-hit \
         queries of camera, reflection and refraction packets; `shadows` = occlusion queries; \
         `shading` = material passes (textures and tabulated BDFs included); `lights` = light \
         sampling and shadow-ray set-up; `other` = camera rays, the hit-to-surface gather and \
         secondary-ray set-up; `film` = the frame's time outside the tracer (Halton sampling, \
         accumulation, scheduling); `tonemap` = tone mapping the frame. Share of the total, \
         %:\n\n",
    );
    let mut rows = Vec::new();
    for s in b.distinct("scene")? {
        for be in b.distinct("backend")? {
            let mut row = vec![s.clone(), be.clone()];
            let mut any = false;
            for stage in STAGES {
                row.push(
                    match find(b, &[("scene", &s), ("backend", &be), ("stage", stage)])? {
                        Some(r) => {
                            any = true;
                            format!("{:.1}", 100.0 * b.f64(r, "share")?)
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let mut header = vec!["scene", "backend"];
    header.extend(STAGES);
    md.push_str(&markdown_table(&header, &rows));
    if let Some(p) = ctx.plot_markdown("table3_breakdown", "share of frame time per stage") {
        md.push_str(&p);
    }
    md.push_str(&stage_speedups_md(b)?);
    if let Some(p) = ctx.plot_markdown(
        "table3_stage_efficiency",
        "each stage's speedup over scalar per lane",
    ) {
        md.push_str(&p);
    }
    Ok(md)
}

/// Seconds per stage of one scene and backend in the breakdown, in [`STAGES`] order (`None`
/// where a stage has no row), and their sum.
fn stage_seconds(b: &Table, scene: &str, backend: &str) -> anyhow::Result<([Option<f64>; 7], f64)> {
    let mut out = [None; 7];
    let mut total = 0.0;
    for (i, stage) in STAGES.iter().enumerate() {
        if let Some(r) = find(
            b,
            &[("scene", scene), ("backend", backend), ("stage", stage)],
        )? {
            let s = b.f64(r, "seconds")?;
            out[i] = Some(s);
            total += s;
        }
    }
    Ok((out, total))
}

/// One scene and backend of the breakdown against the scalar backend.
#[derive(Debug, PartialEq)]
pub(super) struct StageSpeedups {
    /// Each stage's speedup over the scalar backend's same stage, in [`STAGES`] order.
    pub(super) stages: [Option<f64>; 7],
    /// The whole breakdown frame's speedup.
    pub(super) frame: f64,
    pub(super) lanes: usize,
}

/// Per scene and backend: each stage's speedup over the scalar backend's same stage (the
/// breakdown frames) and the whole breakdown frame's. `None` for the scalar rows and for
/// backends whose name is unknown.
pub(super) fn stage_speedups(
    b: &Table,
    scene: &str,
    backend: &str,
) -> anyhow::Result<Option<StageSpeedups>> {
    let Ok(be) = backend.parse::<Backend>() else {
        return Ok(None);
    };
    if be.lanes() == 1 {
        return Ok(None);
    }
    let (base, base_total) = stage_seconds(b, scene, "scalar")?;
    let (this, total) = stage_seconds(b, scene, backend)?;
    if base_total <= 0.0 || total <= 0.0 {
        return Ok(None);
    }
    let mut out = [None; 7];
    for i in 0..STAGES.len() {
        if let (Some(a), Some(t)) = (base[i], this[i])
            && t > 0.0
        {
            out[i] = Some(a / t);
        }
    }
    Ok(Some(StageSpeedups {
        stages: out,
        frame: base_total / total,
        lanes: be.lanes(),
    }))
}

pub(super) fn stage_speedups_md(b: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nEach stage's speedup over the scalar backend's same stage (the frames above), and \
         the whole frame's as a share of the lane count. A packet of N lanes that does the \
         work of its N rays with one instruction stream gains at most N times over them one \
         at a time, unless it does less work than its rays alone: a frame gains N times only \
         if every stage does. The stages below the lane count are where \
         a frame's speedup is lost:\n\n",
    );
    let mut rows = Vec::new();
    for s in b.distinct("scene")? {
        for be in b.distinct("backend")? {
            let Some(StageSpeedups {
                stages,
                frame,
                lanes,
            }) = stage_speedups(b, &s, &be)?
            else {
                continue;
            };
            let mut row = vec![s.clone(), be.clone(), lanes.to_string()];
            row.extend(
                stages
                    .iter()
                    .map(|x| x.map_or_else(|| "—".into(), |v| format!("{v:.2}"))),
            );
            row.push(format!("{frame:.2}"));
            row.push(format!("{:.0}", 100.0 * frame / lanes as f64));
            rows.push(row);
        }
    }
    if rows.is_empty() {
        return Ok(String::new());
    }
    let mut header = vec!["scene", "backend", "lanes"];
    header.extend(STAGES);
    header.extend(["frame", "frame / lanes, %"]);
    md.push_str(&markdown_table(&header, &rows));
    Ok(md)
}

fn coherence_md(ctx: &Ctx, c: &Table) -> anyhow::Result<String> {
    let mut md = String::from(
        "\nCoherence by ray depth (`table3_coherence.csv`): average active lanes per traced \
         packet (camera rays at depth 0, then reflection and refraction packets; shadow packets \
         are not counted here), per packet width. Secondary packets keep their parent's lanes, \
         so a lane that missed, or whose surface neither reflects nor refracts, stays empty \
         below it (the `regroup` experiment compacts them across packets and measures \
         whether that pays):\n\n",
    );
    let depths = c.distinct("depth")?;
    let mut header = vec!["scene".to_owned(), "lanes".to_owned()];
    header.extend(depths.iter().map(|d| format!("depth {d}")));
    let mut rows = Vec::new();
    for s in c.distinct("scene")? {
        for lanes in c.distinct("lanes")? {
            let mut row = vec![s.clone(), lanes.clone()];
            let mut any = false;
            for d in &depths {
                row.push(
                    match find(c, &[("scene", &s), ("lanes", &lanes), ("depth", d)])? {
                        Some(r) => {
                            any = true;
                            format!(
                                "{} ({} packets)",
                                fmt_num(c.f64(r, "avg_active_lanes")?),
                                c.get(r, "packets")?
                            )
                        }
                        None => "—".into(),
                    },
                );
            }
            if any {
                rows.push(row);
            }
        }
    }
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    md.push_str(&markdown_table(&h, &rows));
    if let Some(p) = ctx.plot_markdown("table3_coherence", "active lanes per packet by depth") {
        md.push_str(&p);
    }
    Ok(md)
}

/// How each scene's image uses the display's range: the mean and 99th percentile of its
/// display values (Rec. 709 weights over the PNG's stored, display-encoded channels, 0-1)
/// and its share of black pixels, read from the images themselves.
fn exposure_md(ctx: &Ctx, scenes: &[String]) -> String {
    let mut rows = Vec::new();
    for s in scenes {
        let path = ctx.path(&format!("images/table3_{s}.png"));
        if !path.is_file() {
            continue;
        }
        rows.push(match display_values(&path) {
            Ok(v) => {
                let n = v.len().max(1) as f64;
                let mean = v.iter().sum::<f64>() / n;
                let black = v.iter().filter(|&&x| x == 0.0).count() as f64 / n;
                vec![
                    s.clone(),
                    format!("{mean:.3}"),
                    format!(
                        "{:.3}",
                        v[((v.len() as f64 * 0.99) as usize).min(v.len() - 1)]
                    ),
                    format!("{:.1}%", 100.0 * black),
                ]
            }
            Err(e) => vec![
                s.clone(),
                format!("cannot read: {e:#}"),
                "-".into(),
                "-".into(),
            ],
        });
    }
    if rows.is_empty() {
        return String::new();
    }
    format!(
        "\nHow the images use the display (default tone mapping; display values 0-1 of the PNGs \
         above, Rec. 709 weights over their stored channels):\n\n{}",
        markdown_table(&["scene", "mean", "99th percentile", "black pixels"], &rows)
    )
}

/// The display values of an image file, sorted (never empty).
fn display_values(path: &std::path::Path) -> anyhow::Result<Vec<f64>> {
    let img = image::open(path)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .to_rgb8();
    let mut v: Vec<f64> = img
        .pixels()
        .map(|p| (0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64) / 255.0)
        .collect();
    if v.is_empty() {
        anyhow::bail!("{}: an empty image", path.display());
    }
    v.sort_by(f64::total_cmp);
    Ok(v)
}
