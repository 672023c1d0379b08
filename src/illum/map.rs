//! The illumination map: per cell, the irradiance (W/m^2 per channel) that light reaching
//! the cell after at least one bounce brings, from the power particles deposited there over
//! the cell's area; and its filtered lookup, which the renderer multiplies by `albedo / pi`.
//!
//! Deposits are sums of integers: each cell and channel holds an [`AtomicU64`] count of
//! quanta, so the map does not depend on the order of deposits, the thread count, or how
//! particles were grouped into packets. See [`Deposits`] for the quantum and its bounds.
//!
//! The filtered lookup interpolates values held at the lattice points of each triangle's grid
//! (see [`super::cells`]) barycentrically inside the cell: a lattice point holds the mean of
//! the cells of its triangle that touch it; a triangle's corner holds the area-weighted mean
//! of the corner cells of the triangles of the same instance that share the mesh vertex (by
//! position) and whose normals lie within [`SMOOTH_ANGLE_DEG`] of its own, so tessellated
//! surfaces come out smooth while creases stay sharp.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use coherent_simd::{Lanes, Rgbs, SimdF32, SimdI32, SimdMask};
use glam::Vec3;

use super::IllumError;
use super::cells::{CellLayout, local_cell, local_point, world_triangle};
use crate::scene::RenderScene;

/// Triangles meeting at a vertex with normals closer than this share their corner values.
pub const SMOOTH_ANGLE_DEG: f32 = 25.0;

/// Fractional bits of a particle's share of the light's power in a quantum (see
/// [`Deposits`]).
pub const QUANTUM_BITS: u32 = 24;

/// The most quanta one deposit may add (2^52): a particle that grew to 2^28 times a mean
/// particle's power (colour-weighted roulette can grow a channel, at most threefold per
/// bounce) is clamped rather than let overflow the sums.
const MAX_DEPOSIT: f64 = (1u64 << 52) as f64;

/// The particle pass's deposits: per cell and channel a count of quanta, added atomically.
///
/// The quantum of channel `c` is `P_c / (N 2^24)`, `P_c` the lights' power in that channel
/// and `N` the particle count, so a mean particle's power is `2^24` quanta and rounding a
/// deposit to whole quanta changes it by at most `2^-25` of that (below `f32`'s precision
/// of the power itself). The counts are exact integers, so their sum is the same in any
/// order. Headroom: a cell's sum overflows 2^64 only after 2^40 mean-particle deposits land
/// in that one cell (a million particles deposit about a million times per bounce in all).
/// A channel the lights do not emit has quantum 0 and takes no deposits (no particle
/// carries power in it).
#[derive(Debug)]
pub struct Deposits {
    sums: Vec<AtomicU64>,
    quantum: [f64; 3],
}

impl Deposits {
    /// Empty sums for `cells` cells and particles of `particles` sharing `power` (W per
    /// channel).
    pub fn new(cells: usize, power: [f64; 3], particles: u64) -> Self {
        let scale = particles as f64 * f64::from(1u32 << QUANTUM_BITS);
        Deposits {
            sums: (0..3 * cells).map(|_| AtomicU64::new(0)).collect(),
            quantum: power.map(|p| if p > 0.0 { p / scale } else { 0.0 }),
        }
    }

    /// The quantum per channel (W).
    pub fn quantum(&self) -> [f64; 3] {
        self.quantum
    }

    /// Adds `power` to cell `cell`; returns the power deposited (rounded to whole quanta).
    /// Non-finite or negative channels deposit nothing.
    #[inline]
    pub fn add(&self, cell: usize, power: [f32; 3]) -> [f64; 3] {
        let mut done = [0.0; 3];
        for c in 0..3 {
            let q = self.quantum[c];
            if q <= 0.0 {
                continue;
            }
            let n = (f64::from(power[c]) / q).round();
            if n.is_nan() || n <= 0.0 {
                continue;
            }
            let n = n.min(MAX_DEPOSIT);
            self.sums[3 * cell + c].fetch_add(n as u64, Ordering::Relaxed);
            done[c] = n * q;
        }
        done
    }

