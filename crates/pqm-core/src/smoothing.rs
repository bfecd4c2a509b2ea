//! The centroidal, importance-weighted tangential smoothing of qCoarsen
//! (paper §4, "Geometric Fidelity and Element Quality").
//!
//! For a vertex `v` with faces `q_i` around it — centroids `c_i`, unit
//! normals `n_i` and importance `a_i` (the mean of the face's vertices'
//! importance) — the smoothed point is `ṽ = Σ a_i c_i / Σ a_i`, projected
//! onto the tangent plane through `v` with normal `Σ n_i` (normalised), so
//! the vertex slides along the surface instead of shrinking it. Weighting by
//! importance pulls vertices towards important faces, which keeps those
//! faces small.
//!
//! Iterations are Jacobi style: every listed vertex moves from the positions
//! of the previous iteration, so the result does not depend on the order of
//! the list. Which vertices may move is the caller's choice
//! ([`default_movable`] pins boundary and feature vertices).
//!
//! Parameters shared by the functions here:
//! * `importance` — per vertex id, the importance map (`[1, 3]` by
//!   convention). An empty slice means uniform importance; an entry that is
//!   missing, non-finite or not positive counts as 1.
//! * `movable` — per vertex id, whether the vertex may move. An id beyond
//!   the slice, or a deleted vertex, does not move.

use crate::features::FeatureCurves;
use crate::mesh::{FaceId, Mesh, VertexId};
use glam::DVec3;

/// `movable` for the smoothing functions: every live vertex except boundary
/// vertices and, when `features` is given, feature vertices.
pub fn default_movable(mesh: &Mesh, features: Option<&FeatureCurves>) -> Vec<bool> {
    let mut out = vec![false; mesh.vertex_capacity()];
    for v in mesh.vertices() {
        out[v.idx()] =
            !mesh.is_boundary_vertex(v) && !features.is_some_and(|f| f.is_feature_vertex(v));
    }
    out
}

#[inline]
fn weight(importance: &[f64], v: VertexId) -> f64 {
    match importance.get(v.idx()) {
        Some(&a) if a.is_finite() && a > 0.0 => a,
        _ => 1.0,
    }
}

/// What face `f` adds to the smoothed position of each of its corners:
/// `(c·a, a, n̂)` — its centroid times its importance `a` (the mean of its
/// corners'), `a`, and its unit Newell normal, all from the positions read
/// through `pos`; `None` for a face without corners. Written once for
/// [`smoothed_position`] and [`smoothed_positions`], so both reach the same
/// bits.
#[inline]
fn face_term(
    mesh: &Mesh,
    importance: &[f64],
    f: FaceId,
    pos: &impl Fn(VertexId) -> DVec3,
) -> Option<(DVec3, f64, DVec3)> {
    let (mut c, mut a, mut k) = (DVec3::ZERO, 0.0, 0usize);
    // Newell normal from the current positions
    let mut n = DVec3::ZERO;
    if let Some(q) = mesh.quad_vertices(f) {
        // a quad (the coarsener's every face): the loop below with its
        // corners at hand, in the same order, so the same bits (the walk of
        // the face loop cost as much as the arithmetic)
        let p = q.map(pos);
        let mut prev = p[3];
        for i in 0..4 {
            n += prev.cross(p[i]);
            prev = p[i];
            c += p[i];
            a += weight(importance, q[i]);
        }
        k = 4;
    } else {
        let h0 = mesh.face_halfedge(f);
        let mut prev = pos(mesh.from_vertex(h0));
        for h in mesh.face_halfedges(f) {
            let u = mesh.to_vertex(h);
            let p = pos(u);
            n += prev.cross(p);
            prev = p;
            c += p;
            a += weight(importance, u);
            k += 1;
        }
    }
    if k == 0 {
        return None;
    }
    let (c, a) = (c / k as f64, a / k as f64);
    Some((c * a, a, n.normalize_or_zero()))
}

/// The smoothed point of `v` from the sums of its faces' [`face_term`]s.
#[inline]
fn smoothed_from(csum: DVec3, wsum: f64, nsum: DVec3, p: DVec3) -> Option<DVec3> {
    let n = nsum.normalize_or_zero();
    if wsum.is_nan() || wsum <= 0.0 || n == DVec3::ZERO {
        return None;
    }
    let target = csum / wsum;
    let moved = target - n * n.dot(target - p);
    moved.is_finite().then_some(moved)
}

/// The smoothed position of `v` (see the module docs), reading positions
/// through `pos`; `None` when `v` has no face or no usable normal.
/// Allocation-free.
pub fn smoothed_position(
    mesh: &Mesh,
    importance: &[f64],
    v: VertexId,
    pos: impl Fn(VertexId) -> DVec3,
) -> Option<DVec3> {
    let mut wsum = 0.0;
    let mut csum = DVec3::ZERO;
    let mut nsum = DVec3::ZERO;
    for f in mesh.vertex_faces(v) {
        if let Some((ca, a, n)) = face_term(mesh, importance, f, &pos) {
            csum += ca;
            wsum += a;
            nsum += n;
        }
    }
    smoothed_from(csum, wsum, nsum, pos(v))
}

