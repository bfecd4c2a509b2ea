//! Mesh quality metrics: the figures the qCoarsen paper reports in its Table 1,
//! computed on an [`IndexedMesh`].
//!
//! * [`mod@scaled_jacobian`] — per-face Scaled Jacobian and its `{median, worst}`;
//! * [`mod@valence`] — vertex structure: ideal fraction, extraordinary count, worst valence;
//! * [`mod@topology`] — Euler characteristic, components, boundary loops, genus;
//! * [`mod@hausdorff`] — symmetric surface-sampled Hausdorff distance (uses [`crate::bvh`]);
//! * [`stats`] — [`MeshStats`], all of the above in one serialisable record.
//!
//! ## Which faces count
//!
//! The metrics never panic on a malformed soup. A face is *usable* when its
//! `face_starts` range lies inside `indices`, it has at least three corners and
//! every corner indexes into `positions`. Faces that are not usable are skipped
//! by the topology, valence and Hausdorff metrics and score 0 in the Scaled
//! Jacobian (see there). "Referenced vertices" are the vertices of usable faces.
//! An edge is an unordered pair of distinct vertices that are consecutive in a
//! usable face; a corner whose two neighbouring indices coincide (a face that
//! repeats a vertex consecutively) contributes no edge.

pub mod hausdorff;
pub mod scaled_jacobian;
pub mod stats;
pub mod topology;
pub mod valence;

pub use hausdorff::{
    hausdorff, HausdorffOptions, HausdorffReference, HausdorffReport, HausdorffStats,
};
pub use scaled_jacobian::{scaled_jacobian, ScaledJacobianReport, ScaledJacobianStats};
pub use stats::{mesh_stats, MeshStats};
pub use topology::{topology, Topology};
pub use valence::{valence, ValenceReport, ValenceStats};

use crate::IndexedMesh;

/// Face `f` of `mesh` if it is usable (see the module documentation), else `None`.
pub(crate) fn usable_face(mesh: &IndexedMesh, f: usize) -> Option<&[u32]> {
    let start = *mesh.face_starts.get(f)? as usize;
    let end = *mesh.face_starts.get(f + 1)? as usize;
    let face = mesh.indices.get(start..end)?;
    let n = mesh.positions.len();
    (face.len() >= 3 && face.iter().all(|&v| (v as usize) < n)).then_some(face)
}

/// All usable faces with their face index.
pub(crate) fn usable_faces(mesh: &IndexedMesh) -> impl Iterator<Item = (usize, &[u32])> + '_ {
    (0..mesh.face_count()).filter_map(move |f| usable_face(mesh, f).map(|face| (f, face)))
}

/// The undirected edges of the usable faces, built by sorting edge keys
/// (`O(n log n)` in the number of corners).
pub(crate) struct EdgeTable {
    /// Unique edges `[lo, hi]` with `lo < hi`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// Number of face sides on each edge (1 = boundary, 2 = interior, more = non-manifold).
    pub face_count: Vec<u32>,
}

impl EdgeTable {
    pub fn new(mesh: &IndexedMesh) -> Self {
        let mut keys: Vec<[u32; 2]> = Vec::with_capacity(mesh.indices.len());
        for (_, face) in usable_faces(mesh) {
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                if a != b {
                    keys.push([a.min(b), a.max(b)]);
                }
            }
        }
        keys.sort_unstable();
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(keys.len() / 2 + 1);
        let mut face_count: Vec<u32> = Vec::with_capacity(keys.len() / 2 + 1);
        for k in keys {
            if edges.last() == Some(&k) {
                if let Some(c) = face_count.last_mut() {
                    *c += 1;
                }
            } else {
                edges.push(k);
                face_count.push(1);
            }
        }
        EdgeTable { edges, face_count }
    }

    /// Iterates over the boundary edges (exactly one incident face side).
    pub fn boundary_edges(&self) -> impl Iterator<Item = [u32; 2]> + '_ {
        self.edges
            .iter()
            .zip(&self.face_count)
            .filter(|(_, &c)| c == 1)
            .map(|(e, _)| *e)
    }
}

/// Per-vertex flag: is the vertex a corner of a usable face.
pub(crate) fn referenced_vertices(mesh: &IndexedMesh) -> Vec<bool> {
    let mut used = vec![false; mesh.positions.len()];
    for (_, face) in usable_faces(mesh) {
        for &v in face {
            used[v as usize] = true;
        }
    }
    used
}

/// Union-find over `0..n` with path halving and union by size.
pub(crate) struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    pub fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    pub fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let grand = self.parent[self.parent[a as usize] as usize];
            self.parent[a as usize] = grand;
            a = grand;
        }
        a
    }

    pub fn union(&mut self, a: u32, b: u32) {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        if self.size[ra as usize] < self.size[rb as usize] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
    }
}
