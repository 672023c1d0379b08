//! The `coherent` binary's subcommands that need more than a few lines.

pub mod render;
pub mod view;
