//! A per-pixel map (`coherent render --aov`) written as a picture and as data: a PNG in the
//! viridis colour map with a colour bar and its label, and a one-channel OpenEXR file with
//! the values themselves.

use std::path::Path;

use exr::prelude::{self as ex, WritableImage};
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use super::FilmError;
use crate::plot_font;

fn write_error(path: &Path, reason: impl ToString) -> FilmError {
    FilmError::Write {
        path: path.to_path_buf(),
        reason: reason.to_string(),
    }
}

/// Width of the strip right of the map that holds the colour bar and its labels.
const STRIP: u32 = 200;

/// The top of the colour scale for `values`: their 99th percentile (one hot pixel does not
/// flatten the rest), at least the smallest positive value, 1 when all are 0.
pub fn scale_top(values: &[f32]) -> f32 {
    let mut v: Vec<f32> = values
        .iter()
        .copied()
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_unstable_by(f32::total_cmp);
    v[((v.len() - 1) as f64 * 0.99).round() as usize]
}

fn label(v: f32) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// Writes the `w` x `h` map `values` (row by row from the top) as `png`, coloured from 0 to
/// `top` (values above it take the top colour; its label says so), with `what` naming the
/// values on the colour bar.
pub fn write_heatmap_png(
    png: &Path,
    values: &[f32],
    w: u32,
    h: u32,
    top: f32,
    what: &str,
) -> Result<(), FilmError> {
    let img = heatmap_image(values, w, h, top, what).map_err(|e| write_error(png, e))?;
    img.save_with_format(png, image::ImageFormat::Png)
        .map_err(|e| write_error(png, e))
}

/// The heat map of [`write_heatmap_png`] as a PNG file in memory (what a viewer shows).
pub fn heatmap_png(
    values: &[f32],
    w: u32,
    h: u32,
    top: f32,
    what: &str,
) -> Result<Vec<u8>, FilmError> {
    let img = heatmap_image(values, w, h, top, what)
        .map_err(|e| FilmError::Options(format!("drawing the {what} map: {e}")))?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| FilmError::Options(format!("encoding the {what} map: {e}")))?;
    Ok(out.into_inner())
}

/// The map drawn with its colour bar, or why it could not be.
fn heatmap_image(
    values: &[f32],
    w: u32,
    h: u32,
    top: f32,
    what: &str,
) -> Result<image::RgbImage, String> {
    if values.len() != w as usize * h as usize {
        return Err("map size does not match the image".into());
    }
    plot_font::register().map_err(|e| e.to_string())?;
    let (bw, bh) = (w + STRIP, h.max(160));
    let mut buf = vec![255u8; bw as usize * bh as usize * 3];
    let top = if top > 0.0 && top.is_finite() {
        top
    } else {
        1.0
    };
    let colour = |v: f32| {
        let c = ViridisRGB.get_color_normalized(v.clamp(0.0, top), 0.0, top);
        [c.0, c.1, c.2]
    };
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = (y * bw as usize + x) * 3;
            buf[i..i + 3].copy_from_slice(&colour(values[y * w as usize + x]));
        }
    }
    let (x0, y0, y1) = (w as i32 + 16, 24i32, bh as i32 - 24);
    {
        let root = BitMapBackend::with_buffer(&mut buf, (bw, bh)).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| e.to_string();
        for y in y0..=y1 {
            let v = top * (y1 - y) as f32 / (y1 - y0) as f32;
            let [r, g, b] = colour(v);
            root.draw(&Rectangle::new(
                [(x0, y), (x0 + 18, y + 1)],
                RGBColor(r, g, b).filled(),
            ))
            .map_err(err)?;
        }
        let font = (plot_font::FAMILY, 14).into_font();
        let over = values.iter().any(|&v| v > top);
        let marks = [
            (
                y0,
                format!("{}{}", if over { ">= " } else { "" }, label(top)),
            ),
            ((y0 + y1) / 2, label(top / 2.0)),
            (y1, "0".to_owned()),
        ];
        for (y, text) in marks {
            root.draw(&Text::new(text, (x0 + 24, y - 7), font.clone()))
                .map_err(err)?;
        }
        root.draw(&Text::new(what.to_owned(), (x0 - 4, 4), font.clone()))
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    image::RgbImage::from_raw(bw, bh, buf)
        .ok_or_else(|| "image size does not match the pixels".into())
}

/// Writes the `w` x `h` map `values` as a one-channel OpenEXR file, the channel named
/// `channel`.
pub fn write_map_exr(
    path: &Path,
    values: &[f32],
    w: u32,
    h: u32,
    channel: &str,
) -> Result<(), FilmError> {
    if values.len() != w as usize * h as usize {
        return Err(write_error(path, "map size does not match the image"));
    }
    let ch = ex::AnyChannel::new(channel, ex::FlatSamples::F32(values.to_vec()));
    let layer = ex::Layer::new(
        (w as usize, h as usize),
        ex::LayerAttributes::named(channel),
        ex::Encoding::FAST_LOSSLESS,
        ex::AnyChannels::sort(ex::SmallVec::from_vec(vec![ch])),
    );
    ex::Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| write_error(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_ignores_the_hottest_pixel_and_zeros() {
        let mut v = vec![0.0; 50];
        v.extend((1..=200).map(|i| i as f32));
        v.push(1e9);
        let top = scale_top(&v);
        assert!((195.0..=201.0).contains(&top), "{top}");
        assert_eq!(scale_top(&[0.0, 0.0]), 1.0);
    }

    #[test]
    fn maps_are_written_and_read_back() {
        let dir = std::env::temp_dir().join(format!("coherent-heatmap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (24u32, 10u32);
        let v: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
        let png = dir.join("m.png");
        write_heatmap_png(&png, &v, w, h, scale_top(&v), "inner nodes per sample").unwrap();
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!((img.width(), img.height()), (w + STRIP, 160));
        // The first pixel is the colour map's bottom, the last row's end near its top.
        assert_ne!(img.get_pixel(0, 0), img.get_pixel(w - 1, h - 1));
        let exr_path = dir.join("m.exr");
        write_map_exr(&exr_path, &v, w, h, "steps").unwrap();
        let back = ex::read_first_flat_layer_from_file(&exr_path).unwrap();
        let ch = &back.layer_data.channel_data.list[0];
        assert_eq!(ch.name, ex::Text::from("steps"));
        match &ch.sample_data {
            ex::FlatSamples::F32(s) => assert_eq!(s, &v),
            other => panic!("{other:?}"),
        }
        let e = write_map_exr(&exr_path, &v[1..], w, h, "steps").unwrap_err();
        assert!(e.to_string().contains("does not match"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
