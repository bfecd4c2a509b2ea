//! `pqm`: progressive quad meshes.
//!
//! This facade re-exports the workspace crates so that cross-crate tests in
//! `tests/` (and users who want one dependency) can reach everything:
//!
//! * [`core`] — the quad mesh, I/O, operators, coarsener and metrics;
//! * [`mod@format`] — the `.pqm` writer, reader and streaming decoder.
pub use pqm_core as core;
pub use pqm_format as format;
