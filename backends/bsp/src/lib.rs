//! `coherent-bsp`: the paper's two-level BSP (section 3) with packet and single-ray
//! traversal.
//!
//! - Object level: a surface-area-heuristic kd-tree per mesh, built in O(N log N) with sorted
//!   split events and perfect splits (Wald & Havran 2006; Havran's thesis), [`build_sah`],
//!   with parameters and presets in [`SahParams`]; or, with [`BuildPreset::Fast`], binned SAH
//!   above a node size and that sweep below, subtrees built in parallel ([`build_binned`]).
//!   With [`BuildPreset::Binned`], binned SAH at every level on flat reference arrays,
//!   parallel at both scales ([`build_flat`]).
//!   All make leaves rather than pass a reference budget ([`SahParams::max_refs_per_tri`]).
//! - Top level: a binned-SAH kd-tree over the instances' world boxes, [`build_top`], rebuilt
//!   by [`coherent_accel::Accel::set_instances`] without touching the mesh trees.
//! - 8-byte [`Node`]s with both children adjacent; triangles as projection-test records
//!   ([`coherent_accel::TriAccel`]); degenerate triangles dropped and counted.
//! - Traversal: single-ray (`walk1`) with a per-ray intersection cache, and packets (`walk`)
//!   near/far with a stack and masks (lanes of mixed direction signs together, or per sign
//!   group as in the paper: [`BspParams::mixed_signs`]), switching to single rays
//!   below a threshold of active lanes ([`BspParams::single_ray_threshold`]). Single rays
//!   may test a leaf's triangles four at a time ([`BspParams::simd_leaves`], [`Leaves4`]),
//!   on leaves priced per four triangles ([`SahParams::leaf_group`]).
//!
//! Built and queried through [`coherent_accel::Accel`], like every accelerator:
//!
//! ```
//! use coherent_accel::{Accel, Mesh, Ray1, Rays, Scene};
//! use coherent_bsp::{Bsp, BspParams};
//! use coherent_simd::{Lanes, scalar::Scalar};
//! use glam::Vec3;
//!
//! // A square at z = 0, two triangles.
//! let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
//! let square = Mesh::new(
//!     "square",
//!     corners.map(|(x, y)| Vec3::new(x, y, 0.0)).to_vec(),
//!     vec![[0, 1, 2], [0, 2, 3]],
//! );
//! let bsp = Bsp::build(&Scene::single(square), &BspParams::default())?;
//!
//! // One ray at a time: the first hit, and whether anything is in the way.
//! let down = Ray1::new(Vec3::new(0.5, 0.2, 3.0), -Vec3::Z, 0.0, f32::INFINITY);
//! let hit = bsp.intersect1(&down).expect("the ray meets the square");
//! assert!((hit.t - 3.0).abs() < 1e-5);
//! assert!(bsp.occluded1(&down));
//!
//! // A packet of rays under a mask of active lanes, on any lane backend (here the scalar
//! // one's single lane; `coherent_simd::Backend::run` picks one at run time).
//! let l = Scalar;
//! let rays = Rays::from_fn(l, |_| down);
//! let hits = bsp.intersect(l, &rays, l.splat_mask(true));
//! assert_eq!(hits.lane(0), Some(hit));
//! # Ok::<(), coherent_accel::AccelError>(())
//! ```

mod beam;
mod bsp;
mod build_binned;
mod build_flat;
mod build_sah;
mod build_top;
mod clip;
mod counters;
mod frustum;
mod group;
mod leaf4;
mod mailbox;
mod node;
mod params;
mod query;
mod reverse;
mod stack;
mod tree;
mod walk;
mod walk1;

pub use bsp::{Bsp, MeshTree};
pub use build_binned::{PARALLEL_MIN, build_binned};
pub use build_flat::build_flat;
pub use build_sah::build_sah;
pub use build_top::build_top;
pub use clip::clipped_bounds;
pub use counters::TraversalStats;
pub use leaf4::{Leaves4, Tri4};
pub use node::{MAX_CHILD, MAX_INDEX, Node};
pub use params::{
    BspParams, BuildPreset, MAX_BINS, MAX_TREE_DEPTH, SahParams, TopParams,
    default_single_ray_threshold,
};
pub use tree::{KdTree, TreeStats};
