//! Image output of the film: HDR radiance to OpenEXR, the tone-mapped image (section 6.1)
//! to PNG, and either screen matrix (mean colour, sample count as alpha) for inspection.

use std::path::Path;

use coherent_simd::Backend;

use super::{Film, FilmError, Rendered};
use crate::tonemap;

fn write_error(path: &Path, reason: impl ToString) -> FilmError {
    FilmError::Write {
        path: path.to_path_buf(),
        reason: reason.to_string(),
    }
}

impl Film {
    /// The image as a display shows it (see [`Rendered::displayed`]), tone-mapped in
    /// packets with `backend`: what a viewer shows after each pass.
    pub fn displayed(&self, backend: Backend) -> Result<Vec<[f32; 3]>, FilmError> {
        let mut image = tonemap::apply_image(backend, &self.tonemap, &self.estimate())?;
        for px in &mut image {
            for c in px.iter_mut() {
                *c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
            }
        }
        Ok(image)
    }

    /// The displayed image encoded as an sRGB PNG file, in memory: bands of rows estimated,
    /// tone-mapped and encoded to sRGB in parallel on the current rayon pool, so that a
    /// viewer, which makes one after every pass, keeps its threads busy.
    pub fn png(&self, backend: Backend) -> Result<Vec<u8>, FilmError> {
        use rayon::prelude::*;
        const ROWS: usize = 16;
        let w = self.width as usize;
        let mut bytes = vec![0u8; self.pixels() * 3];
        bytes
            .par_chunks_mut(ROWS * w * 3)
            .enumerate()
            .try_for_each(|(i, band)| {
                let first = i * ROWS * w;
                let px: Vec<[f32; 3]> = (first..first + band.len() / 3)
                    .map(|p| self.pixel(p))
                    .collect();
                let mut mapped = vec![[0.0f32; 3]; px.len()];
                tonemap::apply_into(backend, &self.tonemap, &px, &mut mapped)?;
                // `srgb8` clips as the display does ([`Film::displayed`]).
                for (b, c) in band.chunks_exact_mut(3).zip(&mapped) {
                    for (b, v) in b.iter_mut().zip(c) {
                        *b = tonemap::srgb8(*v);
                    }
                }
                Ok::<(), FilmError>(())
            })?;
        let img = image::RgbImage::from_raw(self.width, self.height, bytes)
            .ok_or_else(|| FilmError::Options("image size does not match the pixels".into()))?;
        // Fast compression: a viewer encodes a frame after every pass, and the default
        // level took longer than a pass of a small image.
        let mut out = Vec::new();
        let encoder = image::codecs::png::PngEncoder::new_with_quality(
            &mut out,
            image::codecs::png::CompressionType::Fast,
            image::codecs::png::FilterType::Sub,
        );
        img.write_with_encoder(encoder)
            .map_err(|e| FilmError::Options(format!("encoding the PNG: {e}")))?;
        Ok(out)
    }
}

/// sRGB-encoded bytes of display values, 3 per pixel.
fn srgb_bytes(px: &[[f32; 3]]) -> Vec<u8> {
    px.iter().flat_map(|c| c.map(tonemap::srgb8)).collect()
}

impl<S> Rendered<S> {
    /// The HDR radiance estimate, row by row.
    pub fn image(&self) -> Vec<[f32; 3]> {
        self.film.estimate()
    }

    /// The tone-mapped image, computed in packets with `backend`: each pixel's colour scaled
    /// so that its luminance is the operator's display luminance in `[0, 1]`. A saturated
    /// colour's channels may then exceed 1 (pure blue at display luminance 1 has
    /// `b = 1 / 0.0722`); a display clips them, see [`Rendered::displayed`].
    pub fn tone_mapped(&self, backend: Backend) -> Result<Vec<[f32; 3]>, FilmError> {
        Ok(tonemap::apply_image(backend, &self.tonemap, &self.image())?)
    }

    /// The image as a display shows it and the PNG encodes it (before the sRGB curve): the
    /// tone-mapped image with each channel clipped to `[0, 1]` (NaN as 0, as in the PNG).
    /// Images are compared on these values (PSNR with peak 1), since channels above 1 are
    /// never shown.
    pub fn displayed(&self, backend: Backend) -> Result<Vec<[f32; 3]>, FilmError> {
        self.film.displayed(backend)
    }

    /// Writes the HDR radiance to an OpenEXR file.
    pub fn write_exr(&self, path: &Path) -> Result<(), FilmError> {
        write_exr_rgb(path, self.film.width, self.film.height, &self.image())
    }

    /// Writes the tone-mapped image, sRGB encoded, to a PNG file (tone mapping runs on the
    /// widest backend usable here).
    pub fn write_png(&self, path: &Path) -> Result<(), FilmError> {
        let backend = Backend::widest();
        write_png_rgb(
            path,
            self.film.width,
            self.film.height,
            &self.displayed(backend)?,
        )
    }

    /// Writes screen matrix `which` (0 or 1): RGB = its mean colour, A = its sample count.
    pub fn write_matrix_exr(&self, which: usize, path: &Path) -> Result<(), FilmError> {
        let m = self
            .film
            .matrices
            .get(which)
            .ok_or_else(|| FilmError::Options(format!("screen matrix {which}: there are 2")))?;
        let w = self.film.width as usize;
        exr::prelude::write_rgba_file(path, w, self.film.height as usize, |x, y| {
            let p = y * w + x;
            let c = m.mean(p);
            (c[0], c[1], c[2], m.count[p] as f32)
        })
        .map_err(|e| write_error(path, e))
    }

    /// Writes the image to `path`, as EXR or PNG by its extension.
    pub fn write(&self, path: &Path) -> Result<(), FilmError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("exr") => self.write_exr(path),
            Some("png") => self.write_png(path),
            _ => Err(write_error(
                path,
                "unknown image format: the extension must be .exr or .png",
            )),
        }
    }
}

/// Writes RGB radiance to an OpenEXR file.
pub fn write_exr_rgb(path: &Path, w: u32, h: u32, px: &[[f32; 3]]) -> Result<(), FilmError> {
    let wu = w as usize;
    exr::prelude::write_rgb_file(path, wu, h as usize, |x, y| {
        let c = px[y * wu + x];
        (c[0], c[1], c[2])
    })
    .map_err(|e| write_error(path, e))
}

/// Writes display values in `[0, 1]`, sRGB encoded, to a PNG file.
pub fn write_png_rgb(path: &Path, w: u32, h: u32, px: &[[f32; 3]]) -> Result<(), FilmError> {
    let img = image::RgbImage::from_raw(w, h, srgb_bytes(px))
        .ok_or_else(|| write_error(path, "image size does not match the pixels"))?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| write_error(path, e))
}
