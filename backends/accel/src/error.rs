//! Build-time errors of every acceleration structure: bad meshes, bad instances (paper
//! section 3: the scene is a set of meshes placed by transforms).

/// What is wrong with the input of an acceleration-structure build. Every variant names the
/// mesh (index and name) or the instance it is about.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AccelError {
    /// A triangle refers to a vertex the mesh does not have.
    #[error(
        "mesh {mesh} ('{name}'): triangle {tri} refers to vertex {index}, but the mesh has {len} positions"
    )]
    IndexOutOfRange {
        mesh: usize,
        name: String,
        tri: usize,
        index: u32,
        len: usize,
    },
    /// A vertex position is NaN or infinite.
    #[error("mesh {mesh} ('{name}'): position {index} is not finite: {value:?}")]
    NonFinitePosition {
        mesh: usize,
        name: String,
        index: usize,
        value: [f32; 3],
    },
    /// A mesh without triangles or without positions.
    #[error("mesh {mesh} ('{name}') is empty: {positions} positions, {triangles} triangles")]
    EmptyMesh {
        mesh: usize,
        name: String,
        positions: usize,
        triangles: usize,
    },
    /// More triangles or vertices than the 32-bit (or 30-bit node) indices can address.
    #[error("mesh {mesh} ('{name}') is too large: {what}")]
    TooLarge {
        mesh: usize,
        name: String,
        what: String,
    },
    /// An instance names a mesh the scene does not have.
    #[error("instance {instance}: mesh id {mesh} is out of range (the scene has {meshes} meshes)")]
    MeshOutOfRange {
        instance: usize,
        mesh: usize,
        meshes: usize,
    },
    /// An instance transform that cannot be inverted (or is not finite).
    #[error(
        "instance {instance} (mesh {mesh}): world_from_object is singular or not finite (determinant {det:e})"
    )]
    SingularTransform {
        instance: usize,
        mesh: usize,
        det: f32,
    },
    /// More instances than 32-bit indices can address.
    #[error("too many instances: {count}")]
    TooManyInstances { count: usize },
    /// The accelerator cannot run here (a native library missing, an unsupported CPU); the
    /// reason names the cause and the fix. The other accelerators are unaffected.
    #[error("accelerator {accel} is unavailable: {reason}")]
    Unavailable { accel: &'static str, reason: String },
}
