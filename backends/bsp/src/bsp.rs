//! The two-level BSP of paper section 3: a kd-tree per mesh (built once, carefully) and a
//! kd-tree over the instances' world boxes (rebuilt fast when instances move).

use std::mem::MaybeUninit;
use std::time::Instant;

use coherent_accel::{
    Accel, AccelError, BuildStats, Hit1, Hits, Instance, Ray1, Rays, Scene, TriAccel, Work,
    scene::validate_instances,
};
use coherent_simd::{Lanes, SimdMask};
use glam::{Affine3A, Vec3};
use rayon::prelude::*;

use crate::counters::{Counters, TraversalStats};
use crate::group::{GROUP, group_size};
use crate::leaf4::Leaves4;
use crate::query::{All1, AllP, Any1, AnyP, First1, FirstP};
use crate::{BspParams, KdTree, build_sah, build_top};

/// One mesh's kd-tree and triangle records (leaf items index `tris`).
#[derive(Debug, Clone)]
pub struct MeshTree {
    pub tree: KdTree,
    pub tris: Vec<TriAccel>,
    /// Degenerate triangles dropped.
    pub degenerate: usize,
    /// The leaves' records in blocks of four, for single rays ([`BspParams::simd_leaves`]).
    pub leaves4: Option<Leaves4>,
    /// Per record, the box its projection test can hit: what beams cull a leaf's triangles
    /// with against a group's frustum (see `frustum.rs`).
    pub(crate) boxes: Vec<coherent_accel::Aabb>,
}

impl MeshTree {
    /// Builds the tree of one mesh's positions and triangles (validated); the records take
    /// the [`coherent_accel::EDGE_EPS`] band on shared edges only
    /// ([`coherent_accel::edges::mesh_records`]).
    ///
    /// The tree is built over the exact triangles, not over the band of
    /// [`coherent_accel::EDGE_EPS`] the projection test also accepts beyond their edges: so a
    /// hit in that band can be missed when the ray visits no leaf of the triangle (the
    /// [`Accel`] contract allows it). Growing the triangles instead (tried: by `1 + 4 EDGE_EPS`
    /// about the centroid) made every box face straddle its neighbours' planes, so a box's 12
    /// triangles stayed in one leaf (13.8 triangle tests per primary ray in `room`).
    pub fn build(positions: &[Vec3], indices: &[[u32; 3]], p: &crate::SahParams) -> Self {
        let (tris, verts) = coherent_accel::edges::mesh_records(positions, indices);
        Self {
            tree: build_sah(&verts, p),
            degenerate: indices.len() - tris.len(),
            tris,
            leaves4: None,
            boxes: verts.iter().map(crate::frustum::cull_box).collect(),
        }
    }

    /// Adds the blocks single rays test four triangles at a time.
    pub fn with_simd_leaves(mut self) -> Self {
        self.leaves4 = Some(Leaves4::new(&self.tree, &self.tris));
        self
    }

    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes()
            + self.tris.len() * size_of::<TriAccel>()
            + self.boxes.len() * size_of::<coherent_accel::Aabb>()
            + self.leaves4.as_ref().map_or(0, Leaves4::memory_bytes)
    }
}

/// An instance as the traversal needs it.
#[derive(Debug, Clone)]
pub(crate) struct InstanceData {
    pub object_from_world: Affine3A,
    pub mesh: u32,
    /// The transform is the identity: rays need not be moved.
    pub identity: bool,
    /// The mesh's box moved into the world (what the top tree was built over).
    pub world_bounds: coherent_accel::Aabb,
}

/// The paper's two-level BSP. Build with [`Accel::build`]; query through [`Accel`].
#[derive(Debug, Clone)]
pub struct Bsp {
    pub(crate) params: BspParams,
    pub(crate) meshes: Vec<MeshTree>,
    pub(crate) instances: Vec<InstanceData>,
    pub(crate) top: KdTree,
    world_from_object: Vec<Affine3A>,
    mesh_ids: Vec<usize>,
    stats: BuildStats,
}

impl Bsp {
    pub fn params(&self) -> &BspParams {
        &self.params
    }

    /// Changes the traversal-only parameters (mailbox, switch threshold) without a rebuild.
    pub fn set_traversal_params(&mut self, mailbox: bool, single_ray_threshold: Option<u32>) {
        self.params.mailbox = mailbox;
        self.params.single_ray_threshold = single_ray_threshold;
    }

    /// Turns the beams' leaf culling and their reversal of shadow segments on or off
    /// (traversal only: no rebuild).
    pub fn set_beam_params(&mut self, cull: bool, reverse: bool) {
        self.params.beam_cull = cull;
        self.params.beam_reverse = reverse;
    }

