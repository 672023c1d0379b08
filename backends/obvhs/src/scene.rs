//! The two-level scene on obvhs (paper section 3's objects and scene): one tree per mesh over
//! its triangles, and a top tree over the instances' world boxes. obvhs' own TLAS path does
//! not transform rays, so the top level here moves each ray into the instance's space
//! (`object_from_world`) itself before traversing the mesh's tree.

use std::time::Instant;

use coherent_accel::{AccelError, BuildStats, Hit1, Instance, Ray1, Scene, TriAccel};
use glam::{Affine3A, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;

use crate::packet::BeamTree;
use crate::tree::{Count, Counts, Kind, Preset, Tree};

/// How the scene is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObvhsParams {
    pub kind: Kind,
    /// Preset of each mesh's tree (built once).
    pub mesh_preset: Preset,
    /// Preset of the top tree (rebuilt when instances move).
    pub top_preset: Preset,
    /// CWBVHs also build the BVH2s the beams walk (`crate::packet`); without them the beams
    /// of a CWBVH trace packet after packet. Off by default: a CWBVH built only for single
    /// rays and packets should not pay a second build.
    pub beam_bvh2: bool,
}

impl Default for ObvhsParams {
    /// CWBVH; obvhs' medium preset for the meshes, its fast one for the top tree (rebuilt
    /// often, like the BSP's top level).
    fn default() -> Self {
        Self {
            kind: Kind::Cwbvh,
            mesh_preset: Preset::MediumBuild,
            top_preset: Preset::FastBuild,
            beam_bvh2: false,
        }
    }
}

pub(crate) struct Mesh {
    /// The non-degenerate triangles (the tree maps its leaves back to these indices).
    pub(crate) tris: Vec<Triangle>,
    /// Each triangle's index in the input mesh.
    pub(crate) prims: Vec<u32>,
    pub(crate) tree: Tree,
    /// The BVH2 the beams walk (`tree` itself when it is one; see [`crate::packet`]).
    pub(crate) beam: BeamTree,
    bounds: Aabb,
}

pub(crate) struct Placed {
    pub(crate) mesh: usize,
    world_from_object: Affine3A,
    pub(crate) object_from_world: Affine3A,
}

/// The obvhs accelerator: a built two-level obvhs scene.
pub struct Obvhs {
    pub(crate) meshes: Vec<Mesh>,
    pub(crate) instances: Vec<Placed>,
    pub(crate) top: Tree,
    /// The BVH2 the beams walk over the instances (`top` itself when it is one).
    pub(crate) top_beam: BeamTree,
    /// The instance of each primitive of the top tree.
    pub(crate) top_ids: Vec<u32>,
    /// The world box of every instance, grown a little (rays with `tmin < 0` are clipped to
    /// it: obvhs searches `t >= 0` only).
    pub(crate) bounds: coherent_accel::Aabb,
    params: ObvhsParams,
    stats: BuildStats,
    /// One instance with the identity transform: rays go straight into its mesh's tree, with
    /// no top level (the BSP and Embree skip it likewise).
    pub(crate) direct: Option<usize>,
}

/// The non-degenerate triangles of a (validated) mesh, as obvhs triangles, with their
/// indices; degenerate means what [`TriAccel`] rejects, as for every accelerator.
fn mesh_tris(mesh: &coherent_accel::Mesh) -> (Vec<Triangle>, Vec<u32>) {
    (0..mesh.indices.len())
        .filter_map(|i| {
            let p = mesh.triangle(i);
            TriAccel::new(p, i as u32)?;
            let [v0, v1, v2] = p.map(Vec3A::from);
            Some((Triangle { v0, v1, v2 }, i as u32))
        })
        .unzip()
}

/// World bounds of `inst` (the eight corners of its mesh's box, transformed).
fn world_box(mesh: &Mesh, inst: &Placed) -> Aabb {
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

/// The top tree's side of a count: its nodes count, its primitives (instance boxes) are not
/// triangle tests.
struct TopNodes<'a, C>(&'a C);

impl<C: Count> Count for TopNodes<'_, C> {
    const COUNTS: bool = C::COUNTS;
    #[inline(always)]
    fn prim(&self) {}
    #[inline(always)]
    fn node(&self) {
        self.0.node();
    }
}

