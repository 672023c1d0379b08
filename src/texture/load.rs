//! Texture files (paper section 4.1): 8-bit (or 16-bit) PNG and JPEG images through
//! `image`, turned into linear values by inverse tone mapping ("the initial texture image is
//! stored with only 8 bits of precision"), and HDR OpenEXR images through `exr`, already
//! linear.

use std::io::Cursor;
use std::path::Path;

use coherent_simd::scalar::Scalar;

use super::error::TextureError;
use super::pyramid::Texture;
use super::sample::Wrap;
use crate::approx;

/// The inverse of the display transform: a display value `v` in `[0, 1]` came from the
/// linear value `white * v^gamma`. Computed with the approximate [`approx::pow`], as the
/// forward tone mapping is (paper section 6.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InverseToneMap {
    pub gamma: f32,
    /// The linear value shown as display white.
    pub white: f32,
}

impl Default for InverseToneMap {
    /// Gamma 2.2, white 1.
    fn default() -> Self {
        Self {
            gamma: 2.2,
            white: 1.0,
        }
    }
}

impl InverseToneMap {
    /// The linear value of display value `v` (`[0, 1]`).
    pub fn linear(&self, v: f32) -> f32 {
        let v = v.clamp(0.0, 1.0);
        self.white * approx::pow(Scalar, v, self.gamma)
    }
}

/// Loads a texture: `.png`, `.jpg`/`.jpeg` (display values, inverse tone mapped with
/// `tone`) or `.exr` (linear RGB, `tone` unused).
pub fn load(
    path: impl AsRef<Path>,
    wrap: Wrap,
    tone: &InverseToneMap,
) -> Result<Texture, TextureError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| TextureError::Io {
        name: path.display().to_string(),
        source,
    })?;
    decode(path, bytes, wrap, tone)
}

/// [`load`] on the file's bytes, as if read from `path` (its extension picks the format; errors
/// name it).
pub fn decode(
    path: &Path,
    bytes: Vec<u8>,
    wrap: Wrap,
    tone: &InverseToneMap,
) -> Result<Texture, TextureError> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "png" | "jpg" | "jpeg" => decode_display(name, &bytes, &ext, wrap, tone),
        "exr" => decode_exr(name, bytes, wrap),
        _ => Err(TextureError::UnknownFormat { name }),
    }
}

/// A PNG or JPEG image in memory, inverse tone mapped.
pub fn decode_display(
    name: String,
    bytes: &[u8],
    ext: &str,
    wrap: Wrap,
    tone: &InverseToneMap,
) -> Result<Texture, TextureError> {
    let format = match ext {
        "png" => image::ImageFormat::Png,
        _ => image::ImageFormat::Jpeg,
    };
    let img =
        image::load_from_memory_with_format(bytes, format).map_err(|e| TextureError::Decode {
            name: name.clone(),
            message: e.to_string(),
        })?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    if width == 0 || height == 0 {
        return Err(TextureError::Empty {
            name,
            width,
            height,
        });
    }
    let rgb = img.to_rgb32f();
    // 8-bit images have 256 display values: map each once.
    let lut: Vec<f32> = (0..256).map(|v| tone.linear(v as f32 / 255.0)).collect();
    let is_8bit = img.color().bytes_per_pixel() == img.color().channel_count();
    let texels: Vec<[f32; 3]> = rgb
        .pixels()
        .map(|p| {
            p.0.map(|v| {
                if is_8bit {
                    lut[(v * 255.0).round().clamp(0.0, 255.0) as usize]
                } else {
                    tone.linear(v)
                }
            })
        })
        .collect();
    Texture::from_linear(name, width, height, &texels, wrap)
}

/// The sides of every layer of an OpenEXR file, from its headers. The decoders allocate a
/// layer's texels before they read any, so a size the caller refuses must be refused from
/// the headers first: a broken header can claim billions of texels.
pub(crate) fn exr_layer_sizes(bytes: &[u8]) -> Result<Vec<(usize, usize)>, exr::error::Error> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)?;
    Ok(meta
        .headers
        .iter()
        .map(|h| (h.layer_size.width(), h.layer_size.height()))
        .collect())
}

