//! Tabulated BDFs on non-uniform grids (paper section 4.2): 3D isotropic tables over
//! `(theta_i, theta_o, delta_phi)` and 4D anisotropic tables over
//! `(theta_i, phi_i, theta_o, phi_o)`, evaluated for a packet by the paper's three steps:
//! angles, an N-wide binary search per axis, multilinear interpolation in the cell.
//!
//! Directions are in the local frame (x along the tangent, y along the bitangent, z along
//! the normal), both pointing away from the surface; the value is zero where either lies
//! below the surface. Angles are in radians: `theta` in `[0, pi/2]`, `phi` in `[-pi, pi]`
//! (or `[0, pi/2]` for `phi_i` under [`Symmetry::Quadrant`]), `delta_phi` in `[0, pi]`.
//! Coordinates beyond an axis clamp to its ends.

use std::f32::consts::{FRAC_PI_2, PI};

use coherent_simd::{Lanes, Rgbs, SimdF32, Vec3s};

use super::angles;
use super::error::BdfProblem;
use crate::tabulated::{Axis, Grid};

/// Symmetries an anisotropic table relies on to cover fewer azimuths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// None: `phi_i` covers `[-pi, pi]`.
    None,
    /// Mirror symmetry about the tangent and the bitangent planes (anisotropic Ward,
    /// anisotropic GGX, brushed metal): both directions are mirrored so that `wi` is in the
    /// first quadrant, and `phi_i` covers `[0, pi/2]`.
    Quadrant,
}

/// Names of the isotropic table's axes, in order.
pub const ISOTROPIC_AXES: [&str; 3] = ["theta_i", "theta_o", "delta_phi"];
/// Names of the anisotropic table's axes, in order.
pub const ANISOTROPIC_AXES: [&str; 4] = ["theta_i", "phi_i", "theta_o", "phi_o"];

/// Slack allowed beyond an axis's natural range (radians), for nodes written as rounded
/// decimals of pi.
const RANGE_SLACK: f32 = 1e-4;

/// Checks that an axis stays in `[lo, hi]` and that values are not negative.
fn check_range(axis: usize, name: &str, a: &Axis, lo: f32, hi: f32) -> Result<(), BdfProblem> {
    if a.first() < lo - RANGE_SLACK || a.last() > hi + RANGE_SLACK {
        return Err(BdfProblem::AxisRange {
            axis,
            name: name.to_string(),
            first: a.first(),
            last: a.last(),
            lo,
            hi,
        });
    }
    Ok(())
}

