//! Experiment `aa`: progressive adaptive anti-aliasing against classical supersampling
//! (paper section 6.2). Both render a test scene with edges and smooth walls through the
//! film; after every pass the image so far is compared with a converged reference (RMSE of
//! the radiance), giving error against rays traced and against time. The paper claims that
//! adaptive rendering with anti-aliasing can be faster than the classical algorithm at the
//! same quality; the target here: adaptive reaches uniform's final RMSE with at least 2x
//! fewer rays.
//!
//! The integrator is a small stand-in (camera rays through the BSP, Lambert surfaces, one
//! point light with shadow rays): the film only needs radiance per sample. The renderer's
//! packet pipeline, which implements the same `SampleTracer`, may replace it.

use std::sync::Mutex;
use std::time::Instant;

use coherent::accel::scenes::{self, SceneSize, View};
use coherent::accel::{Accel, Rays, Scene};
use coherent::bsp::{Bsp, BspParams};
use coherent::film::{self, FilmOptions, Method, PassRecord, PassReport, SampleTracer};
use coherent::sampler::HaltonTile;
use coherent::simd::{Backend, Lanes, MAX_LANES, Rgbs, SimdF32, SimdMask};
use glam::Vec3;

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
    status: Status::Ready { run, report },
};

const FILE: &str = "aa.csv";
const HEADER: &[&str] = &["method", "rays", "seconds", "rmse"];
const GROUPS_FILE: &str = "aa_groups.csv";
const GROUPS_HEADER: &[&str] = &[
    "method",
    "pass",
    "span",
    "radius",
    "mean_distance",
    "max_distance",
    "groups_traced",
    "groups_skipped",
    "rays",
];

/// Camera rays, Lambert surfaces (albedo 0.7) and one point light with shadow rays, over
/// the BSP. Stats: shadow rays traced.
pub struct LambertTracer {
    bsp: Bsp,
    scene: Scene,
    view: View,
    light: Vec3,
    intensity: f32,
    width: f32,
    height: f32,
}

impl LambertTracer {
    pub fn new(s: scenes::BuiltinScene, width: u32, height: u32) -> anyhow::Result<Self> {
        let bsp = Bsp::build(&s.scene, &BspParams::default())?;
        Ok(LambertTracer {
            bsp,
            scene: s.scene,
            view: s.view,
            light: s.light,
            intensity: 20.0,
            width: width as f32,
            height: height as f32,
        })
    }

    /// Radiance of a hit: Lambert under the point light, shadowed, plus a little ambient.
    fn shade(
        &self,
        ray_o: Vec3,
        ray_d: Vec3,
        hit: coherent::accel::Hit1,
        shadows: &mut u64,
    ) -> [f32; 3] {
        let inst = &self.scene.instances[hit.inst as usize];
        let [a, b, c] = self.scene.meshes[inst.mesh].triangle(hit.prim as usize);
        let m = inst.world_from_object;
        let (a, b, c) = (
            m.transform_point3(a),
            m.transform_point3(b),
            m.transform_point3(c),
        );
        let mut n = (b - a).cross(c - a).normalize_or_zero();
        if n.dot(ray_d) > 0.0 {
            n = -n;
        }
        let p = ray_o + ray_d * hit.t;
        let to_light = self.light - p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let cos = n.dot(wi);
        let albedo = [0.7, 0.65, 0.55];
        let ambient = 0.03;
        let mut direct = 0.0;
        if cos > 0.0 {
            *shadows += 1;
            let shadow = coherent::accel::Ray1::new(p + n * 1e-3, to_light, 0.0, 1.0 - 1e-4);
            if !self.bsp.occluded1(&shadow) {
                direct = self.intensity * cos / dist2 / core::f32::consts::PI;
            }
        }
        let e = direct + ambient;
        [albedo[0] * e, albedo[1] * e, albedo[2] * e]
    }
}

impl SampleTracer for LambertTracer {
    type Stats = u64;
    fn merge_stats(into: &mut u64, from: u64) {
        *into += from;
    }
    #[inline(always)]
    fn trace<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        _ids: L::I32s,
        active: L::Mask,
        stats: &mut u64,
    ) -> Rgbs<L> {
        let aspect = self.width / self.height;
        let rays = Rays::from_fn(l, |i| {
            self.view
                .ray_at(xs.lane(i) / self.width, ys.lane(i) / self.height, aspect)
        });
        let hits = self.bsp.intersect(l, &rays, active);
        let mut c = [[0.0f32; 3]; MAX_LANES];
        for (i, ci) in c.iter_mut().enumerate().take(L::N) {
            if !active.lane(i) {
                continue;
            }
            if let Some(h) = hits.lane(i) {
                let r = rays.lane(i);
                *ci = self.shade(r.origin, r.dir, h, stats);
            }
        }
        Rgbs::new(
            l.from_fn(|i| c[i][0]),
            l.from_fn(|i| c[i][1]),
            l.from_fn(|i| c[i][2]),
        )
    }
}

fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let mut s = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            s += ((x[c] - y[c]) as f64).powi(2);
        }
    }
    (s / (3 * a.len().max(1)) as f64).sqrt()
}

