//! The two-level scene on obvhs (paper section 3's objects and scene): one tree per mesh over
//! its triangles, and a top tree over the instances' world boxes. obvhs' own TLAS path does
//! not transform rays, so the top level here moves each ray into the instance's space
//! (`object_from_world`) itself before traversing the mesh's tree.

use std::time::Instant;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;

use crate::tree::{Kind, Preset, Tree};
use crate::ObvhsError;

/// One ray: origin, direction, and the segment `[tmin, tmax]` searched.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray1 {
    pub org: [f32; 3],
    pub dir: [f32; 3],
    pub tmin: f32,
    pub tmax: f32,
}

/// One hit: distance along the ray, barycentrics (of vertices 1 and 2), triangle, instance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit1 {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub prim: u32,
    pub inst: u32,
}

impl Ray1 {
    /// Rays that miss without traversal: non-finite origins or directions, a zero
    /// direction, or an empty or NaN segment.
    #[inline(always)]
    pub fn is_valid(&self) -> bool {
        let finite = self.org.iter().chain(&self.dir).all(|x| x.is_finite());
        let nonzero = self.dir.iter().any(|&x| x != 0.0);
        finite && nonzero && self.tmin >= 0.0 && self.tmin <= self.tmax
    }
}

/// How the scene is built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct BuildParams {
    pub kind: Kind,
    /// Preset of each mesh's tree (built once).
    pub mesh_preset: Preset,
    /// Preset of the top tree (rebuilt when instances move).
    pub top_preset: Preset,
}

/// One mesh: vertex positions and triangles (indices into `positions`).
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    pub positions: &'a [Vec3],
    pub indices: &'a [[u32; 3]],
}

/// One placed copy of a mesh.
#[derive(Clone, Copy, Debug)]
pub struct InstanceRef {
    pub mesh: usize,
    pub world_from_object: Affine3A,
}

struct Mesh {
    /// Triangles in input order (the tree maps its leaves back to these indices).
    tris: Vec<Triangle>,
    tree: Tree,
    bounds: Aabb,
}

struct Instance {
    mesh: usize,
    world_from_object: Affine3A,
    object_from_world: Affine3A,
}

/// A built two-level obvhs scene.
pub struct ObvhsScene {
    meshes: Vec<Mesh>,
    instances: Vec<Instance>,
    top: Tree,
    /// The instance of each primitive of the top tree.
    top_ids: Vec<u32>,
    params: BuildParams,
    build_ms: f64,
}

fn check_instance(i: usize, inst: &InstanceRef, meshes: usize) -> Result<(), ObvhsError> {
    if inst.mesh >= meshes {
        return Err(ObvhsError::InvalidInstance {
            instance: i,
            problem: format!("mesh {} out of range ({meshes} meshes)", inst.mesh),
        });
    }
    let m = inst.world_from_object;
    let det = m.matrix3.determinant();
    if !m.matrix3.is_finite() || !m.translation.is_finite() || det == 0.0 || !det.is_finite() {
        return Err(ObvhsError::InvalidInstance {
            instance: i,
            problem: format!("world_from_object is not finite and invertible ({m:?})"),
        });
    }
    Ok(())
}

fn mesh_tris(m: usize, mesh: &MeshRef<'_>) -> Result<Vec<Triangle>, ObvhsError> {
    if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(ObvhsError::InvalidMesh {
            mesh: m,
            problem: format!("vertex {v} is not finite ({})", mesh.positions[v]),
        });
    }
    let n = mesh.positions.len();
    mesh.indices
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let p = |k: usize| {
                mesh.positions.get(tri[k] as usize).map(|&p| Vec3A::from(p)).ok_or_else(|| {
                    ObvhsError::InvalidMesh {
                        mesh: m,
                        problem: format!("triangle {t} has index {tri:?} out of range ({n} vertices)"),
                    }
                })
            };
            Ok(Triangle { v0: p(0)?, v1: p(1)?, v2: p(2)? })
        })
        .collect()
}

/// World bounds of `inst` (the eight corners of its mesh's box, transformed).
fn world_box(mesh: &Mesh, inst: &Instance) -> Aabb {
    let (lo, hi) = (mesh.bounds.min, mesh.bounds.max);
    let mut b = Aabb::empty();
    for c in 0..8 {
        let corner = Vec3A::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        );
        b.extend(inst.world_from_object.transform_point3a(corner));
    }
    b
}

/// Distance to `tri` along `ray` within `[tmin, tmax]`, or infinity (obvhs' Möller-Trumbore).
#[inline(always)]
fn hit_t(tri: &Triangle, ray: &Ray) -> f32 {
    tri.intersect(ray)
}

/// Barycentrics (u of v1, v of v2) of the ray's crossing of `tri`'s plane.
#[inline(always)]
fn barycentrics(tri: &Triangle, ray: &Ray) -> (f32, f32) {
    let e1 = tri.v0 - tri.v1;
    let e2 = tri.v2 - tri.v0;
    let inv_det = 1.0 / e1.cross(e2).dot(ray.direction);
    let r = ray.direction.cross(tri.v0 - ray.origin);
    (r.dot(e2) * inv_det, r.dot(e1) * inv_det)
}

