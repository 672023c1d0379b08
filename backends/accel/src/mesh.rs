//! Triangle meshes, the objects of the two-level hierarchy (paper section 3): positions and
//! triangle indices in the object's own space.

use glam::Vec3;

use crate::{Aabb, AccelError};

/// A triangle mesh in object space. `indices[i]` are the three vertices of triangle `i`;
/// hits report `i` as the primitive id, whatever the accelerator does inside.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Named in error messages.
    pub name: String,
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn new(name: impl Into<String>, positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Self {
        Self {
            name: name.into(),
            positions,
            indices,
        }
    }

    /// A mesh of unshared triangles (`positions.len()` a multiple of 3).
    pub fn from_triangles(name: impl Into<String>, triangles: &[[Vec3; 3]]) -> Self {
        let positions = triangles.iter().flatten().copied().collect();
        let indices = (0..triangles.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        Self::new(name, positions, indices)
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The vertices of triangle `i` (the mesh must be valid).
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The box of the referenced vertices (empty for an empty mesh).
    pub fn bounds(&self) -> Aabb {
        self.indices
            .iter()
            .flatten()
            .fold(Aabb::EMPTY, |b, &i| b.grow(self.positions[i as usize]))
    }

    /// Checks the mesh; `id` is its index in the scene (for the message). Rejects empty
    /// meshes, out-of-range indices, non-finite positions and meshes too large for 32-bit ids.
    pub fn validate(&self, id: usize) -> Result<(), AccelError> {
        let name = || self.name.clone();
        if self.indices.is_empty() || self.positions.is_empty() {
            return Err(AccelError::EmptyMesh {
                mesh: id,
                name: name(),
                positions: self.positions.len(),
                triangles: self.indices.len(),
            });
        }
        // Triangle ids are reported as i32 lanes (-1 = miss), and leaves keep 30-bit offsets.
        if self.indices.len() >= (1 << 30) || self.positions.len() > u32::MAX as usize {
            return Err(AccelError::TooLarge {
                mesh: id,
                name: name(),
                what: format!(
                    "{} triangles, {} positions (at most 2^30 - 1 triangles)",
                    self.indices.len(),
                    self.positions.len()
                ),
            });
        }
        if let Some((index, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.is_finite())
        {
            return Err(AccelError::NonFinitePosition {
                mesh: id,
                name: name(),
                index,
                value: p.to_array(),
            });
        }
        let len = self.positions.len();
        for (tri, t) in self.indices.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= len) {
                return Err(AccelError::IndexOutOfRange {
                    mesh: id,
                    name: name(),
                    tri,
                    index,
                    len,
                });
            }
        }
        Ok(())
    }
}
