//! Doublet removal: two quads `(v, a, x, b)` and `(v, b, y, a)` share the two
//! edges `va` and `vb`, so interior vertex `v` has valence 2 (a degenerate
//! dual polygon). Both quads are replaced by `(a, x, b, y)`; `v` disappears.
//! Counts: V−1, E−2, F−1. The coarsener runs it after every qeMerge/qvMerge
//! until no doublet is left, each removal its own record.
//!
//! Inverse: split quad `(a, x, b, y)` along its diagonal `a–b` with a new
//! vertex `v` at its old position.

use super::{Patch, Reject};
use crate::mesh::{Mesh, VertexId};

/// Builds and checks the removal of the doublet at `v`.
pub fn can_remove_doublet(mesh: &Mesh, v: VertexId) -> Result<Patch, Reject> {
    if !mesh.is_vertex_alive(v) || mesh.is_boundary_vertex(v) {
        return Err(Reject::NotApplicable("not an interior vertex"));
    }
    let hs: Vec<_> = mesh.outgoing(v).take(3).collect();
    if hs.len() != 2 {
        return Err(Reject::NotApplicable("vertex valence is not 2"));
    }
    let (Some(f1), Some(f2)) = (mesh.face(hs[0]), mesh.face(hs[1])) else {
        return Err(Reject::NotApplicable("doublet faces missing"));
    };
    let (Some(q1), Some(q2)) = (mesh.quad_vertices(f1), mesh.quad_vertices(f2)) else {
        return Err(Reject::NotApplicable("doublet faces are not quads"));
    };
    let rot = |q: [VertexId; 4]| {
        let k = q.iter().position(|&x| x == v).unwrap_or(0);
        [q[k], q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]]
    };
    // q1 = (v, a, x, b), q2 = (v, b, y, a)
    let (q1, q2) = (rot(q1), rot(q2));
    if q1[1] != q2[3] || q1[3] != q2[1] || q1[2] == q2[2] {
        return Err(Reject::NotApplicable("not a doublet"));
    }
    let (a, x, b, y) = (q1[1], q1[2], q1[3], q2[2]);
    // `v` merges into `x` (a qvMerge of the first quad that keeps x's place).
    let patch = Patch {
        remove: vec![f1, f2],
        add: vec![[a, x, b, y]],
        merged: vec![(v, x)],
        moved: Vec::new(),
    };
    // Topology only: a doublet is degenerate whatever its shape, so it goes
    // even when the merged quad is poor (smoothing repairs the shape).
    mesh.can_replace_patch(&patch.remove, &patch.add)
        .map_err(Reject::Invalid)?;
    Ok(patch)
}

/// Applies a doublet removal accepted by [`can_remove_doublet`].
pub fn remove_doublet(mesh: &mut Mesh, patch: &Patch) -> Result<(), crate::mesh::MeshError> {
    super::apply_patch(mesh, patch).map(|_| ())
}

/// Interior vertices of valence 2 among `candidates` (sorted, deduplicated).
pub fn find_doublets(mesh: &Mesh, candidates: &[VertexId]) -> Vec<VertexId> {
    let mut out: Vec<VertexId> = candidates
        .iter()
        .copied()
        .filter(|&v| mesh.is_vertex_alive(v) && !mesh.is_boundary_vertex(v) && mesh.valence(v) == 2)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}
