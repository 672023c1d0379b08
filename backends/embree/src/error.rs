//! What can go wrong with the Embree backend, each error naming its cause and its fix.

/// An Embree backend error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmbreeError {
    /// No Embree 4 library could be loaded.
    #[error(
        "no usable Embree 4 library (tried {tried}); fix: run `python3 scripts/native.py` \
         (fetches the pinned Embree 4.4 into .native/), or set EMBREE_DIR to an Embree 4 \
         install, or build without the `embree` feature"
    )]
    NotFound { tried: String },
    /// This target has no Embree 4 in the registries the native set-up fetches from, and
    /// `EMBREE_DIR` names none.
    #[error(
        "no Embree 4 library for {target}: the registries the project fetches from have none \
         (PyPI's embreex has x86-64 wheels only; Debian's {target} packages have Embree 3.13); \
         fix: build Embree 4 for this machine and set EMBREE_DIR to its install, or build \
         without the `embree` feature"
    )]
    NotForTarget { target: &'static str },
    /// A library was found but is not an Embree 4 this backend can use.
    #[error(
        "the Embree library {path} is not usable: {why}; fix: delete .native/embree and run \
         `python3 scripts/native.py`, or point EMBREE_DIR at an Embree 4 install"
    )]
    Unusable { path: String, why: String },
    /// Embree reported an error from a call.
    #[error("Embree failed to {what}: {code}")]
    Call { what: &'static str, code: String },
    /// The scene is not valid input (names the mesh or instance).
    #[error(transparent)]
    Scene(#[from] coherent_accel::AccelError),
}

impl From<EmbreeError> for coherent_accel::AccelError {
    fn from(e: EmbreeError) -> Self {
        match e {
            EmbreeError::Scene(e) => e,
            other => Self::Unavailable {
                accel: "embree",
                reason: other.to_string(),
            },
        }
    }
}