/// Distance to `tri` along `ray` within `[tmin, tmax]`, or infinity (obvhs' Möller-Trumbore).
#[inline(always)]
pub(crate) fn hit_t(tri: &Triangle, ray: &Ray) -> f32 {
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

impl Obvhs {
    /// Builds every mesh's tree and the top tree (the scene is validated first: errors name
    /// the mesh or instance).
    pub fn build_scene(scene: &Scene, params: &ObvhsParams) -> Result<Self, AccelError> {
        let object_from_world = scene.validate()?;
        let start = Instant::now();
        let mut stats = BuildStats::default();
        let meshes = scene
            .meshes
            .iter()
            .map(|mesh| {
                let (tris, prims) = mesh_tris(mesh);
                stats.triangles += tris.len();
                stats.degenerate += mesh.indices.len() - tris.len();
                let bounds = tris.iter().fold(Aabb::empty(), |b, t| b.union(&t.aabb()));
                let tree = Tree::over_triangles(params.kind, &tris, params.mesh_preset);
                let beam = if params.beam_bvh2 {
                    BeamTree::over_triangles(&tree, &tris, params.mesh_preset)
                } else {
                    BeamTree::default()
                };
                Mesh {
                    tris,
                    prims,
                    tree,
                    beam,
                    bounds,
                }
            })
            .collect();
        let mut o = Self {
            meshes,
            instances: Vec::new(),
            top: Tree::Empty,
            top_beam: BeamTree::default(),
            top_ids: Vec::new(),
            bounds: coherent_accel::Aabb::EMPTY,
            params: *params,
            stats,
            direct: None,
        };
        o.place(&scene.instances, object_from_world);
        o.stats.build_seconds = start.elapsed().as_secs_f64();
        o.stats.memory_bytes = o.memory();
        Ok(o)
    }

    /// Places the instances and builds the top tree over them.
    fn place(&mut self, instances: &[Instance], object_from_world: Vec<Affine3A>) {
        let start = Instant::now();
        self.instances = instances
            .iter()
            .zip(object_from_world)
            .map(|(i, inv)| Placed {
                mesh: i.mesh,
                world_from_object: i.world_from_object,
                object_from_world: inv,
            })
            .collect();
        // Instances of meshes without triangles are never hit: they stay out of the tree.
        self.top_ids.clear();
        let mut boxes = Vec::with_capacity(self.instances.len());
        for (i, inst) in self.instances.iter().enumerate() {
            let mesh = &self.meshes[inst.mesh];
            if !mesh.tris.is_empty() {
                self.top_ids.push(i as u32);
                boxes.push(world_box(mesh, inst));
            }
        }
        let world = boxes.iter().fold(coherent_accel::Aabb::EMPTY, |w, b| {
            w.union(coherent_accel::Aabb::new(b.min.into(), b.max.into()))
        });
        self.bounds = if world.is_empty() {
            world
        } else {
            let margin = glam::Vec3::splat(1e-4 * world.extent().max_element() + 1e-6);
            coherent_accel::Aabb::new(world.min - margin, world.max + margin)
        };
        self.top = Tree::over_boxes(self.params.kind, &boxes, self.params.top_preset);
        self.top_beam = if self.params.beam_bvh2 {
            BeamTree::over_boxes(&self.top, &boxes, self.params.top_preset)
        } else {
            BeamTree::default()
        };
        self.direct = match instances {
            [one] if one.world_from_object == Affine3A::IDENTITY => Some(one.mesh),
            _ => None,
        };
        self.stats.instances = instances.len();
        self.stats.top_build_seconds = start.elapsed().as_secs_f64();
    }

    /// Replaces the instances and rebuilds the top tree only.
    pub fn replace_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        let inv = coherent_accel::scene::validate_instances(instances, self.meshes.len())?;
        self.place(instances, inv);
        self.stats.memory_bytes = self.memory();
        Ok(())
    }

    /// Bytes of the trees, the triangles they index and the instance data, with the BVH2s
    /// kept for the beams when the trees are CWBVHs ([`Self::beam_memory`]).
    pub(crate) fn memory(&self) -> usize {
        let meshes: usize = self
            .meshes
            .iter()
            .map(|m| m.tree.memory_bytes() + m.tris.len() * (size_of::<Triangle>() + 4))
            .sum();
        meshes
            + self.beam_memory()
            + self.top.memory_bytes()
            + self.top_ids.len() * 4
            + self.instances.len() * size_of::<Placed>()
    }

    /// Bytes of the BVH2s kept for the beams besides the trees (0 when the trees are BVH2s:
    /// the beams walk them).
    pub fn beam_memory(&self) -> usize {
        self.meshes
            .iter()
            .map(|m| m.beam.memory_bytes())
            .sum::<usize>()
            + self.top_beam.memory_bytes()
    }

    pub(crate) fn stats_now(&self) -> BuildStats {
        let mut s = self.stats.clone();
        s.extra
            .push(("beam_bvh2_bytes".into(), self.beam_memory() as f64));
        s
    }

    pub fn params(&self) -> ObvhsParams {
        self.params
    }

    /// `r` in instance `inst`'s space, with the segment `[tmin, tmax]`.
    #[inline(always)]
    pub(crate) fn object_ray(&self, inst: &Placed, world: &Ray, tmax: f32) -> Ray {
        // The interface's arithmetic (`Ray1::transformed`), so t agrees with the others.
        let m = &inst.object_from_world;
        let o = coherent_accel::transform_point1(m, world.origin.into());
        let d = coherent_accel::transform_vector1(m, world.direction.into());
        Ray::new(o.into(), positive_zeros(d.into()), world.tmin, tmax)
    }

    /// First hit of one ray.
    pub(crate) fn first_hit1(&self, r: &Ray1) -> Option<Hit1> {
        self.first_hit1_c(r, &())
    }

    /// Triangle tests and CWBVH nodes (top tree's included) of one ray's first-hit (or, with
    /// `occlusion`, any-hit) query: the BVH's side of the traversal counters the `accel`
    /// experiment reports beside the BSP's. Returns `(tests, nodes)`; nodes are 0 for BVH2.
    pub fn counts1(&self, r: &Ray1, occlusion: bool) -> (u64, u64) {
        let c = Counts::default();
        if occlusion {
            self.any_hit1_c(r, &c);
        } else {
            self.first_hit1_c(r, &c);
        }
        (c.prims.get(), c.nodes.get())
    }

    #[inline(always)]
    pub(crate) fn first_hit1_c(&self, r: &Ray1, c: &impl Count) -> Option<Hit1> {
        if !r.is_valid() {
            return None;
        }
        let (r, shift) = r.forward(&self.bounds)?;
        let world = world_ray(&r);
        if let Some(m) = self.direct {
            let mesh = &self.meshes[m];
            let (k, t) = mesh
                .tree
                .closest(world, c, |lr, t| hit_t(&mesh.tris[t as usize], lr))?;
            let (u, v) = barycentrics(&mesh.tris[k as usize], &world);
            return Some(Hit1 {
                t: t + shift,
                u,
                v,
                prim: mesh.prims[k as usize],
                inst: 0,
            });
        }
        let mut best: Option<(u32, u32, Ray)> = None;
        let found = self.top.closest(world, &TopNodes(c), |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            match mesh
                .tree
                .closest(local, c, |lr, t| hit_t(&mesh.tris[t as usize], lr))
            {
                Some((prim, t)) if t < ray.tmax => {
                    best = Some((i, prim, local));
                    t
                }
                _ => f32::INFINITY,
            }
        });
        let ((_, t), (inst, k, local)) = (found?, best?);
        let mesh = &self.meshes[self.instances[inst as usize].mesh];
        let (u, v) = barycentrics(&mesh.tris[k as usize], &local);
        Some(Hit1 {
            t: t + shift,
            u,
            v,
            prim: mesh.prims[k as usize],
            inst,
        })
    }

    /// Whether anything lies on the ray's segment.
    pub(crate) fn any_hit1(&self, r: &Ray1) -> bool {
        self.any_hit1_c(r, &())
    }

    #[inline(always)]
    pub(crate) fn any_hit1_c(&self, r: &Ray1, c: &impl Count) -> bool {
        if !r.is_valid() {
            return false;
        }
        let Some((r, _)) = r.forward(&self.bounds) else {
            return false;
        };
        let world = world_ray(&r);
        if let Some(m) = self.direct {
            let mesh = &self.meshes[m];
            return mesh
                .tree
                .any(world, c, |lr, t| hit_t(&mesh.tris[t as usize], lr));
        }
        self.top.any(world, &TopNodes(c), |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            if mesh
                .tree
                .any(local, c, |lr, t| hit_t(&mesh.tris[t as usize], lr))
            {
                0.0
            } else {
                f32::INFINITY
            }
        })
    }

    /// Every hit on the ray's segment, each (triangle, instance) once (a triangle split
    /// into several leaves by the slow presets is met more than once).
    pub(crate) fn every_hit1(&self, r: &Ray1, f: &mut impl FnMut(Hit1)) {
        if !r.is_valid() {
            return;
        }
        let Some((r, shift)) = r.forward(&self.bounds) else {
            return;
        };
        let world = world_ray(&r);
        let mut seen: Vec<(u32, u32)> = Vec::new();
        if let Some(m) = self.direct {
            let mesh = &self.meshes[m];
            mesh.tree.each(world, |lr, k| {
                let tri = &mesh.tris[k as usize];
                let t = hit_t(tri, lr);
                if t.is_finite() && !seen.contains(&(0, k)) {
                    seen.push((0, k));
                    let (u, v) = barycentrics(tri, lr);
                    f(Hit1 {
                        t: t + shift,
                        u,
                        v,
                        prim: mesh.prims[k as usize],
                        inst: 0,
                    });
                }
            });
            return;
        }
        self.top.each(world, |ray, i| {
            let i = self.top_ids[i as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let local = self.object_ray(inst, ray, ray.tmax);
            mesh.tree.each(local, |lr, k| {
                let tri = &mesh.tris[k as usize];
                let t = hit_t(tri, lr);
                if t.is_finite() && !seen.contains(&(i, k)) {
                    seen.push((i, k));
                    let (u, v) = barycentrics(tri, lr);
                    f(Hit1 {
                        t: t + shift,
                        u,
                        v,
                        prim: mesh.prims[k as usize],
                        inst: i,
                    });
                }
            });
        });
    }
}

/// The world ray as obvhs takes it (valid rays only).
#[inline(always)]
fn world_ray(r: &Ray1) -> Ray {
    Ray::new(
        r.origin.into(),
        positive_zeros(r.dir.into()),
        r.tmin,
        r.tmax,
    )
}

/// `-0.0` components made `+0.0`: obvhs 0.4's CWBVH traversal misses every hit of a ray
/// whose direction has a `-0.0` component (its octant and its inverse direction then
/// disagree; found by `tests/accel_equivalence.rs`).
#[inline(always)]
fn positive_zeros(d: Vec3A) -> Vec3A {
    d + Vec3A::ZERO
}
