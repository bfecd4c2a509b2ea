//! qeMerge — quad-edge merge with 1-ring re-meshing.
//!
//! Quads `q1 = (a, b, c, d)` and `q2 = (a, d, e, f)` share the edge `a–d`.
//! 1. **Collapse**: `b` and `f` merge into `a` (the result is called `A`),
//!    `c` and `e` into `d` (`D`). The faces beyond `bc` and `fe` become
//!    neighbours across `A–D`; the faces beyond `ab`, `fa` (at `A`) and `dc`,
//!    `de` (at `D`) each lose a vertex and become triangles.
//! 2. **Re-fan**: around `A`, the faces from one triangle `T1` to the other
//!    `T2` on the side that does not cross `A–D` — `T1, G1 … Gk, T2`, `k`
//!    quads — have an outer path `p0 … p(2k+2)` of `2k + 2` edges, and the
//!    unique all-quad fan around `A` over it is
//!    `(A, p0, p1, p2), (A, p2, p3, p4), …`: `k + 1` quads replace `k + 2`
//!    faces. The same around `D`. This is the paper's "rotate the edge shared
//!    by a triangle and a quad until two triangles meet, then join them",
//!    done in one step.
//!
//! **Crossing side.** Each endpoint's fan may instead run over the other
//! side, the one that crosses `A–D` (`shared/design/operators.md`: "also
//! legal; it is a candidate the cost can choose"): same construction, the
//! path then passes through the other endpoint. [`qe_merge_patch_with`]
//! takes the side per endpoint; the two fans must not share a face, so
//! "both crossing" (whose fans would both take the two faces on `A–D`) is
//! rejected, leaving three usable combinations.
//!
//! Net: V−4, F−4, E−8. An endpoint whose collapse makes no triangle (both of
//! its collapsing edges on the boundary) needs no re-fan; any other count, or
//! a face that degenerates further (an endpoint of valence 3), is rejected by
//! validation rather than special-cased, as `shared/design/operators.md`
//! recommends.
//!
//! Invariants kept: those of [`super::check_patch`].

use super::{check_patch, map_face, Patch, Reject};
use crate::mesh::{FaceId, HalfedgeId, Mesh, VertexId};

/// A face's vertex list after the collapse (inline up to eight vertices).
type FaceVerts = crate::mesh::smallvec_lite::Small;
use glam::DVec3;

/// The six vertices and two quads of a qeMerge across half-edge `h`:
/// `h` runs `d → a` inside `q1 = (a, b, c, d)`; its twin runs `a → d` inside
/// `q2 = (a, d, e, f)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QeSite {
    /// The quad on `h`'s side.
    pub q1: FaceId,
    /// The quad on the twin's side.
    pub q2: FaceId,
    /// `[a, b, c, d, e, f]`.
    pub v: [VertexId; 6],
}

/// Finds the qeMerge site across the edge of `h`.
pub fn qe_site(mesh: &Mesh, h: HalfedgeId) -> Result<QeSite, Reject> {
    if !mesh.is_halfedge_alive(h) {
        return Err(Reject::NotApplicable("edge is deleted"));
    }
    let t = mesh.twin(h);
    let (Some(q1), Some(q2)) = (mesh.face(h), mesh.face(t)) else {
        return Err(Reject::NotApplicable("boundary edge"));
    };
    if mesh.face_degree(q1) != 4 || mesh.face_degree(q2) != 4 {
        return Err(Reject::NotApplicable("faces are not quads"));
    }
    let a = mesh.to_vertex(h);
    let d = mesh.from_vertex(h);
    let b = mesh.to_vertex(mesh.next(h));
    let c = mesh.to_vertex(mesh.next(mesh.next(h)));
    let e = mesh.to_vertex(mesh.next(t));
    let f = mesh.to_vertex(mesh.next(mesh.next(t)));
    let v = [a, b, c, d, e, f];
    for i in 0..6 {
        if v[..i].contains(&v[i]) {
            return Err(Reject::NotApplicable(
                "the two quads share more than an edge",
            ));
        }
    }
    Ok(QeSite { q1, q2, v })
}

/// Builds and checks the qeMerge across the edge of `h` (see [`qe_site`]),
/// placing `A` at `pos_a` and `D` at `pos_d`.
pub fn can_qe_merge(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
) -> Result<Patch, Reject> {
    let patch = qe_merge_patch(mesh, h, pos_a, pos_d)?;
    check_patch(mesh, &patch)?;
    Ok(patch)
}

/// [`can_qe_merge`] with the re-fan side chosen per endpoint (see
/// [`qe_merge_patch_with`]).
pub fn can_qe_merge_with(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
    cross: [bool; 2],
) -> Result<Patch, Reject> {
    let patch = qe_merge_patch_with(mesh, h, pos_a, pos_d, cross)?;
    check_patch(mesh, &patch)?;
    Ok(patch)
}

