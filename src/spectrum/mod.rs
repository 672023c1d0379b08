//! Spectral colour (the paper's future work: "one spectral color object contains 20 to 40
//! intensities measured for different wavelengths"): the CIE 1931 observer and illuminants,
//! blackbody emitters, RGB reflectances upsampled to smooth spectra (Jakob and Hanika 2019),
//! dispersive indices of refraction, and the wavelengths a spectral sample carries.
//!
//! Wavelengths are in nanometres over [`LAMBDA_MIN`, `LAMBDA_MAX`]. Radiometric conventions:
//! the display's white, linear sRGB `(1, 1, 1)`, is the CIE D65 spectrum scaled to a
//! luminance `Y` of 1; an RGB reflectance is upsampled so that, lit by that white and seen
//! by the CIE 1931 observer, it gives back its RGB.

pub mod blackbody;
pub mod cie;
pub mod dispersion;
pub mod error;
pub mod illuminant;
pub mod sampling;
pub mod upsample;

pub use error::SpectrumError;

/// The shortest wavelength rendered, in nm.
pub const LAMBDA_MIN: f32 = 380.0;
/// The longest wavelength rendered, in nm.
pub const LAMBDA_MAX: f32 = 780.0;
