//! The qCoarsen deletion operators as check/act pairs (PMP style).
//!
//! Every operator is first built as a [`Patch`] — "remove these faces, insert
//! those quads, merge these vertices" — without touching the mesh. The check
//! half (`can_qv_merge`, `can_qe_merge`, `can_remove_doublet`) builds and
//! validates the patch *before* anything is committed; the act half applies a
//! checked patch with [`apply_patch`]. This is what lets the coarsener score a
//! candidate (valences after, moved distance, alignment) on the exact result
//! it would commit, and what makes every step a recordable, invertible
//! replacement.
//!
//! * [`mod@qv_merge`] — quad-vertex merge: a quad's diagonal vertices merge.
//! * [`mod@qe_merge`] — quad-edge merge: two adjacent quads collapse onto their
//!   shared edge, then the 1-ring of each endpoint is re-fanned into quads.
//! * [`doublet`] — doublet removal: two quads sharing two edges become one.

pub mod doublet;
pub mod qe_merge;
pub mod qv_merge;

use crate::mesh::{FaceId, Mesh, MeshError, PatchResult, VertexId};
use glam::DVec3;

pub use doublet::{can_remove_doublet, find_doublets, remove_doublet};
pub use qe_merge::{can_qe_merge, qe_merge};
pub use qv_merge::{can_qv_merge, qv_merge};

