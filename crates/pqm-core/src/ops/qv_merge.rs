//! qvMerge — quad-vertex merge (a "quad collapse" in QMS, "quad close" in
//! Kinney 1997): quad `(a, b, c, d)` disappears as its diagonal vertices `a`
//! and `c` merge into one vertex `m`. Edges `ab`/`cb` become `mb`, `ad`/`cd`
//! become `md`. Counts: V−1, E−2, F−1.
//!
//! Invariants kept (checked on the candidate patch, see
//! [`super::check_patch`]): quad-only, edge- and vertex-manifold, every quad
//! has four distinct dual chords, Euler characteristic unchanged, no new quad
//! folds over or inverts.
//!
//! Inverse: a *quad vertex split* of `m` with wings `b` and `d`: the faces of
//! `star(m)` on `c`'s side of the path `b – m – d` go back to `c`, and the
//! quad `(a, b, c, d)` is re-inserted.

use super::{check_patch, map_face, Patch, Reject};
use crate::mesh::{FaceId, Mesh};
use glam::DVec3;

/// Builds and checks the qvMerge of quad `f` along diagonal `diag` (0: the
/// quad's vertices 0 and 2 in [`Mesh::quad_vertices`] order, 1: vertices 1
/// and 3). `keep` chooses which of the two ids survives (`false`: the first,
/// `true`: the second) and `position` is where the merged vertex goes.
///
/// Returns the patch to hand to [`qv_merge`], or why it is not allowed.
pub fn can_qv_merge(
    mesh: &Mesh,
    f: FaceId,
    diag: usize,
    keep_second: bool,
    position: DVec3,
) -> Result<Patch, Reject> {
    let patch = qv_merge_patch(mesh, f, diag, keep_second, position)?;
    check_patch(mesh, &patch)?;
    Ok(patch)
}

/// The unchecked patch of a qvMerge (for scoring; commit only after
/// [`check_patch`]).
pub fn qv_merge_patch(
    mesh: &Mesh,
    f: FaceId,
    diag: usize,
    keep_second: bool,
    position: DVec3,
) -> Result<Patch, Reject> {
    let mut patch = Patch::default();
    qv_merge_patch_into(mesh, f, diag, keep_second, position, &mut patch)?;
    Ok(patch)
}

thread_local! {
    /// A face's vertex list after the merge (reused: the coarsener builds
    /// a patch for every candidate it scores).
    static BUF: std::cell::RefCell<Vec<crate::mesh::VertexId>> =
        std::cell::RefCell::new(Vec::with_capacity(8));
}

/// [`qv_merge_patch`] into `out` (cleared first, its buffers reused). On an
/// error `out` holds no usable patch.
pub fn qv_merge_patch_into(
    mesh: &Mesh,
    f: FaceId,
    diag: usize,
    keep_second: bool,
    position: DVec3,
    out: &mut Patch,
) -> Result<(), Reject> {
    BUF.with(|b| match b.try_borrow_mut() {
        Ok(mut buf) => build_into(mesh, f, diag, keep_second, position, out, &mut buf),
        Err(_) => build_into(mesh, f, diag, keep_second, position, out, &mut Vec::new()),
    })
}

fn build_into(
    mesh: &Mesh,
    f: FaceId,
    diag: usize,
    keep_second: bool,
    position: DVec3,
    patch: &mut Patch,
    buf: &mut Vec<crate::mesh::VertexId>,
) -> Result<(), Reject> {
    patch.remove.clear();
    patch.add.clear();
    patch.merged.clear();
    patch.moved.clear();
    if !mesh.is_face_alive(f) {
        return Err(Reject::NotApplicable("face is deleted"));
    }
    let q = mesh
        .quad_vertices(f)
        .ok_or(Reject::NotApplicable("face is not a quad"))?;
    let (mut keep, mut gone) = (q[diag % 2], q[diag % 2 + 2]);
    if keep_second {
        std::mem::swap(&mut keep, &mut gone);
    }
    patch.merged.push((gone, keep));
    patch.moved.push((keep, position));
    for g in mesh.vertex_faces(gone) {
        if g == f {
            continue;
        }
        map_face(mesh, g, &patch.merged, buf);
        if buf.len() != 4 || mesh.face_vertices(g).any(|v| v == keep) {
            // `keep` and `gone` share a second face: merging them pinches it.
            return Err(Reject::NotApplicable(
                "diagonal vertices share another face",
            ));
        }
        patch.remove.push(g);
        patch.add.push([buf[0], buf[1], buf[2], buf[3]]);
    }
    patch.remove.push(f);
    Ok(())
}

/// Applies a qvMerge patch accepted by [`can_qv_merge`].
pub fn qv_merge(mesh: &mut Mesh, patch: &Patch) -> Result<(), crate::mesh::MeshError> {
    super::apply_patch(mesh, patch).map(|_| ())
}
