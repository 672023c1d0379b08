//! `coherent-accel`: the traversal interface of the ray tracer (paper section 3). Scenes of
//! triangle meshes placed by instance transforms go in; first hits, all hits and occlusion
//! come out, for single rays and for packets of rays under a mask of active lanes.
//!
//! - [`Scene`], [`Mesh`], [`Instance`]: the input, validated at build time ([`AccelError`]).
//! - [`Ray1`]/[`Hit1`] and [`Rays`]/[`Hits`]: single-ray and packet queries.
//! - [`Accel`]: the interface every accelerator implements (BSP, Embree, obvhs), and
//!   [`BuildStats`].
//! - [`TriAccel`]: the projection ray-triangle test shared by the accelerators of this family,
//!   and [`edges::mesh_records`]: a mesh's records, the band beyond edges on shared ones only.
//! - [`BruteForce`]: the reference implementation for tests.
//! - [`shapes`]: mesh generators (boxes, spheres, tori, terrain) for scenes.
//!
//! With the cargo feature `fixtures`, for tests, benches and experiments only: `scenes` (the
//! generated test scenes with their views and lights), `testing` (the checks every
//! accelerator's tests share) and `workload` (the rays and timed loops of the comparisons).

pub mod aabb;
pub mod accel;
pub mod alloc_count;
pub mod brute;
pub mod edges;
pub mod error;
pub mod instance;
pub mod mesh;
pub mod packet;
pub mod ray;
pub mod scene;
#[cfg(any(test, feature = "fixtures"))]
pub mod scenes;
pub mod shapes;
#[cfg(any(test, feature = "fixtures"))]
pub mod testing;
pub mod triangle;
pub mod work;
#[cfg(any(test, feature = "fixtures"))]
pub mod workload;

pub use aabb::Aabb;
pub use accel::{Accel, BuildStats};
pub use brute::BruteForce;
pub use error::AccelError;
pub use instance::Instance;
pub use mesh::Mesh;
pub use packet::{Hits, Rays, Vec3s};
pub use ray::{Hit1, Ray1, transform_point1, transform_vector1};
pub use scene::Scene;
pub use triangle::{ALL_EDGES, EDGE_EPS, MIN_THINNESS, TriAccel};
pub use work::Work;
