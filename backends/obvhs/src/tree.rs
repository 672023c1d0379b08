//! One obvhs tree, BVH2 or CWBVH (8-wide compressed), with its build presets and the three
//! single-ray traversals the comparison with section 3's BSP needs: closest hit, any hit,
//! and every hit. obvhs traverses single rays only.
//!
//! The closest- and any-hit traversals take a [`Count`]: `()` runs obvhs' own traversal
//! functions (the timed path), [`Counts`] runs the same CWBVH traversal through obvhs'
//! `traverse!` macro with the node test counted (the BVH's side of the `accel` experiment's
//! traversal counters).

use std::cell::Cell;
use std::time::Duration;

use glam::UVec2;

use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::{Boundable, BvhBuildParams};

/// Which obvhs structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Binary BVH (PLOC build, reinsertion, leaf collapse).
    Bvh2,
    /// Compressed wide BVH (8 children per node).
    #[default]
    Cwbvh,
}

impl Kind {
    pub const ALL: [Kind; 2] = [Kind::Bvh2, Kind::Cwbvh];

    pub fn name(self) -> &'static str {
        match self {
            Self::Bvh2 => "bvh2",
            Self::Cwbvh => "cwbvh",
        }
    }
}

impl core::str::FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown obvhs structure {s:?} (bvh2, cwbvh)"))
    }
}

/// obvhs' build presets (`BvhBuildParams::*_build()`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Preset {
    FastestBuild,
    VeryFastBuild,
    FastBuild,
    /// "Tries to be around the same build time as embree but with faster traversal" (obvhs).
    #[default]
    MediumBuild,
    SlowBuild,
    VerySlowBuild,
}

impl Preset {
    pub const ALL: [Preset; 6] = [
        Preset::FastestBuild,
        Preset::VeryFastBuild,
        Preset::FastBuild,
        Preset::MediumBuild,
        Preset::SlowBuild,
        Preset::VerySlowBuild,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::FastestBuild => "fastest",
            Self::VeryFastBuild => "very_fast",
            Self::FastBuild => "fast",
            Self::MediumBuild => "medium",
            Self::SlowBuild => "slow",
            Self::VerySlowBuild => "very_slow",
        }
    }

    pub fn params(self) -> BvhBuildParams {
        match self {
            Self::FastestBuild => BvhBuildParams::fastest_build(),
            Self::VeryFastBuild => BvhBuildParams::very_fast_build(),
            Self::FastBuild => BvhBuildParams::fast_build(),
            Self::MediumBuild => BvhBuildParams::medium_build(),
            Self::SlowBuild => BvhBuildParams::slow_build(),
            Self::VerySlowBuild => BvhBuildParams::very_slow_build(),
        }
    }
}

impl core::str::FromStr for Preset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown obvhs preset {s:?} (fastest, very_fast, fast, medium, slow, very_slow)"
                )
            })
    }
}

/// What a traversal counts: nothing (`()`, obvhs' own traversal) or [`Counts`].
pub trait Count {
    /// False for `()`: the traversal is obvhs' own function, with nothing counted.
    const COUNTS: bool;
    /// One primitive test.
    fn prim(&self);
    /// One node whose children's boxes were tested (8 at once in a CWBVH node).
    fn node(&self);
}

impl Count for () {
    const COUNTS: bool = false;
    #[inline(always)]
    fn prim(&self) {}
    #[inline(always)]
    fn node(&self) {}
}

/// Primitive tests and node visits of counted traversals (summed over calls).
#[derive(Debug, Default)]
pub struct Counts {
    pub prims: Cell<u64>,
    /// CWBVH nodes visited; a BVH2 traversal (obvhs' own, which has no node hook) leaves it 0.
    pub nodes: Cell<u64>,
}

impl Count for Counts {
    const COUNTS: bool = true;
    #[inline(always)]
    fn prim(&self) {
        self.prims.set(self.prims.get() + 1);
    }
    #[inline(always)]
    fn node(&self) {
        self.nodes.set(self.nodes.get() + 1);
    }
}

/// A built tree over some primitives (triangles of a mesh, or instance boxes). `None` for
/// no primitives (obvhs needs at least one).
pub enum Tree {
    Empty,
    Bvh2(Bvh2),
    Cwbvh(CwBvh),
}

impl Tree {
    /// A tree over triangles; obvhs splits large triangles when the preset asks for it, so a
    /// triangle may sit in several leaves.
    pub fn over_triangles(kind: Kind, tris: &[Triangle], preset: Preset) -> Self {
        if tris.is_empty() {
            return Self::Empty;
        }
        let mut t = Duration::ZERO;
        match kind {
            Kind::Bvh2 => Self::Bvh2(obvhs::bvh2::builder::build_bvh2_from_tris(
                tris,
                preset.params(),
                &mut t,
            )),
            Kind::Cwbvh => Self::Cwbvh(obvhs::cwbvh::builder::build_cwbvh_from_tris(
                tris,
                preset.params(),
                &mut t,
            )),
        }
    }

