//! Feature curves under vertex merges: the paper's three rules.
//!
//! Feature edges (user polylines, sharp edges, and every boundary edge — a
//! boundary loop is a closed feature curve) are grouped into curves. While
//! the coarsener merges vertices, this state checks, on the candidate before
//! it is committed:
//! 1. merging feature vertices are consecutive on one curve (no pinching);
//! 2. no curve is split: every feature edge still exists after the step;
//! 3. no curve vanishes: an open curve keeps ≥ 1 edge, a closed one ≥ 3.
//!
//! Feature corners (feature degree ≠ 2) never move; at most one may be in a
//! merge group.

use crate::bvh::segment_closest;
use crate::features::FeatureCurves;
use crate::mesh::{FaceId, Mesh, VertexId};
use crate::ops::Reject;
use std::collections::HashMap;

/// Feature edges keyed by sorted vertex pair, with their curve ids.
#[derive(Clone, Debug, Default)]
pub struct FeatureState {
    edges: HashMap<(u32, u32), u32>,
    curve_len: Vec<u32>,
    curve_closed: Vec<bool>,
    /// Feature neighbours of each vertex (empty for most vertices, so no
    /// allocation there); the feature degree is its length.
    adj: Vec<Vec<u32>>,
}

/// The feature-edge changes a step makes, applied by [`FeatureState::commit`].
#[derive(Clone, Debug, Default)]
pub struct FeatureDelta {
    removed: Vec<(u32, u32)>,
    added: Vec<((u32, u32), u32)>,
    shrink: Vec<u32>,
}

fn key(a: VertexId, b: VertexId) -> (u32, u32) {
    (a.0.min(b.0), a.0.max(b.0))
}

impl FeatureState {
    /// Builds the state from the feature curves (see
    /// [`crate::features::FeatureCurves`]; build them with
    /// `include_boundary = true` so boundary loops are curves too). A curve
    /// that returns to its starting corner counts as closed for rule 3.
    pub fn new(mesh: &Mesh, curves: &FeatureCurves) -> Self {
        let mut s = FeatureState {
            adj: vec![Vec::new(); mesh.vertex_capacity()],
            ..Default::default()
        };
        for (id, c) in curves.curves.iter().enumerate() {
            let vs = &c.vertices;
            let mut n = 0;
            let closing = if c.closed {
                vs.len()
            } else {
                vs.len().saturating_sub(1)
            };
            for i in 0..closing {
                let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
                if a != b && s.edges.insert(key(a, b), id as u32).is_none() {
                    s.adj[a.idx()].push(b.0);
                    s.adj[b.idx()].push(a.0);
                    n += 1;
                }
            }
            s.curve_len.push(n);
            s.curve_closed.push(c.closed || vs.first() == vs.last());
        }
        s
    }

    /// True when `v` lies on a feature curve.
    #[inline]
    pub fn is_feature(&self, v: VertexId) -> bool {
        self.adj.get(v.idx()).is_some_and(|n| !n.is_empty())
    }
    /// True when `v` is a feature corner (feature degree other than 0 or 2).
    #[inline]
    pub fn is_corner(&self, v: VertexId) -> bool {
        self.adj
            .get(v.idx())
            .is_some_and(|n| !n.is_empty() && n.len() != 2)
    }
    /// True when `a–b` is a feature edge.
    pub fn is_feature_edge(&self, a: VertexId, b: VertexId) -> bool {
        self.edges.contains_key(&key(a, b))
    }
    /// Number of feature edges.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }
    /// Number of curves that still have edges.
    pub fn live_curves(&self) -> usize {
        self.curve_len.iter().filter(|&&n| n > 0).count()
    }

