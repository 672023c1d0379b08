//! The kernels of Tables 1 and 2 per colour form (`spectral_kernels.csv`): what a colour
//! evaluation costs in each form, per backend.
//!
//! Protocol: the kernels are table1's three materials (the brushed metal's tabulated
//! anisotropic BDF, Phong plastic, Fresnel glass's Phong part) on table1's calls (a brushed
//! sphere's pixels in 4 x 4 tiles), and table2's eight light kinds on its shading points (a
//! curved patch of ground in 4 x 4 tiles, every sample of the light). Each produces an RGB
//! value per lane as Tables 1 and 2 do (`reflected` = f cos for the materials, under a
//! constant white light; `li` for the lights, times a grey diffuse BRDF's f cos); one *colour
//! evaluation* is that plus `add_reflected` of it into a colour accumulator of the form
//! (`Rgbs` for `rgb`, `Spectral` for `hero` and `binsN-LAYOUT`), in the lanes the light
//! reaches. A packet also draws its wavelengths (`Colour::waves`, per packet as the renderer
//! does per path) and the accumulator goes to RGB once at the end (`to_rgb`). The inputs of
//! every packet go through `black_box` and the sum of the final RGB comes out, so nothing is
//! optimised away. One timed sample sweeps the inputs until about `evals` evaluations were
//! made; every contender (backend and form) of a kernel makes the same evaluations, and the
//! samples visit them round-robin (the order rotating), after one untimed sample each;
//! medians. RGB runs on every backend usable here, the spectral forms on those the renderer
//! renders spectra on (`SPECTRAL_BACKENDS`; their kernel is compiled there alone). `ns_per_eval_rgb` is
//! the same kernel's `rgb` row on the same backend, `ratio` this row's over it.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use coherent::bdf::workload::BdfInputs;
use coherent::bdf::{
    Analytic, Bdf, Frames, PAPER_ANISOTROPIC_SHAPE, Symmetry, tabulate_anisotropic,
};
use coherent::light::Light;
use coherent::material::{Material, Optics, ShadeHits};
use coherent::render::colour::{Colour, ColourForm, Layout, SPECTRAL_BACKENDS, Spectra, Spectral};
use coherent::simd::{Backend, Kernel, Lanes, Rgbs, SimdF32, SimdMask, Vec3s};

use crate::ctx::Ctx;
use crate::table2::{self, Points};
use crate::timing::median;

pub const FILE: &str = "spectral_kernels.csv";
pub const HEADER: &[&str] = &[
    "backend",
    "lanes",
    "kind",
    "kernel",
    "colour",
    "channels",
    "layout",
    "evals",
    "ns_per_eval",
    "ns_per_eval_rgb",
    "ratio",
    "samples",
];

/// The bin counts timed, in both layouts.
pub const BINS: [u32; 4] = [8, 16, 32, 64];

/// The constant light the materials are shaded under (RGB radiance).
const LIGHT: [f32; 3] = [1.0, 0.95, 0.9];
/// The grey diffuse reflectance the lights shine on.
const ALBEDO: f32 = 0.7;

/// The forms timed: RGB, hero, then each bin count over rays and over wavelengths.
pub fn forms(bins: &[u32]) -> Vec<ColourForm> {
    let mut out = vec![ColourForm::Rgb, ColourForm::Hero];
    for &n in bins {
        for layout in Layout::ALL {
            out.push(ColourForm::bins(n, layout).expect("bins within 1-1024"));
        }
    }
    out
}

/// What one kernel evaluates.
#[derive(Clone, Copy)]
enum Work<'a> {
    Material {
        material: &'a Material,
        inputs: &'a BdfInputs,
        passes: u32,
    },
    Light {
        light: &'a Light,
        points: &'a Points,
        passes: u32,
    },
}

impl Work<'_> {
    /// Colour evaluations per run: one per lane per call (materials) or per light sample
    /// (lights).
    fn evals(&self) -> u64 {
        match self {
            Work::Material { inputs, passes, .. } => *passes as u64 * inputs.len() as u64,
            Work::Light {
                light,
                points,
                passes,
            } => *passes as u64 * points.len() as u64 * u64::from(light.samples()),
        }
    }
}

/// The packet of vectors `k` of the calls starting at `i`.
#[inline(always)]
fn load3<L: Lanes>(l: L, v: &[Vec<f32>; 3], i: usize) -> Vec3s<L> {
    Vec3s::new(l.load(&v[0][i..]), l.load(&v[1][i..]), l.load(&v[2][i..]))
}

