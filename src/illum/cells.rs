//! The cells of an illumination map: a grid on every triangle of every instance (instances
//! of one mesh get cells of their own: their light differs). A triangle of world area `A`
//! is cut into `n * n` equal sub-triangles by `n` steps per edge in barycentric
//! coordinates, `n = clamp(round(sqrt(A * density)), 1, 64)` with
//! `density = cells_target / total_area`, so cells have about the same area everywhere.
//!
//! Within a triangle, with `x = u n`, `y = v n` (`u`, `v` the barycentric weights of its
//! vertices 1 and 2, as the accelerators report them), the cell of the point is in row
//! `j = floor(y)`, column `i = floor(x)`, the lower sub-triangle (corners `(i, j)`,
//! `(i + 1, j)`, `(i, j + 1)`) when `frac(x) + frac(y) <= 1`, else the upper one (corners
//! `(i + 1, j)`, `(i, j + 1)`, `(i + 1, j + 1)`). Rows are numbered from `v = 0`; row `j`
//! holds `2 (n - j) - 1` cells, lower and upper alternating, so the cell's index within its
//! triangle is `j (2n - j) + 2i + upper`. The map's filtered lookup interpolates values at
//! the lattice points `(i, j)`, `i + j <= n`, numbered row by row:
//! `j (n + 1) - j (j - 1) / 2 + i`.

use glam::Vec3;

use super::IllumError;
use crate::scene::RenderScene;

/// The total number of cells a map aims at by default.
pub const DEFAULT_CELLS: u64 = 65_536;
/// The most cells along a triangle's edge (a triangle has at most its square).
pub const MAX_PER_EDGE: u32 = 64;
/// The most memory a map may take by default (bytes), checked before anything is allocated.
pub const MAP_BUDGET: u64 = 1 << 30;

/// Bytes a map takes per triangle slot (cells per edge twice, first cell, first lattice
/// point), per cell (area, irradiance, and the build's three 64-bit sums) and per lattice
/// point (three channels).
const BYTES_PER_SLOT: u64 = 16;
const BYTES_PER_CELL: u64 = 4 + 12 + 24;
const BYTES_PER_POINT: u64 = 12;

/// Where every (instance, triangle, barycentrics) falls among the cells.
#[derive(Debug, Clone, PartialEq)]
pub struct CellLayout {
    cells_target: u64,
    /// Per instance, its first triangle slot; one more entry: the number of slots.
    pub(super) inst_first: Vec<u32>,
    /// Per slot: cells per edge, as an integer and as a float (for the lanes).
    pub(super) per_edge: Vec<u32>,
    pub(super) per_edge_f: Vec<f32>,
    /// Per slot, its first cell; one more entry: the number of cells.
    pub(super) first_cell: Vec<u32>,
    /// Per slot, its first lattice point; one more entry: the number of points.
    pub(super) first_point: Vec<u32>,
    /// Per cell, its world area (m^2).
    pub(super) cell_area: Vec<f32>,
}

/// Triangle `prim` of instance `inst` in world space.
pub(super) fn world_triangle(scene: &RenderScene, inst: usize, prim: usize) -> [Vec3; 3] {
    let instance = &scene.instances[inst];
    let mesh = &scene.meshes[instance.mesh].mesh;
    let tri = mesh.indices[prim];
    tri.map(|k| {
        instance
            .world_from_object
            .transform_point3(mesh.positions[k as usize])
    })
}

/// The barycentrics `(u, v)` made valid: negative and NaN values to 0, a sum over 1 scaled
/// back to 1 (hits may lie slightly outside by the intersection test's edge tolerance).
#[inline]
pub(super) fn clamp_barycentrics(u: f32, v: f32) -> (f32, f32) {
    // `max` maps NaN to 0.
    let (u, v) = (u.max(0.0), v.max(0.0));
    let s = u + v;
    if s > 1.0 { (u / s, v / s) } else { (u, v) }
}