    /// Per cell, the deposited power over the cell's area (W/m^2; 0 on a cell without area).
    pub fn irradiance(&self, layout: &CellLayout) -> Vec<[f32; 3]> {
        layout
            .cell_area()
            .iter()
            .enumerate()
            .map(|(k, &a)| {
                let mut e = [0.0f32; 3];
                if a > 0.0 {
                    for (c, e) in e.iter_mut().enumerate() {
                        let p =
                            self.sums[3 * k + c].load(Ordering::Relaxed) as f64 * self.quantum[c];
                        *e = (p / f64::from(a)) as f32;
                    }
                }
                e
            })
            .collect()
    }
}

/// Per-cell irradiance with its filtered lookup.
#[derive(Debug, Clone)]
pub struct IllumMap {
    layout: CellLayout,
    irradiance: Vec<[f32; 3]>,
    /// Lattice point values, one array per channel, triangle by triangle.
    lattice: [Vec<f32>; 3],
    particles: u64,
    fingerprint: u64,
}

impl IllumMap {
    /// The map of per-cell `irradiance` over `layout` of `scene`, from `particles` particles.
    /// `layout` must be `scene`'s and `irradiance` hold one value per cell of it.
    pub fn from_cells(
        scene: &RenderScene,
        layout: CellLayout,
        irradiance: Vec<[f32; 3]>,
        particles: u64,
    ) -> Result<Self, IllumError> {
        let same_triangles = layout.instances() == scene.instances.len()
            && scene.instances.iter().enumerate().all(|(i, inst)| {
                let n = layout.inst_first[i + 1] - layout.inst_first[i];
                scene
                    .meshes
                    .get(inst.mesh)
                    .is_some_and(|m| m.mesh.indices.len() == n as usize)
            });
        if irradiance.len() != layout.cells() || !same_triangles {
            return Err(IllumError::Options {
                what: "illumination map",
                problem: format!(
                    "{} irradiance values for {} cells of {} instances, {} triangles \
                     (scene {} has {} instances, {} triangles); the layout must be the scene's",
                    irradiance.len(),
                    layout.cells(),
                    layout.instances(),
                    layout.slots(),
                    scene.name,
                    scene.instances.len(),
                    scene.triangles()
                ),
            });
        }
        let lattice = lattice(scene, &layout, &irradiance);
        Ok(IllumMap {
            fingerprint: super::file::fingerprint(scene),
            layout,
            irradiance,
            lattice,
            particles,
        })
    }

    /// The cells.
    pub fn layout(&self) -> &CellLayout {
        &self.layout
    }

    /// Cells in all.
    pub fn cells(&self) -> usize {
        self.layout.cells()
    }

    /// The cells target the map was made for.
    pub fn cells_target(&self) -> u64 {
        self.layout.cells_target()
    }

    /// Particles traced for it.
    pub fn particles(&self) -> u64 {
        self.particles
    }

    /// The scene's fingerprint (see [`super::file::fingerprint`]).
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Per cell, its irradiance (W/m^2 per channel).
    pub fn cell_irradiance(&self) -> &[[f32; 3]] {
        &self.irradiance
    }

    /// Per cell, its world area (m^2).
    pub fn cell_area(&self) -> &[f32] {
        self.layout.cell_area()
    }

    /// Per channel, the lattice point values of the filtered lookup.
    pub fn lattice(&self) -> &[Vec<f32>; 3] {
        &self.lattice
    }

    /// Memory held (bytes).
    pub fn bytes(&self) -> usize {
        let l = &self.layout;
        4 * (l.inst_first.len()
            + l.per_edge.len()
            + l.per_edge_f.len()
            + l.first_cell.len()
            + l.first_point.len()
            + l.cell_area.len())
            + 12 * self.irradiance.len()
            + 4 * self.lattice.iter().map(Vec::len).sum::<usize>()
    }

