//! Merging static instances: the instances that never move (no keyframes) and share a
//! transform become one mesh under that transform, so that a scene of thousands of objects
//! placed as they are (a city's buildings, a CAD assembly's parts) gives the accelerators one
//! object tree instead of thousands under a top tree. The paper's two levels pay off for
//! objects that move or repeat; for static ones the top tree over thousands of boxes and
//! every ray's restart in each object it enters cost more than they give back.
//!
//! What the renderer needs per triangle stays per triangle (material ids, normals and UVs
//! per vertex), so the image is the one of the unmerged scene up to which of two triangles
//! sharing an edge a ray hits. Meshes merge only with meshes that carry the same shading data
//! (normals or not, UVs or not): a flat-shaded mesh has no per-vertex normals to merge with a
//! smooth one's.

use std::collections::HashMap;

use coherent_accel::{Instance, Mesh};
use glam::Affine3A;

use super::{RenderScene, ShadedMesh};

/// What the merge did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MergeReport {
    /// Instances before.
    pub instances_before: usize,
    /// Instances after.
    pub instances_after: usize,
    /// Instances merged into the new meshes.
    pub merged: usize,
}

/// The key of a group: the transform's bits (the same transform exactly) and which shading
/// data the mesh carries.
type Key = ([u32; 12], bool, bool);

fn key(t: &Affine3A, m: &ShadedMesh) -> Key {
    let cols = t.to_cols_array();
    (cols.map(f32::to_bits), m.normals.is_some(), m.uvs.is_some())
}

impl RenderScene {
    /// The scene with its static instances merged per transform (see the module
    /// documentation); the moving ones and the static ones alone at their transform are kept
    /// as they are, first, in their order (the motion's instance ids follow them), then one
    /// instance per merged group. Meshes no instance uses any more are dropped.
    pub fn merge_static(self) -> (RenderScene, MergeReport) {
        let before = self.instances.len();
        let moving: Vec<bool> = {
            let mut m = vec![false; before];
            for x in &self.motion {
                if let Some(v) = m.get_mut(x.instance) {
                    *v = true;
                }
            }
            m
        };
        let mut groups: HashMap<Key, Vec<usize>> = HashMap::new();
        let mut order: Vec<Key> = Vec::new();
        for (i, inst) in self.instances.iter().enumerate() {
            if moving[i] {
                continue;
            }
            let k = key(&inst.world_from_object, &self.meshes[inst.mesh]);
            let g = groups.entry(k).or_default();
            if g.is_empty() {
                order.push(k);
            }
            g.push(i);
        }
        let merged_away: Vec<bool> = {
            let mut m = vec![false; before];
            for g in groups.values().filter(|g| g.len() > 1) {
                for &i in g {
                    m[i] = true;
                }
            }
            m
        };
        if !merged_away.contains(&true) {
            let report = MergeReport {
                instances_before: before,
                instances_after: before,
                merged: 0,
            };
            return (self, report);
        }

        let mut meshes: Vec<ShadedMesh> = Vec::new();
        let mut mesh_id: HashMap<usize, usize> = HashMap::new();
        let mut instances = Vec::new();
        let mut new_index = vec![usize::MAX; before];
        for (i, inst) in self.instances.iter().enumerate() {
            if merged_away[i] {
                continue;
            }
            let id = *mesh_id.entry(inst.mesh).or_insert_with(|| {
                meshes.push(self.meshes[inst.mesh].clone());
                meshes.len() - 1
            });
            new_index[i] = instances.len();
            instances.push(Instance::new(id, inst.world_from_object));
        }
        let mut merged = 0;
        for k in &order {
            let g = &groups[k];
            if g.len() < 2 {
                continue;
            }
            merged += g.len();
            let parts: Vec<&ShadedMesh> = g
                .iter()
                .map(|&i| &self.meshes[self.instances[i].mesh])
                .collect();
            meshes.push(concat(&parts));
            instances.push(Instance::new(
                meshes.len() - 1,
                self.instances[g[0]].world_from_object,
            ));
        }
        let mut motion = self.motion;
        for m in &mut motion {
            m.instance = new_index[m.instance];
        }
        let report = MergeReport {
            instances_before: before,
            instances_after: instances.len(),
            merged,
        };
        (
            RenderScene {
                meshes,
                instances,
                motion,
                ..self
            },
            report,
        )
    }
}

