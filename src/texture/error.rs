//! What can be wrong with a texture (paper section 4.1): every error names the file (or
//! the texture's label) and the problem.

use thiserror::Error;

/// A texture that could not be loaded or built.
#[derive(Debug, Error)]
pub enum TextureError {
    #[error("texture {name}: cannot read the file: {source}")]
    Io {
        name: String,
        #[source]
        source: std::io::Error,
    },
    #[error("texture {name}: cannot decode the image: {message}")]
    Decode { name: String, message: String },
    #[error("texture {name}: unknown image type (expected .png, .jpg, .jpeg or .exr)")]
    UnknownFormat { name: String },
    #[error("texture {name}: the image is {width} x {height} texels, which is empty")]
    Empty {
        name: String,
        width: usize,
        height: usize,
    },
    #[error("texture {name}: {width} x {height} texels is beyond the {max} x {max} limit")]
    TooLarge {
        name: String,
        width: usize,
        height: usize,
        max: usize,
    },
    #[error("texture {name}: {given} texels given for {width} x {height}")]
    WrongSize {
        name: String,
        width: usize,
        height: usize,
        given: usize,
    },
    #[error(
        "texture {name}: texel {index} channel {channel} is {value}, not a finite non-negative value"
    )]
    BadTexel {
        name: String,
        index: usize,
        channel: usize,
        value: f32,
    },
}
