//! The input of every acceleration structure: meshes and their instances (paper section 3,
//! the two-level scene).

use glam::Affine3A;

use crate::{AccelError, Instance, Mesh};

/// Meshes in object space and the instances that place them in the world. A mesh may be
/// placed by any number of instances, or by none.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
}

impl Scene {
    pub fn new(meshes: Vec<Mesh>, instances: Vec<Instance>) -> Self {
        Self { meshes, instances }
    }

    /// One mesh placed once with the identity transform.
    pub fn single(mesh: Mesh) -> Self {
        Self::new(vec![mesh], vec![Instance::identity(0)])
    }

    /// Adds a mesh and returns its id.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Places mesh `mesh` and returns the instance id.
    pub fn add_instance(&mut self, mesh: usize, world_from_object: Affine3A) -> usize {
        self.instances.push(Instance::new(mesh, world_from_object));
        self.instances.len() - 1
    }

    /// Triangles over all instances (a mesh placed twice counts twice).
    pub fn instanced_triangles(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes.get(i.mesh).map_or(0, |m| m.indices.len()))
            .sum()
    }

    /// Checks every mesh and instance; returns `object_from_world` per instance.
    pub fn validate(&self) -> Result<Vec<Affine3A>, AccelError> {
        for (i, m) in self.meshes.iter().enumerate() {
            m.validate(i)?;
        }
        validate_instances(&self.instances, self.meshes.len())
    }
}

/// Checks instances against a scene of `meshes` meshes; returns `object_from_world` per
/// instance.
pub fn validate_instances(
    instances: &[Instance],
    meshes: usize,
) -> Result<Vec<Affine3A>, AccelError> {
    if instances.len() >= i32::MAX as usize {
        return Err(AccelError::TooManyInstances {
            count: instances.len(),
        });
    }
    instances
        .iter()
        .enumerate()
        .map(|(i, inst)| inst.object_from_world(i, meshes))
        .collect()
}