/// One mesh of `parts` in order: positions, shading data and materials appended, indices
/// offset by the vertices before them.
fn concat(parts: &[&ShadedMesh]) -> ShadedMesh {
    let vertices: usize = parts.iter().map(|p| p.mesh.positions.len()).sum();
    let triangles: usize = parts.iter().map(|p| p.mesh.indices.len()).sum();
    let mut positions = Vec::with_capacity(vertices);
    let mut indices = Vec::with_capacity(triangles);
    let mut material = Vec::with_capacity(triangles);
    let smooth = parts[0].normals.is_some();
    let textured = parts[0].uvs.is_some();
    let mut normals = smooth.then(|| Vec::with_capacity(vertices));
    let mut uvs = textured.then(|| Vec::with_capacity(vertices));
    for p in parts {
        let base = positions.len() as u32;
        positions.extend_from_slice(&p.mesh.positions);
        indices.extend(p.mesh.indices.iter().map(|t| t.map(|v| v + base)));
        material.extend_from_slice(&p.material);
        if let (Some(out), Some(n)) = (&mut normals, &p.normals) {
            out.extend_from_slice(n);
        }
        if let (Some(out), Some(uv)) = (&mut uvs, &p.uvs) {
            out.extend_from_slice(uv);
        }
    }
    ShadedMesh {
        mesh: Mesh::new(
            format!("{} static objects merged", parts.len()),
            positions,
            indices,
        ),
        normals,
        uvs,
        material,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{InstanceMotion, Keyframe};
    use glam::{Quat, Vec3};

    #[test]
    fn static_instances_at_one_transform_become_one_mesh() {
        let s = crate::scene::load("room2").unwrap();
        let triangles = s.triangles();
        let (m, r) = s.clone().merge_static();
        m.validate().unwrap();
        assert_eq!(m.triangles(), triangles);
        assert_eq!(r.instances_before, s.instances.len());
        assert_eq!(r.instances_after, m.instances.len());
        assert!(r.instances_after < r.instances_before, "{r:?}");
        // Every triangle keeps its material, in the merged mesh's order.
        let count = |s: &RenderScene| {
            let mut by_material = std::collections::BTreeMap::new();
            for i in &s.instances {
                for &id in &s.meshes[i.mesh].material {
                    *by_material.entry(id).or_insert(0usize) += 1;
                }
            }
            by_material
        };
        assert_eq!(count(&m), count(&s));
    }

    #[test]
    fn moving_instances_stay_and_keep_their_motion() {
        let mut s = crate::scene::load("cornell").unwrap();
        let n = s.instances.len();
        assert!(n >= 3);
        let keys = vec![Keyframe {
            time: 0.0,
            translation: Vec3::X,
            rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
        }];
        s.motion.push(InstanceMotion {
            instance: n - 1,
            keys: keys.clone(),
        });
        let moving_mesh = s.meshes[s.instances[n - 1].mesh].clone();
        let (m, _) = s.merge_static();
        m.validate().unwrap();
        assert_eq!(m.motion.len(), 1);
        let inst = m.instances[m.motion[0].instance];
        assert_eq!(m.meshes[inst.mesh], moving_mesh);
        assert_eq!(m.motion[0].keys, keys);
    }

    // That merged scenes render the unmerged image is checked in `tests/render.rs`: a frame
    // here would compile the renderer for every backend once more, into the unit tests.

    #[test]
    fn a_scene_with_nothing_to_merge_is_unchanged() {
        let s = crate::scene::load("cornell").unwrap();
        let one = RenderScene {
            instances: vec![s.instances[0]],
            ..s
        };
        let (m, r) = one.clone().merge_static();
        assert_eq!(r.merged, 0);
        assert_eq!(m.instances, one.instances);
        assert_eq!(m.meshes, one.meshes);
    }
}
