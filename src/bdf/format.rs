//! The tabulated BDF file format (paper section 4.2: BDFs are tabulated on non-uniform
//! grids and loaded by the renderer). A small binary format of our own, all numbers
//! little-endian:
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `CBDFTAB\0` |
//! | 8 | 4 | `u32` version, 1 |
//! | 12 | 4 | `u32` dimensions D: 3 isotropic `(theta_i, theta_o, delta_phi)`, 4 anisotropic `(theta_i, phi_i, theta_o, phi_o)` |
//! | 16 | 4 | `u32` channels C: 1 to 3 (`MAX_CHANNELS`; 1 is grey, 3 RGB) |
//! | 20 | 4 | `u32` symmetry: 0 none, 1 quadrant (4D only: `phi_i` in `[0, pi/2]`) |
//! | 24 | 4 D | `u32` node count of each axis, `n_0 .. n_{D-1}` (each at least 2) |
//! | | 4 (n_0 + .. + n_{D-1}) | `f32` nodes, axis after axis, strictly increasing, radians |
//! | | 4 n_0 ... n_{D-1} C | `f32` values, row-major (axis 0 slowest), channels innermost; finite, not negative |
//!
//! Nothing follows the values. Readers reject anything else with an error naming the file
//! and the problem.

use std::path::Path;

use super::error::{BdfError, BdfProblem};
use super::table::{AnisotropicBdf, Bdf, IsotropicBdf, Symmetry};
use crate::tabulated::{Axis, Grid, MAX_CHANNELS, TableError};

/// The first eight bytes of every table file.
pub const MAGIC: [u8; 8] = *b"CBDFTAB\0";
/// The format version this build writes and reads.
pub const VERSION: u32 = 1;

/// Reads a table file.
pub fn read(path: impl AsRef<Path>) -> Result<Bdf, BdfError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| BdfError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(&bytes).map_err(|p| p.at(path))
}

/// Writes a table file.
pub fn write(path: impl AsRef<Path>, bdf: &Bdf) -> Result<(), BdfError> {
    let path = path.as_ref();
    std::fs::write(path, encode(bdf)).map_err(|source| BdfError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The file's bytes for `bdf`.
pub fn encode(bdf: &Bdf) -> Vec<u8> {
    let (axes, channels, values, symmetry): (&[Axis], usize, &[f32], u32) = match bdf {
        Bdf::Isotropic(b) => (b.grid().axes(), b.grid().channels(), b.grid().values(), 0),
        Bdf::Anisotropic(b) => (
            b.grid().axes(),
            b.grid().channels(),
            b.grid().values(),
            match b.symmetry() {
                Symmetry::None => 0,
                Symmetry::Quadrant => 1,
            },
        ),
    };
    let nodes: usize = axes.iter().map(Axis::len).sum();
    let mut out = Vec::with_capacity(24 + 4 * (axes.len() + nodes + values.len()));
    out.extend_from_slice(&MAGIC);
    for word in [VERSION, axes.len() as u32, channels as u32, symmetry] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    for a in axes {
        out.extend_from_slice(&(a.len() as u32).to_le_bytes());
    }
    for v in axes.iter().flat_map(|a| a.nodes()).chain(values) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// A cursor over the file's bytes that reports truncation.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, what: &'static str, n: usize) -> Result<&'a [u8], BdfProblem> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        match end {
            Some(end) => {
                let s = &self.bytes[self.at..end];
                self.at = end;
                Ok(s)
            }
            None => Err(BdfProblem::Truncated {
                what,
                offset: self.at,
                needed: n,
                len: self.bytes.len(),
            }),
        }
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, BdfProblem> {
        let b = self.take(what, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn f32s(&mut self, what: &'static str, n: usize) -> Result<Vec<f32>, BdfProblem> {
        let b = self.take(what, n.saturating_mul(4))?;
        Ok(b.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }
}

/// Parses a table from the file's bytes.
pub fn decode(bytes: &[u8]) -> Result<Bdf, BdfProblem> {
    let mut r = Reader { bytes, at: 0 };
    if r.take("the magic", 8)? != MAGIC {
        return Err(BdfProblem::BadMagic);
    }
    let version = r.u32("the version")?;
    if version != VERSION {
        return Err(BdfProblem::BadVersion(version));
    }
    let dims = r.u32("the dimension count")?;
    if dims != 3 && dims != 4 {
        return Err(BdfProblem::BadDims(dims));
    }
    let channels = r.u32("the channel count")? as usize;
    if channels == 0 || channels > MAX_CHANNELS {
        return Err(TableError::BadChannels { channels }.into());
    }
    let symmetry = match r.u32("the symmetry")? {
        0 => Symmetry::None,
        1 if dims == 4 => Symmetry::Quadrant,
        1 => return Err(BdfProblem::SymmetryOnIsotropic(1)),
        s => return Err(BdfProblem::BadSymmetry(s)),
    };
    let mut lens = Vec::new();
    for axis in 0..dims as usize {
        let len = r.u32("the axis node counts")?;
        // Each node takes 4 bytes in the file: a count beyond the file's size is either
        // truncation (reported below) or corruption; stop absurd allocations here.
        if len as usize > bytes.len() {
            return Err(BdfProblem::HugeAxis { axis, len });
        }
        lens.push(len as usize);
    }
    let mut axes = Vec::new();
    for (axis, &len) in lens.iter().enumerate() {
        axes.push(Axis::new(axis, r.f32s("the axis nodes", len)?)?);
    }
    let count: u128 = lens.iter().map(|&n| n as u128).product::<u128>() * channels as u128;
    if count * 4 > (bytes.len() - r.at) as u128 {
        return Err(BdfProblem::Truncated {
            what: "the values",
            offset: r.at,
            needed: usize::try_from(count * 4).unwrap_or(usize::MAX),
            len: bytes.len(),
        });
    }
    let count = count as usize;
    let values = r.f32s("the values", count)?;
    if r.at != bytes.len() {
        return Err(BdfProblem::TrailingBytes(bytes.len() - r.at));
    }
    Ok(match dims {
        3 => {
            let axes: [Axis; 3] = axes.try_into().expect("three axes");
            IsotropicBdf::new(Grid::new(axes, channels, values)?)?.into()
        }
        _ => {
            let axes: [Axis; 4] = axes.try_into().expect("four axes");
            AnisotropicBdf::new(Grid::new(axes, channels, values)?, symmetry)?.into()
        }
    })
}