fn check_values(values: &[f32]) -> Result<(), BdfProblem> {
    match values.iter().position(|v| *v < 0.0) {
        Some(index) => Err(BdfProblem::NegativeValue {
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

/// Zero where either direction is at or below the surface.
#[inline(always)]
fn above<L: Lanes>(l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> L::Mask {
    let zero = l.splat(0.0);
    wi.z.gt(zero) & wo.z.gt(zero)
}

/// Interpolates up to three channels and spreads a single channel to RGB.
#[inline(always)]
fn rgb<L: Lanes, const D: usize>(l: L, grid: &Grid<D>, x: [L::F32s; D], keep: L::Mask) -> Rgbs<L> {
    let cells = grid.locate(l, x);
    let mut out = [l.splat(0.0); 3];
    grid.interpolate(l, &cells, &mut out);
    if grid.channels() == 1 {
        out[1] = out[0];
        out[2] = out[0];
    }
    Rgbs::select(keep, Rgbs::new(out[0], out[1], out[2]), Rgbs::zero(l))
}

/// An isotropic BDF over `(theta_i, theta_o, delta_phi)`.
#[derive(Debug, Clone, PartialEq)]
pub struct IsotropicBdf {
    grid: Grid<3>,
}

impl IsotropicBdf {
    /// Checks the grid: theta axes within `[0, pi/2]`, `delta_phi` within `[0, pi]`, no
    /// negative values.
    pub fn new(grid: Grid<3>) -> Result<Self, BdfProblem> {
        let [ti, to, dp] = grid.axes();
        check_range(0, ISOTROPIC_AXES[0], ti, 0.0, FRAC_PI_2)?;
        check_range(1, ISOTROPIC_AXES[1], to, 0.0, FRAC_PI_2)?;
        check_range(2, ISOTROPIC_AXES[2], dp, 0.0, PI)?;
        check_values(grid.values())?;
        Ok(Self { grid })
    }

    /// The table.
    pub fn grid(&self) -> &Grid<3> {
        &self.grid
    }

    /// The table's coordinates for local directions.
    #[inline(always)]
    pub fn coords<L: Lanes>(l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> [L::F32s; 3] {
        [
            angles::theta(l, wi),
            angles::theta(l, wo),
            angles::delta_phi(l, wi, wo),
        ]
    }

    /// The BDF (RGB) for local unit directions `wi` (to the light) and `wo` (to the viewer).
    #[inline(always)]
    pub fn eval<L: Lanes>(&self, l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> Rgbs<L> {
        let keep = above(l, wi, wo);
        rgb(l, &self.grid, Self::coords(l, wi, wo), keep)
    }
}

/// An anisotropic BDF over `(theta_i, phi_i, theta_o, phi_o)`.
#[derive(Debug, Clone, PartialEq)]
pub struct AnisotropicBdf {
    grid: Grid<4>,
    symmetry: Symmetry,
}

impl AnisotropicBdf {
    /// Checks the grid: theta axes within `[0, pi/2]`, `phi_i` within `[0, pi/2]` (under
    /// [`Symmetry::Quadrant`]) or `[-pi, pi]`, `phi_o` within `[-pi, pi]`, no negative
    /// values.
    pub fn new(grid: Grid<4>, symmetry: Symmetry) -> Result<Self, BdfProblem> {
        let [ti, pi_, to, po] = grid.axes();
        check_range(0, ANISOTROPIC_AXES[0], ti, 0.0, FRAC_PI_2)?;
        match symmetry {
            Symmetry::None => check_range(1, ANISOTROPIC_AXES[1], pi_, -PI, PI)?,
            Symmetry::Quadrant => check_range(1, ANISOTROPIC_AXES[1], pi_, 0.0, FRAC_PI_2)?,
        }
        check_range(2, ANISOTROPIC_AXES[2], to, 0.0, FRAC_PI_2)?;
        check_range(3, ANISOTROPIC_AXES[3], po, -PI, PI)?;
        check_values(grid.values())?;
        Ok(Self { grid, symmetry })
    }

    /// The table.
    pub fn grid(&self) -> &Grid<4> {
        &self.grid
    }

    /// The symmetry the table relies on.
    pub fn symmetry(&self) -> Symmetry {
        self.symmetry
    }

    /// The table's coordinates for local directions (after folding by the symmetry).
    #[inline(always)]
    pub fn coords<L: Lanes>(&self, l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> [L::F32s; 4] {
        let (mut wi, mut wo) = (*wi, *wo);
        if self.symmetry == Symmetry::Quadrant {
            angles::fold_quadrant(l, &mut wi, &mut wo);
        }
        [
            angles::theta(l, &wi),
            angles::phi(l, &wi),
            angles::theta(l, &wo),
            angles::phi(l, &wo),
        ]
    }

    /// The BDF (RGB) for local unit directions `wi` (to the light) and `wo` (to the viewer).
    #[inline(always)]
    pub fn eval<L: Lanes>(&self, l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> Rgbs<L> {
        let keep = above(l, wi, wo);
        rgb(l, &self.grid, self.coords(l, wi, wo), keep)
    }
}

/// A tabulated BDF of either dimension.
#[derive(Debug, Clone, PartialEq)]
pub enum Bdf {
    Isotropic(IsotropicBdf),
    Anisotropic(AnisotropicBdf),
}

impl Bdf {
    /// The BDF (RGB) for local unit directions `wi` (to the light) and `wo` (to the viewer).
    #[inline(always)]
    pub fn eval<L: Lanes>(&self, l: L, wi: &Vec3s<L>, wo: &Vec3s<L>) -> Rgbs<L> {
        match self {
            Bdf::Isotropic(b) => b.eval(l, wi, wo),
            Bdf::Anisotropic(b) => b.eval(l, wi, wo),
        }
    }

    /// Number of table dimensions (3 or 4).
    pub fn dims(&self) -> usize {
        match self {
            Bdf::Isotropic(_) => 3,
            Bdf::Anisotropic(_) => 4,
        }
    }

    /// Values per node (1 or 3).
    pub fn channels(&self) -> usize {
        match self {
            Bdf::Isotropic(b) => b.grid.channels(),
            Bdf::Anisotropic(b) => b.grid.channels(),
        }
    }
}

impl From<IsotropicBdf> for Bdf {
    fn from(b: IsotropicBdf) -> Self {
        Bdf::Isotropic(b)
    }
}

impl From<AnisotropicBdf> for Bdf {
    fn from(b: AnisotropicBdf) -> Self {
        Bdf::Anisotropic(b)
    }
}
