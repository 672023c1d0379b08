//! The traversal interface every acceleration structure implements (paper section 3: the two
//! intersection methods, first hit and all hits, plus occlusion for shadow rays), in
//! single-ray and packet forms.

use coherent_simd::{Lanes, SimdMask};

use crate::{AccelError, Hit1, Hits, Instance, Ray1, Rays, Scene, Work};

/// An acceleration structure over a [`Scene`] of instanced triangle meshes.
///
/// The packet methods are generic over the lane type `L`, so the trait is used through
/// generics (or an `enum` over accelerators), never as `dyn Accel`.
///
/// Conventions shared by all methods:
/// - a ray hits in `[tmin, tmax)`; invalid rays (see [`Ray1`]) and inactive lanes are misses;
/// - `t` is in units of the ray's `dir`, in world space (instances do not rescale it);
/// - hits name the triangle by its index in its mesh's `indices` and the instance by its
///   index in the scene's `instances`;
/// - when two triangles are hit at the same `t` (a shared edge, coplanar overlap), which one
///   is reported is unspecified;
/// - a hit within [`crate::EDGE_EPS`] (barycentric) of a triangle's edge, inside or in the
///   tolerance band the projection test accepts beyond an edge the mesh shares (for
///   watertightness; outline edges take no band, see [`crate::edges`]), may be missed:
///   accelerators reference a triangle in the cells its exact shape reaches, and rounding
///   decides on which side of an edge such a hit truly is. Hits farther inside are
///   always found (watertightness is measured by `backends/bsp/tests/watertight.rs`).
///
/// The packet forms have default implementations that loop over the active lanes and call
/// the single-ray forms; accelerators with real packet traversal override them.
pub trait Accel: Send + Sync + Sized {
    /// Build parameters (presets, costs); `Default` is the recommended setting.
    type Params: Clone + Default;

    /// Builds the structure. Validates the scene first: empty meshes, out-of-range indices,
    /// non-finite positions, bad mesh ids and singular transforms are errors naming the mesh
    /// or instance. Degenerate (zero-area) triangles are dropped and counted in
    /// [`BuildStats::degenerate`]: they are never hit.
    fn build(scene: &Scene, params: &Self::Params) -> Result<Self, AccelError>;

    /// Replaces the instances (moved objects, objects added or removed, meshes unchanged)
    /// and rebuilds only what depends on them (the BSP's top-level tree). The result answers
    /// as a fresh build of the scene with these instances would.
    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError>;

    /// Short name, as used in results (`bsp`, `embree`, `obvhs`, `brute`).
    fn name(&self) -> &'static str;

    /// Bytes held by the structure (nodes, leaf lists, triangle records, instance data).
    fn memory_bytes(&self) -> usize;

    /// What the last build did.
    fn stats(&self) -> BuildStats;

    /// The nearest hit of one ray.
    fn intersect1(&self, ray: &Ray1) -> Option<Hit1>;

    /// Whether anything is hit in `[tmin, tmax)` (shadow rays).
    fn occluded1(&self, ray: &Ray1) -> bool;

