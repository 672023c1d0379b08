//! Meshes with shading data (paper section 4: materials need the shading normal and texture
//! coordinates at a hit): per-vertex normals and UVs and per-triangle material ids beside the
//! positions and indices that the accelerators see.

use coherent_accel::Mesh;
use glam::{Vec2, Vec3};

/// A triangle mesh with what shading needs.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadedMesh {
    /// Positions and indices: all the accelerators ever see.
    pub mesh: coherent_accel::Mesh,
    /// Per vertex, unit (None: flat shading with the geometric normal).
    pub normals: Option<Vec<Vec3>>,
    /// Per vertex.
    pub uvs: Option<Vec<Vec2>>,
    /// Per triangle, index into `RenderScene::materials`.
    pub material: Vec<u32>,
}

impl ShadedMesh {
    /// A flat-shaded mesh of one material, without UVs.
    pub fn flat(mesh: Mesh, material: u32) -> Self {
        let material = vec![material; mesh.indices.len()];
        Self {
            mesh,
            normals: None,
            uvs: None,
            material,
        }
    }

    /// Adds smooth per-vertex normals: the area-weighted average of the normals of the
    /// triangles around each vertex (a vertex of only degenerate triangles gets +z).
    pub fn with_smooth_normals(mut self) -> Self {
        self.normals = Some(smooth_normals(&self.mesh));
        self
    }

    /// Adds per-vertex UVs.
    pub fn with_uvs(mut self, uvs: Vec<Vec2>) -> Self {
        self.uvs = Some(uvs);
        self
    }

    /// Checks the shading data against the mesh (the mesh itself is checked by
    /// [`Mesh::validate`]): one normal and one UV per position, unit finite normals, finite
    /// UVs, one material id per triangle below `materials`. The message names the mesh.
    pub fn problem(&self, materials: usize) -> Option<String> {
        let name = &self.mesh.name;
        let n = self.mesh.positions.len();
        if let Some(normals) = &self.normals {
            if normals.len() != n {
                return Some(format!(
                    "mesh '{name}': {} normals for {n} positions",
                    normals.len()
                ));
            }
            if let Some((i, v)) = normals
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && (v.length() - 1.0).abs() < 1e-3))
            {
                return Some(format!(
                    "mesh '{name}': normal {i} ({v}) is not a unit vector"
                ));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != n {
                return Some(format!(
                    "mesh '{name}': {} UVs for {n} positions",
                    uvs.len()
                ));
            }
            if let Some((i, v)) = uvs.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Some(format!("mesh '{name}': UV {i} ({v}) is not finite"));
            }
        }
        if self.material.len() != self.mesh.indices.len() {
            return Some(format!(
                "mesh '{name}': {} material ids for {} triangles",
                self.material.len(),
                self.mesh.indices.len()
            ));
        }
        if let Some((t, &m)) = self
            .material
            .iter()
            .enumerate()
            .find(|&(_, &m)| m as usize >= materials)
        {
            return Some(format!(
                "mesh '{name}': triangle {t} uses material {m}, but the scene has {materials}"
            ));
        }
        None
    }
}

/// Area-weighted vertex normals of `mesh` (unit; +z where undefined).
pub fn smooth_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a); // length = twice the area
        for &i in t {
            acc[i as usize] += n;
        }
    }
    acc.into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_normals_of_a_box_point_outwards() {
        let m = coherent_accel::shapes::cuboid("b", Vec3::splat(-1.0), Vec3::splat(1.0));
        let s = ShadedMesh::flat(m, 0).with_smooth_normals();
        assert_eq!(s.problem(1), None);
        for (p, n) in s.mesh.positions.iter().zip(s.normals.as_ref().unwrap()) {
            assert!(p.normalize().dot(*n) > 0.5, "{p} {n}");
        }
    }

    #[test]
    fn mismatched_shading_data_is_named() {
        let m = coherent_accel::shapes::cuboid("crate", Vec3::ZERO, Vec3::ONE);
        let s = ShadedMesh::flat(m.clone(), 3);
        assert!(s.problem(2).unwrap().contains("'crate'"));
        let s = ShadedMesh::flat(m, 0).with_uvs(vec![Vec2::ZERO; 2]);
        assert!(s.problem(1).unwrap().contains("2 UVs for 8 positions"));
    }
}