    /// The filtered irradiance at barycentrics `(u, v)` (the weights of vertices 1 and 2) of
    /// triangle `prim` of instance `inst`, per lane; zero on lanes outside `active`. Active
    /// lanes must name an existing triangle (as the accelerators' hits do).
    #[inline(always)]
    pub fn irradiance<L: Lanes>(
        &self,
        l: L,
        inst: L::I32s,
        prim: L::I32s,
        u: L::F32s,
        v: L::F32s,
        active: L::Mask,
    ) -> Rgbs<L> {
        let lay = &self.layout;
        let zero_i = l.splat_i32(0);
        let one_i = l.splat_i32(1);
        let (zero, one) = (l.splat(0.0), l.splat(1.0));
        let inst = active.select_i32(inst, zero_i);
        let prim = active.select_i32(prim, zero_i);
        let slot = l.gather_u32(&lay.inst_first, inst) + prim;
        let nf = l.gather(&lay.per_edge_f, slot);
        let first = l.gather_u32(&lay.first_point, slot);
        // Valid barycentrics (`max` maps NaN to 0), then the grid cell.
        let (u, v) = (u.max(zero), v.max(zero));
        let s = u + v;
        let inv = one / s.gt(one).select(s, one);
        let (x, y) = (u * inv * nf, v * inv * nf);
        let n = nf.to_i32();
        let nm1 = n - one_i;
        let i = x.floor().to_i32().min(nm1);
        let j = y.floor().to_i32().min(nm1 - i);
        let (fx, fy) = ((x - i.to_f32()).max(zero), (y - j.to_f32()).max(zero));
        let sum = fx + fy;
        let past = sum.gt(one);
        let upper = past & (i + j).lt(nm1);
        // A lower cell with fx + fy > 1 (only through the clamps): onto its far edge.
        let k = one / past.and_not(upper).select(sum, one);
        let (fx, fy) = (fx * k, fy * k);
        let wa = upper.select(fx + fy - one, one - fx - fy);
        let wb = upper.select(one - fy, fx);
        let wc = upper.select(one - fx, fy);
        let np1 = n + one_i;
        let up = upper.select_i32(one_i, zero_i);
        let pa = point_index(first, np1, i + up, j + up);
        let pb = point_index(first, np1, i + one_i, j);
        let pc = point_index(first, np1, i, j + one_i);
        let mut out = [zero; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let t = &self.lattice[c];
            *o = wa.mul_add(
                l.gather(t, pa),
                wb.mul_add(l.gather(t, pb), wc * l.gather(t, pc)),
            );
        }
        Rgbs::new(
            active.select(out[0], zero),
            active.select(out[1], zero),
            active.select(out[2], zero),
        )
    }

    /// [`IllumMap::irradiance`] for one point; zero for a triangle that does not exist.
    pub fn irradiance1(&self, inst: u32, prim: u32, u: f32, v: f32) -> [f32; 3] {
        if self.layout.slot(inst, prim).is_none() {
            return [0.0; 3];
        }
        let l = coherent_simd::scalar::Scalar;
        let e = self.irradiance(
            l,
            l.splat_i32(inst as i32),
            l.splat_i32(prim as i32),
            u,
            v,
            true,
        );
        e.lane(0)
    }
}

/// The global index of lattice point `(i, j)` of a triangle whose points start at `first`,
/// `np1` = cells per edge + 1.
#[inline(always)]
fn point_index<I: SimdI32>(first: I, np1: I, i: I, j: I) -> I {
    let one = first.splat_same(1);
    first + j * np1 - (j * (j - one)).shr_logical(1) + i
}

