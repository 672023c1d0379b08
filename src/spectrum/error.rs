//! What can be wrong with a spectral setting (a scene file's or the command line's): the
//! caller names the file or flag.

use thiserror::Error;

/// A spectral setting that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectrumError {
    #[error("unknown spectrum \"{name}\" (known: {known})")]
    UnknownSpectrum { name: String, known: String },
    #[error("a temperature of {kelvin} K is not in (0, 100000] K")]
    BadTemperature { kelvin: f32 },
    #[error("{what} is {value}, expected {expected}")]
    BadCoefficient {
        what: String,
        value: f32,
        expected: &'static str,
    },
    #[error("unknown glass \"{name}\" (known: {known})")]
    UnknownGlass { name: String, known: String },
    #[error("{bins} spectral bins: expected 1 to 1024")]
    BadBins { bins: u32 },
}