impl CellLayout {
    /// The cells of `scene` for about `cells_target` cells in all. A target of 0, a scene
    /// without surface area, more cells than 32-bit indices reach, or a map that would take
    /// more than `max_bytes` is an error naming the numbers, found before anything large is
    /// allocated.
    pub fn new(scene: &RenderScene, cells_target: u64, max_bytes: u64) -> Result<Self, IllumError> {
        let options = |problem: String| IllumError::Options {
            what: "illumination map cells",
            problem,
        };
        if cells_target == 0 {
            return Err(options(
                "the cells target is 0; ask for at least 1 cell".into(),
            ));
        }
        let slots: u64 = scene
            .instances
            .iter()
            .map(|i| {
                scene
                    .meshes
                    .get(i.mesh)
                    .map_or(0, |m| m.mesh.indices.len() as u64)
            })
            .sum();
        if slots * (BYTES_PER_SLOT + BYTES_PER_CELL + 3 * BYTES_PER_POINT) > max_bytes {
            return Err(options(format!(
                "scene {}: {slots} instanced triangles take at least one cell each, {} bytes, \
                 over the budget of {max_bytes} bytes",
                scene.name,
                slots * (BYTES_PER_SLOT + BYTES_PER_CELL + 3 * BYTES_PER_POINT)
            )));
        }
        let mut inst_first = Vec::with_capacity(scene.instances.len() + 1);
        let mut areas = Vec::with_capacity(slots as usize);
        for (i, inst) in scene.instances.iter().enumerate() {
            inst_first.push(areas.len() as u32);
            let Some(m) = scene.meshes.get(inst.mesh) else {
                return Err(options(format!(
                    "scene {}: instance {i} places mesh {}, but the scene has {} meshes",
                    scene.name,
                    inst.mesh,
                    scene.meshes.len()
                )));
            };
            for k in 0..m.mesh.indices.len() {
                let [a, b, c] = world_triangle(scene, i, k);
                let area = 0.5 * f64::from((b - a).cross(c - a).length());
                areas.push(if area.is_finite() { area } else { 0.0 });
            }
        }
        inst_first.push(areas.len() as u32);
        let total: f64 = areas.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return Err(options(format!(
                "scene {}: its triangles have no area to put cells on",
                scene.name
            )));
        }
        let density = cells_target as f64 / total;
        let per_edge: Vec<u32> = areas
            .iter()
            .map(|&a| ((a * density).sqrt().round() as u32).clamp(1, MAX_PER_EDGE))
            .collect();
        let cells: u64 = per_edge.iter().map(|&n| u64::from(n) * u64::from(n)).sum();
        let points: u64 = per_edge
            .iter()
            .map(|&n| u64::from(n + 1) * u64::from(n + 2) / 2)
            .sum();
        let bytes = slots * BYTES_PER_SLOT + cells * BYTES_PER_CELL + points * BYTES_PER_POINT;
        if bytes > max_bytes {
            return Err(options(format!(
                "scene {}: {cells} cells (target {cells_target}) on {slots} instanced triangles \
                 take {bytes} bytes, over the budget of {max_bytes} bytes; ask for fewer cells",
                scene.name
            )));
        }
        if cells.max(points) > i32::MAX as u64 {
            return Err(options(format!(
                "scene {}: {cells} cells and {points} lattice points, more than 32-bit indices \
                 reach",
                scene.name
            )));
        }
        let mut first_cell = Vec::with_capacity(per_edge.len() + 1);
        let mut first_point = Vec::with_capacity(per_edge.len() + 1);
        let mut cell_area = Vec::with_capacity(cells as usize);
        let (mut c, mut p) = (0u32, 0u32);
        for (&n, &a) in per_edge.iter().zip(&areas) {
            first_cell.push(c);
            first_point.push(p);
            let nn = n * n;
            cell_area.extend(std::iter::repeat_n((a / f64::from(nn)) as f32, nn as usize));
            c += nn;
            p += (n + 1) * (n + 2) / 2;
        }
        first_cell.push(c);
        first_point.push(p);
        Ok(CellLayout {
            cells_target,
            inst_first,
            per_edge_f: per_edge.iter().map(|&n| n as f32).collect(),
            per_edge,
            first_cell,
            first_point,
            cell_area,
        })
    }

    /// The cells target the layout was made for.
    pub fn cells_target(&self) -> u64 {
        self.cells_target
    }

    /// Cells in all.
    pub fn cells(&self) -> usize {
        self.cell_area.len()
    }

    /// Triangle slots (every instance's triangles).
    pub fn slots(&self) -> usize {
        self.per_edge.len()
    }

    /// Instances.
    pub fn instances(&self) -> usize {
        self.inst_first.len() - 1
    }

    /// Lattice points in all (the filtered lookup's values).
    pub fn points(&self) -> usize {
        *self.first_point.last().unwrap_or(&0) as usize
    }

    /// Per cell, its world area (m^2).
    pub fn cell_area(&self) -> &[f32] {
        &self.cell_area
    }

    /// The slot of triangle `prim` of instance `inst`, or `None` where there is none.
    #[inline]
    pub fn slot(&self, inst: u32, prim: u32) -> Option<usize> {
        let i = inst as usize;
        if i + 1 >= self.inst_first.len() {
            return None;
        }
        let s = self.inst_first[i] as usize + prim as usize;
        (s < self.inst_first[i + 1] as usize).then_some(s)
    }

    /// Cells per edge of slot `slot`.
    pub fn per_edge(&self, slot: usize) -> u32 {
        self.per_edge[slot]
    }

    /// Slot `slot`'s cells.
    pub fn slot_cells(&self, slot: usize) -> core::ops::Range<usize> {
        self.first_cell[slot] as usize..self.first_cell[slot + 1] as usize
    }

    /// The cell of barycentrics `(u, v)` on triangle `prim` of instance `inst` (see the
    /// module documentation), or `None` for a triangle that does not exist.
    #[inline]
    pub fn cell(&self, inst: u32, prim: u32, u: f32, v: f32) -> Option<usize> {
        let s = self.slot(inst, prim)?;
        let n = self.per_edge[s];
        let nf = self.per_edge_f[s];
        let (u, v) = clamp_barycentrics(u, v);
        let (x, y) = (u * nf, v * nf);
        let i = (x.floor() as u32).min(n - 1);
        let j = (y.floor() as u32).min(n - 1 - i);
        let (fx, fy) = (x - i as f32, y - j as f32);
        let upper = fx + fy > 1.0 && i + j + 1 < n;
        Some(self.first_cell[s] as usize + local_cell(n, i, j, upper))
    }
}