    /// Rule 1 on a merge group (`into` plus the vertices merging into it):
    /// its feature vertices are consecutive on one curve — one, two joined
    /// by a feature edge, or a run of three (`FeatureState::check_run`) —
    /// with at most one corner. Returns the vertex whose position the group
    /// must keep, if any (the corner, or the single feature vertex), and
    /// whether the group merges along a feature edge.
    pub fn check_group(&self, mesh: &Mesh, group: &[VertexId]) -> Result<GroupConstraint, Reject> {
        let feats: Vec<VertexId> = group
            .iter()
            .copied()
            .filter(|&v| self.is_feature(v))
            .collect();
        let corners = feats.iter().filter(|&&v| self.is_corner(v)).count();
        if corners > 1 {
            return Err(Reject::Feature("two feature corners would merge"));
        }
        match feats.len() {
            0 => Ok(GroupConstraint::Free),
            1 => Ok(GroupConstraint::Pinned(feats[0])),
            2 => {
                if !self.is_feature_edge(feats[0], feats[1]) {
                    return Err(Reject::Feature(
                        "merging feature vertices are not consecutive",
                    ));
                }
                match feats.iter().find(|&&v| self.is_corner(v)) {
                    Some(&c) => Ok(GroupConstraint::Pinned(c)),
                    None => Ok(GroupConstraint::OnEdge(feats[0], feats[1])),
                }
            }
            3 => self.check_run(mesh, &feats),
            _ => Err(Reject::Feature(
                "more than three feature vertices would merge",
            )),
        }
    }

    /// Rule 1 on three merging feature vertices: they must be a run of one
    /// curve, `x–m–y` (two feature edges of the same curve meeting at `m`),
    /// at most one of them a corner; the group stays at the corner if there
    /// is one, else at `m` — on a boundary loop only where that does not cut
    /// a corner of the loop ([`FeatureState::cuts_loop_corner`]).
    ///
    /// This is the merge that shortens a curve where the mesh's rows run
    /// across it: a qeMerge whose shared edge `a–d` leaves the curve at `a`,
    /// both quads on one side, merges `a`'s two curve neighbours `b`, `f`
    /// into it. The paper asks merging feature points to be consecutive on a
    /// common curve, which a run of three is; refusing it (groups of at most
    /// two) left fandisk's curves at 241 of their 246 edges and its
    /// coarsening stuck at 453 faces. (Placing the group at the best of `m`
    /// and the two midpoints by QEM measured worse there: 75.3 % ideal and
    /// 2.08 % Hausdorff at 249 faces, against 77.9 % and 1.78 % at 247,
    /// both with every feature vertex a crease for the geometry guard.)
    fn check_run(&self, mesh: &Mesh, feats: &[VertexId]) -> Result<GroupConstraint, Reject> {
        let not_run = Reject::Feature("merging feature vertices are not consecutive");
        let Some(mid) = (0..3).find(|&i| {
            let m = feats[i];
            self.is_feature_edge(m, feats[(i + 1) % 3])
                && self.is_feature_edge(m, feats[(i + 2) % 3])
        }) else {
            return Err(not_run);
        };
        let (m, x, y) = (feats[mid], feats[(mid + 1) % 3], feats[(mid + 2) % 3]);
        // one curve (a corner `m` may join two), and not a closed curve of
        // three edges (rule 3 refuses that too)
        if self.edges[&key(m, x)] != self.edges[&key(m, y)] || self.is_feature_edge(x, y) {
            return Err(not_run);
        }
        let pin = match feats.iter().copied().find(|&v| self.is_corner(v)) {
            Some(c) => c,
            None if mesh.is_boundary_vertex(m) && self.cuts_loop_corner(mesh, x, m, y) => {
                return Err(Reject::Feature(
                    "merging feature vertices would cut a corner of the curve",
                ));
            }
            None => m,
        };
        Ok(GroupConstraint::Pinned(pin))
    }

