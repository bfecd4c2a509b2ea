//! Step logs and their conversion to canonical split records.
//!
//! While coarsening, every committed step (qvMerge, qeMerge, doublet removal,
//! smoothing) is logged in the coarsener's own ids (which never get reused,
//! so a log is unambiguous). [`to_progressive`] then replays the logs in
//! reverse — coarse to fine — and assigns the canonical numbering of
//! [`crate::progressive`]: base vertices and faces in id order, each record's
//! re-inserted vertices appended, each face kept at its slot.

use crate::indexed::IndexedMesh;
use crate::mesh::{FaceId, Mesh, VertexId};
use crate::ops::{Applied, Patch};
use crate::progressive::{OpKind, ProgressiveMesh, SplitRecord};
use glam::DVec3;

/// One committed coarsening step, in the coarsener's ids.
///
/// Kept for every step until [`to_progressive`] runs, so it stores only what
/// the records need, compactly (one allocation per list, quads inline).
#[derive(Clone, Debug, PartialEq)]
pub struct StepLog {
    /// The operator.
    pub op: OpKind,
    /// Faces the step removed or rewrote, with their vertex lists before it
    /// (a face of fewer than four vertices is padded with
    /// `VertexId(u32::MAX)`; a longer one keeps its first four, all a record
    /// can hold).
    pub faces_before: Vec<(FaceId, [VertexId; 4])>,
    /// Faces the step wrote (a step never creates a face id: every id here
    /// is also in `faces_before`).
    pub faces_after: Vec<FaceId>,
    /// Vertices the step deleted, with their positions before it.
    pub removed_vertices: Vec<(VertexId, DVec3)>,
    /// Vertices the step moved, with their positions before it.
    pub moved: Vec<(VertexId, DVec3)>,
}

/// The first four vertices of a face, padded with `VertexId(u32::MAX)`.
fn quad_of(vs: &[VertexId]) -> [VertexId; 4] {
    let mut q = [VertexId(NONE); 4];
    for (i, &v) in vs.iter().take(4).enumerate() {
        q[i] = v;
    }
    q
}

impl StepLog {
    /// The log of an applied patch: its removed faces with their old vertex
    /// lists, the ids of its inserted quads.
    pub fn of_patch(
        op: OpKind,
        patch: &Patch,
        applied: &Applied,
        removed_vertices: Vec<(VertexId, DVec3)>,
        moved: Vec<(VertexId, DVec3)>,
    ) -> StepLog {
        StepLog {
            op,
            faces_before: patch
                .remove
                .iter()
                .copied()
                .zip(applied.old_faces.iter().map(|vs| quad_of(vs)))
                .collect(),
            faces_after: applied
                .faces
                .iter()
                .take(patch.add.len())
                .copied()
                .collect(),
            removed_vertices,
            moved,
        }
    }
}

const NONE: u32 = u32::MAX;

/// Builds the progressive mesh from the coarsest mesh and the logs (in
/// coarsening order). `errors[s]` is the error bound after `s` steps
/// (`logs.len() + 1` entries).
pub fn to_progressive(coarsest: &Mesh, logs: &[StepLog], errors: &[f64]) -> ProgressiveMesh {
    build(coarsest, logs.len(), logs.iter().rev(), errors)
}

/// [`to_progressive`] that consumes the logs and frees each one as soon as
/// its record is built, so the logs and the records are not both held in
/// full (the same result).
pub fn into_progressive(
    coarsest: &Mesh,
    mut logs: Vec<StepLog>,
    errors: &[f64],
) -> ProgressiveMesh {
    let n = logs.len();
    let fine_to_coarse = std::iter::from_fn(move || {
        let log = logs.pop();
        // the log array itself shrinks as it empties
        if logs.len() < logs.capacity() / 4 {
            logs.shrink_to_fit();
        }
        log
    });
    build(coarsest, n, fine_to_coarse, errors)
}

/// Replays `n` logs given last-logged first (coarse → fine).
fn build<L: std::borrow::Borrow<StepLog>>(
    coarsest: &Mesh,
    n: usize,
    coarse_to_fine: impl Iterator<Item = L>,
    errors: &[f64],
) -> ProgressiveMesh {
    let mut cv = vec![NONE; coarsest.vertex_capacity()];
    let mut cf = vec![NONE; coarsest.face_capacity()];
    let mut base = IndexedMesh::new();
    let mut vertex_order = Vec::with_capacity(coarsest.vertex_capacity());
    for v in coarsest.vertices() {
        cv[v.idx()] = base.positions.len() as u32;
        vertex_order.push(v.0);
        base.positions.push(coarsest.position(v));
    }
    let mut buf = Vec::with_capacity(4);
    for f in coarsest.faces() {
        cf[f.idx()] = base.face_count() as u32;
        buf.clear();
        buf.extend(coarsest.face_vertices(f).map(|v| cv[v.idx()]));
        base.push_face(&buf);
    }
    let mut n_faces = base.face_count() as u32;
    let mut records = Vec::with_capacity(n);
    for log in coarse_to_fine {
        let log = log.borrow();
        let mut rec = SplitRecord {
            op: log.op,
            new_vertices: Vec::new(),
            moved: Vec::new(),
            rewritten: Vec::new(),
            appended_faces: Vec::new(),
        };
        let mut removed = log.removed_vertices.clone();
        removed.sort_by_key(|r| r.0);
        for (v, p) in removed {
            cv[v.idx()] = vertex_order.len() as u32;
            vertex_order.push(v.0);
            rec.new_vertices.push(p);
        }
        let mut moved: Vec<(u32, DVec3)> = log
            .moved
            .iter()
            .map(|&(v, before)| (cv[v.idx()], before))
            .collect();
        moved.sort_by_key(|m| m.0);
        rec.moved = moved;
        let quad = |vs: &[VertexId; 4], cv: &[u32]| -> [u32; 4] {
            vs.map(|v| if v.0 == NONE { NONE } else { cv[v.idx()] })
        };
        let mut appended: Vec<(FaceId, [u32; 4])> = Vec::new();
        for (f, vs) in &log.faces_before {
            let q = quad(vs, &cv);
            if log.faces_after.contains(f) {
                rec.rewritten.push((cf[f.idx()], q));
            } else {
                appended.push((*f, q));
            }
        }
        rec.rewritten.sort_by_key(|r| r.0);
        appended.sort_by_key(|a| a.0);
        for (f, q) in appended {
            cf[f.idx()] = n_faces;
            n_faces += 1;
            rec.appended_faces.push(q);
        }
        records.push(rec);
    }
    let level_error = (0..=n)
        .map(|k| errors.get(n - k).copied().unwrap_or(0.0))
        .collect();
    ProgressiveMesh {
        base,
        records,
        vertex_order,
        level_error,
    }
}