/// Checks the counters that open each DWAA/DWAB block of an OpenEXR file (whose layer sizes
/// the caller has accepted): the exr crate allocates what they ask for before it compares
/// them with the block, so a broken one asks for exabytes (a panic, or the process aborts).
pub(crate) fn check_exr_dwa_blocks(bytes: &[u8]) -> Result<(), exr::error::Error> {
    use exr::block::chunk::CompressedBlock;
    use exr::compression::Compression::{DWAA, DWAB};
    let reader = exr::block::read(Cursor::new(bytes), false)?;
    let headers = reader.headers().to_vec();
    let dwa = |h: &exr::meta::header::Header| matches!(h.compression, DWAA(_) | DWAB(_));
    if !headers.iter().any(dwa) {
        return Ok(());
    }
    for chunk in reader.all_chunks(false)? {
        let chunk = chunk?;
        let Some(h) = headers.get(chunk.layer_index).filter(|h| dwa(h)) else {
            continue;
        };
        let data = match &chunk.compressed_block {
            CompressedBlock::ScanLine(b) => &b.compressed_pixels_le,
            CompressedBlock::Tile(b) => &b.compressed_pixels_le,
            _ => continue,
        };
        let at = h.get_absolute_block_pixel_coordinates(
            h.get_block_data_indices(&chunk.compressed_block)?,
        )?;
        at.validate(Some(h.layer_size))?;
        let expected = at.size.area().saturating_mul(h.channels.bytes_per_pixel);
        // Too short for the counters (the decoder says so), or stored raw.
        if data.len() < 88 || data.len() == expected {
            continue;
        }
        let counter = |k: usize| u64::from_le_bytes(data[8 * k..8 * k + 8].try_into().unwrap());
        // Uncompressed sizes of the sections and the AC and DC coefficient counts, in bytes.
        // A section may exceed the block (8 x 8 DCT blocks pad a block of few lines): 16
        // times the block and 64 KiB is far above that.
        let limit = (expected as u64).saturating_mul(16).saturating_add(1 << 16);
        for (k, bytes_each, what) in [
            (1, 1, "unknown section"),
            (6, 1, "RLE section"),
            (7, 1, "RLE raw section"),
            (8, 2, "AC coefficients"),
            (9, 2, "DC coefficients"),
        ] {
            let size = counter(k).saturating_mul(bytes_each);
            if size > limit {
                return Err(exr::error::Error::Invalid(
                    format!("a DWA block of {expected} bytes claims {size} bytes of {what}").into(),
                ));
            }
        }
    }
    Ok(())
}

/// An OpenEXR image in memory (its first RGB(A) layer; alpha ignored).
pub fn decode_exr(name: String, bytes: Vec<u8>, wrap: Wrap) -> Result<Texture, TextureError> {
    use exr::prelude::*;
    let decode_error = |e: exr::error::Error| TextureError::Decode {
        name: name.clone(),
        message: e.to_string(),
    };
    let max = super::pyramid::MAX_SIDE;
    let sizes = exr_layer_sizes(&bytes).map_err(decode_error)?;
    if let Some(&(width, height)) = sizes.iter().find(|(w, h)| *w > max || *h > max) {
        return Err(TextureError::TooLarge {
            name,
            width,
            height,
            max,
        });
    }
    check_exr_dwa_blocks(&bytes).map_err(decode_error)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size: Vec2<usize>, _: &RgbaChannels| {
                (size.width(), size.height(), vec![[0.0f32; 3]; size.area()])
            },
            |(w, _, texels): &mut (usize, usize, Vec<[f32; 3]>),
             at: Vec2<usize>,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                texels[at.y() * *w + at.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(decode_error)?;
    let (width, height, texels) = image.layer_data.channel_data.pixels;
    if width == 0 || height == 0 {
        return Err(TextureError::Empty {
            name,
            width,
            height,
        });
    }
    Texture::from_linear(name, width, height, &texels, wrap)
}