/// The faces around a list of vertices, each once, with each vertex's
/// faces as indices into that list (in [`Mesh::vertex_faces`] order), for
/// [`FaceStars::smoothed`]: a local relaxation smooths the same few dozen
/// vertices for several iterations on an unchanged topology, and each face
/// around them is around up to four of them.
pub struct FaceStars {
    faces: Vec<FaceId>,
    star: Vec<u32>,
    /// End of each listed vertex's indices in `star`.
    ends: Vec<u32>,
}

impl FaceStars {
    /// The stars of `vs` in `mesh` (valid while its topology is unchanged).
    pub fn new(mesh: &Mesh, vs: &[VertexId]) -> FaceStars {
        let mut faces: Vec<FaceId> = Vec::with_capacity(2 * vs.len() + 8);
        let mut star = Vec::with_capacity(5 * vs.len());
        let mut ends = Vec::with_capacity(vs.len());
        for &v in vs {
            for f in mesh.vertex_faces(v) {
                let i = match faces.iter().position(|&g| g == f) {
                    Some(i) => i,
                    None => {
                        faces.push(f);
                        faces.len() - 1
                    }
                };
                star.push(i as u32);
            }
            ends.push(star.len() as u32);
        }
        FaceStars { faces, star, ends }
    }

    /// [`smoothed_position`] of each vertex the stars were made for (same
    /// list, same order) into `out`, from the mesh's positions: the same
    /// values, with each face evaluated once (`terms` is working space).
    pub fn smoothed(
        &self,
        mesh: &Mesh,
        importance: &[f64],
        vs: &[VertexId],
        terms: &mut Vec<Option<(DVec3, f64, DVec3)>>,
        out: &mut Vec<Option<DVec3>>,
    ) {
        let pos = |u: VertexId| mesh.position(u);
        terms.clear();
        terms.extend(
            self.faces
                .iter()
                .map(|&f| face_term(mesh, importance, f, &pos)),
        );
        out.clear();
        let mut lo = 0;
        for (&v, &hi) in vs.iter().zip(&self.ends) {
            let mut wsum = 0.0;
            let mut csum = DVec3::ZERO;
            let mut nsum = DVec3::ZERO;
            for &i in &self.star[lo..hi as usize] {
                if let Some((ca, a, n)) = terms[i as usize] {
                    csum += ca;
                    wsum += a;
                    nsum += n;
                }
            }
            lo = hi as usize;
            out.push(smoothed_from(csum, wsum, nsum, pos(v)));
        }
    }
}

/// Smooths the listed vertices for `iterations` Jacobi iterations without
/// touching the mesh, and returns their new positions in list order
/// (duplicates in the list are returned once, at their first place;
/// vertices that may not move are left out). Positions of unlisted vertices
/// are read from the mesh and stay fixed. Costs O(listed vertices × their
/// ring sizes × iterations) plus a sort of the list; it allocates only the
/// returned vector and one working copy of the listed positions.
pub fn smooth_vertices(
    mesh: &Mesh,
    importance: &[f64],
    movable: &[bool],
    vertices: &[VertexId],
    iterations: u32,
) -> Vec<(VertexId, DVec3)> {
    let can_move =
        |v: VertexId| mesh.is_vertex_alive(v) && movable.get(v.idx()).copied().unwrap_or(false);
    // working set sorted by id for lookups, plus first-appearance order
    let mut work: Vec<(VertexId, DVec3)> = vertices
        .iter()
        .copied()
        .filter(|&v| can_move(v))
        .map(|v| (v, mesh.position(v)))
        .collect();
    work.sort_unstable_by_key(|e| e.0);
    work.dedup_by_key(|e| e.0);
    let mut next = work.clone();
    for _ in 0..iterations {
        {
            let cur = &work;
            let pos = |u: VertexId| match cur.binary_search_by_key(&u, |e| e.0) {
                Ok(i) => cur[i].1,
                Err(_) => mesh.position(u),
            };
            for (i, &(v, p)) in cur.iter().enumerate() {
                next[i] = (v, smoothed_position(mesh, importance, v, pos).unwrap_or(p));
            }
        }
        std::mem::swap(&mut work, &mut next);
    }
    let mut taken = vec![false; work.len()];
    let mut out = Vec::with_capacity(work.len());
    for &v in vertices {
        if let Ok(i) = work.binary_search_by_key(&v, |e| e.0) {
            if !taken[i] {
                taken[i] = true;
                out.push(work[i]);
            }
        }
    }
    out
}

/// Smooths every movable live vertex of `mesh` in place for `iterations`
/// Jacobi iterations. O(F × iterations); allocates two position arrays.
pub fn smooth_global(mesh: &mut Mesh, importance: &[f64], movable: &[bool], iterations: u32) {
    let mut cur: Vec<DVec3> = mesh.positions().to_vec();
    let mut next = cur.clone();
    let list: Vec<VertexId> = mesh
        .vertices()
        .filter(|v| movable.get(v.idx()).copied().unwrap_or(false))
        .collect();
    for _ in 0..iterations {
        {
            let m: &Mesh = mesh;
            let c = &cur;
            let pos = |u: VertexId| c[u.idx()];
            for &v in &list {
                next[v.idx()] = smoothed_position(m, importance, v, pos).unwrap_or(c[v.idx()]);
            }
        }
        std::mem::swap(&mut cur, &mut next);
    }
    for &v in &list {
        mesh.set_position(v, cur[v.idx()]);
    }
}
