//! # pqm-core
//!
//! The quad mesh core of pqm: data flows
//! `file → io (IndexedMesh) → Mesh (half-edge) → coarsener → SplitRecords`.
//!
//! * [`indexed`] — [`IndexedMesh`], the polygon soup readers produce and writers consume;
//! * [`mesh`] — [`Mesh`], the half-edge mesh with typed handles, ring iterators,
//!   local patch replacement and `validate()`.

pub mod bvh;
pub mod coarsen;
pub mod indexed;
pub mod io;
pub mod mesh;
pub mod metrics;

pub use indexed::IndexedMesh;
pub use mesh::{FaceId, HalfedgeId, Mesh, VertexId};
pub mod bridging;
pub mod ops;
pub mod pairing;
pub mod progressive;
pub mod shapes;
pub mod subdivide;
pub use progressive::{OpKind, ProgressiveMesh, SplitRecord};
pub mod attributes;
pub mod features;
pub mod qem;
pub mod remesh;
pub mod smoothing;
