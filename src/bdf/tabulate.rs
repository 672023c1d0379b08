//! Tables made by sampling an analytic model on a non-uniform grid (paper section 4.2:
//! BDFs "can't be tabulated uniformly", so the grid is denser where the BDF changes
//! fastest).
//!
//! - Polar angles: `theta = pi/2 (0.6 u + 0.4 sin(pi u / 2))` for `u` uniform in `[0, 1]`;
//!   nodes are about twice as dense at grazing angles (where Fresnel and masking change
//!   fastest) as at the normal.
//! - Outgoing azimuth of a quadrant-folded anisotropic table: half the nodes in
//!   `[-pi, -pi/2]`, where the mirror direction of any folded `wi` lies (the specular
//!   lobe), the rest spread over the other three quadrants.
//! - Azimuth difference of an isotropic table: half the nodes in `[pi/2, pi]` (the lobe).
//! - Incoming azimuth: uniform.

use std::f64::consts::{FRAC_PI_2, PI};

use super::analytic::Analytic;
use super::error::BdfProblem;
use super::table::{AnisotropicBdf, IsotropicBdf, Symmetry};
use crate::tabulated::{Axis, Grid};

/// The paper's anisotropic table: 17 x 7 x 17 x 13 nodes over
/// `(theta_i, phi_i, theta_o, phi_o)` (section 4.2, Table 1).
pub const PAPER_ANISOTROPIC_SHAPE: [usize; 4] = [17, 7, 17, 13];

fn to_axis(axis: usize, nodes: Vec<f64>) -> Result<Axis, BdfProblem> {
    Ok(Axis::new(
        axis,
        nodes.into_iter().map(|x| x as f32).collect(),
    )?)
}

/// `n` uniform nodes over `[lo, hi]`.
pub fn uniform_nodes(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let last = n.saturating_sub(1).max(1) as f64;
    (0..n).map(|k| lo + (hi - lo) * k as f64 / last).collect()
}

/// `n` polar-angle nodes over `[0, pi/2]`, denser toward grazing.
pub fn theta_nodes(n: usize) -> Vec<f64> {
    uniform_nodes(0.0, 1.0, n)
        .into_iter()
        .map(|u| FRAC_PI_2 * (0.6 * u + 0.4 * (FRAC_PI_2 * u).sin()))
        .collect()
}

/// `n` nodes over `[lo, hi]`: `n_lobe` of them uniform over `[lobe_lo, lobe_hi]`, the
/// others uniform over the rest of the range on either side, shared by length.
pub fn lobe_nodes(
    lo: f64,
    hi: f64,
    lobe_lo: f64,
    lobe_hi: f64,
    n: usize,
    n_lobe: usize,
) -> Vec<f64> {
    let rest = n.saturating_sub(n_lobe);
    let (left_len, right_len) = (lobe_lo - lo, hi - lobe_hi);
    let left = if left_len + right_len > 0.0 {
        ((rest as f64) * left_len / (left_len + right_len)).round() as usize
    } else {
        0
    };
    let right = rest - left;
    let mut nodes: Vec<f64> = (0..left)
        .map(|i| lo + left_len * i as f64 / left as f64)
        .collect();
    nodes.extend(uniform_nodes(lobe_lo, lobe_hi, n_lobe));
    nodes.extend((1..=right).map(|i| lobe_hi + right_len * i as f64 / right as f64));
    nodes
}

/// The isotropic grid's axes for `shape = [theta_i, theta_o, delta_phi]` node counts.
pub fn isotropic_axes(shape: [usize; 3]) -> Result<[Axis; 3], BdfProblem> {
    Ok([
        to_axis(0, theta_nodes(shape[0]))?,
        to_axis(1, theta_nodes(shape[1]))?,
        to_axis(
            2,
            lobe_nodes(0.0, PI, FRAC_PI_2, PI, shape[2], shape[2].div_ceil(2)),
        )?,
    ])
}

/// The anisotropic grid's axes for `shape = [theta_i, phi_i, theta_o, phi_o]` node counts.
pub fn anisotropic_axes(shape: [usize; 4], symmetry: Symmetry) -> Result<[Axis; 4], BdfProblem> {
    let (phi_i, phi_o) = match symmetry {
        Symmetry::Quadrant => (
            uniform_nodes(0.0, FRAC_PI_2, shape[1]),
            lobe_nodes(-PI, PI, -PI, -FRAC_PI_2, shape[3], shape[3].div_ceil(2)),
        ),
        Symmetry::None => (
            uniform_nodes(-PI, PI, shape[1]),
            uniform_nodes(-PI, PI, shape[3]),
        ),
    };
    Ok([
        to_axis(0, theta_nodes(shape[0]))?,
        to_axis(1, phi_i)?,
        to_axis(2, theta_nodes(shape[2]))?,
        to_axis(3, phi_o)?,
    ])
}

/// `model` sampled at every node of `axes` (RGB, row-major).
fn sample<const D: usize>(axes: &[Axis; D], f: impl Fn([f64; D]) -> [f64; 3]) -> Vec<f32> {
    let shape: [usize; D] = core::array::from_fn(|k| axes[k].len());
    let total: usize = shape.iter().product();
    let mut values = Vec::with_capacity(total * 3);
    for flat in 0..total {
        let mut rem = flat;
        let mut x = [0.0f64; D];
        for k in (0..D).rev() {
            x[k] = axes[k].nodes()[rem % shape[k]] as f64;
            rem /= shape[k];
        }
        values.extend(f(x).map(|v| v as f32));
    }
    values
}

/// An isotropic table of `model` with `shape = [theta_i, theta_o, delta_phi]` nodes.
pub fn tabulate_isotropic(model: &Analytic, shape: [usize; 3]) -> Result<IsotropicBdf, BdfProblem> {
    let axes = isotropic_axes(shape)?;
    let values = sample(&axes, |[ti, to, dp]| model.eval_angles(ti, 0.0, to, dp));
    IsotropicBdf::new(Grid::new(axes, 3, values)?)
}

/// An anisotropic table of `model` with `shape = [theta_i, phi_i, theta_o, phi_o]` nodes.
pub fn tabulate_anisotropic(
    model: &Analytic,
    shape: [usize; 4],
    symmetry: Symmetry,
) -> Result<AnisotropicBdf, BdfProblem> {
    let axes = anisotropic_axes(shape, symmetry)?;
    let values = sample(&axes, |[ti, pi, to, po]| model.eval_angles(ti, pi, to, po));
    AnisotropicBdf::new(Grid::new(axes, 3, values)?, symmetry)
}