/// The kernel in colour form `C`: every evaluation of `work` into one accumulator, whose RGB
/// sum comes out.
#[inline(always)]
fn eval<L: Lanes, C: Colour<L>>(l: L, t: &C::Tables, work: &Work<'_>) -> f32 {
    let zero = l.splat(0.0);
    let all = l.splat_mask(true);
    let mut acc = C::zero(l, t);
    let mut w = C::waves(l, t, l.splat_i32(0));
    match *work {
        Work::Material {
            material,
            inputs,
            passes,
        } => {
            let li = Rgbs::splat(l, LIGHT);
            for _ in 0..passes {
                let mut i = 0;
                while i + L::N <= inputs.len() {
                    let v = black_box(&inputs.v);
                    let frames = Frames {
                        tangent: load3(l, &v[0], i),
                        bitangent: load3(l, &v[1], i),
                        normal: load3(l, &v[2], i),
                    };
                    let hits = ShadeHits {
                        active: all,
                        material: l.splat_i32(0),
                        frames,
                        wo: load3(l, &v[4], i),
                        s: zero,
                        t: zero,
                        lod: zero,
                    };
                    let wi = load3(l, &v[3], i);
                    w = C::waves(l, t, l.from_fn_i32(|k| (i + k) as i32));
                    let s = material.shade(l, &hits, &wi);
                    acc.add_reflected(l, t, &w, all, s.reflected, li, None);
                    i += L::N;
                }
            }
        }
        Work::Light {
            light,
            points,
            passes,
        } => {
            let f = Rgbs::splat(l, [ALBEDO * std::f32::consts::FRAC_1_PI; 3]);
            let samples = light.samples();
            for _ in 0..passes {
                let mut i = 0;
                while i + L::N <= points.len() {
                    let pts = black_box(points);
                    let p = load3(l, &pts.p, i);
                    let n = load3(l, &pts.n, i);
                    let u = [l.load(&pts.u[0][i..]), l.load(&pts.u[1][i..])];
                    w = C::waves(l, t, l.from_fn_i32(|k| (i + k) as i32));
                    for k in 0..samples {
                        let s = light.sample(l, &p, &n, all, k, u);
                        let cos = s.active.select(n.dot(s.wi).max(zero), zero);
                        acc.add_reflected(l, t, &w, s.active, f.scale(cos), s.li, None);
                    }
                    i += L::N;
                }
            }
        }
    }
    let rgb = acc.to_rgb(l, t, &w);
    let total = rgb.r + rgb.g + rgb.b;
    (0..L::N).map(|k| total.lane(k)).sum()
}

/// The kernel accumulating in RGB, on every backend.
#[derive(Clone, Copy)]
struct RgbEval<'a> {
    work: &'a Work<'a>,
}

impl Kernel for RgbEval<'_> {
    type Output = f32;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f32 {
        eval::<L, Rgbs<L>>(l, &(), self.work)
    }
}

/// The kernel accumulating in a spectral form, on `SPECTRAL_BACKENDS` alone (where the
/// renderer renders spectra).
#[derive(Clone, Copy)]
struct SpectralEval<'a> {
    work: &'a Work<'a>,
    spectra: &'a Spectra,
}

impl Kernel for SpectralEval<'_> {
    type Output = f32;
    const BACKENDS: u32 = SPECTRAL_BACKENDS;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> f32 {
        eval::<L, Spectral<L>>(l, self.spectra, self.work)
    }
}

/// One run of `work` on `backend` in the form of `spectra` (RGB for `None`); its seconds.
fn time_once(backend: Backend, work: &Work<'_>, spectra: Option<&Spectra>) -> anyhow::Result<f64> {
    let start = Instant::now();
    let out = match spectra {
        None => backend.run(RgbEval { work })?,
        Some(spectra) => backend.run(SpectralEval { work, spectra })?,
    };
    let seconds = start.elapsed().as_secs_f64();
    black_box(out);
    Ok(seconds)
}

/// Table1's three materials (those of `table1_splits.csv`), by name.
fn materials() -> anyhow::Result<Vec<(&'static str, Material)>> {
    let brushed = Arc::new(Bdf::from(tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )?));
    let mut metal = Material::phong("brushed metal", [0.0; 3], [0.0; 3], 0.0);
    metal.bdf = Some(brushed);
    let plastic = Material::phong("plastic", [0.6, 0.1, 0.1], [0.3; 3], 30.0);
    let mut glass = Material::phong("glass", [0.0; 3], [0.05; 3], 200.0);
    glass.optics = Optics {
        reflectance: [1.0; 3],
        transmittance: [0.9; 3],
        ior: 1.5,
        fresnel: true,
        dispersion: None,
    };
    Ok(vec![
        ("brushed", metal),
        ("plastic", plastic),
        ("glass", glass),
    ])
}

pub(super) fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let backends = Backend::available();
    // The spectral ones are noted once, by the experiment.
    for b in Backend::ALL
        .into_iter()
        .filter(|b| SPECTRAL_BACKENDS & b.bit() == 0)
    {
        if let Some(why) = b.unavailable_reason() {
            ctx.note(format!("spectral kernels: backend {b} skipped: {why}"));
        }
    }
    let size = ctx.pick(32, 64);
    let evals = ctx.pick(1_000, 20_000);
    let samples = ctx.pick(2, 9);
    run_with(ctx, &backends, &BINS, size, evals, samples)
}