    /// Whether a run `x–m–y` of a boundary loop (no corner among them)
    /// merged at `m` cuts a corner of the loop: the loop through `m` passes
    /// further than [`RUN_CORNER_CUT`] times the run's mean edge length from
    /// `x` or `y`. A boundary's shape within its surface is seen by neither
    /// the faces' quadrics nor the surface-deviation limit (a crease's is:
    /// cut short, it leaves the planes of one of its sides), so a loop
    /// merged at `m` always lost the corners of a flat square (the remesh
    /// pipeline's height field: Hausdorff 2.9 %).
    fn cuts_loop_corner(&self, mesh: &Mesh, x: VertexId, m: VertexId, y: VertexId) -> bool {
        let outer = |end: VertexId, inner: VertexId| {
            self.adj[end.idx()]
                .iter()
                .map(|&u| VertexId(u))
                .find(|&u| u != inner)
        };
        let (Some(xo), Some(yo)) = (outer(x, m), outer(y, m)) else {
            return false;
        };
        let p = |v: VertexId| mesh.position(v);
        let off = |v: VertexId| {
            let d = |a: VertexId, b: VertexId| (segment_closest(p(v), p(a), p(b)) - p(v)).length();
            d(xo, m).min(d(m, yo))
        };
        // (a turn of about 30° at `x` or `y` is cut off by a quarter edge)
        let edge = 0.5 * ((p(x) - p(m)).length() + (p(y) - p(m)).length());
        off(x).max(off(y)) > RUN_CORNER_CUT * edge
    }

    /// The feature vertices on sharp creases around `faces` (at their
    /// vertices and at the vertices of the faces around those; sorted, no
    /// repeats): those with a feature edge whose two faces' normals are
    /// further apart than the geometry guard lets a face turn
    /// (`MIN_NORMAL_COSINE`) — see [`crate::ops::GeometryGuard::with_creases`].
    /// The faces a step's guard checks afterwards are those around the
    /// vertices it touched, so this covers every crease vertex they have.
    ///
    /// Only such creases: at a gentler one the two sides' normals mix
    /// without reading as a fold-over, and spot (ten sharp edges of 60–90°)
    /// lost 1.7 points of ideal vertices (86.6 → 84.9 %) when every feature
    /// vertex counted — a changed order, its steps as legal as before.
    pub fn crease_vertices_near(&self, mesh: &Mesh, faces: &[FaceId]) -> Vec<VertexId> {
        let mut out = Vec::new();
        // called for every step tried: a mesh without feature edges (a
        // closed scan) skips the walk over the faces' two rings
        if self.edges.is_empty() {
            return out;
        }
        // the faces' vertices, then the faces around those, each once: the
        // faces share most of their vertices, and walking every face of
        // every vertex's star repeats each face up to sixteen times
        let mut vs: Vec<VertexId> = Vec::with_capacity(2 * faces.len() + 4);
        for &f in faces {
            if !mesh.is_face_alive(f) {
                continue;
            }
            for v in mesh.face_vertices(f) {
                if !vs.contains(&v) {
                    vs.push(v);
                }
            }
        }
        // the feature vertices of the faces around those, with repeats (a
        // face around two of them is read twice): the sort below removes
        // them, and feature vertices are few, where checking each face
        // against a list of the faces seen cost up to ≈ 80 compares a face
        for &v in &vs {
            for g in mesh.vertex_faces(v) {
                out.extend(mesh.face_vertices(g).filter(|&u| self.is_feature(u)));
            }
        }
        out.sort_unstable();
        out.dedup();
        out.retain(|&v| self.on_sharp_crease(mesh, v));
        out
    }

    /// Whether a feature edge at `v` has two faces whose normals are
    /// further apart than `ops::MIN_NORMAL_COSINE` allows a face to turn.
    fn on_sharp_crease(&self, mesh: &Mesh, v: VertexId) -> bool {
        self.adj[v.idx()].iter().any(|&u| {
            let Some(h) = mesh.find_halfedge(v, VertexId(u)) else {
                return false;
            };
            match (mesh.face(h), mesh.face(mesh.twin(h))) {
                (Some(f), Some(g)) => {
                    mesh.face_normal(f).dot(mesh.face_normal(g)) < crate::ops::MIN_NORMAL_COSINE
                }
                _ => false,
            }
        })
    }

