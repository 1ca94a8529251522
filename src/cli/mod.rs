//! The commands of the `rlpt` binary, one file each; `src/main.rs` holds the
//! command line's shape, the settings render, view and bench share, and the checks
//! and notes they make before rendering.

pub(crate) mod bench;
pub(crate) mod gpus;
pub(crate) mod info;
pub(crate) mod merge;
pub(crate) mod render;
pub(crate) mod tools;
pub(crate) mod view;