/// Times the kernels on `backends` (RGB; the spectral forms of `bins` on the hand-written
/// ones among them): table1's calls for a `size` x `size` sphere image, table2's points on a
/// `size` x `size` grid, about `evals` evaluations per timed sample, `samples` samples.
pub(super) fn run_with(
    ctx: &mut Ctx,
    backends: &[Backend],
    bins: &[u32],
    size: usize,
    evals: usize,
    samples: usize,
) -> anyhow::Result<()> {
    let materials = materials()?;
    let lights: Vec<(&'static str, Light)> = table2::lights()?
        .into_iter()
        .filter(|(name, _)| table2::PAPER.rows.iter().any(|(k, _)| k == name))
        .collect();
    let inputs = BdfInputs::sphere(size);
    anyhow::ensure!(
        !inputs.is_empty(),
        "a {size} x {size} sphere image has no whole tile"
    );
    let points = table2::points(size);
    let forms = forms(bins);
    let tables: Vec<Option<Spectra>> = forms
        .iter()
        .map(|&f| Spectra::plain(f))
        .collect::<Result<_, _>>()?;
    // Contenders: RGB on every backend, spectral forms on the hand-written ones.
    let mut contenders: Vec<(Backend, usize)> = Vec::new();
    for &b in backends {
        for (k, form) in forms.iter().enumerate() {
            if !form.is_spectral() || SPECTRAL_BACKENDS & b.bit() != 0 {
                contenders.push((b, k));
            }
        }
    }

    let mut works: Vec<(&str, &str, Work<'_>)> = Vec::new();
    for (name, material) in &materials {
        let passes = evals.div_ceil(inputs.len()).max(1) as u32;
        works.push((
            "material",
            name,
            Work::Material {
                material,
                inputs: &inputs,
                passes,
            },
        ));
    }
    for (name, light) in &lights {
        let per = points.len() * light.samples() as usize;
        let passes = evals.div_ceil(per).max(1) as u32;
        works.push((
            "light",
            name,
            Work::Light {
                light,
                points: &points,
                passes,
            },
        ));
    }

    let bar = ctx.progress((works.len() * samples) as u64, "spec kern");
    let mut csv = ctx.csv(FILE, HEADER)?;
    for (kind, name, work) in &works {
        bar.set_message(name.to_string());
        let mut seconds: BTreeMap<(Backend, usize), Vec<f64>> = BTreeMap::new();
        for &(b, k) in &contenders {
            time_once(b, work, tables[k].as_ref())?; // warm-up
        }
        for s in 0..samples {
            for i in 0..contenders.len() {
                let (b, k) = contenders[(i + s) % contenders.len()];
                let t = time_once(b, work, tables[k].as_ref())?;
                seconds.entry((b, k)).or_default().push(t);
            }
            bar.inc(1);
        }
        let n = work.evals();
        let ns = |b: Backend, k: usize| median(&seconds[&(b, k)]) * 1e9 / n as f64;
        for &(b, k) in &contenders {
            let (here, rgb) = (ns(b, k), ns(b, 0));
            let form = &forms[k];
            let cells: [&dyn Display; 12] = [
                &b.name(),
                &b.lanes(),
                kind,
                name,
                &form.label(),
                &form.channels(),
                &super::layout_name(form),
                &n,
                &format!("{here:.3}"),
                &format!("{rgb:.3}"),
                &format!("{:.4}", here / rgb),
                &samples,
            ];
            csv.row(&cells)?;
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent::simd::scalar::Scalar;

    #[test]
    fn every_form_accumulates_about_the_same_rgb() {
        // The forms differ in how they carry colour, not in what they add up: a grey light
        // on a grey surface gives nearly the same RGB in every form.
        let lights = table2::lights().unwrap();
        let (_, omni) = lights.iter().find(|(n, _)| *n == "omni").unwrap();
        let points = table2::points(8);
        let work = Work::Light {
            light: omni,
            points: &points,
            passes: 1,
        };
        let rgb = eval::<Scalar, Rgbs<Scalar>>(Scalar, &(), &work);
        assert!(rgb > 0.0);
        // Hero's accumulator mixes packets of other wavelengths (its sum means nothing, its
        // time is what counts): the bins only.
        for form in forms(&[8, 32]).into_iter().skip(2) {
            let t = Spectra::plain(form).unwrap().unwrap();
            let v = eval::<Scalar, Spectral<Scalar>>(Scalar, &t, &work);
            assert!(
                (v / rgb - 1.0).abs() < 0.1,
                "{}: {v} against rgb {rgb}",
                form.label()
            );
        }
    }
}
