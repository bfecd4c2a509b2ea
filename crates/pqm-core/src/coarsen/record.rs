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
#[derive(Clone, Debug, PartialEq)]
pub struct StepLog {
    /// The operator.
    pub op: OpKind,
    /// Faces the step removed or rewrote, with their vertex lists before it.
    pub faces_before: Vec<(FaceId, Vec<VertexId>)>,
    /// Faces the step wrote, with their vertex lists after it; every id here
    /// is also in `faces_before` (a step never creates a face id).
    pub faces_after: Vec<(FaceId, Vec<VertexId>)>,
    /// Vertices the step deleted, with their positions before it.
    pub removed_vertices: Vec<(VertexId, DVec3)>,
    /// Vertices the step moved: `(vertex, before, after)`.
    pub moved: Vec<(VertexId, DVec3, DVec3)>,
}

impl StepLog {
    /// The log of an applied patch: its removed faces with their old vertex
    /// lists, its inserted quads with their ids.
    pub fn of_patch(
        op: OpKind,
        patch: &Patch,
        applied: &Applied,
        removed_vertices: Vec<(VertexId, DVec3)>,
        moved: Vec<(VertexId, DVec3, DVec3)>,
    ) -> StepLog {
        StepLog {
            op,
            faces_before: patch
                .remove
                .iter()
                .copied()
                .zip(applied.old_faces.iter().cloned())
                .collect(),
            faces_after: applied
                .faces
                .iter()
                .zip(&patch.add)
                .map(|(&f, q)| (f, q.to_vec()))
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
    let mut records = Vec::with_capacity(logs.len());
    for log in logs.iter().rev() {
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
            .map(|&(v, before, _)| (cv[v.idx()], before))
            .collect();
        moved.sort_by_key(|m| m.0);
        rec.moved = moved;
        let quad = |vs: &[VertexId], cv: &[u32]| -> [u32; 4] {
            let mut q = [NONE; 4];
            for (i, v) in vs.iter().take(4).enumerate() {
                q[i] = cv[v.idx()];
            }
            q
        };
        let mut appended: Vec<(FaceId, [u32; 4])> = Vec::new();
        for (f, vs) in &log.faces_before {
            let q = quad(vs, &cv);
            if log.faces_after.iter().any(|a| a.0 == *f) {
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
    let n = logs.len();
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
