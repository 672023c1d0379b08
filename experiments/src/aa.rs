//! Experiment `aa`: progressive adaptive anti-aliasing against classical supersampling
//! (paper section 6.2). Both render a test scene with edges and smooth walls through the
//! film; after every pass the image so far is compared with a converged reference (RMSE of
//! the tone-mapped display values), giving error against rays traced and against time. The paper claims that
//! adaptive rendering with anti-aliasing can be faster than the classical algorithm at the
//! same quality; the target here: adaptive reaches uniform's final RMSE with at least 2x
//! fewer rays.
//!
//! The renderer itself traces the samples (`coherent::render::Renderer` on the BSP, camera
//! rays and the shadow rays of one omni light): the generated `room` test scene (boxes with
//! sharp edges inside smooth walls) as a render scene with matte surfaces.

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
    plots: &["aa_rmse_vs_rays", "aa_rmse_vs_seconds"],
    status: Status::Ready {
        run,
        plot: plots,
        report,
    },
};

const FILE: &str = "aa.csv";
/// The contract's columns, then the adaptive run's accuracy (empty for uniform).
const HEADER: &[&str] = &["method", "rays", "seconds", "rmse", "accuracy"];
/// The adaptive runs' accuracies (display difference of the two screen matrices).
const ACCURACIES: [f32; 4] = [0.02, 0.01, 0.005, 0.0025];
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
    };
    scene.validate()?;
    Ok(scene)
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
    let (w, h) = ctx.pick((120, 90), (320, 240));
    let size = ctx.pick(SceneSize::Quick, SceneSize::Full);
    let scene = aa_scene(size, w, h)?;
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
    let renderer = Renderer::new(&scene, accel, w, h)?;
    // The paper's 4-lane packets where the CPU has them.
    let backend = Backend::preferred_for_lanes(4).unwrap_or(Backend::Scalar);
    let ref_spp = ctx.pick(64, 256);
    let uniform_spp = ctx.pick(16, 64);
    let bar = ctx.progress(2 + ACCURACIES.len() as u64, "aa");

    // The reference: many more samples, from another Halton tile (other positions).
    let mut ref_opts = FilmOptions::new(w, h, Method::Uniform { spp: ref_spp });
    ref_opts.tile = HaltonTile::new(3, 3);
    let reference = render_frame(backend, &renderer, &ref_opts, &|_| {})?;
    let display = reference.tonemap;
    let reference = reference.image();
    bar.inc(1);

    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut groups = ctx.csv(GROUPS_FILE, GROUPS_HEADER)?;
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
    for (name, method, accuracy) in methods {
        let opts = FilmOptions::new(w, h, method);
        let (records, rendered) = passes(backend, &renderer, &opts)?;
        for (rec, seconds, img) in &records {
            csv.row(&[
                &name,
                &rec.rays,
                &format!("{seconds:.6e}"),
                &format!("{:.6e}", rmse(&display, img, &reference)),
                &accuracy,
            ])?;
            groups.row(&[
                &name,
                &accuracy,
                &rec.pass,
                &rec.span.value(),
                &format!("{:.3}", rec.radius),
                &format!("{:.3}", rec.coherence.mean_distance),
                &format!("{:.3}", rec.coherence.max_distance),
                &rec.groups_traced,
                &rec.groups_skipped,
                &rec.rays_this_pass,
            ])?;
        }
        if rendered.fixups != Default::default() {
            ctx.note(format!(
                "aa: {name}: radiance fixed up: {:?}",
                rendered.fixups
            ));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    groups.finish()?;
    Ok(())
}

/// (rays, seconds, rmse) per pass, per run (`uniform`, `adaptive 0.01`, ...).
type Curves = Vec<(String, Vec<(f64, f64, f64)>)>;

/// The runs of `aa.csv`, in pass order.
fn curves(ctx: &Ctx) -> anyhow::Result<Option<Curves>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut out: Curves = Vec::new();
    for r in 0..t.len() {
        let acc = t.get(r, "accuracy")?;
        let key = if acc.is_empty() {
            t.get(r, "method")?.to_string()
        } else {
            format!("{} {acc}", t.get(r, "method")?)
        };
        let p = (t.f64(r, "rays")?, t.f64(r, "seconds")?, t.f64(r, "rmse")?);
        match out.iter_mut().find(|c| c.0 == key) {
            Some(c) => c.1.push(p),
            None => out.push((key, vec![p])),
        }
    }
    Ok(Some(out))
}

