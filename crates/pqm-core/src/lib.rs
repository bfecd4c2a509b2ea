//! # pqm-core
//!
//! The quad mesh core of pqm: data flows
//! `file → io (IndexedMesh) → Mesh (half-edge) → coarsener → SplitRecords`.
//!
//! * [`indexed`] — [`IndexedMesh`], the polygon soup readers produce and writers consume;
//! * [`mesh`] — [`Mesh`], the half-edge mesh with typed handles, ring iterators,
//!   local patch replacement and `validate()`.

pub mod bvh;
pub mod indexed;
pub mod mesh;
pub mod metrics;

pub use indexed::IndexedMesh;
pub use mesh::{FaceId, HalfedgeId, Mesh, VertexId};
pub mod progressive;
pub use progressive::{OpKind, ProgressiveMesh, SplitRecord};
