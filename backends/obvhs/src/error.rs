//! What can go wrong building an obvhs scene, each error naming the mesh or instance.

/// An obvhs backend error.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ObvhsError {
    /// A mesh cannot be built.
    #[error("mesh {mesh}: {problem}")]
    InvalidMesh { mesh: usize, problem: String },
    /// An instance cannot be placed.
    #[error("instance {instance}: {problem}")]
    InvalidInstance { instance: usize, problem: String },
}
