//! Instances: a mesh placed in the world by a transform (paper section 3: "the object is
//! placed into the scene using the transformation matrix"). Moving instances only rebuilds
//! the top-level tree.

use glam::Affine3A;

use crate::AccelError;

/// Mesh `mesh` of the scene, placed by `world_from_object`. Hits report the instance's
/// index in the scene's instance list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    pub mesh: usize,
    pub world_from_object: Affine3A,
}

impl Instance {
    pub fn new(mesh: usize, world_from_object: Affine3A) -> Self {
        Self {
            mesh,
            world_from_object,
        }
    }

    /// Mesh `mesh` with the identity transform.
    pub fn identity(mesh: usize) -> Self {
        Self::new(mesh, Affine3A::IDENTITY)
    }

    /// The inverse transform, checked: `id` is the instance's index (for the message), `meshes`
    /// the number of meshes in the scene. A transform is singular when it is not finite or
    /// when `|det| <= 1e-12 * |x| |y| |z|` (columns of the linear part), i.e. it squashes
    /// some direction by more than twelve orders of magnitude.
    pub fn object_from_world(&self, id: usize, meshes: usize) -> Result<Affine3A, AccelError> {
        if self.mesh >= meshes {
            return Err(AccelError::MeshOutOfRange {
                instance: id,
                mesh: self.mesh,
                meshes,
            });
        }
        let m = self.world_from_object;
        let det = m.matrix3.determinant();
        let scale =
            m.matrix3.x_axis.length() * m.matrix3.y_axis.length() * m.matrix3.z_axis.length();
        let singular = || AccelError::SingularTransform {
            instance: id,
            mesh: self.mesh,
            det,
        };
        if !m.is_finite() || !det.is_finite() || det.abs() <= 1e-12 * scale || scale == 0.0 {
            return Err(singular());
        }
        let inv = m.inverse();
        if !inv.is_finite() {
            return Err(singular());
        }
        Ok(inv)
    }
}