impl ObvhsScene {
    /// Builds every mesh's tree and the top tree. Fails with the mesh or instance at fault
    /// for non-finite vertices, out-of-range indices, unknown meshes and singular transforms.
    pub fn build(
        meshes: &[MeshRef<'_>],
        instances: &[InstanceRef],
        params: BuildParams,
    ) -> Result<Self, ObvhsError> {
        for (i, inst) in instances.iter().enumerate() {
            check_instance(i, inst, meshes.len())?;
        }
        let start = Instant::now();
        let meshes = meshes
            .iter()
            .enumerate()
            .map(|(m, mesh)| {
                let tris = mesh_tris(m, mesh)?;
                let mut bounds = Aabb::empty();
                for t in &tris {
                    bounds = bounds.union(&t.aabb());
                }
                let tree = Tree::over_triangles(params.kind, &tris, params.mesh_preset);
                Ok(Mesh { tris, tree, bounds })
            })
            .collect::<Result<Vec<_>, ObvhsError>>()?;
        let instances = instances
            .iter()
            .map(|i| Instance {
                mesh: i.mesh,
                world_from_object: i.world_from_object,
                object_from_world: i.world_from_object.inverse(),
            })
            .collect();
        let mut scene =
            Self { meshes, instances, top: Tree::Empty, top_ids: Vec::new(), params, build_ms: 0.0 };
        scene.build_top();
        scene.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(scene)
    }

    fn build_top(&mut self) {
        // Instances of empty meshes have no box and are never hit: they stay out of the tree.
        self.top_ids.clear();
        let mut boxes = Vec::with_capacity(self.instances.len());
        for (i, inst) in self.instances.iter().enumerate() {
            let mesh = &self.meshes[inst.mesh];
            if !mesh.tris.is_empty() {
                self.top_ids.push(i as u32);
                boxes.push(world_box(mesh, inst));
            }
        }
        self.top = Tree::over_boxes(self.params.kind, &boxes, self.params.top_preset);
    }

    /// Moves instance `i` and rebuilds the top tree only (the meshes' trees are kept).
    pub fn move_instance(
        &mut self,
        i: usize,
        world_from_object: Affine3A,
    ) -> Result<(), ObvhsError> {
        check_instance(i, &InstanceRef { mesh: 0, world_from_object }, 1)?;
        let Some(inst) = self.instances.get_mut(i) else {
            return Err(ObvhsError::InvalidInstance {
                instance: i,
                problem: format!("no such instance ({} instances)", self.instances.len()),
            });
        };
        let start = Instant::now();
        inst.world_from_object = world_from_object;
        inst.object_from_world = world_from_object.inverse();
        self.build_top();
        self.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// Milliseconds of the last build (everything after `build`, the top tree after
    /// `move_instance`).
    pub fn build_ms(&self) -> f64 {
        self.build_ms
    }

    /// Bytes of the trees and the triangles they index.
    pub fn memory_bytes(&self) -> usize {
        let meshes: usize = self
            .meshes
            .iter()
            .map(|m| m.tree.memory_bytes() + m.tris.len() * size_of::<Triangle>())
            .sum();
        meshes
            + self.top.memory_bytes()
            + self.top_ids.len() * 4
            + self.instances.len() * size_of::<Instance>()
    }

    pub fn params(&self) -> BuildParams {
        self.params
    }

    /// `r` in instance `inst`'s space, with the segment `[tmin, tmax]`.
    #[inline(always)]
    fn object_ray(&self, inst: &Instance, world: &Ray, tmax: f32) -> Ray {
        let o = inst.object_from_world.transform_point3a(world.origin);
        let d = inst.object_from_world.transform_vector3a(world.direction);
        Ray::new(o, d, world.tmin, tmax)
    }

    /// First hit of one ray.
    pub fn intersect1(&self, r: &Ray1) -> Option<Hit1> {
        if !r.is_valid() {
            return None;
        }
        let world = Ray::new(r.org.into(), r.dir.into(), r.tmin, r.tmax);
        let mut best: Option<(u32, u32, Ray)> = None;
        let found = self.top.closest(world, |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            match mesh.tree.closest(local, |lr, t| hit_t(&mesh.tris[t as usize], lr)) {
                Some((prim, t)) if t < ray.tmax => {
                    best = Some((i, prim, local));
                    t
                }
                _ => f32::INFINITY,
            }
        });
        let ((_, t), (inst, prim, local)) = (found?, best?);
        let tri = &self.meshes[self.instances[inst as usize].mesh].tris[prim as usize];
        let (u, v) = barycentrics(tri, &local);
        Some(Hit1 { t, u, v, prim, inst })
    }

    /// Whether anything lies on the ray's segment.
    pub fn occluded1(&self, r: &Ray1) -> bool {
        if !r.is_valid() {
            return false;
        }
        let world = Ray::new(r.org.into(), r.dir.into(), r.tmin, r.tmax);
        self.top.any(world, |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            if mesh.tree.any(local, |lr, t| hit_t(&mesh.tris[t as usize], lr)) {
                0.0
            } else {
                f32::INFINITY
            }
        })
    }

    /// Every hit on the ray's segment, each (triangle, instance) once, appended to `out`.
    pub fn all_hits1(&self, r: &Ray1, out: &mut Vec<Hit1>) {
        if !r.is_valid() {
            return;
        }
        let world = Ray::new(r.org.into(), r.dir.into(), r.tmin, r.tmax);
        let first = out.len();
        self.top.each(world, |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            mesh.tree.each(local, |lr, prim| {
                let tri = &mesh.tris[prim as usize];
                let t = hit_t(tri, lr);
                if t.is_finite()
                    && !out[first..].iter().any(|h| h.prim == prim && h.inst == i)
                {
                    let (u, v) = barycentrics(tri, lr);
                    out.push(Hit1 { t, u, v, prim, inst: i });
                }
            });
        });
    }
}