    /// Rules 2 and 3 after a step (on the mesh *after* it): maps every
    /// feature edge at the `merged` vertices through the merge, and checks
    /// that each mapped edge exists and no curve vanishes or fuses with
    /// another. `merged` is `(gone, into)` composed over the whole step.
    pub fn check_after(
        &self,
        mesh_after: &Mesh,
        merged: &[(VertexId, VertexId)],
    ) -> Result<FeatureDelta, Reject> {
        let image = |v: u32| merged.iter().find(|m| m.0 .0 == v).map_or(v, |m| m.1 .0);
        let mut delta = FeatureDelta::default();
        let mut touched: Vec<((u32, u32), u32)> = Vec::new();
        for &(gone, _) in merged {
            if !self.is_feature(gone) {
                continue;
            }
            for &n in &self.adj[gone.idx()] {
                let k = key(gone, VertexId(n));
                if !touched.iter().any(|t| t.0 == k) {
                    touched.push((k, self.edges[&k]));
                }
            }
        }
        touched.sort_unstable();
        let mut shrink: Vec<u32> = Vec::new();
        for &((a, b), curve) in &touched {
            let (ia, ib) = (image(a), image(b));
            delta.removed.push((a, b));
            if ia == ib {
                shrink.push(curve);
                continue;
            }
            let k = (ia.min(ib), ia.max(ib));
            if mesh_after
                .find_halfedge(VertexId(ia), VertexId(ib))
                .is_none()
            {
                return Err(Reject::Feature("a feature curve would be split"));
            }
            let existing = self
                .edges
                .get(&k)
                .copied()
                .filter(|_| !touched.iter().any(|t| t.0 == k))
                .or_else(|| delta.added.iter().find(|x| x.0 == k).map(|x| x.1));
            match existing {
                Some(c) if c == curve => shrink.push(curve),
                Some(_) => return Err(Reject::Feature("two feature curves would fuse")),
                None => delta.added.push((k, curve)),
            }
        }
        shrink.sort_unstable();
        for (i, &c) in shrink.iter().enumerate() {
            let lost = shrink[i..].iter().take_while(|&&x| x == c).count() as u32;
            if i > 0 && shrink[i - 1] == c {
                continue;
            }
            let min = if self.curve_closed[c as usize] { 3 } else { 1 };
            if self.curve_len[c as usize] < min + lost {
                return Err(Reject::Feature("a feature curve would vanish"));
            }
        }
        delta.shrink = shrink;
        Ok(delta)
    }

    /// Applies a delta accepted by [`FeatureState::check_after`].
    pub fn commit(&mut self, delta: FeatureDelta) {
        for k in &delta.removed {
            if self.edges.remove(k).is_some() {
                self.adj[k.0 as usize].retain(|&x| x != k.1);
                self.adj[k.1 as usize].retain(|&x| x != k.0);
            }
        }
        for (k, c) in delta.added {
            if self.edges.insert(k, c).is_none() {
                self.adj[k.0 as usize].push(k.1);
                self.adj[k.1 as usize].push(k.0);
            }
        }
        for c in delta.shrink {
            self.curve_len[c as usize] -= 1;
        }
    }
}

/// What rule 1 demands of a merge group's position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupConstraint {
    /// No feature vertex: the position is free (QEM).
    Free,
    /// Keep this vertex's position (a corner or the only feature vertex).
    Pinned(VertexId),
    /// Two feature vertices joined by a feature edge: stay on that edge.
    OnEdge(VertexId, VertexId),
}

/// A run of three of a boundary loop may merge only where the loop through
/// its middle vertex passes within this (times the run's mean edge length)
/// of the run's vertices (`FeatureState::cuts_loop_corner`).
pub const RUN_CORNER_CUT: f64 = 0.25;