fn plots(ctx: &Ctx) -> anyhow::Result<()> {
    let Some(curves) = curves(ctx)? else {
        return Ok(());
    };
    for (stem, x_label, pick) in [
        ("aa_rmse_vs_rays", "rays traced", 0usize),
        ("aa_rmse_vs_seconds", "seconds", 1),
    ] {
        let series = curves
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
            stem,
            &LineChart {
                title: format!("Anti-aliasing: RMSE against the reference vs {x_label}"),
                x_label: x_label.into(),
                y_label: "RMSE (display values)".into(),
                series,
                log2_x: true,
            },
        )?;
    }
    Ok(())
}

/// Rays (and seconds) the method needs to reach `target` RMSE: the first pass at or below.
fn reach(pts: &[(f64, f64, f64)], target: f64) -> Option<(f64, f64)> {
    pts.iter().find(|p| p.2 <= target).map(|p| (p.0, p.1))
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(curves) = curves(ctx)? else {
        return Ok(None);
    };
    let Some(uni) = curves
        .iter()
        .find(|c| c.0 == "uniform")
        .map(|c| c.1.clone())
    else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "The room scene (edges, smooth walls, shadows) rendered by the renderer itself: matte \
         surfaces, one omni light with shadow rays, the BSP, 4-lane packets. `uniform`: Halton supersampling, one pass per \
         sample per pixel; `adaptive A`: the paper's superpixels (8 x 6, interpolated where \
         their corners agree within A), then Halton groups of growing span, a pixel stopping \
         when its two screen matrices agree within A (display units, 0-1) over its 3x3 neighbourhood \
         (cap: twice the uniform spp). RMSE of the tone-mapped display values (0-1, \
         Tumblin-Rushmeier with the reference's adaptation) against a converged uniform render \
         from another Halton tile. Target: adaptive reaches uniform's final RMSE with at least \
         2x fewer rays.\n\n",
    );
    let Some(&u) = uni.last() else {
        return Ok(None);
    };
    let mut rows = vec![vec![
        "uniform".to_string(),
        fmt_num(u.0),
        format!("{:.3}", u.1),
        format!("{:.4e}", u.2),
        "-".into(),
        "-".into(),
        "-".into(),
    ]];
    for (name, pts) in curves.iter().filter(|c| c.0 != "uniform") {
        let Some(&a) = pts.last() else { continue };
        let r = reach(pts, u.2);
        // The other way round: what uniform needs for this run's final quality.
        let back = reach(&uni, a.2);
        rows.push(vec![
            name.clone(),
            fmt_num(a.0),
            format!("{:.3}", a.1),
            format!("{:.4e}", a.2),
            r.map_or("not reached".into(), |r| {
                format!("{} ({:.3} s)", fmt_num(r.0), r.1)
            }),
            r.map_or("-".into(), |r| format!("{:.2}x", u.0 / r.0)),
            back.map_or("not reached".into(), |b| {
                format!("{} ({:.2}x)", fmt_num(b.0), b.0 / a.0)
            }),
        ]);
    }
    md.push_str(&markdown_table(
        &[
            "run",
            "final rays",
            "final s",
            "final RMSE",
            "rays (time) to uniform's final RMSE",
            "fewer rays than uniform",
            "uniform rays to this run's final RMSE (ratio)",
        ],
        &rows,
    ));
    let best = curves
        .iter()
        .filter(|c| c.0 != "uniform")
        .filter_map(|(n, pts)| reach(pts, u.2).map(|r| (n.clone(), u.0 / r.0)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    md.push_str(&match best {
        Some((n, x)) if x >= 2.0 => {
            format!("\nTarget met: `{n}` reaches uniform's final RMSE with {x:.2}x fewer rays.\n")
        }
        Some((n, x)) => format!(
            "\nTarget missed: the best, `{n}`, reaches uniform's final RMSE with {x:.2}x fewer \
             rays (target 2x).\n"
        ),
        None => "\nTarget missed: no adaptive run reaches uniform's final RMSE.\n".into(),
    });
    if let Some(g) = ctx.read_csv(GROUPS_FILE, GROUPS_HEADER)? {
        md.push_str(
            "\nHow close the samples of a traced group are (distance to the group's centroid, \
             pixels) against the coherence radius R = sqrt(tile area / (pi span)), per pass \
             (adaptive; pass 0 is the superpixel pre-render):\n\n",
        );
        let mut rows = Vec::new();
        let finest = format!("{}", ACCURACIES[ACCURACIES.len() - 1]);
        md.push_str(&format!("(`adaptive {finest}`; the uniform passes use span 36 at 4 lanes: cells of 4 x 1 pixels.)\n\n"));
        for r in g.rows_where("accuracy", &finest)? {
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
    for (stem, alt) in [
        ("aa_rmse_vs_rays", "RMSE vs rays"),
        ("aa_rmse_vs_seconds", "RMSE vs seconds"),
    ] {
        if let Some(p) = ctx.plot_markdown(stem, alt) {
            md.push_str(&p);
        }
    }
    Ok(Some(md))
}
