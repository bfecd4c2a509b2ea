//! One module per subcommand; each exposes `Args` (clap) and `run`.

pub mod coarsen;
pub mod convert;
pub mod decode;
pub mod demo;
pub mod encode;
pub mod fixtures;
pub mod info;
pub mod levels;
pub mod remesh;
pub mod stats;
pub mod view;
