//! Each form's image against a converged spectral reference (`spectral_error.csv`), and
//! without dispersion against RGB.
//!
//! Protocol, per scene (BSP, the widest hand-written backend, every thread, a small image):
//! a reference of 32 bins over rays at `reference_spp` samples per pixel; then each form
//! (rgb, hero, bins32 over rays and over wavelengths) at each of a few sample counts, each
//! image's PSNR against the reference (`dispersion` `on`: the scene as built, dispersive
//! glass included where it has any). Then the same forms with every material's dispersion
//! taken out (`off`; for a scene without dispersive materials these are the same images),
//! hero and bins against the RGB image of the same samples per pixel: the spectral forms
//! should then agree with RGB up to their upsampling (Jakob and Hanika's sigmoids) and, for
//! hero, their wavelength noise.
//!
//! PSNR: both images go through the reference's tone map (the scene's operator, adapted to
//! the reference image) and are clipped to [0, 1], as displayed; the peak is 1.

use std::fmt::Display;
use std::time::Instant;

use coherent::accel_any::AccelKind;
use coherent::film::{FilmOptions, Method};
use coherent::render::centres::psnr;
use coherent::render::colour::ColourForm;
use coherent::render::{Renderer, render_frame};
use coherent::scene::RenderScene;
use coherent::simd::Backend;
use coherent::tonemap::ToneMap;

use crate::ctx::Ctx;
use crate::frames as film_frames;

pub const FILE: &str = "spectral_error.csv";
pub const HEADER: &[&str] = &[
    "scene",
    "dispersion",
    "dispersive",
    "colour",
    "channels",
    "layout",
    "spp",
    "width",
    "height",
    "reference",
    "reference_spp",
    "psnr_db",
    "seconds",
];

/// The target's floor: without dispersion, hero and bins within this of RGB.
pub const AGREEMENT_DB: f64 = 35.0;

/// Measures `scenes` on `backend` (the widest hand-written one usable here).
pub(super) fn run(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    backend: Backend,
) -> anyhow::Result<()> {
    let size = ctx.pick((32, 24), (128, 96));
    // Up to 256 samples per pixel: the agreement target is for converged images, and hero's
    // wavelength noise takes many more samples to fall than RGB's; the reference has 4x the
    // most.
    let levels: Vec<u32> = ctx.pick(vec![1, 2], vec![1, 4, 16, 64, 256]);
    let reference_spp = ctx.pick(4, 1024);
    run_with(ctx, scenes, backend, size, &levels, reference_spp)
}

/// The displayed values of `image` through `tonemap`: clipped to [0, 1], NaN as 0.
fn displayed(tonemap: &ToneMap, image: &[[f32; 3]]) -> anyhow::Result<Vec<[f32; 3]>> {
    let mut out = coherent::tonemap::apply_image(Backend::Scalar, tonemap, image)?;
    for px in &mut out {
        for c in px.iter_mut() {
            *c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
        }
    }
    Ok(out)
}

/// A linear image and its tone map, and the seconds it took.
struct Image {
    linear: Vec<[f32; 3]>,
    tonemap: ToneMap,
    seconds: f64,
}

/// Renders `r` in `form` at `spp` samples per pixel.
fn render(
    pool: &rayon::ThreadPool,
    backend: Backend,
    r: &mut Renderer<'_, coherent::accel_any::AnyAccel>,
    form: ColourForm,
    (width, height): (u32, u32),
    spp: u32,
) -> anyhow::Result<Image> {
    r.set_colour(form)?;
    let opts = FilmOptions::new(width, height, Method::Uniform { spp });
    let start = Instant::now();
    let rendered = pool.install(|| render_frame(backend, r, &opts, &|_| {}))?;
    let seconds = start.elapsed().as_secs_f64();
    Ok(Image {
        linear: rendered.image(),
        tonemap: rendered.tonemap,
        seconds,
    })
}

/// PSNR of `image` against `reference`, both through the reference's tone map.
fn against(image: &Image, reference: &Image) -> anyhow::Result<f64> {
    let a = displayed(&reference.tonemap, &image.linear)?;
    let b = displayed(&reference.tonemap, &reference.linear)?;
    Ok(psnr(&a, &b, 1.0))
}

