//! Input checking: [`check`] names the first defect of an [`IndexedMesh`].
//!
//! The checks run in this order, and the first failing one is reported with
//! the index of the offending element:
//!
//! 1. the mesh has no faces ([`Defect::NoFaces`], element `mesh`);
//! 2. a vertex has a NaN or infinite coordinate ([`Defect::NonFiniteCoordinate`]);
//! 3. per face, in face order: fewer than 3 vertices ([`Defect::TooFewVertices`]),
//!    an index out of range ([`Defect::IndexOutOfRange`]), a vertex listed twice
//!    ([`Defect::RepeatedVertex`]), zero area ([`Defect::ZeroArea`]);
//! 4. a vertex used by no face ([`Defect::UnreferencedVertex`]);
//! 5. an edge used by more than two faces ([`Defect::NonManifoldEdge`]);
//! 6. an edge traversed twice in the same direction ([`Defect::InconsistentOrientation`]);
//! 7. a vertex whose faces form more than one fan ([`Defect::NonManifoldVertex`]).
//!
//! Cost: O(C log C) for C face corners (one sort of the edge keys), plus
//! near-linear union-find for the fans; 500k quads take well under a second
//! in release builds.
//!
//! "Zero area" is relative: a face is degenerate when twice its vector area
//! (the length of its Newell normal) is at most `1e-12` times the square of its
//! longest edge. Exactly collinear or coincident corners land there even after
//! rounding, while real slivers of scanned meshes do not.

use crate::IndexedMesh;
use glam::DVec3;
use rayon::slice::ParallelSliceMut;
use std::fmt;

/// Relative threshold for [`Defect::ZeroArea`] (see the module docs).
pub(crate) const ZERO_AREA_REL: f64 = 1e-12;

/// The element a defect is attached to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Element {
    /// The mesh as a whole.
    Mesh,
    /// A vertex, by 0-based index.
    Vertex(u32),
    /// A face, by 0-based index.
    Face(u32),
    /// An undirected edge between two vertices (smaller index first).
    Edge(u32, u32),
}

impl fmt::Display for Element {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Element::Mesh => write!(f, "mesh"),
            Element::Vertex(v) => write!(f, "vertex {v}"),
            Element::Face(i) => write!(f, "face {i}"),
            Element::Edge(a, b) => write!(f, "edge {a}-{b}"),
        }
    }
}

/// The kinds of defects [`check`] detects (in the order it checks them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Defect {
    /// The mesh has no faces.
    NoFaces,
    /// A vertex coordinate is NaN or infinite.
    NonFiniteCoordinate,
    /// A face has fewer than three vertices.
    TooFewVertices,
    /// A face index is not below the vertex count.
    IndexOutOfRange,
    /// A face lists the same vertex twice.
    RepeatedVertex,
    /// A face has (relatively) zero area.
    ZeroArea,
    /// A vertex is used by no face.
    UnreferencedVertex,
    /// An edge is shared by more than two faces.
    NonManifoldEdge,
    /// Two faces traverse an edge in the same direction.
    InconsistentOrientation,
    /// The faces around a vertex form more than one fan.
    NonManifoldVertex,
}

/// The first defect found by [`check`]. Displays as
/// `face 812 repeats vertex 40`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{element} {message}")]
pub struct InvalidMesh {
    /// What kind of defect.
    pub defect: Defect,
    /// The offending element.
    pub element: Element,
    /// Description that reads after the element (`repeats vertex 40`).
    pub message: String,
}

fn bad(defect: Defect, element: Element, message: impl Into<String>) -> InvalidMesh {
    InvalidMesh {
        defect,
        element,
        message: message.into(),
    }
}

/// Checks `mesh` and returns the first defect (see the module docs for the
/// list and order). `Ok(())` means: at least one face, finite coordinates,
/// every face a simple polygon of 3+ distinct in-range vertices with non-zero
/// area, every vertex used, every edge on one or two faces, consistent
/// orientation, and every vertex with a single fan of faces — i.e. an oriented
/// 2-manifold (possibly with boundary), ready for a half-edge structure.
pub fn check(mesh: &IndexedMesh) -> Result<(), InvalidMesh> {
    let nf = mesh.face_count();
    if nf == 0 {
        return Err(bad(Defect::NoFaces, Element::Mesh, "has no faces"));
    }
    if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(bad(
            Defect::NonFiniteCoordinate,
            Element::Vertex(v as u32),
            "has a non-finite coordinate",
        ));
    }
    check_faces(mesh)?;
    let mut used = vec![false; mesh.positions.len()];
    for &i in &mesh.indices {
        used[i as usize] = true;
    }
    if let Some(v) = used.iter().position(|u| !u) {
        return Err(bad(
            Defect::UnreferencedVertex,
            Element::Vertex(v as u32),
            "is used by no face",
        ));
    }
    let edges = EdgeTable::new(mesh);
    edges.check_manifold_and_orientation(mesh)?;
    let fans = fan_roots(mesh, &edges);
    check_fans(mesh, &fans)
}