    /// Whether [`Accel::occluded_beam`] walks packets `rays` (lanes `active`, one group's
    /// worth or fewer) from their segments' far ends back (see `reverse.rs`) when they form
    /// a group (more than one packet, on a backend of more than one lane): their far ends
    /// lie closer together than their near ends, and [`BspParams::beam_reverse`] is on.
    pub fn reverses_beam<L: Lanes>(&self, l: L, rays: &[Rays<L>], active: &[L::Mask]) -> bool {
        self.params.beam_reverse && crate::reverse::far_ends_closer(l, rays, active)
    }

    /// The mesh trees.
    pub fn mesh_trees(&self) -> &[MeshTree] {
        &self.meshes
    }

    /// The top-level tree.
    pub fn top_tree(&self) -> &KdTree {
        &self.top
    }

    /// [`Accel::intersect1`], counting what the traversal did into `c`.
    pub fn intersect1_counted(&self, ray: &Ray1, c: &mut TraversalStats) -> Option<Hit1> {
        self.first1(ray, c)
    }

    /// [`Accel::intersect`], counting what the traversal did into `c`.
    #[inline(always)]
    pub fn intersect_counted<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        c: &mut TraversalStats,
    ) -> Hits<L> {
        self.first(l, rays, active, c)
    }

    /// [`Accel::occluded1`], counting what the traversal did into `c`.
    pub fn occluded1_counted(&self, ray: &Ray1, c: &mut TraversalStats) -> bool {
        self.any1(ray, c)
    }

    /// [`Accel::occluded`], counting what the traversal did into `c`.
    #[inline(always)]
    pub fn occluded_counted<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        c: &mut TraversalStats,
    ) -> L::Mask {
        self.any(l, rays, active, c)
    }

    /// [`Accel::intersect_beam`], counting what the traversal did into `c`.
    #[inline(always)]
    pub fn intersect_beam_counted<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        c: &mut TraversalStats,
    ) {
        self.first_beam(l, rays, active, hits, c);
    }

    /// [`Accel::occluded_beam`], counting what the traversal did into `c`.
    #[inline(always)]
    pub fn occluded_beam_counted<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
        c: &mut TraversalStats,
    ) {
        self.any_beam(l, rays, active, occluded, c);
    }

    /// A beam query out of line (`Lanes::apart`): one copy per lane type and counter, which
    /// every caller shares. Inlined, each call site took its own copy of two lane walks and
    /// the group walks' entry (the build's cost: docs/architecture.md); one call per beam
    /// costs nothing beside its walk. A beam of one packet stays inline (the control).
    #[inline(always)]
    fn first_beam<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        c: &mut C,
    ) {
        // A beam of one packet is the lane walk, inline as the lane query is: the control
        // that a beam costs nothing over its packets.
        if let ([r], [m], [h]) = (rays, active, &mut *hits) {
            *h = self.first(l, r, *m, c);
            return;
        }
        l.apart(
            #[inline(always)]
            |l| self.first_beam_apart(l, rays, active, hits, c),
        )
    }

    #[inline(always)]
    fn first_beam_apart<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        c: &mut C,
    ) {
        assert!(rays.len() == active.len() && rays.len() == hits.len());
        // The queries of one group at a time, on the stack: no allocation inside a query.
        // Loops, not iterator adaptors: those stay out of line, outside the kernel's features.
        let mut a = 0;
        while a < rays.len() {
            let b = (a + group_size::<L>()).min(rays.len());
            if b - a == 1 {
                // One packet (every packet of the scalar backend): the packet query itself,
                // without a group's query slots to fill.
                hits[a] = self.first(l, &rays[a], active[a], c);
                a = b;
                continue;
            }
            let mut qs = [FirstP {
                best: rays[a].tmax,
                hits: Hits::miss(l),
            }; GROUP];
            for j in a..b {
                qs[j - a].best = rays[j].tmax;
            }
            crate::beam::scene_beam(l, self, &rays[a..b], &active[a..b], &mut qs[..b - a], c);
            for j in a..b {
                hits[j] = qs[j - a].hits;
            }
            a = b;
        }
    }

    /// Out of line, as [`Bsp::first_beam`].
    #[inline(always)]
    fn any_beam<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
        c: &mut C,
    ) {
        if let ([r], [m], [o]) = (rays, active, &mut *occluded) {
            *o = self.any(l, r, *m, c);
            return;
        }
        l.apart(
            #[inline(always)]
            |l| self.any_beam_apart(l, rays, active, occluded, c),
        )
    }

    #[inline(always)]
    fn any_beam_apart<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
        c: &mut C,
    ) {
        assert!(rays.len() == active.len() && rays.len() == occluded.len());
        let neg_inf = l.splat(f32::NEG_INFINITY);
        let none = l.splat_mask(false);
        let mut a = 0;
        while a < rays.len() {
            let b = (a + group_size::<L>()).min(rays.len());
            if b - a == 1 {
                occluded[a] = self.any(l, &rays[a], active[a], c);
                a = b;
                continue;
            }
            let mut qs = [AnyP {
                tmax: neg_inf,
                occluded: none,
                active: none,
                neg_inf,
            }; GROUP];
            // Walked from the far ends when they lie closer together (shadow rays toward
            // one point of a light: from the light).
            let (chunk, on) = (&rays[a..b], &active[a..b]);
            let mut back = [MaybeUninit::<Rays<L>>::uninit(); GROUP];
            let reverse = self.params.beam_reverse
                && l.apart(
                    #[inline(always)]
                    |l| crate::reverse::far_ends_closer(l, chunk, on),
                );
            if reverse {
                for j in a..b {
                    back[j - a] = MaybeUninit::new(crate::reverse::reversed(l, &rays[j]));
                    c.beam_reversed((active[j] & rays[j].valid(l)).count());
                }
            }
            let walked: &[Rays<L>] = if reverse {
                // SAFETY: slots `..b - a` were written just above.
                unsafe { std::slice::from_raw_parts(back.as_ptr().cast::<Rays<L>>(), b - a) }
            } else {
                chunk
            };
            for j in a..b {
                qs[j - a] = AnyP {
                    tmax: walked[j - a].tmax,
                    occluded: none,
                    active: active[j] & rays[j].valid(l),
                    neg_inf,
                };
            }
            crate::beam::scene_beam(l, self, walked, on, &mut qs[..b - a], c);
            for j in a..b {
                occluded[j] = qs[j - a].occluded & active[j];
            }
            a = b;
        }
    }

    #[inline(always)]
    fn any1<C: Counters>(&self, ray: &Ray1, c: &mut C) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let mut q = Any1 {
            tmax: ray.tmax,
            occluded: false,
        };
        crate::walk1::scene1(self, ray.origin, ray.dir, ray.tmin, &mut q, c);
        q.occluded
    }

    #[inline(always)]
    fn any<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        c: &mut C,
    ) -> L::Mask {
        let mut q = AnyP {
            tmax: rays.tmax,
            occluded: l.splat_mask(false),
            active: active & rays.valid(l),
            neg_inf: l.splat(f32::NEG_INFINITY),
        };
        crate::walk::scene_packet(l, self, rays, active, &mut q, c);
        q.occluded & active
    }

    #[inline(always)]
    fn first1<C: Counters>(&self, ray: &Ray1, c: &mut C) -> Option<Hit1> {
        if !ray.is_valid() {
            return None;
        }
        let mut q = First1 {
            tmax: ray.tmax,
            best: None,
        };
        crate::walk1::scene1(self, ray.origin, ray.dir, ray.tmin, &mut q, c);
        q.best
    }

    #[inline(always)]
    fn first<L: Lanes, C: Counters>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        c: &mut C,
    ) -> Hits<L> {
        let mut q = FirstP {
            best: rays.tmax,
            hits: Hits::miss(l),
        };
        crate::walk::scene_packet(l, self, rays, active, &mut q, c);
        q.hits
    }

    fn build_top_level(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        let t0 = Instant::now();
        let inverse = validate_instances(instances, self.meshes.len())?;
        let boxes: Vec<_> = instances
            .iter()
            .map(|i| {
                self.meshes[i.mesh]
                    .tree
                    .bounds
                    .transformed(&i.world_from_object)
            })
            .collect();
        self.top = build_top(&boxes, &self.params.top);
        self.instances = instances
            .iter()
            .zip(inverse)
            .zip(&boxes)
            .map(|((i, inv), b)| InstanceData {
                object_from_world: inv,
                mesh: i.mesh as u32,
                identity: i.world_from_object == Affine3A::IDENTITY,
                world_bounds: *b,
            })
            .collect();
        self.world_from_object = instances.iter().map(|i| i.world_from_object).collect();
        self.mesh_ids = instances.iter().map(|i| i.mesh).collect();
        self.stats.top_build_seconds = t0.elapsed().as_secs_f64();
        self.stats.instances = instances.len();
        self.refresh_stats();
        Ok(())
    }

    fn refresh_stats(&mut self) {
        let s = &mut self.stats;
        let trees = self.meshes.iter().map(|m| &m.tree).chain([&self.top]);
        (s.nodes, s.leaves, s.empty_leaves, s.leaf_refs, s.max_depth) = (0, 0, 0, 0, 0);
        for t in trees {
            s.nodes += t.stats.nodes;
            s.leaves += t.stats.leaves;
            s.empty_leaves += t.stats.empty_leaves;
            s.leaf_refs += t.stats.leaf_refs;
            s.max_depth = s.max_depth.max(t.stats.max_depth);
        }
        s.extra = vec![
            (
                "object_sah_cost_sum".into(),
                self.meshes.iter().map(|m| m.tree.stats.sah_cost).sum(),
            ),
            ("top_sah_cost".into(), self.top.stats.sah_cost),
            ("top_nodes".into(), self.top.stats.nodes as f64),
        ];
        self.stats.memory_bytes = self.memory_bytes();
    }
}