/// Why an operator cannot be applied at a place. The coarsener just skips
/// such candidates; tests assert on the reason.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Reject {
    /// The element is not (or no longer) of the shape the operator needs.
    #[error("not applicable: {0}")]
    NotApplicable(&'static str),
    /// The result would break a mesh invariant (manifold, Euler, dual chords).
    #[error("invalid result: {0}")]
    Invalid(MeshError),
    /// The result would fold over or create an inverted quad.
    #[error("geometry: {0}")]
    Geometry(&'static str),
    /// A feature curve (or boundary loop) would be pinched, split or lost.
    #[error("feature: {0}")]
    Feature(&'static str),
}

/// A local replacement, built by an operator's check half.
///
/// Applying it removes `remove` and inserts `add`: new quad `i` takes the id
/// of `remove[i]` (a rewritten face slot); removed faces past `add.len()` are
/// deleted. `merged` lists `(gone, into)` vertex merges (the gone vertex has
/// no face afterwards); `moved` gives the new position of surviving vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Patch {
    /// Faces removed (the first `add.len()` are rewritten in place).
    pub remove: Vec<FaceId>,
    /// Quads inserted, counter-clockwise.
    pub add: Vec<[VertexId; 4]>,
    /// `(gone, into)`: vertex `gone` merges into vertex `into`.
    pub merged: Vec<(VertexId, VertexId)>,
    /// `(vertex, new position)` for surviving vertices that move.
    pub moved: Vec<(VertexId, DVec3)>,
}

impl Patch {
    /// Where `v` ends up after the merges (itself when it does not merge).
    pub fn image(&self, v: VertexId) -> VertexId {
        self.merged.iter().find(|m| m.0 == v).map_or(v, |m| m.1)
    }
    /// Position of `v` after the patch.
    pub fn position_after(&self, mesh: &Mesh, v: VertexId) -> DVec3 {
        self.moved
            .iter()
            .find(|m| m.0 == v)
            .map_or_else(|| mesh.position(v), |m| m.1)
    }
}

/// Applies a patch that its operator's check half accepted. Returns what the
/// mesh did (face ids, deleted vertices).
pub fn apply_patch(mesh: &mut Mesh, patch: &Patch) -> Result<PatchResult, MeshError> {
    let res = mesh.replace_patch(&patch.remove, &patch.add)?;
    for &(v, p) in &patch.moved {
        mesh.set_position(v, p);
    }
    Ok(res)
}

/// What [`apply_undoable`] changed, enough to put it back exactly.
#[derive(Clone, Debug, Default)]
pub struct Applied {
    /// Ids of the inserted quads.
    pub faces: Vec<FaceId>,
    /// Vertex lists of the removed faces, in `Patch::remove` order.
    pub old_faces: Vec<Vec<VertexId>>,
    /// Removed faces that were deleted rather than rewritten.
    pub deleted_faces: Vec<FaceId>,
    /// Vertices deleted by the patch.
    pub removed_vertices: Vec<VertexId>,
    /// Old positions of the moved vertices.
    pub old_positions: Vec<(VertexId, DVec3)>,
}

/// Applies `patch` and returns what it takes to undo it (see [`undo`]).
pub fn apply_undoable(mesh: &mut Mesh, patch: &Patch) -> Result<Applied, MeshError> {
    let old_faces = patch
        .remove
        .iter()
        .map(|&f| mesh.face_vertices(f).collect())
        .collect();
    let old_positions = patch
        .moved
        .iter()
        .map(|&(v, _)| (v, mesh.position(v)))
        .collect();
    let res = apply_patch(mesh, patch)?;
    Ok(Applied {
        faces: res.faces,
        old_faces,
        deleted_faces: res.removed_faces,
        removed_vertices: res.removed_vertices,
        old_positions,
    })
}

/// Puts back exactly what [`apply_undoable`] changed: same face ids, same
/// vertex ids, same positions.
pub fn undo(mesh: &mut Mesh, applied: &Applied) -> Result<(), MeshError> {
    mesh.replace_patch_reviving(&applied.faces, &applied.old_faces, &applied.deleted_faces)?;
    for &(v, p) in &applied.old_positions {
        mesh.set_position(v, p);
    }
    Ok(())
}

/// Scaled Jacobian of a quad given its corner positions — exactly the
/// quality metric's [`polygon_scaled_jacobian`](crate::metrics::scaled_jacobian::polygon_scaled_jacobian)
/// (corner sine `|e1 × e2| / (|e1||e2|)`, negative where the corner turns
/// against the Newell normal). The guard must use the metric's measure: the
/// projected form `dot(e1 × e2, n) / (|e1||e2|)` used before rates a twisted,
/// non-planar corner much better (loki: −0.02 where the metric says −0.44),
/// so the guard let through quads the quality bars call inverted.
/// 1 for a square, ≤ 0 for a folded or degenerate corner.
pub fn quad_scaled_jacobian(p: [DVec3; 4]) -> f64 {
    crate::metrics::scaled_jacobian::polygon_scaled_jacobian(&p)
}

/// Unit Newell normal of a polygon (zero when degenerate).
pub fn newell_normal(p: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..p.len() {
        n += p[i].cross(p[(i + 1) % p.len()]);
    }
    n.normalize_or_zero()
}

/// Minimum Scaled Jacobian a new quad may have: a step never makes a quad
/// worse than this unless the faces it replaces were already worse.
pub const MIN_NEW_QUAD_JACOBIAN: f64 = 0.2;
/// A new face's normal may turn at most this far (cosine) from the normal
/// of what it replaces; below it counts as a fold-over.
pub const MIN_NORMAL_COSINE: f64 = 0.2;
/// Fold-over reference: the captured faces around the new face (true) or
/// the face that had its id before (false).
const LOCAL_FOLD_REFERENCE: bool = true;

/// The shared validation of every operator, run on the candidate patch
/// before anything is committed: the mesh stays edge- and vertex-manifold
/// and keeps its Euler characteristic ([`Mesh::can_replace_patch`]). Dual
/// chords and geometry are checked after the step and its doublet removals
/// and relaxation, by the coarsener (see [`GeometryGuard`]).
pub fn check_patch(mesh: &Mesh, patch: &Patch) -> Result<(), Reject> {
    mesh.can_replace_patch(&patch.remove, &patch.add)
        .map_err(Reject::Invalid)
}

/// Shape test around a step: captures the normals and Scaled Jacobians of a
/// region before the step, then checks the faces there afterwards — no face
/// folds over (its normal turns by more than `acos(MIN_NORMAL_COSINE)` from
/// the captured faces around it, on its side of a sharp crease, else from
/// the face that had its id, else from the region's average normal) and no
/// quad gets a Scaled Jacobian below `min(MIN_NEW_QUAD_JACOBIAN, worst
/// before)`.
#[derive(Clone, Debug, Default)]
pub struct GeometryGuard {
    before: Vec<(FaceId, DVec3)>,
    /// Per captured face: its vertices (`local_vs[lo..hi]`), its
    /// area-weighted normal and a mask of its vertex ids ([`vertex_mask`]).
    /// One flat vertex list, not a list per face: a commit captures ≈ 60
    /// faces, and their allocations were a tenth of its instructions.
    local: Vec<(u32, u32, DVec3, u64)>,
    local_vs: Vec<VertexId>,
    average: DVec3,
    min_sj: f64,
    /// Corner margin and least [`quad_twist`] a new quad may have (see
    /// [`GeometryGuard::with_corner_margin`]); `None`: not checked.
    twist: Option<(f64, f64)>,
    /// See [`GeometryGuard::with_creases`].
    creases: Vec<VertexId>,
}

/// How far a quad is from having a twisted corner: the least, over its
/// corners, of the projected sine (see [`quad_projected_corner_sine`])
/// minus `min(margin, s / 2)`, `s` the corner's unsigned sine. Negative at
/// a twisted corner, whose Scaled Jacobian flips sign — with a magnitude
/// near `s` — under a small move of its vertices; a straight corner (`s`
/// near 0) is not twisted: flipped, it is off by about as little as it
/// moved.
pub fn quad_twist(p: [DVec3; 4], margin: f64) -> f64 {
    let n = newell_normal(&p);
    (0..4)
        .map(|i| {
            let e1 = p[(i + 1) % 4] - p[i];
            let e2 = p[(i + 3) % 4] - p[i];
            let l = e1.length() * e2.length();
            if l <= 0.0 {
                return 0.0;
            }
            let c = e1.cross(e2);
            c.dot(n) / l - margin.min(0.5 * c.length() / l)
        })
        .fold(f64::INFINITY, f64::min)
}

/// True when [`quad_twist`] is negative.
pub fn quad_twisted(p: [DVec3; 4], margin: f64) -> bool {
    quad_twist(p, margin) < 0.0
}

/// Least projected corner sine of a quad: `(e1 × e2) · n / (|e1||e2|)` at
/// each corner, `n` the unit Newell normal — the Scaled Jacobian's corner
/// value before its sign is taken, so it is near 0 where that sign is
/// ill-conditioned: a straight corner, or a twisted (non-planar) one whose
/// cross product is nearly perpendicular to the quad's normal.
pub fn quad_projected_corner_sine(p: [DVec3; 4]) -> f64 {
    // the twist with no margin: min(0, s / 2) is 0
    quad_twist(p, 0.0)
}

impl GeometryGuard {
    /// Records the faces of `region` (live faces only) before the step.
    pub fn capture(mesh: &Mesh, region: &[FaceId]) -> Self {
        Self::capture_with(mesh, region, MIN_NEW_QUAD_JACOBIAN)
    }

    /// [`GeometryGuard::capture`] with another shape floor: new quads must
    /// have a Scaled Jacobian of at least `min(min_jacobian, worst before)`.
    pub fn capture_with(mesh: &Mesh, region: &[FaceId], min_jacobian: f64) -> Self {
        let mut g = GeometryGuard {
            min_sj: min_jacobian,
            ..Default::default()
        };
        for &f in region {
            if let Some((weighted, quad)) = g.add_reference(mesh, f) {
                if let Some(q) = quad {
                    g.min_sj = g.min_sj.min(quad_scaled_jacobian(q));
                }
                g.average += weighted;
            }
        }
        g.average = g.average.normalize_or_zero();
        g
    }

    /// Also refuses a quad with a twisted corner — one whose Scaled
    /// Jacobian sign a small move of its vertices (quantization onto a
    /// file's grid) flips: a [`quad_twist`] below `min(0, the worst of the
    /// quads of region before)`. Call it right after the capture, on the
    /// same region.
    pub fn with_corner_margin(mut self, mesh: &Mesh, region: &[FaceId], margin: f64) -> Self {
        let worst = region
            .iter()
            .filter_map(|&f| mesh.quad_vertices(f))
            .map(|q| quad_twist(q.map(|v| mesh.position(v)), margin))
            .fold(0.0, f64::min);
        self.twist = Some((margin, worst));
        self
    }

    /// Adds `faces` (live ones) to the fold-over reference without changing
    /// the shape floor: for steps that may move vertices beyond the region.
    pub fn extend(&mut self, mesh: &Mesh, faces: &[FaceId]) {
        for &f in faces {
            self.add_reference(mesh, f);
        }
    }

    /// Adds live face `f` to the fold-over reference (its normal, and its
    /// vertices with its area-weighted normal); returns that weighted
    /// normal and, for a quad, its corner positions. `None` for a dead face.
    fn add_reference(&mut self, mesh: &Mesh, f: FaceId) -> Option<(DVec3, Option<[DVec3; 4]>)> {
        if !mesh.is_face_alive(f) {
            return None;
        }
        let lo = self.local_vs.len();
        // a quad's corners in an array (no list of positions)
        let (n, quad) = match mesh.quad_vertices(f) {
            Some(q) => {
                self.local_vs.extend_from_slice(&q);
                let p = q.map(|v| mesh.position(v));
                (newell_normal(&p), Some(p))
            }
            None => {
                self.local_vs.extend(mesh.face_vertices(f));
                let p: Vec<DVec3> = self.local_vs[lo..]
                    .iter()
                    .map(|&v| mesh.position(v))
                    .collect();
                (newell_normal(&p), None)
            }
        };
        let weighted = quad.map_or(n, |q| n * area4(&q));
        self.before.push((f, n));
        let hi = self.local_vs.len();
        let mask = vertex_mask(&self.local_vs[lo..hi]);
        self.local.push((lo as u32, hi as u32, weighted, mask));
        Some((weighted, quad))
    }

    /// Vertices on sharp creases: a face's fold-over reference does not
    /// reach across them (see `GeometryGuard::local_normal`).
    pub fn with_creases(mut self, creases: Vec<VertexId>) -> Self {
        self.creases = creases;
        self
    }

    /// Area-weighted normal of the captured faces that share a vertex with
    /// `q`: the surface the new face replaces, wherever its id came from —
    /// linked through a vertex off the creases when `q` has one that a
    /// captured face shares. The faces around a crease vertex lie on both
    /// sides of the crease, so their mean is off either side by half the
    /// crease's angle or more — by all of it where only the other side's
    /// faces were captured — and a face that had not turned at all read as
    /// folded over (on fandisk, e.g., a side-wall quad that had not moved,
    /// linked only through its two crease vertices to the top faces a
    /// curve-shortening merge captured: 0.005 against them).
    fn local_normal(&self, q: &[VertexId; 4]) -> Option<DVec3> {
        let mut side = [VertexId(u32::MAX); 4];
        let mut k = 0;
        for &v in q {
            if !self.creases.contains(&v) {
                side[k] = v;
                k += 1;
            }
        }
        if k < 4 {
            if let Some(n) = self.normal_around(&side[..k]) {
                return Some(n);
            }
        }
        self.normal_around(q)
    }

    /// Area-weighted normal of the captured faces that share a vertex of
    /// `vs` (`None` when there is none, or they cancel).
    // inlined into `local_normal`, where `vs` is a quad's four corners or
    // fewer (out of line, the id compares were twice the instructions)
    #[inline(always)]
    fn normal_around(&self, vs: &[VertexId]) -> Option<DVec3> {
        // a wide step checks ≈ 100 faces against ≈ 100 captured ones: the
        // masks skip most of the captured faces without comparing ids
        let qm = vertex_mask(vs);
        let mut n = DVec3::ZERO;
        for &(lo, hi, ref w, m) in &self.local {
            if m & qm == 0 {
                continue;
            }
            let fvs = &self.local_vs[lo as usize..hi as usize];
            if fvs.iter().any(|v| vs.contains(v)) {
                n += *w;
            }
        }
        let n = n.normalize_or_zero();
        (n != DVec3::ZERO).then_some(n)
    }

    /// Checks the faces of `region` (live faces only) after the step.
    pub fn check(&self, mesh: &Mesh, region: &[FaceId]) -> Result<(), Reject> {
        for &f in region {
            let Some(q) = mesh.quad_vertices(f) else {
                continue;
            };
            let p = q.map(|v| mesh.position(v));
            if quad_scaled_jacobian(p) < self.min_sj {
                return Err(Reject::Geometry(
                    "a quad would be inverted or too distorted",
                ));
            }
            if self
                .twist
                .is_some_and(|(margin, worst)| quad_twist(p, margin) < worst)
            {
                return Err(Reject::Geometry("a quad corner would be twisted"));
            }
            let reference = if LOCAL_FOLD_REFERENCE {
                self.local_normal(&q)
            } else {
                None
            }
            .or_else(|| self.before.iter().find(|b| b.0 == f).map(|b| b.1))
            .unwrap_or(self.average);
            if newell_normal(&p).dot(reference) < MIN_NORMAL_COSINE {
                return Err(Reject::Geometry("a quad would fold over"));
            }
        }
        Ok(())
    }
}

/// One bit per vertex id modulo 64: faces whose masks share no bit share
/// no vertex.
fn vertex_mask(vs: &[VertexId]) -> u64 {
    vs.iter().fold(0, |m, v| m | 1 << (v.0 % 64))
}

/// Area of a quad (sum of its two triangles on the 0–2 diagonal).
pub fn area4(p: &[DVec3; 4]) -> f64 {
    0.5 * ((p[1] - p[0]).cross(p[2] - p[0]).length() + (p[2] - p[0]).cross(p[3] - p[0]).length())
}

/// `face` with every vertex replaced by its image under `merged`, and
/// consecutive repeats (cyclically) dropped — what a face becomes when its
/// vertices merge. A quad that loses one vertex becomes a triangle.
pub(crate) fn map_face(
    mesh: &Mesh,
    f: FaceId,
    merged: &[(VertexId, VertexId)],
    out: &mut Vec<VertexId>,
) -> bool {
    out.clear();
    let mut changed = false;
    for v in mesh.face_vertices(f) {
        let w = merged.iter().find(|m| m.0 == v).map_or(v, |m| m.1);
        changed |= w != v;
        if out.last() != Some(&w) {
            out.push(w);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    changed
}