/// The unchecked patch of a qeMerge (for scoring; commit only after
/// [`check_patch`]).
pub fn qe_merge_patch(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
) -> Result<Patch, Reject> {
    qe_merge_patch_with(mesh, h, pos_a, pos_d, [false, false])
}

/// [`qe_merge_patch`] with the re-fan side chosen per endpoint:
/// `cross[0]` re-fans `A` over the side crossing `A–D`, `cross[1]` the same
/// for `D` (`false`: the non-crossing side, the default operator). An
/// endpoint without triangles has no fan, so asking it to cross is
/// rejected (the candidate would duplicate the plain one).
pub fn qe_merge_patch_with(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
    cross: [bool; 2],
) -> Result<Patch, Reject> {
    let mut patch = Patch::default();
    qe_merge_patch_into(mesh, h, pos_a, pos_d, cross, &mut patch)?;
    Ok(patch)
}

/// Reused buffers of [`qe_merge_patch_into`] (one per thread: the
/// coarsener builds patches on every scoring thread).
#[derive(Default)]
struct Scratch {
    faces: Vec<FaceId>,
    mapped: Vec<(FaceId, FaceVerts, bool)>,
    buf: Vec<VertexId>,
    fan_old: [Vec<FaceId>; 2],
    fan_new: [Vec<[VertexId; 4]>; 2],
    deleted: Vec<FaceId>,
    refan: RefanScratch,
}

/// Reused buffers of [`refan`].
#[derive(Default)]
struct RefanScratch {
    corners: Vec<(VertexId, VertexId, usize)>,
    tris: Vec<usize>,
    chain: Vec<usize>,
    path: Vec<VertexId>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// [`qe_merge_patch_with`] into `out` (cleared first; its buffers are
/// reused, and so are per-thread working buffers: the coarsener builds a
/// patch for every candidate it scores). On an error `out` holds no usable
/// patch.
pub fn qe_merge_patch_into(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
    cross: [bool; 2],
    out: &mut Patch,
) -> Result<(), Reject> {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => build_into(mesh, h, pos_a, pos_d, cross, out, &mut s),
        // (re-entered on this thread: cannot happen, but fresh buffers
        // are always correct)
        Err(_) => build_into(mesh, h, pos_a, pos_d, cross, out, &mut Scratch::default()),
    })
}

fn build_into(
    mesh: &Mesh,
    h: HalfedgeId,
    pos_a: DVec3,
    pos_d: DVec3,
    cross: [bool; 2],
    patch: &mut Patch,
    s: &mut Scratch,
) -> Result<(), Reject> {
    patch.remove.clear();
    patch.add.clear();
    patch.merged.clear();
    patch.moved.clear();
    let site = qe_site(mesh, h)?;
    let [a, b, c, d, e, f] = site.v;
    patch
        .merged
        .extend_from_slice(&[(b, a), (f, a), (c, d), (e, d)]);
    let merged = &patch.merged;
    // Every face touching the six vertices, except the two collapsing quads.
    let faces = &mut s.faces;
    faces.clear();
    for v in site.v {
        for g in mesh.vertex_faces(v) {
            if g != site.q1 && g != site.q2 && !faces.contains(&g) {
                faces.push(g);
            }
        }
    }
    // Their vertex lists after the collapse.
    // (vertex lists inline: this runs for every re-scored candidate)
    let mapped = &mut s.mapped;
    mapped.clear();
    let buf = &mut s.buf;
    for &g in faces.iter() {
        let changed = map_face(mesh, g, merged, buf);
        if buf.len() < 3 {
            return Err(Reject::NotApplicable(
                "a face degenerates (valence-3 endpoint)",
            ));
        }
        if buf.len() == 3 && !(buf.contains(&a) ^ buf.contains(&d)) {
            return Err(Reject::NotApplicable(
                "a triangle forms away from one endpoint",
            ));
        }
        mapped.push((g, buf.iter().copied().collect(), changed));
    }
    patch.moved.extend_from_slice(&[(a, pos_a), (d, pos_d)]);
    let (fan_old, fan_new) = (&mut s.fan_old, &mut s.fan_new);
    for side in 0..2 {
        fan_old[side].clear();
        fan_new[side].clear();
    }
    for (side, (x, y)) in [(a, d), (d, a)].into_iter().enumerate() {
        refan(
            mapped,
            x,
            y,
            cross[side],
            &mut fan_old[side],
            &mut fan_new[side],
            &mut s.refan,
        )?;
    }
    // Crossing fans take the faces on A–D; two fans must not share one.
    if fan_old[0].iter().any(|g| fan_old[1].contains(g)) {
        return Err(Reject::NotApplicable("the two re-fans share a face"));
    }
    // Rewritten faces first (each keeps its id), then the fans (k + 1 new
    // quads take the ids of the first k + 1 old fan faces), then the deleted
    // faces: the last old face of each fan and the two collapsed quads.
    for (g, vs, changed) in mapped.iter() {
        if !changed || fan_old.iter().any(|fan| fan.contains(g)) {
            continue;
        }
        if vs.len() != 4 {
            return Err(Reject::NotApplicable("a non-quad remains after re-fanning"));
        }
        patch.remove.push(*g);
        patch.add.push([vs[0], vs[1], vs[2], vs[3]]);
    }
    let deleted = &mut s.deleted;
    deleted.clear();
    for side in 0..2 {
        let n_new = fan_new[side].len();
        for (i, &g) in fan_old[side].iter().enumerate() {
            if i < n_new {
                patch.remove.push(g);
            } else {
                deleted.push(g);
            }
        }
        patch.add.extend_from_slice(&fan_new[side]);
    }
    // Deletions trail, so that `remove[i]` lines up with `add[i]`.
    patch.remove.extend_from_slice(deleted);
    patch.remove.push(site.q1);
    patch.remove.push(site.q2);
    Ok(())
}