/// Face-local checks: size, index range, repeated vertices, zero area.
fn check_faces(mesh: &IndexedMesh) -> Result<(), InvalidMesh> {
    let nv = mesh.positions.len();
    for (f, face) in mesh.faces().enumerate() {
        let el = Element::Face(f as u32);
        if face.len() < 3 {
            return Err(bad(
                Defect::TooFewVertices,
                el,
                format!("has {} vertices (at least 3 needed)", face.len()),
            ));
        }
        if let Some(&i) = face.iter().find(|&&i| i as usize >= nv) {
            return Err(bad(
                Defect::IndexOutOfRange,
                el,
                format!("references vertex {i} but the mesh has {nv} vertices"),
            ));
        }
        if let Some(v) = repeated_vertex(face) {
            return Err(bad(
                Defect::RepeatedVertex,
                el,
                format!("repeats vertex {v}"),
            ));
        }
        if is_zero_area(&mesh.positions, face) {
            return Err(bad(Defect::ZeroArea, el, "has zero area"));
        }
    }
    Ok(())
}

/// The first vertex that appears twice in `face`, if any. Faces are small, so
/// the quadratic scan is faster than hashing up to a few dozen corners.
pub(crate) fn repeated_vertex(face: &[u32]) -> Option<u32> {
    if face.len() <= 32 {
        for (k, &v) in face.iter().enumerate() {
            if face[k + 1..].contains(&v) {
                return Some(v);
            }
        }
        None
    } else {
        let mut s = face.to_vec();
        s.sort_unstable();
        s.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
    }
}

/// True when the polygon's area is zero relative to its longest edge (see
/// the module docs). Indices must be in range.
pub(crate) fn is_zero_area(positions: &[DVec3], face: &[u32]) -> bool {
    // Newell / fan sum: |sum (p_k - o) x (p_k+1 - o)| = 2 * area. Taking the
    // vectors relative to the first corner keeps rounding small far from the
    // origin.
    let o = positions[face[0] as usize];
    let n = face.len();
    let mut normal = DVec3::ZERO;
    let mut longest2: f64 = 0.0;
    for k in 0..n {
        let a = positions[face[k] as usize] - o;
        let b = positions[face[(k + 1) % n] as usize] - o;
        normal += a.cross(b);
        longest2 = longest2.max(a.distance_squared(b));
    }
    longest2 == 0.0 || normal.length() <= ZERO_AREA_REL * longest2
}

/// All half-edges of the mesh sorted by undirected edge key.
///
/// Entry: `(key, corner)` where `key = min << 32 | max` of the half-edge's
/// endpoints and `corner` is the global index (into `mesh.indices`) of the
/// corner the half-edge leaves from.
pub(crate) struct EdgeTable {
    pub(crate) entries: Vec<(u64, u32)>,
    /// `next[c]`: the corner after `c` in its face.
    pub(crate) next: Vec<u32>,
}

impl EdgeTable {
    /// Builds the table; indices must be in range.
    pub(crate) fn new(mesh: &IndexedMesh) -> Self {
        let nc = mesh.indices.len();
        let mut next = vec![0u32; nc];
        let mut entries = Vec::with_capacity(nc);
        for f in 0..mesh.face_count() {
            let s = mesh.face_starts[f] as usize;
            let e = mesh.face_starts[f + 1] as usize;
            for (c, nx) in next.iter_mut().enumerate().take(e).skip(s) {
                let n = if c + 1 == e { s } else { c + 1 };
                *nx = n as u32;
                let (a, b) = (mesh.indices[c], mesh.indices[n]);
                entries.push((edge_key(a, b), c as u32));
            }
        }
        entries.par_sort_unstable();
        EdgeTable { entries, next }
    }