/// Renders and records, per pass, (record, seconds without the recording, image).
fn passes(
    backend: Backend,
    tracer: &LambertTracer,
    opts: &FilmOptions,
) -> anyhow::Result<(Vec<(PassRecord, f64, Vec<[f32; 3]>)>, film::Rendered<u64>)> {
    // The callback's own time (copying the image) is left out of the pass times.
    let spent = Mutex::new((0.0f64, Vec::new()));
    let r = film::render(backend, tracer, opts, &|p: &PassReport| {
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
    let tracer = LambertTracer::new(scenes::room(size), w, h)?;
    // The paper's 4-lane packets where the CPU has them.
    let backend = Backend::preferred_for_lanes(4).unwrap_or(Backend::Scalar);
    let ref_spp = ctx.pick(64, 256);
    let uniform_spp = ctx.pick(16, 64);
    let bar = ctx.progress(3, "aa");

    // The reference: many more samples, from another Halton tile (other positions).
    let mut ref_opts = FilmOptions::new(w, h, Method::Uniform { spp: ref_spp });
    ref_opts.tile = HaltonTile::new(3, 3);
    let reference = film::render(backend, &tracer, &ref_opts, &|_| {})?.image();
    bar.inc(1);

    let mut csv = ctx.csv(FILE, HEADER)?;
    let mut groups = ctx.csv(GROUPS_FILE, GROUPS_HEADER)?;
    let methods = [
        ("uniform", Method::Uniform { spp: uniform_spp }),
        (
            "adaptive",
            Method::Adaptive {
                accuracy: 0.02,
                max_samples_per_pixel: uniform_spp * 2,
                time_budget: None,
            },
        ),
    ];
    for (name, method) in methods {
        let opts = FilmOptions::new(w, h, method);
        let (records, rendered) = passes(backend, &tracer, &opts)?;
        for (rec, seconds, img) in &records {
            csv.row(&[
                &name,
                &rec.rays,
                &format!("{seconds:.6e}"),
                &format!("{:.6e}", rmse(img, &reference)),
            ])?;
            groups.row(&[
                &name,
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
    plots(ctx)?;
    Ok(())
}

/// (rays, seconds, rmse) per method, in pass order.
fn curves(ctx: &Ctx) -> anyhow::Result<Option<Vec<(String, Vec<(f64, f64, f64)>)>>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for m in t.distinct("method")? {
        let mut pts = Vec::new();
        for r in t.rows_where("method", &m)? {
            pts.push((t.f64(r, "rays")?, t.f64(r, "seconds")?, t.f64(r, "rmse")?));
        }
        out.push((m, pts));
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
                y_label: "RMSE (radiance)".into(),
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
    let get = |m: &str| curves.iter().find(|c| c.0 == m).map(|c| c.1.clone());
    let (Some(uni), Some(ada)) = (get("uniform"), get("adaptive")) else {
        return Ok(None);
    };
    let mut md = String::new();
    md.push_str(
        "The room scene (edges, smooth walls, shadows) through a small Lambert + point-light \
         tracer over the BSP, 4-lane packets. `uniform`: Halton supersampling, one pass per \
         sample per pixel; `adaptive`: the paper's superpixels (8 x 6, interpolated where \
         their corners agree), then Halton groups of growing span, a pixel stopping when its \
         two screen matrices agree within 2% over its 3x3 neighbourhood (cap: twice the \
         uniform spp). RMSE of the radiance against a converged uniform render from another \
         Halton tile. Target: adaptive reaches uniform's final RMSE with at least 2x fewer \
         rays.\n\n",
    );
    let mut rows = Vec::new();
    for u in uni.iter().skip(1).filter(|p| p.2.is_finite()) {
        let a = reach(&ada, u.2);
        rows.push(vec![
            fmt_num(u.0),
            format!("{:.4e}", u.2),
            a.map_or("not reached".into(), |a| fmt_num(a.0)),
            a.map_or("-".into(), |a| format!("{:.2}x", u.0 / a.0)),
            format!("{:.3}", u.1),
            a.map_or("-".into(), |a| format!("{:.3}", a.1)),
        ]);
    }
    md.push_str(&markdown_table(
        &[
            "uniform rays",
            "uniform RMSE",
            "adaptive rays to that RMSE",
            "rays saved",
            "uniform s",
            "adaptive s",
        ],
        &rows,
    ));
    let last_u = uni.last().copied();
    let last_a = ada.last().copied();
    if let (Some(u), Some(a)) = (last_u, last_a) {
        md.push_str(&format!(
            "\nFinal: uniform {} rays, RMSE {:.4e}, {:.3} s; adaptive {} rays, RMSE {:.4e}, {:.3} s.\n",
            fmt_num(u.0),
            u.2,
            u.1,
            fmt_num(a.0),
            a.2,
            a.1
        ));
        md.push_str(&match reach(&ada, u.2) {
            Some(r) if u.0 / r.0 >= 2.0 => format!(
                "Target met: adaptive reaches uniform's final RMSE with {:.2}x fewer rays.\n",
                u.0 / r.0
            ),
            Some(r) => format!(
                "Target missed: adaptive reaches uniform's final RMSE with {:.2}x fewer rays (target 2x).\n",
                u.0 / r.0
            ),
            None => "Target missed: adaptive does not reach uniform's final RMSE.\n".into(),
        });
    }
    if let Some(g) = ctx.read_csv(GROUPS_FILE, GROUPS_HEADER)? {
        md.push_str(
            "\nHow close the samples of a traced group are (distance to the group's centroid, \
             pixels) against the coherence radius R = sqrt(tile area / (pi span)), per pass \
             (adaptive; pass 0 is the superpixel pre-render):\n\n",
        );
        let mut rows = Vec::new();
        for r in g.rows_where("method", "adaptive")? {
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