/// The lattice point values of every triangle (see the module documentation).
fn lattice(scene: &RenderScene, layout: &CellLayout, irr: &[[f32; 3]]) -> [Vec<f32>; 3] {
    let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0f32; layout.points()]);
    let mut sum: Vec<[f32; 3]> = Vec::new();
    let mut count: Vec<u32> = Vec::new();
    for s in 0..layout.slots() {
        let n = layout.per_edge(s);
        let cells = &irr[layout.slot_cells(s)];
        let pts = ((n + 1) * (n + 2) / 2) as usize;
        sum.clear();
        sum.resize(pts, [0.0; 3]);
        count.clear();
        count.resize(pts, 0);
        for j in 0..n {
            for i in 0..n - j {
                for upper in [false, true] {
                    if upper && i + j + 1 >= n {
                        continue;
                    }
                    let e = cells[local_cell(n, i, j, upper)];
                    let corners = if upper {
                        [(i + 1, j), (i, j + 1), (i + 1, j + 1)]
                    } else {
                        [(i, j), (i + 1, j), (i, j + 1)]
                    };
                    for (a, b) in corners {
                        let p = local_point(n, a, b);
                        for c in 0..3 {
                            sum[p][c] += e[c];
                        }
                        count[p] += 1;
                    }
                }
            }
        }
        let base = layout.first_point[s] as usize;
        for p in 0..pts {
            for c in 0..3 {
                out[c][base + p] = sum[p][c] / count[p] as f32;
            }
        }
    }
    smooth_corners(scene, layout, irr, &mut out);
    out
}

/// Sets each triangle's corner points to the area-weighted mean of the corner cells of the
/// triangles of its instance that share the vertex's position with normals within
/// [`SMOOTH_ANGLE_DEG`].
fn smooth_corners(
    scene: &RenderScene,
    layout: &CellLayout,
    irr: &[[f32; 3]],
    out: &mut [Vec<f32>; 3],
) {
    let cos_max = SMOOTH_ANGLE_DEG.to_radians().cos();
    // Per mesh, a group id per vertex: vertices at the same position share one.
    let groups: Vec<Vec<u32>> = scene
        .meshes
        .iter()
        .map(|m| {
            let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
            m.mesh
                .positions
                .iter()
                .map(|p| {
                    let next = ids.len() as u32;
                    *ids.entry(p.to_array().map(f32::to_bits)).or_insert(next)
                })
                .collect()
        })
        .collect();
    // (group, slot, corner), per instance.
    let mut members: Vec<(u32, u32, u8)> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    for (ii, inst) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[inst.mesh].mesh;
        let group = &groups[inst.mesh];
        let first = layout.inst_first[ii] as usize;
        members.clear();
        normals.clear();
        for (k, tri) in mesh.indices.iter().enumerate() {
            let [a, b, c] = world_triangle(scene, ii, k);
            normals.push((b - a).cross(c - a).normalize_or_zero());
            for (corner, &vi) in tri.iter().enumerate() {
                members.push((group[vi as usize], (first + k) as u32, corner as u8));
            }
        }
        members.sort_unstable();
        for run in members.chunk_by(|a, b| a.0 == b.0) {
            for &(_, s, corner) in run {
                let s = s as usize;
                let nrm = normals[s - first];
                let mut acc = [0.0f64; 3];
                let mut w = 0.0f64;
                let mut plain = [0.0f64; 3];
                let mut m = 0u32;
                for &(_, s2, corner2) in run {
                    let s2 = s2 as usize;
                    if s2 != s && nrm.dot(normals[s2 - first]) < cos_max {
                        continue;
                    }
                    let cell =
                        layout.first_cell[s2] as usize + corner_cell(layout.per_edge(s2), corner2);
                    let a = f64::from(layout.cell_area()[cell]);
                    for c in 0..3 {
                        acc[c] += f64::from(irr[cell][c]) * a;
                        plain[c] += f64::from(irr[cell][c]);
                    }
                    w += a;
                    m += 1;
                }
                let n = layout.per_edge(s);
                let (pi, pj) = match corner {
                    0 => (0, 0),
                    1 => (n, 0),
                    _ => (0, n),
                };
                let p = layout.first_point[s] as usize + local_point(n, pi, pj);
                for c in 0..3 {
                    out[c][p] = if w > 0.0 {
                        (acc[c] / w) as f32
                    } else {
                        (plain[c] / f64::from(m)) as f32
                    };
                }
            }
        }
    }
}

/// The cell at corner `corner` (vertex 0, 1 or 2) of a grid of `n` per edge.
fn corner_cell(n: u32, corner: u8) -> usize {
    match corner {
        0 => local_cell(n, 0, 0, false),
        1 => local_cell(n, n - 1, 0, false),
        _ => local_cell(n, 0, n - 1, false),
    }
}
