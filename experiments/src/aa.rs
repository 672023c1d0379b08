//! Experiment `aa`: progressive adaptive anti-aliasing against classical supersampling
//! (paper section 6.2). Both render a test scene with edges and smooth walls through the
//! film; after every pass the image so far is compared with a converged reference (RMSE of
//! the tone-mapped display values), giving error against rays traced and against time. The paper claims that
//! adaptive rendering with anti-aliasing can be faster than the classical algorithm at the
//! same quality; the target here: adaptive reaches uniform's final RMSE with at least 2x
//! fewer rays.
//!
//! The renderer itself traces the samples (`coherent::render::Renderer` on the BSP): the
//! generated `room` test scene (boxes with sharp edges inside smooth walls) as a render scene
//! with matte surfaces and one omni light, and the built-in `cornell` and `glass1` scenes as
//! they are (area lights, mirrors, glass), each at a small and a large size.

use std::sync::Mutex;
use std::time::Instant;

use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{self, FilmOptions, Method, PassRecord, PassReport};
use coherent::light::{Light, Omni};
use coherent::material::Material;
use coherent::render::{RenderStats, Renderer, render_frame};
use coherent::sampler::HaltonTile;
use coherent::scene::RenderScene;
use coherent::scene::camera::Camera;
use coherent::scene::shaded::ShadedMesh;
use coherent::simd::Backend;
use coherent::tonemap::ToneMap;
use coherent_accel::scenes::{self, SceneSize};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::plot::{LineChart, Series};
use crate::table::{fmt_num, markdown_table};

