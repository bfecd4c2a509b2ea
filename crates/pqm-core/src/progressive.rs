//! Progressive quad mesh in canonical numbering: a base (coarsest) mesh plus
//! split records in refinement order (coarse → fine), Hoppe-style.
//!
//! # Canonical numbering (what every decoder reproduces, id for id)
//! * **Vertices**: the base mesh has vertices `0..base.vertex_count()`. Each
//!   record appends its `new_vertices` at the end, in order, so vertex ids are
//!   never reused and the vertex array only grows while refining.
//! * **Face slots**: the base mesh has faces `0..base.face_count()`. A record
//!   first *rewrites* the slots it names (`rewritten`, new vertex lists), then
//!   *appends* `appended_faces` at the end. Coarsening back undoes exactly that
//!   (truncate, restore the old contents). A quad keeps its slot for as long as
//!   it exists, which is what lets a renderer update sub-ranges of its buffers.
//! * **Positions**: a record may move existing vertices (`moved`), for example
//!   the merged vertex of a qvMerge going back to where one of its parents was.
//!
//! Applying records `0..k` to the base gives level `k`; level `records.len()`
//! is the finest mesh (the coarsener's input, vertices permuted by
//! `vertex_order`).

use crate::indexed::IndexedMesh;
use glam::DVec3;

/// Which coarsening step a record undoes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OpKind {
    /// Inverse of a quad-vertex merge (a quad vertex split).
    QvMerge = 0,
    /// Inverse of a quad-edge merge with 1-ring re-meshing.
    QeMerge = 1,
    /// Inverse of a doublet removal.
    Doublet = 2,
    /// Inverse of smoothing: moves vertices only.
    Smooth = 3,
}

/// One refinement step in canonical numbering (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SplitRecord {
    /// The coarsening operator this record undoes.
    pub op: OpKind,
    /// Positions of the vertices this record appends (ids `n, n+1, …` where
    /// `n` is the vertex count before the record).
    pub new_vertices: Vec<DVec3>,
    /// Existing vertices that move: `(vertex id, position after refinement)`.
    pub moved: Vec<(u32, DVec3)>,
    /// Face slots whose vertex list changes: `(slot, new quad)`; slots ascending.
    pub rewritten: Vec<(u32, [u32; 4])>,
    /// Quads appended at the end of the face array.
    pub appended_faces: Vec<[u32; 4]>,
}

/// A base mesh plus refinement records (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProgressiveMesh {
    /// The coarsest level, quad-only, in canonical numbering.
    pub base: IndexedMesh,
    /// Refinement records, coarse → fine.
    pub records: Vec<SplitRecord>,
    /// Canonical vertex id → vertex index in the coarsener's input, for the
    /// finest level (lets a writer restore the input's vertex order).
    pub vertex_order: Vec<u32>,
    /// Geometric error bound of each level, `records.len() + 1` entries
    /// (index k = level k), non-increasing with k, in units of the input's
    /// bounding-box diagonal. Level `records.len()` has error 0.
    pub level_error: Vec<f64>,
}
