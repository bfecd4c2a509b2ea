//! Mesh statistics for the CLI (`pqm stats`, `--stats`): the figures of
//! `pqm_core::metrics` (the qCoarsen paper's Table 1 columns).

pub use pqm_core::metrics::{mesh_stats, MeshStats};