    /// A tree over boxes (the instances' world bounds).
    pub fn over_boxes<T: Boundable>(kind: Kind, boxes: &[T], preset: Preset) -> Self {
        if boxes.is_empty() {
            return Self::Empty;
        }
        let mut t = Duration::ZERO;
        match kind {
            Kind::Bvh2 => Self::Bvh2(obvhs::bvh2::builder::build_bvh2(
                boxes,
                preset.params(),
                &mut t,
            )),
            Kind::Cwbvh => Self::Cwbvh(obvhs::cwbvh::builder::build_cwbvh(
                boxes,
                preset.params(),
                &mut t,
            )),
        }
    }

    /// Bytes of the tree (nodes and the primitive index map).
    pub fn memory_bytes(&self) -> usize {
        match self {
            Self::Empty => 0,
            Self::Bvh2(b) => {
                b.nodes.len() * size_of_val(&b.nodes[0]) + b.primitive_indices.len() * 4
            }
            Self::Cwbvh(b) => {
                b.nodes.len() * size_of_val(&b.nodes[0]) + b.primitive_indices.len() * 4
            }
        }
    }

    /// Closest hit: `f(ray, i)` is the distance to primitive `i` (an original index) or
    /// infinity; returns the primitive and distance of the closest one below `ray.tmax`.
    /// `c` counts the primitive tests and (CWBVH) nodes.
    #[inline(always)]
    pub fn closest<C: Count>(
        &self,
        ray: Ray,
        c: &C,
        mut f: impl FnMut(&Ray, u32) -> f32,
    ) -> Option<(u32, f32)> {
        let mut hit = RayHit::none();
        let found = match self {
            Self::Empty => false,
            Self::Bvh2(b) => {
                let ids = &b.primitive_indices;
                b.ray_traverse(ray, &mut hit, |r, i| {
                    c.prim();
                    f(r, ids[i])
                })
            }
            Self::Cwbvh(b) if C::COUNTS => {
                // `CwBvh::ray_traverse` with the node test counted.
                let ids = &b.primitive_indices;
                let mut r = ray;
                let mut state = b.new_traversal(ray.direction);
                let mut node;
                obvhs::traverse!(
                    b,
                    node,
                    state,
                    {
                        c.node();
                        node.intersect_ray(&r, state.oct_inv4)
                    },
                    {
                        c.prim();
                        let t = f(&r, ids[state.primitive_id as usize]);
                        if t < r.tmax {
                            hit.primitive_id = state.primitive_id;
                            hit.t = t;
                            r.tmax = t;
                        }
                    }
                );
                hit.t < ray.tmax
            }
            Self::Cwbvh(b) => {
                let ids = &b.primitive_indices;
                b.ray_traverse(ray, &mut hit, |r, i| f(r, ids[i]))
            }
        };
        let ids = match self {
            Self::Empty => return None,
            Self::Bvh2(b) => &b.primitive_indices,
            Self::Cwbvh(b) => &b.primitive_indices,
        };
        found.then(|| (ids[hit.primitive_id as usize], hit.t))
    }

    /// Whether `f(ray, i)` is finite for some primitive (stops at the first). `c` counts the
    /// primitive tests and (CWBVH) nodes.
    #[inline(always)]
    pub fn any<C: Count>(&self, ray: Ray, c: &C, mut f: impl FnMut(&Ray, u32) -> f32) -> bool {
        match self {
            Self::Empty => false,
            Self::Bvh2(b) => {
                let ids = &b.primitive_indices;
                !b.ray_traverse_miss(ray, |r, i| {
                    c.prim();
                    f(r, ids[i])
                })
            }
            Self::Cwbvh(b) if C::COUNTS => {
                // `CwBvh::ray_traverse_miss` with the node test counted.
                let ids = &b.primitive_indices;
                let mut state = b.new_traversal(ray.direction);
                let mut node;
                let mut found = false;
                'outer: {
                    obvhs::traverse!(
                        b,
                        node,
                        state,
                        {
                            c.node();
                            node.intersect_ray(&ray, state.oct_inv4)
                        },
                        {
                            c.prim();
                            if f(&ray, ids[state.primitive_id as usize]) < ray.tmax {
                                found = true;
                                break 'outer;
                            }
                        }
                    );
                }
                found
            }
            Self::Cwbvh(b) => {
                let ids = &b.primitive_indices;
                !b.ray_traverse_miss(ray, |r, i| f(r, ids[i]))
            }
        }
    }

    /// Calls `f(ray, i)` for every primitive whose box the ray meets (a primitive split into
    /// several leaves comes more than once).
    #[inline(always)]
    pub fn each(&self, ray: Ray, mut f: impl FnMut(&Ray, u32)) {
        match self {
            Self::Empty => {}
            Self::Bvh2(b) => {
                let ids = &b.primitive_indices;
                b.ray_traverse_anyhit(ray, |r, i| f(r, ids[i]))
            }
            Self::Cwbvh(b) => {
                let ids = &b.primitive_indices;
                b.ray_traverse_anyhit(ray, |r, i| f(r, ids[i]))
            }
        }
    }
}