/// Measures `scenes` on `backend` at `size`, at the sample counts `levels`, against a
/// reference of `reference_spp`.
pub(super) fn run_with(
    ctx: &mut Ctx,
    scenes: &[(String, Box<RenderScene>)],
    backend: Backend,
    size: (u32, u32),
    levels: &[u32],
    reference_spp: u32,
) -> anyhow::Result<()> {
    let forms = super::frame_forms();
    let reference_form =
        ColourForm::bins(super::FRAME_BINS, coherent::render::colour::Layout::Rays)?;
    let every = film_frames::pool(
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
    )?;
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress(scenes.len() as u64, "spec err");
    for (name, scene) in scenes {
        bar.set_message(name.clone());
        let dispersive = super::disperses(scene);
        let plain;
        let ways: Vec<(&str, &RenderScene)> = if dispersive {
            plain = super::without_dispersion(scene);
            vec![("on", scene.as_ref()), ("off", &plain)]
        } else {
            vec![("on", scene.as_ref())]
        };
        // Per way, per form, per level: the images.
        let mut images: Vec<Vec<Vec<Image>>> = Vec::new();
        let mut reference: Option<Image> = None;
        for (w, (_, s)) in ways.iter().enumerate() {
            let mut r = film_frames::renderer(s, AccelKind::Bsp)?;
            r.set_view(&s.camera, size.0, size.1)?;
            if w == 0 {
                reference = Some(render(
                    &every,
                    backend,
                    &mut r,
                    reference_form,
                    size,
                    reference_spp,
                )?);
            }
            let mut per_form = Vec::new();
            for form in &forms {
                let mut per_level = Vec::new();
                for &spp in levels {
                    per_level.push(render(&every, backend, &mut r, *form, size, spp)?);
                }
                per_form.push(per_level);
            }
            images.push(per_form);
        }
        let reference = reference.expect("rendered with the first way");
        let row = |csv: &mut crate::table::CsvOut,
                   way: &str,
                   form: &ColourForm,
                   spp: u32,
                   reference_label: &str,
                   reference_spp: u32,
                   db: f64,
                   seconds: f64|
         -> anyhow::Result<()> {
            let cells: [&dyn Display; 13] = [
                name,
                &way,
                &u8::from(dispersive),
                &form.label(),
                &form.channels(),
                &super::layout_name(form),
                &spp,
                &size.0,
                &size.1,
                &reference_label,
                &reference_spp,
                &format!("{db:.3}"),
                &format!("{seconds:.4}"),
            ];
            csv.row(&cells)
        };
        // The scene as built, against the spectral reference.
        for (k, form) in forms.iter().enumerate() {
            for (j, &spp) in levels.iter().enumerate() {
                let img = &images[0][k][j];
                let db = against(img, &reference)?;
                let label = reference_form.label();
                row(
                    &mut csv,
                    "on",
                    form,
                    spp,
                    &label,
                    reference_spp,
                    db,
                    img.seconds,
                )?;
            }
        }
        // Without dispersion, hero and bins against RGB of the same samples.
        let off = images.last().expect("at least one way");
        for (k, form) in forms.iter().enumerate().skip(1) {
            for (j, &spp) in levels.iter().enumerate() {
                let img = &off[k][j];
                let db = against(img, &off[0][j])?;
                row(&mut csv, "off", form, spp, "rgb", spp, db, img.seconds)?;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn displayed_values_clip_and_zero_nan() {
        let t = ToneMap::new(
            coherent::tonemap::Operator::default(),
            coherent::tonemap::Adaptation {
                log_average: 1.0,
                max: 10.0,
            },
            coherent::tonemap::Display::default(),
        );
        let out = displayed(&t, &[[f32::NAN, 1e9, 0.0]]).unwrap();
        assert_eq!(out[0][0], 0.0);
        assert!(out[0][1] <= 1.0);
        assert_eq!(out[0][2], 0.0);
    }
}
