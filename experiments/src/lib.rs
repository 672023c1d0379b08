//! The experiments of `reproduce`.