    /// Groups of half-edges on the same undirected edge.
    pub(crate) fn groups(&self) -> impl Iterator<Item = &[(u64, u32)]> + '_ {
        self.entries.chunk_by(|a, b| a.0 == b.0)
    }

    fn check_manifold_and_orientation(&self, mesh: &IndexedMesh) -> Result<(), InvalidMesh> {
        for g in self.groups() {
            if g.len() > 2 {
                let (a, b) = key_vertices(g[0].0);
                let mut faces: Vec<u32> = g.iter().map(|e| face_of_corner(mesh, e.1)).collect();
                faces.sort_unstable();
                return Err(bad(
                    Defect::NonManifoldEdge,
                    Element::Edge(a, b),
                    format!("is shared by {} faces ({})", g.len(), list(&faces)),
                ));
            }
        }
        for g in self.groups() {
            if let [(k, c1), (_, c2)] = *g {
                if mesh.indices[c1 as usize] == mesh.indices[c2 as usize] {
                    let (a, b) = key_vertices(k);
                    let (f1, f2) = (face_of_corner(mesh, c1), face_of_corner(mesh, c2));
                    return Err(bad(
                        Defect::InconsistentOrientation,
                        Element::Edge(a, b),
                        format!(
                            "is traversed in the same direction by faces {} and {}",
                            f1.min(f2),
                            f1.max(f2)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

fn list(v: &[u32]) -> String {
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Undirected key of edge `a`-`b`.
pub(crate) fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

fn key_vertices(k: u64) -> (u32, u32) {
    ((k >> 32) as u32, k as u32)
}

/// Face containing global corner `c` (binary search in `face_starts`).
pub(crate) fn face_of_corner(mesh: &IndexedMesh, c: u32) -> u32 {
    (mesh.face_starts.partition_point(|&s| s <= c) - 1) as u32
}

/// Union-find over corners: two corners of the same vertex are joined when
/// they are on either side of a manifold edge. Returns the root of each corner.
pub(crate) fn fan_roots(mesh: &IndexedMesh, edges: &EdgeTable) -> Vec<u32> {
    let mut uf = UnionFind::new(mesh.indices.len());
    for g in edges.groups() {
        if let [(_, c1), (_, c2)] = *g {
            let (n1, n2) = (edges.next[c1 as usize], edges.next[c2 as usize]);
            let (v1, v2) = (mesh.indices[c1 as usize], mesh.indices[c2 as usize]);
            if v1 == v2 {
                // Same direction (misoriented): corners of equal vertices pair up.
                uf.union(c1, c2);
                uf.union(n1, n2);
            } else {
                // Opposite directions: c1 (a->b) and c2 (b->a).
                uf.union(c1, n2);
                uf.union(n1, c2);
            }
        }
    }
    (0..mesh.indices.len() as u32).map(|c| uf.find(c)).collect()
}

/// Reports the first vertex whose corners have more than one fan root, after
/// the orientation check (so it runs on oriented, edge-manifold meshes).
fn check_fans(mesh: &IndexedMesh, roots: &[u32]) -> Result<(), InvalidMesh> {
    let mut fan = vec![u32::MAX; mesh.positions.len()];
    let mut first_bad: Option<u32> = None;
    for (c, &v) in mesh.indices.iter().enumerate() {
        let r = roots[c];
        let slot = &mut fan[v as usize];
        if *slot == u32::MAX {
            *slot = r;
        } else if *slot != r {
            first_bad = Some(first_bad.map_or(v, |b| b.min(v)));
        }
    }
    match first_bad {
        None => Ok(()),
        Some(v) => {
            let mut distinct: Vec<u32> = mesh
                .indices
                .iter()
                .zip(roots)
                .filter(|(&w, _)| w == v)
                .map(|(_, &r)| r)
                .collect();
            distinct.sort_unstable();
            distinct.dedup();
            Err(bad(
                Defect::NonManifoldVertex,
                Element::Vertex(v),
                format!("has {} separate fans of faces", distinct.len()),
            ))
        }
    }
}

/// Path-halving union-find with union by index (small and fast enough).
pub(crate) struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    pub(crate) fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
        }
    }

    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = self.parent[x as usize];
        }
        x
    }

    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            // Keep the smaller index as root so results are deterministic.
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.parent[hi as usize] = lo;
        }
    }
}
