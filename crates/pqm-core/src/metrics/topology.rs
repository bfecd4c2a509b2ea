//! Topological invariants of a polygon soup.
//!
//! ## Definitions (they match `shared/meshes/inspect.py` and its MANIFEST)
//!
//! * `vertices` — referenced vertices (corners of usable faces; see the
//!   [module documentation](super)); `edges` — distinct undirected edges;
//!   `faces` — usable faces.
//! * **Euler characteristic** `χ = V − E + F` over those counts.
//! * **Components** — classes of referenced vertices under "share a face"
//!   (union-find over the corners of each face), so faces touching at a single
//!   vertex are one component.
//! * **Boundary loops** — a boundary edge has exactly one incident face side;
//!   a boundary loop is a connected component of the graph formed by the
//!   boundary edges (union-find over their end points). On a manifold mesh this
//!   is exactly the set of loops obtained by tracing the boundary; two holes
//!   pinched together at one vertex count as one.
//! * **Genus** — `Σ_c (2 − χ_c − b_c) / 2` over the components `c`, with `χ_c`
//!   and `b_c` the Euler characteristic and boundary-loop count of that
//!   component. It is the genus for orientable manifold meshes; for other
//!   inputs the per-component value is rounded down (`div_euclid`) and can be
//!   meaningless (a Möbius strip gives 0).
//! * **Forced irregular vertices** — `Σ_c max(0, 4 χ_c)` over the *closed*
//!   components (no boundary edge). On a closed quad mesh every edge has two
//!   face sides, so `4F = 2E` and `Σ_v (4 − valence_v) = 4V − 2E = 4χ`; a
//!   vertex of valence 3 adds 1 and none adds more unless it has valence 2
//!   (a doublet, which the coarsener removes). So a closed genus-0 component
//!   (`χ = 2`) of a doublet-free quad mesh has at least 8 irregular
//!   vertices, whatever its connectivity — the cube's 8 corners: a lower
//!   bound on `extraordinary` (see [`mod@super::valence`]) that no coarsener can
//!   beat without changing the topology. Components with a boundary are left
//!   out (their corners may be ideal at valence 2).
//!
//! All counts are `O(n log n)` (edge table by sorting) plus near-linear union-find.

use super::{referenced_vertices, usable_faces, EdgeTable, UnionFind};
use crate::IndexedMesh;
use serde::Serialize;

/// Topological counts of a mesh (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Topology {
    /// Referenced vertices.
    pub vertices: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Usable faces.
    pub faces: usize,
    /// Edges with exactly one incident face side.
    pub boundary_edges: usize,
    /// Edges with more than two incident face sides.
    pub nonmanifold_edges: usize,
    /// `χ = V − E + F`.
    pub euler: i64,
    /// Connected components (faces sharing a vertex are connected).
    pub components: usize,
    /// Connected components of the boundary-edge graph.
    pub boundary_loops: usize,
    /// `Σ_c (2 − χ_c − b_c) / 2`.
    pub genus: i64,
    /// `Σ_c max(0, 4 χ_c)` over closed components: at least this many
    /// vertices of a doublet-free quad mesh of this topology are irregular.
    pub forced_irregular: usize,
}

/// Computes the [`Topology`] of `mesh`.
pub fn topology(mesh: &IndexedMesh) -> Topology {
    let n = mesh.positions.len();
    let used = referenced_vertices(mesh);
    let table = EdgeTable::new(mesh);

    let mut components = UnionFind::new(n);
    let mut faces = 0usize;
    for (_, face) in usable_faces(mesh) {
        faces += 1;
        for &v in &face[1..] {
            components.union(face[0], v);
        }
    }
    let mut boundary = UnionFind::new(n);
    let mut boundary_edges = 0usize;
    for [a, b] in table.boundary_edges() {
        boundary.union(a, b);
        boundary_edges += 1;
    }
    let nonmanifold_edges = table.face_count.iter().filter(|&&c| c > 2).count();

    // Per-component tallies, indexed by the component's union-find root.
    // chi[root] accumulates V − E + F, loops[root] the boundary loops.
    let mut chi = vec![0i64; n];
    let mut loops = vec![0i64; n];
    let mut is_root = vec![false; n];
    let mut vertices = 0usize;
    for (v, &u) in used.iter().enumerate() {
        if u {
            vertices += 1;
            let r = components.find(v as u32) as usize;
            is_root[r] = true;
            chi[r] += 1;
        }
    }
    for [a, _] in &table.edges {
        chi[components.find(*a) as usize] -= 1;
    }
    for (_, face) in usable_faces(mesh) {
        chi[components.find(face[0]) as usize] += 1;
    }
    let mut boundary_loops = 0usize;
    let mut counted = vec![false; n];
    for [a, _] in table.boundary_edges() {
        let loop_root = boundary.find(a) as usize;
        if !counted[loop_root] {
            counted[loop_root] = true;
            boundary_loops += 1;
            loops[components.find(a) as usize] += 1;
        }
    }
    let mut genus = 0i64;
    let mut component_count = 0usize;
    let mut forced_irregular = 0usize;
    for r in 0..n {
        if is_root[r] {
            component_count += 1;
            genus += (2 - chi[r] - loops[r]).div_euclid(2);
            if loops[r] == 0 {
                forced_irregular += (4 * chi[r]).max(0) as usize;
            }
        }
    }
    Topology {
        vertices,
        edges: table.edges.len(),
        faces,
        boundary_edges,
        nonmanifold_edges,
        euler: vertices as i64 - table.edges.len() as i64 + faces as i64,
        components: component_count,
        boundary_loops,
        genus,
        forced_irregular,
    }
}