    /// Every hit of one ray in `[tmin, tmax)`, each (triangle, instance) pair once, passed to
    /// `f` in no particular order (sort by `t` if order matters). This is the paper's second
    /// intersection method; a callback, so the caller decides how many hits to keep.
    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1));

    /// The nearest hit per active lane; inactive and missing lanes hold [`Hits::miss`] values.
    #[inline(always)]
    fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        // Unpacked once, and the closure inlined: in a kernel's `#[target_feature]` function,
        // code left out of line calls every intrinsic (`scripts/check-inlining.sh`).
        let rays = rays.unpack();
        let bits = active.bitmask();
        Hits::from_fn(
            l,
            #[inline(always)]
            |i| {
                if bits >> i & 1 != 0 {
                    self.intersect1(&rays[i])
                } else {
                    None
                }
            },
        )
    }

    /// The active lanes that hit anything in `[tmin, tmax)`.
    #[inline(always)]
    fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        let rays = rays.unpack();
        let bits = active.bitmask();
        l.mask_from_fn(
            #[inline(always)]
            |i| bits >> i & 1 != 0 && self.occluded1(&rays[i]),
        )
    }

    /// A beam: many packets of coherent rays traced together (camera rays of a tile, shadow
    /// rays of a tile toward one point), first hits. `hits[j]` receives packet `j`'s answer,
    /// exactly what [`Accel::intersect`] gives for `rays[j]` under `active[j]`; the three
    /// slices have one entry per packet.
    ///
    /// The default traces packet after packet. Structures that can do less work for a
    /// coherent group than for its packets one by one (the BSP's beam traversal: an entry
    /// point shared by the group, interval bounds deciding a node for every ray at once)
    /// override it.
    #[inline(always)]
    fn intersect_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        debug_assert!(rays.len() == active.len() && rays.len() == hits.len());
        for ((r, &m), h) in rays.iter().zip(active).zip(hits.iter_mut()) {
            *h = self.intersect(l, r, m);
        }
    }

    /// A beam's occlusion (see [`Accel::intersect_beam`]): `occluded[j]` receives
    /// [`Accel::occluded`] of packet `j`.
    #[inline(always)]
    fn occluded_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        debug_assert!(rays.len() == active.len() && rays.len() == occluded.len());
        for ((r, &m), o) in rays.iter().zip(active).zip(occluded.iter_mut()) {
            *o = self.occluded(l, r, m);
        }
    }

    /// Whether the `*_work` queries count what their traversal did. `false` (the default)
    /// for structures whose traversal is not ours to count (Embree, obvhs): their `*_work`
    /// queries answer as the plain ones and add nothing.
    fn counts_work(&self) -> bool {
        false
    }

    /// [`Accel::intersect`], adding what the traversal did to `work` (see
    /// [`Accel::counts_work`]).
    #[inline(always)]
    fn intersect_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        _work: &mut Work,
    ) -> Hits<L> {
        self.intersect(l, rays, active)
    }

    /// [`Accel::occluded`], adding what the traversal did to `work`.
    #[inline(always)]
    fn occluded_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        _work: &mut Work,
    ) -> L::Mask {
        self.occluded(l, rays, active)
    }

    /// [`Accel::intersect_beam`], adding what the traversal did to `work`.
    #[inline(always)]
    fn intersect_beam_work<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        _work: &mut Work,
    ) {
        self.intersect_beam(l, rays, active, hits)
    }

    /// Every hit of every active lane, passed to `f(lane, hit)` with the guarantees of
    /// [`Accel::intersect_all1`] per lane; lanes may interleave.
    #[inline(always)]
    fn intersect_all<L: Lanes>(
        &self,
        _l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        for i in 0..L::N {
            if active.lane(i) {
                self.intersect_all1(&rays.lane(i), &mut |h| f(i, h));
            }
        }
    }
}

/// What a build did. Fields that do not apply to an accelerator are 0.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BuildStats {
    /// Wall time of the whole build (all meshes and the top level), seconds.
    pub build_seconds: f64,
    /// Wall time of the last top-level (instance) build, seconds.
    pub top_build_seconds: f64,
    /// Triangles kept, over all meshes (each mesh once, however often it is instanced).
    pub triangles: usize,
    /// Degenerate triangles dropped, over all meshes.
    pub degenerate: usize,
    /// Instances.
    pub instances: usize,
    /// Tree nodes (inner and leaves), over all trees.
    pub nodes: usize,
    /// Leaves, over all trees.
    pub leaves: usize,
    /// Leaves holding nothing.
    pub empty_leaves: usize,
    /// Primitive references in leaves (a primitive straddling leaves counts in each).
    pub leaf_refs: usize,
    /// Deepest leaf, over all trees.
    pub max_depth: usize,
    /// Same as [`Accel::memory_bytes`].
    pub memory_bytes: usize,
    /// Accelerator-specific figures (name, value), e.g. the SAH cost of each tree.
    pub extra: Vec<(String, f64)>,
}