impl Accel for Bsp {
    type Params = BspParams;

    fn build(scene: &Scene, params: &BspParams) -> Result<Self, AccelError> {
        let t0 = Instant::now();
        for (i, m) in scene.meshes.iter().enumerate() {
            m.validate(i)?;
        }
        // One tree per mesh, in parallel: each is built alone, so they are the same trees.
        let meshes: Vec<MeshTree> = scene
            .meshes
            .par_iter()
            .map(|m| {
                let t = MeshTree::build(&m.positions, &m.indices, &params.object);
                if params.simd_leaves {
                    t.with_simd_leaves()
                } else {
                    t
                }
            })
            .collect();
        let mut bsp = Bsp {
            params: params.clone(),
            stats: BuildStats {
                triangles: meshes.iter().map(|m| m.tris.len()).sum(),
                degenerate: meshes.iter().map(|m| m.degenerate).sum(),
                ..BuildStats::default()
            },
            meshes,
            instances: Vec::new(),
            top: KdTree::empty(),
            world_from_object: Vec::new(),
            mesh_ids: Vec::new(),
        };
        bsp.build_top_level(&scene.instances)?;
        bsp.stats.build_seconds = t0.elapsed().as_secs_f64();
        Ok(bsp)
    }

    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        self.build_top_level(instances)
    }

    fn name(&self) -> &'static str {
        "bsp"
    }

    fn memory_bytes(&self) -> usize {
        self.meshes
            .iter()
            .map(MeshTree::memory_bytes)
            .sum::<usize>()
            + self.top.memory_bytes()
            + self.instances.len() * size_of::<InstanceData>()
    }

    fn stats(&self) -> BuildStats {
        self.stats.clone()
    }

    fn intersect1(&self, ray: &Ray1) -> Option<Hit1> {
        self.first1(ray, &mut ())
    }

    fn occluded1(&self, ray: &Ray1) -> bool {
        self.any1(ray, &mut ())
    }

    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1)) {
        if !ray.is_valid() {
            return;
        }
        let mut q = All1 {
            tmax: ray.tmax,
            seen: Vec::new(),
            f,
        };
        crate::walk1::scene1(self, ray.origin, ray.dir, ray.tmin, &mut q, &mut ());
    }

    #[inline(always)]
    fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        self.first(l, rays, active, &mut ())
    }

    fn counts_work(&self) -> bool {
        true
    }

    #[inline(always)]
    fn intersect_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        work: &mut Work,
    ) -> Hits<L> {
        let mut c = TraversalStats::default();
        let h = self.first(l, rays, active, &mut c);
        *work += c.work();
        h
    }

    #[inline(always)]
    fn occluded_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        work: &mut Work,
    ) -> L::Mask {
        let mut c = TraversalStats::default();
        let o = self.any(l, rays, active, &mut c);
        *work += c.work();
        o
    }

    #[inline(always)]
    fn intersect_beam_work<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        work: &mut Work,
    ) {
        let mut c = TraversalStats::default();
        self.first_beam(l, rays, active, hits, &mut c);
        *work += c.work();
    }

    #[inline(always)]
    fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        self.any(l, rays, active, &mut ())
    }

    #[inline(always)]
    fn intersect_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        self.first_beam(l, rays, active, hits, &mut ());
    }

    #[inline(always)]
    fn occluded_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        self.any_beam(l, rays, active, occluded, &mut ());
    }

    #[inline(always)]
    fn intersect_all<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        let mut q = AllP {
            tmax: rays.tmax,
            seen: Vec::new(),
            f,
        };
        crate::walk::scene_packet(l, self, rays, active, &mut q, &mut ());
    }
}
