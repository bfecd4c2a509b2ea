//! Feature edges and feature curves (paper §4, "Feature Edges", Fig. 5).
//!
//! * [`sharp_edges`] — edges whose dihedral angle exceeds a threshold;
//! * [`load_features`] / [`parse_features`] — user-annotated polylines;
//! * [`feature_edges_from_polylines`] — checks polylines against the mesh;
//! * [`FeatureCurves`] — the feature-edge graph split into curves at corners,
//!   which the coarsener keeps topologically intact (merging feature vertices
//!   must be consecutive on one curve, no curve splits, no curve vanishes).
//!
//! Edges are `(a, b)` vertex pairs normalised to `a < b`; every list this
//! module returns is sorted and free of duplicates, so outputs never depend
//! on hashing or traversal order.

use crate::attributes::{data_lines, mismatch, parse_err, path_name, read_text, AttributeError};
use crate::mesh::{Mesh, VertexId};
use std::path::Path;

/// The default dihedral-angle threshold of [`sharp_edges`], in degrees.
pub const DEFAULT_SHARP_ANGLE_DEG: f64 = 60.0;

/// An undirected edge as `(smaller id, larger id)`.
pub type Edge = (VertexId, VertexId);

#[inline]
fn norm_edge(a: VertexId, b: VertexId) -> Edge {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Interior edges whose dihedral angle — the angle between the two face
/// normals, in degrees (0 = flat) — is strictly greater than `angle_deg`.
/// 180 (or more, or NaN) gives none; [`DEFAULT_SHARP_ANGLE_DEG`] is the
/// usual choice. Boundary edges are not included (see
/// [`FeatureCurves::new`] to add them). Sorted, normalised `a < b`.
pub fn sharp_edges(mesh: &Mesh, angle_deg: f64) -> Vec<Edge> {
    let mut out = Vec::new();
    if angle_deg.is_nan() || angle_deg >= 180.0 {
        return out;
    }
    // compare cosines: angle > t ⇔ cos(angle) < cos(t) (both in [0°, 180°])
    let cos_t = angle_deg.max(0.0).to_radians().cos();
    let mut normals = vec![glam::DVec3::ZERO; mesh.face_capacity()];
    for f in mesh.faces() {
        normals[f.idx()] = mesh.face_normal(f);
    }
    for h in mesh.halfedges() {
        let t = mesh.twin(h);
        if h.0 > t.0 {
            continue;
        }
        let (Some(f1), Some(f2)) = (mesh.face(h), mesh.face(t)) else {
            continue;
        };
        let (n1, n2) = (normals[f1.idx()], normals[f2.idx()]);
        if n1 == glam::DVec3::ZERO || n2 == glam::DVec3::ZERO {
            continue; // degenerate face: no meaningful angle
        }
        if n1.dot(n2) < cos_t {
            out.push(norm_edge(mesh.from_vertex(h), mesh.to_vertex(h)));
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Reads a feature file (see [`parse_features`]).
pub fn load_features(path: &Path, vertex_count: usize) -> Result<Vec<Vec<u32>>, AttributeError> {
    let text = read_text(path)?;
    parse_features(&text, &path_name(path), vertex_count)
}

/// Parses annotated feature polylines: one polyline per line, 0-based vertex
/// indices separated by white space, at least two per line; `#` comments
/// and blank lines allowed. A closed curve repeats its first vertex at the
/// end. Errors name the source and line (bad number, index out of range,
/// a vertex repeated consecutively, a single-vertex line).
pub fn parse_features(
    text: &str,
    source_name: &str,
    vertex_count: usize,
) -> Result<Vec<Vec<u32>>, AttributeError> {
    let mut out = Vec::new();
    for (line, content) in data_lines(text) {
        let mut poly: Vec<u32> = Vec::new();
        for tok in content.split_whitespace() {
            let v: u32 = tok.parse().map_err(|_| {
                parse_err(
                    source_name,
                    line,
                    format!("'{tok}' is not a vertex index (a non-negative integer)"),
                )
            })?;
            if v as usize >= vertex_count {
                return Err(parse_err(
                    source_name,
                    line,
                    format!("vertex {v} is out of range (the mesh has {vertex_count} vertices)"),
                ));
            }
            if poly.last() == Some(&v) {
                return Err(parse_err(
                    source_name,
                    line,
                    format!("vertex {v} is repeated consecutively"),
                ));
            }
            poly.push(v);
        }
        if poly.len() < 2 {
            return Err(parse_err(
                source_name,
                line,
                "a polyline needs at least two vertices".to_string(),
            ));
        }
        out.push(poly);
    }
    Ok(out)
}

/// The mesh edges of the polylines (sorted, normalised, duplicates
/// removed). Every consecutive pair must be joined by an edge of `mesh`;
/// the error names the polyline (0-based, in file order) and the pair.
pub fn feature_edges_from_polylines(
    mesh: &Mesh,
    polylines: &[Vec<u32>],
) -> Result<Vec<Edge>, AttributeError> {
    let mut out = Vec::new();
    for (i, poly) in polylines.iter().enumerate() {
        for w in poly.windows(2) {
            let (a, b) = (VertexId(w[0]), VertexId(w[1]));
            if a.idx() >= mesh.vertex_capacity()
                || b.idx() >= mesh.vertex_capacity()
                || mesh.find_halfedge(a, b).is_none()
            {
                return Err(mismatch(
                    &format!("feature polyline {i}"),
                    format!("vertices {a} and {b} are not joined by a mesh edge"),
                ));
            }
            out.push(norm_edge(a, b));
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// One feature curve: a chain of feature edges between two corners, or a
/// closed loop without corners.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FeatureCurve {
    /// The vertices in order along the curve. An open curve lists both end
    /// corners (equal when the curve returns to the corner it started
    /// from); a closed loop lists each vertex once.
    pub vertices: Vec<VertexId>,
    /// Number of edges (`vertices.len() − 1` when open, `vertices.len()`
    /// when closed).
    pub edge_count: usize,
    /// True for a loop through degree-2 vertices only.
    pub closed: bool,
}

/// The feature-edge graph split into curves (see the module docs).
///
/// A vertex with feature degree ≠ 2 (an end point, 1, or a junction, ≥ 3)
/// is a **corner**; curves run between corners. Components made only of
/// degree-2 vertices are closed loops. Curve ids follow the walk order:
/// corners by increasing id, their edges by increasing neighbour id, then
/// the loops by their smallest edge. Everything is deterministic.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FeatureCurves {
    /// All feature edges, normalised `a < b` and sorted.
    pub edges: Vec<Edge>,
    /// The curve id of each entry of `edges`.
    pub edge_curve: Vec<u32>,
    /// Feature degree per vertex id (`mesh.vertex_capacity()` entries).
    pub vertex_degree: Vec<u32>,
    /// The curves, indexed by curve id.
    pub curves: Vec<FeatureCurve>,
}

impl FeatureCurves {
    /// Builds the curves of `edges` (any order, duplicates allowed), plus
    /// every boundary edge of `mesh` when `include_boundary` (boundary loops
    /// are feature curves for the coarsener). Each edge must be an edge of
    /// `mesh`; the error names the first that is not.
    pub fn new(
        mesh: &Mesh,
        edges: &[Edge],
        include_boundary: bool,
    ) -> Result<FeatureCurves, AttributeError> {
        let nv = mesh.vertex_capacity();
        let mut all: Vec<Edge> = Vec::with_capacity(edges.len());
        for &(a, b) in edges {
            if a.idx() >= nv || b.idx() >= nv || mesh.find_halfedge(a, b).is_none() {
                return Err(mismatch(
                    "feature edges",
                    format!("vertices {a} and {b} are not joined by a mesh edge"),
                ));
            }
            all.push(norm_edge(a, b));
        }
        if include_boundary {
            for h in mesh.halfedges() {
                if mesh.is_boundary_halfedge(h) {
                    all.push(norm_edge(mesh.from_vertex(h), mesh.to_vertex(h)));
                }
            }
        }
        all.sort_unstable();
        all.dedup();
        Ok(FeatureCurves::from_sorted_edges(nv, all))
    }

    fn from_sorted_edges(nv: usize, edges: Vec<Edge>) -> FeatureCurves {
        let ne = edges.len();
        let mut degree = vec![0u32; nv];
        for &(a, b) in &edges {
            degree[a.idx()] += 1;
            degree[b.idx()] += 1;
        }
        // CSR adjacency: (neighbour, edge index), sorted by neighbour
        let mut start = vec![0usize; nv + 1];
        for v in 0..nv {
            start[v + 1] = start[v] + degree[v] as usize;
        }
        let mut fill = start.clone();
        let mut adj = vec![(VertexId(0), 0usize); 2 * ne];
        for (i, &(a, b)) in edges.iter().enumerate() {
            adj[fill[a.idx()]] = (b, i);
            fill[a.idx()] += 1;
            adj[fill[b.idx()]] = (a, i);
            fill[b.idx()] += 1;
        }
        for v in 0..nv {
            adj[start[v]..start[v + 1]].sort_unstable();
        }
        let mut edge_curve = vec![u32::MAX; ne];
        let mut curves = Vec::new();
        // Follows the unvisited chain from `from` along edge `e`, stopping
        // at a corner or at `stop`.
        let walk = |from: VertexId,
                    first: usize,
                    id: u32,
                    edge_curve: &mut Vec<u32>|
         -> (Vec<VertexId>, usize) {
            let mut verts = vec![from];
            let (mut cur, mut e) = (from, first);
            let mut count = 0;
            loop {
                edge_curve[e] = id;
                count += 1;
                let (a, b) = edges[e];
                let next = if a == cur { b } else { a };
                verts.push(next);
                cur = next;
                if degree[cur.idx()] != 2 {
                    break;
                }
                let nb = &adj[start[cur.idx()]..start[cur.idx() + 1]];
                match nb.iter().find(|&&(_, i)| edge_curve[i] == u32::MAX) {
                    Some(&(_, i)) => e = i,
                    None => break, // closed the loop
                }
            }
            (verts, count)
        };
        for v in 0..nv {
            if degree[v] == 2 || degree[v] == 0 {
                continue;
            }
            for &(_, e) in &adj[start[v]..start[v + 1]] {
                if edge_curve[e] != u32::MAX {
                    continue;
                }
                let id = curves.len() as u32;
                let (verts, count) = walk(VertexId(v as u32), e, id, &mut edge_curve);
                curves.push(FeatureCurve {
                    vertices: verts,
                    edge_count: count,
                    closed: false,
                });
            }
        }
        for e in 0..ne {
            if edge_curve[e] != u32::MAX {
                continue;
            }
            let id = curves.len() as u32;
            let (mut verts, count) = walk(edges[e].0, e, id, &mut edge_curve);
            verts.pop(); // the walk ends where it started
            curves.push(FeatureCurve {
                vertices: verts,
                edge_count: count,
                closed: true,
            });
        }
        FeatureCurves {
            edges,
            edge_curve,
            vertex_degree: degree,
            curves,
        }
    }

    /// Number of curves.
    pub fn curve_count(&self) -> usize {
        self.curves.len()
    }

    /// The curve of edge `a`-`b` (either order), if it is a feature edge.
    /// O(log E).
    pub fn curve_of(&self, a: VertexId, b: VertexId) -> Option<u32> {
        self.edges
            .binary_search(&norm_edge(a, b))
            .ok()
            .map(|i| self.edge_curve[i])
    }

    /// True when `a`-`b` is a feature edge.
    pub fn is_feature_edge(&self, a: VertexId, b: VertexId) -> bool {
        self.edges.binary_search(&norm_edge(a, b)).is_ok()
    }

    /// Feature degree of `v` (0 for ids beyond the table).
    pub fn degree(&self, v: VertexId) -> u32 {
        self.vertex_degree.get(v.idx()).copied().unwrap_or(0)
    }

    /// True when `v` is on a feature curve.
    pub fn is_feature_vertex(&self, v: VertexId) -> bool {
        self.degree(v) > 0
    }

    /// True when `v` is a corner: on a feature, with degree ≠ 2.
    pub fn is_corner(&self, v: VertexId) -> bool {
        let d = self.degree(v);
        d > 0 && d != 2
    }

    /// Number of edges of each curve, indexed by curve id.
    pub fn curve_edge_counts(&self) -> Vec<usize> {
        self.curves.iter().map(|c| c.edge_count).collect()
    }
}