pub const EXPERIMENT: Experiment = Experiment {
    name: "aa",
    description: "adaptive anti-aliasing with two screen matrices: error against rays and time",
    paper: "section 6.2",
    csv: &[FILE, GROUPS_FILE],
    plots: &[
        "aa_rmse_vs_rays_room_small",
        "aa_rmse_vs_seconds_room_small",
        "aa_rmse_vs_rays_cornell_small",
        "aa_rmse_vs_seconds_cornell_small",
        "aa_rmse_vs_rays_glass1_small",
        "aa_rmse_vs_seconds_glass1_small",
        "aa_rmse_vs_rays_room_large",
        "aa_rmse_vs_seconds_room_large",
        "aa_rmse_vs_rays_cornell_large",
        "aa_rmse_vs_seconds_cornell_large",
        "aa_rmse_vs_rays_glass1_large",
        "aa_rmse_vs_seconds_glass1_large",
    ],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

const FILE: &str = "aa.csv";
/// The contract's columns (the adaptive run's accuracy empty for uniform), the group (scene,
/// resolution), then the film's own estimate of the RMSE after the pass
/// (`PassRecord::estimate`), to hold against the measured one.
const HEADER: &[&str] = &[
    "method",
    "rays",
    "seconds",
    "rmse",
    "accuracy",
    "scene",
    "resolution",
    "estimate",
];
/// The scenes, each at both sizes.
const SCENES: [&str; 3] = ["room", "cornell", "glass1"];
/// A size of the experiment: its word in plot stems, the full run's and the quick run's
/// resolution and uniform samples per pixel (the reference takes 4 times as many, the
/// adaptive runs' cap twice as many). The large size takes fewer samples per pixel to keep
/// the full run near ten minutes on 2 cores: its 16 samples cost 3.3 times the small size's
/// 64.
struct Size {
    word: &'static str,
    full: (u32, u32),
    quick: (u32, u32),
    full_spp: u32,
    quick_spp: u32,
}
const SIZES: [Size; 2] = [
    Size {
        word: "small",
        full: (320, 240),
        quick: (96, 72),
        full_spp: 64,
        quick_spp: 8,
    },
    Size {
        word: "large",
        full: (1024, 768),
        quick: (160, 120),
        full_spp: 16,
        quick_spp: 4,
    },
];
/// The adaptive runs' accuracies (display difference of the two screen matrices).
const ACCURACIES: [f32; 5] = [0.08, 0.04, 0.02, 0.01, 0.005];
const GROUPS_FILE: &str = "aa_groups.csv";
const GROUPS_HEADER: &[&str] = &[
    "method",
    "accuracy",
    "pass",
    "span",
    "radius",
    "mean_distance",
    "max_distance",
    "groups_traced",
    "groups_skipped",
    "rays",
    "scene",
    "resolution",
];

/// The generated room (`coherent_accel::scenes::room`) as the renderer's scene: every mesh
/// matte (albedo 0.7, 0.65, 0.55, a little ambient), one omni light where the test scene
/// puts its light, camera and shadow rays only (depth 0).
fn aa_scene(size: SceneSize, width: u32, height: u32) -> anyhow::Result<RenderScene> {
    let s = scenes::room(size);
    let mut matte = Material::phong("matte", [0.7, 0.65, 0.55], [0.0; 3], 1.0);
    matte.phong.ambient = [0.02; 3];
    let scene = RenderScene {
        name: s.name.to_owned(),
        meshes: s
            .scene
            .meshes
            .into_iter()
            .map(|m| ShadedMesh::flat(m, 0))
            .collect(),
        instances: s.scene.instances,
        materials: vec![matte],
        lights: vec![Light::Omni(Omni::new(s.light, [20.0; 3])?)],
        camera: Camera {
            position: s.view.eye,
            look_at: s.view.target,
            up: s.view.up,
            vfov_deg: s.view.fov_y_degrees,
        },
        width,
        height,
        depth: 0,
        spp: None,
        accuracy: None,
        tonemap: Default::default(),
        background: [0.0; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    };
    scene.validate()?;
    Ok(scene)
}

/// The experiment's scene `name` at `width` x `height`: the matte room, or a built-in scene
/// as it is (static instances merged, as `coherent render` does).
fn scene(name: &str, size: SceneSize, width: u32, height: u32) -> anyhow::Result<RenderScene> {
    if name == "room" {
        return aa_scene(size, width, height);
    }
    let mut s = coherent::scene::load(name)?;
    s.width = width;
    s.height = height;
    s.validate()?;
    Ok(s.merge_static().0)
}

/// RMSE of the display values (both images tone-mapped with the reference's operator and
/// `std` maths): what the viewer sees, so a bright spot near the light does not outweigh
/// every edge.
fn rmse(t: &ToneMap, a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let mut s = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        let (x, y) = (t.apply_exact(*x), t.apply_exact(*y));
        for c in 0..3 {
            s += ((x[c] - y[c]) as f64).powi(2);
        }
    }
    (s / (3 * a.len().max(1)) as f64).sqrt()
}

/// Per pass: its record, its seconds without the recording, the image so far.
type Passes = Vec<(PassRecord, f64, Vec<[f32; 3]>)>;

/// Renders and records every pass.
fn passes(
    backend: Backend,
    renderer: &Renderer<'_, AnyAccel>,
    opts: &FilmOptions,
) -> anyhow::Result<(Passes, film::Rendered<RenderStats>)> {
    // The callback's own time (copying the image) is left out of the pass times.
    let spent = Mutex::new((0.0f64, Vec::new()));
    let r = render_frame(backend, renderer, opts, &|p: &PassReport| {
        let t = Instant::now();
        let mut g = spent.lock().unwrap();
        let img = p.film.estimate();
        let seconds = p.record.seconds - g.0;
        g.1.push((p.record.clone(), seconds, img));
        g.0 += t.elapsed().as_secs_f64();
    })?;
    Ok((spent.into_inner().unwrap().1, r))
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let scene_size = ctx.pick(SceneSize::Quick, SceneSize::Full);
    // The paper's 4-lane packets where the CPU has them.
    let backend = Backend::preferred_for_lanes(4).unwrap_or(Backend::Scalar);
    let runs = (SCENES.len() * SIZES.len() * (2 + ACCURACIES.len())) as u64;
    let bar = ctx.progress(runs, "aa");
    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut groups = ctx.csv(GROUPS_FILE, GROUPS_HEADER)?;
    for size in &SIZES {
        let (w, h) = ctx.pick(size.quick, size.full);
        let uniform_spp = ctx.pick(size.quick_spp, size.full_spp);
        let ref_spp = 4 * uniform_spp;
        let resolution = format!("{w}x{h}");
        for name in SCENES {
            let scene = scene(name, scene_size, w, h)?;
            let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
            let renderer = Renderer::new(&scene, accel, w, h)?;

            // The reference: many more samples, from another Halton tile (other positions).
            let mut ref_opts = FilmOptions::new(w, h, Method::Uniform { spp: ref_spp });
            ref_opts.tile = HaltonTile::new(3, 3);
            let reference = render_frame(backend, &renderer, &ref_opts, &|_| {})?;
            let display = reference.tonemap;
            let reference = reference.image();
            bar.inc(1);

            let mut methods = vec![(
                "uniform",
                Method::Uniform { spp: uniform_spp },
                String::new(),
            )];
            for a in ACCURACIES {
                methods.push((
                    "adaptive",
                    Method::Adaptive {
                        accuracy: a,
                        max_samples_per_pixel: uniform_spp * 2,
                        time_budget: None,
                    },
                    format!("{a}"),
                ));
            }
            for (method, how, accuracy) in methods {
                let opts = FilmOptions::new(w, h, how);
                let (records, rendered) = passes(backend, &renderer, &opts)?;
                for (rec, seconds, img) in &records {
                    csv.row(&[
                        &method,
                        &rec.rays,
                        &format!("{seconds:.6e}"),
                        &format!("{:.6e}", rmse(&display, img, &reference)),
                        &accuracy,
                        &name,
                        &resolution,
                        &format!("{:.6e}", rec.estimate),
                    ])?;
                    groups.row(&[
                        &method,
                        &accuracy,
                        &rec.pass,
                        &rec.span.value(),
                        &format!("{:.3}", rec.radius),
                        &format!("{:.3}", rec.coherence.mean_distance),
                        &format!("{:.3}", rec.coherence.max_distance),
                        &rec.groups_traced,
                        &rec.groups_skipped,
                        &rec.rays_this_pass,
                        &name,
                        &resolution,
                    ])?;
                }
                if rendered.fixups != Default::default() {
                    ctx.note(format!(
                        "aa: {name} {resolution} {method}: radiance fixed up: {:?}",
                        rendered.fixups
                    ));
                }
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    groups.finish()?;
    Ok(())
}

/// One pass: rays, seconds, measured RMSE, the film's estimate.
type Point = (f64, f64, f64, f64);
/// Per run (`uniform`, `adaptive 0.01`, ...), its passes in order.
type Runs = Vec<(String, Vec<Point>)>;
/// Per group (scene, resolution), its runs, in the CSV's order.
type Curves = Vec<((String, String), Runs)>;

/// The runs of `aa.csv` by group, in pass order.
fn curves(ctx: &Ctx) -> anyhow::Result<Option<Curves>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut out: Curves = Vec::new();
    for r in 0..t.len() {
        let group = (
            t.get(r, "scene")?.to_string(),
            t.get(r, "resolution")?.to_string(),
        );
        let acc = t.get(r, "accuracy")?;
        let key = if acc.is_empty() {
            t.get(r, "method")?.to_string()
        } else {
            format!("{} {acc}", t.get(r, "method")?)
        };
        let p = (
            t.f64(r, "rays")?,
            t.f64(r, "seconds")?,
            t.f64(r, "rmse")?,
            t.f64(r, "estimate")?,
        );
        let runs = match out.iter_mut().position(|g| g.0 == group) {
            Some(i) => &mut out[i].1,
            None => {
                out.push((group, Vec::new()));
                &mut out.last_mut().expect("just pushed").1
            }
        };
        match runs.iter_mut().find(|c| c.0 == key) {
            Some(c) => c.1.push(p),
            None => runs.push((key, vec![p])),
        }
    }
    Ok(Some(out))
}

/// The plot stem's size word for a resolution (`small`, `large`), if it is one of ours.
fn size_word(resolution: &str) -> Option<&'static str> {
    SIZES.iter().find_map(|s| {
        [s.full, s.quick]
            .iter()
            .any(|(w, h)| format!("{w}x{h}") == resolution)
            .then_some(s.word)
    })
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(curves) = curves(ctx)? else {
        return Ok(());
    };
    for ((scene, resolution), runs) in &curves {
        let Some(word) = size_word(resolution) else {
            continue;
        };
        for (what, x_label, pick) in [("rays", "rays traced", 0usize), ("seconds", "seconds", 1)] {
            let series = runs
                .iter()
                .map(|(m, pts)| {
                    Series::new(
                        m.clone(),
                        pts.iter()
                            .filter(|p| p.2.is_finite() && p.0 > 0.0 && p.1 > 0.0)
                            .map(|p| (if pick == 0 { p.0 } else { p.1 }, p.2))
                            .collect(),
                    )
                })
                .collect();
            ctx.line_chart(
                &format!("aa_rmse_vs_{what}_{scene}_{word}"),
                &LineChart {
                    title: format!("Anti-aliasing, {scene} {resolution}: RMSE vs {x_label}"),
                    x_label: x_label.into(),
                    y_label: "RMSE (display values)".into(),
                    series,
                    log2_x: true,
                    log_y: true,
                },
            )?;
        }
    }
    Ok(())
}

/// Rays (and seconds) the method needs to reach `target` RMSE: where its curve crosses the
/// target, interpolated in log-log between the last pass above it and the first at or below
/// (an adaptive pass may trace several samples per pixel at once, so the first pass at or
/// below alone would charge a run for the whole of the pass that crossed).
fn reach(pts: &[Point], target: f64) -> Option<(f64, f64)> {
    let i = pts.iter().position(|p| p.2 <= target)?;
    let b = pts[i];
    let Some(a) = i.checked_sub(1).map(|j| pts[j]) else {
        return Some((b.0, b.1));
    };
    if !(a.0 > 0.0 && a.2 > target && b.2 > 0.0 && b.0 > a.0) {
        return Some((b.0, b.1));
    }
    // The fraction of the way from a to b, in log error.
    let t = (a.2.ln() - target.ln()) / (a.2.ln() - b.2.ln());
    let rays = (a.0.ln() + t * (b.0.ln() - a.0.ln())).exp();
    let seconds = a.1 + t * (b.1 - a.1);
    Some((rays, seconds))
}

/// One group's table and its best adaptive run's factor over uniform (rays to uniform's
/// final RMSE), if any reaches it.
fn group_report(runs: &Runs) -> Option<(String, Option<(String, f64)>)> {
    let uni = &runs.iter().find(|c| c.0 == "uniform")?.1;
    let &u = uni.last()?;
    let mut rows = vec![vec![
        "uniform".to_string(),
        fmt_num(u.0),
        format!("{:.3}", u.1),
        format!("{:.3e}", u.2),
        format!("{:.3e}", u.3),
        "-".into(),
        "-".into(),
        "-".into(),
    ]];
    let mut best: Option<(String, f64)> = None;
    for (name, pts) in runs.iter().filter(|c| c.0 != "uniform") {
        let Some(&a) = pts.last() else { continue };
        let r = reach(pts, u.2);
        // The other way round: what uniform needs for this run's final quality.
        let back = reach(uni, a.2);
        if let Some(r) = r
            && best.as_ref().is_none_or(|b| u.0 / r.0 > b.1)
        {
            best = Some((name.clone(), u.0 / r.0));
        }
        rows.push(vec![
            name.clone(),
            fmt_num(a.0),
            format!("{:.3}", a.1),
            format!("{:.3e}", a.2),
            format!("{:.3e}", a.3),
            r.map_or("not reached".into(), |r| {
                format!("{} ({:.3} s)", fmt_num(r.0), r.1)
            }),
            r.map_or("-".into(), |r| format!("{:.2}x", u.0 / r.0)),
            back.map_or("not reached".into(), |b| {
                format!("{} ({:.2}x)", fmt_num(b.0), b.0 / a.0)
            }),
        ]);
    }
    let md = markdown_table(
        &[
            "run",
            "final rays",
            "final s",
            "final RMSE",
            "film's estimate",
            "rays (time) to uniform's final RMSE",
            "fewer rays than uniform",
            "uniform rays to this run's final RMSE (ratio)",
        ],
        &rows,
    );
    Some((md, best))
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(curves) = curves(ctx)? else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "Each scene rendered by the renderer itself on the BSP with 4-lane packets: `room` \
         (edges, smooth walls, shadows; matte surfaces, one omni light with shadow rays), and \
         the built-in `cornell` and `glass1` as they are. `uniform`: Halton supersampling, one \
         pass per sample per pixel; `adaptive A`: the paper's superpixels (8 x 6, interpolated \
         where their corners agree within A) as the first image, then Halton groups of growing \
         span over every pixel, interpolated ones included, a pixel stopping when its two \
         screen matrices agree within A (display units, 0-1) over its 3x3 neighbourhood (cap: \
         twice the uniform spp). RMSE of the tone-mapped display values (0-1, with the \
         reference's operator) against a converged uniform render from another Halton tile; \
         the film's estimate is its own figure for that RMSE (half the two matrices' \
         difference per pixel). Target: adaptive reaches uniform's final RMSE with at least \
         2x fewer rays at both sizes on every scene.\n\n",
    );
    let mut summary = Vec::new();
    let mut tables = String::new();
    // Whether the film's own estimate at the stop bounds the measured RMSE.
    let (mut bounded, mut stops, mut lo, mut hi) = (0, 0, f64::INFINITY, 0.0f64);
    for (_, runs) in &curves {
        for (_, pts) in runs.iter().filter(|c| c.0 != "uniform") {
            if let Some(&(_, _, measured, estimate)) = pts.last() {
                stops += 1;
                bounded += usize::from(estimate >= measured);
                lo = lo.min(estimate / measured);
                hi = hi.max(estimate / measured);
            }
        }
    }
    for ((scene, resolution), runs) in &curves {
        let Some((table, best)) = group_report(runs) else {
            continue;
        };
        tables.push_str(&format!("\n### {scene} {resolution}\n\n{table}"));
        summary.push(vec![
            scene.clone(),
            resolution.clone(),
            best.as_ref()
                .map_or("none".into(), |b| format!("`{}`", b.0)),
            best.as_ref()
                .map_or("not reached".into(), |b| format!("{:.2}x", b.1)),
            match &best {
                Some(b) if b.1 >= 2.0 => "met".into(),
                _ => "missed".to_string(),
            },
        ]);
        if let Some(word) = size_word(resolution) {
            for (what, alt) in [("rays", "RMSE vs rays"), ("seconds", "RMSE vs seconds")] {
                let stem = format!("aa_rmse_vs_{what}_{scene}_{word}");
                if let Some(p) = ctx.plot_markdown(&stem, &format!("{scene} {resolution}: {alt}")) {
                    tables.push_str(&p);
                }
            }
        }
    }
    md.push_str(&markdown_table(
        &[
            "scene",
            "resolution",
            "best adaptive run",
            "fewer rays than uniform at uniform's final RMSE",
            "target (2x)",
        ],
        &summary,
    ));
    if stops > 0 {
        md.push_str(&format!(
            "\nThe film's estimate at the stop bounds the measured RMSE in {bounded} of {stops} \
             adaptive runs (estimate over measured: {lo:.2}-{hi:.2}). Rays to a target RMSE are \
             read where the run's curve crosses it (log-log between its passes).\n"
        ));
    }
    md.push_str(&tables);
    if let Some(g) = ctx.read_csv(GROUPS_FILE, GROUPS_HEADER)? {
        md.push_str(
            "\nHow close the samples of a traced group are (distance to the group's centroid, \
             pixels) against the coherence radius R = sqrt(tile area / (pi span)), per pass \
             (adaptive; pass 0 is the superpixel pre-render):\n\n",
        );
        let finest = format!("{}", ACCURACIES[ACCURACIES.len() - 1]);
        let first = curves.first().map(|c| c.0.clone()).unwrap_or_default();
        md.push_str(&format!(
            "(`adaptive {finest}` on {} {}; the uniform passes use span 36 at 4 lanes: cells \
             of 4 x 1 pixels.)\n\n",
            first.0, first.1
        ));
        let mut rows = Vec::new();
        for r in g.rows_where("accuracy", &finest)? {
            if (g.get(r, "scene")?, g.get(r, "resolution")?) != (&first.0[..], &first.1[..]) {
                continue;
            }
            rows.push(
                [
                    "pass",
                    "span",
                    "radius",
                    "mean_distance",
                    "max_distance",
                    "groups_traced",
                    "groups_skipped",
                    "rays",
                ]
                .iter()
                .map(|c| g.get(r, c).map(|s| s.to_string()))
                .collect::<Result<Vec<_>, _>>()?,
            );
        }
        md.push_str(&markdown_table(
            &[
                "pass",
                "span",
                "R",
                "mean dist",
                "max dist",
                "groups traced",
                "groups skipped",
                "rays",
            ],
            &rows,
        ));
    }
    Ok(Some(md))
}