/// Re-fans the faces around `x` between its two triangles on the side that
/// does not cross edge `x–y` (`cross`: on the side that does). Appends the
/// old faces (in walk order) to `old` and the new quads to `new`. No
/// triangle at `x`: nothing to do (an error when `cross` asks for a fan).
fn refan(
    mapped: &[(FaceId, FaceVerts, bool)],
    x: VertexId,
    y: VertexId,
    cross: bool,
    old: &mut Vec<FaceId>,
    new: &mut Vec<[VertexId; 4]>,
    s: &mut RefanScratch,
) -> Result<(), Reject> {
    // Corners at x: (vertex before x, vertex after x, index into mapped).
    let corners = &mut s.corners;
    corners.clear();
    let tris = &mut s.tris;
    tris.clear();
    for (i, (_, vs, _)) in mapped.iter().enumerate() {
        if let Some(k) = vs.iter().position(|&v| v == x) {
            let n = vs.len();
            corners.push((vs[(k + n - 1) % n], vs[(k + 1) % n], i));
            if n == 3 {
                tris.push(corners.len() - 1);
            }
        }
    }
    match tris.len() {
        0 if cross => return Err(Reject::NotApplicable("no fan to cross with")),
        0 => return Ok(()),
        2 => {}
        _ => return Err(Reject::NotApplicable("odd triangle count at an endpoint")),
    }
    // Walk forward (corner A → B when A.after == B.before) from one triangle
    // to the other; the walk must step across edge x–y exactly when `cross`
    // (going round x, it does so at most once).
    let corners = &*corners;
    let walk = |from: usize, to: usize, chain: &mut Vec<usize>| -> bool {
        chain.clear();
        chain.push(from);
        let mut cur = from;
        let mut crossed = false;
        while cur != to {
            if corners[cur].1 == y {
                if !cross {
                    return false;
                }
                crossed = true;
            }
            let Some(next) = corners.iter().position(|c| c.0 == corners[cur].1) else {
                return false;
            };
            if chain.contains(&next) {
                return false;
            }
            chain.push(next);
            cur = next;
        }
        crossed == cross
    };
    let chain = &mut s.chain;
    if !walk(tris[0], tris[1], chain) && !walk(tris[1], tris[0], chain) {
        return Err(Reject::NotApplicable(if cross {
            "no re-fan side crosses the merged edge"
        } else {
            "no re-fan side avoids the merged edge"
        }));
    }
    // Outer path in walk order: each face contributes its link from the
    // vertex before x to the vertex after x (reverse of its ccw order).
    let path = &mut s.path;
    path.clear();
    for &ci in chain.iter() {
        let vs = &mapped[corners[ci].2].1;
        let n = vs.len();
        let k = vs.iter().position(|&v| v == x).unwrap_or(0);
        for j in (1..n).rev() {
            let v = vs[(k + j) % n];
            if path.last() != Some(&v) {
                path.push(v);
            }
        }
        if mapped[corners[ci].2].1.len() > 4 {
            return Err(Reject::NotApplicable("a fan face is not a quad"));
        }
    }
    if path.len().is_multiple_of(2) || path.len() < 3 {
        return Err(Reject::NotApplicable("fan path has odd length"));
    }
    for i in (0..path.len() - 2).step_by(2) {
        new.push([x, path[i + 2], path[i + 1], path[i]]);
    }
    old.extend(chain.iter().map(|&ci| mapped[corners[ci].2].0));
    Ok(())
}

/// Applies a qeMerge patch accepted by [`can_qe_merge`].
pub fn qe_merge(mesh: &mut Mesh, patch: &Patch) -> Result<(), crate::mesh::MeshError> {
    super::apply_patch(mesh, patch).map(|_| ())
}