/// The index within its triangle of cell `(i, j)` (lower or upper) of a grid of `n` per edge.
#[inline]
pub(super) fn local_cell(n: u32, i: u32, j: u32, upper: bool) -> usize {
    (j * (2 * n - j) + 2 * i + u32::from(upper)) as usize
}

/// The index within its triangle of lattice point `(i, j)` of a grid of `n` per edge.
#[inline]
pub(super) fn local_point(n: u32, i: u32, j: u32) -> usize {
    (j * (n + 1) - j * j.saturating_sub(1) / 2 + i) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_number_each_sub_triangle_once_and_points_each_lattice_point_once() {
        for n in 1..=6u32 {
            let mut seen = vec![false; (n * n) as usize];
            for j in 0..n {
                for i in 0..n - j {
                    for upper in [false, true] {
                        if upper && i + j + 1 >= n {
                            continue;
                        }
                        let c = local_cell(n, i, j, upper);
                        assert!(!seen[c], "n {n} cell ({i}, {j}, {upper})");
                        seen[c] = true;
                    }
                }
            }
            assert!(seen.iter().all(|&s| s), "n {n}");
            let mut k = 0;
            for j in 0..=n {
                for i in 0..=n - j {
                    assert_eq!(local_point(n, i, j), k, "n {n} point ({i}, {j})");
                    k += 1;
                }
            }
        }
    }
}
