//! Vertex structure of a quad mesh: valences against their ideal values.
//!
//! ## Definitions
//!
//! * **Valence** of a vertex: the number of distinct edges incident to it
//!   (edges as in the [module documentation](super)), counted from the sorted
//!   edge table, `O(n log n)`.
//! * **Boundary vertex**: a vertex on a boundary edge (an edge with exactly one
//!   incident face side). All other referenced vertices are interior.
//! * **Ideal valence** — the quad-mesh ideal, for every face type:
//!   - interior vertex: **4**;
//!   - boundary vertex: `max(2, round(θ / 90°) + 1)`, where `θ` is the sum of
//!     the corner angles of the faces at that vertex (each corner angle in
//!     `[0°, 180°]`, `atan2(|e1 × e2|, e1 · e2)`). A regular quad boundary has
//!     `θ/90°` quads around the vertex and one more edge than quads. So a
//!     **corner** (`θ < 135°`) has ideal valence **2**, a **smooth boundary**
//!     vertex (`135° ≤ θ < 225°`) has **3**, and a concave boundary vertex
//!     (`225° ≤ θ < 315°`) has 4, and so on (halves round up).
//! * **Ideal fraction**: ideal vertices / referenced vertices (0 when there
//!   are none). **Extraordinary**: number of referenced vertices that are not
//!   ideal.
//! * **Worst**: the valence of the referenced vertex whose valence is farthest
//!   from its ideal (absolute difference); among ties the larger valence wins.
//!   A perfect mesh therefore reports 4 (or 3 / 2 for meshes that are only a
//!   boundary strip), like the "worst case valence" column of the paper. The
//!   cube reports 3, an empty mesh 0.

use super::{referenced_vertices, usable_faces, EdgeTable};
use crate::IndexedMesh;
use serde::Serialize;

/// The three valence figures of the paper's Table 1.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ValenceStats {
    /// Ideal vertices / referenced vertices, in `[0, 1]`.
    pub ideal_fraction: f64,
    /// Number of referenced vertices whose valence is not ideal.
    pub extraordinary: usize,
    /// Valence of the vertex farthest from its ideal (ties: larger valence).
    pub worst: u32,
}

/// Full valence report.
#[derive(Clone, Debug, PartialEq)]
pub struct ValenceReport {
    /// The summary figures.
    pub stats: ValenceStats,
    /// `histogram[k]` = number of referenced vertices of valence `k`.
    pub histogram: Vec<usize>,
    /// Valence per vertex (0 for unreferenced vertices), aligned with `positions`.
    pub valence: Vec<u32>,
    /// Ideal valence per vertex (0 for unreferenced vertices).
    pub ideal: Vec<u32>,
}

/// Ideal valence of a boundary vertex whose incident corner angles sum to
/// `angle_sum` radians: `max(2, round(angle_sum / (π/2)) + 1)`.
pub fn boundary_ideal_valence(angle_sum: f64) -> u32 {
    let quads = (angle_sum / std::f64::consts::FRAC_PI_2).round();
    // `as` saturates, and a NaN angle (non-finite coordinates) becomes 0 → ideal 2.
    ((quads as u32).saturating_add(1)).max(2)
}

/// Valence statistics of `mesh` (see the module documentation).
pub fn valence(mesh: &IndexedMesh) -> ValenceReport {
    let n = mesh.positions.len();
    let table = EdgeTable::new(mesh);
    let mut valence = vec![0u32; n];
    let mut on_boundary = vec![false; n];
    for (e, &c) in table.edges.iter().zip(&table.face_count) {
        for &v in e {
            valence[v as usize] += 1;
            if c == 1 {
                on_boundary[v as usize] = true;
            }
        }
    }
    // Corner angle sums, needed for boundary vertices only.
    let mut angle_sum = vec![0.0f64; n];
    for (_, face) in usable_faces(mesh) {
        let k = face.len();
        for i in 0..k {
            let v = face[i] as usize;
            if !on_boundary[v] {
                continue;
            }
            let p = mesh.positions[v];
            let e1 = mesh.positions[face[(i + 1) % k] as usize] - p;
            let e2 = mesh.positions[face[(i + k - 1) % k] as usize] - p;
            angle_sum[v] += e1.cross(e2).length().atan2(e1.dot(e2));
        }
    }
    let used = referenced_vertices(mesh);
    let mut ideal = vec![0u32; n];
    let mut histogram: Vec<usize> = Vec::new();
    let (mut referenced, mut ideal_count) = (0usize, 0usize);
    let mut worst: Option<(u32, u32)> = None; // (deviation, valence)
    for v in 0..n {
        if !used[v] {
            valence[v] = 0;
            continue;
        }
        referenced += 1;
        ideal[v] = if on_boundary[v] {
            boundary_ideal_valence(angle_sum[v])
        } else {
            4
        };
        let k = valence[v];
        if histogram.len() <= k as usize {
            histogram.resize(k as usize + 1, 0);
        }
        histogram[k as usize] += 1;
        if k == ideal[v] {
            ideal_count += 1;
        }
        let candidate = (k.abs_diff(ideal[v]), k);
        // `None < Some(_)` and tuples compare lexicographically: deviation, then valence.
        worst = worst.max(Some(candidate));
    }
    let stats = ValenceStats {
        ideal_fraction: if referenced > 0 {
            ideal_count as f64 / referenced as f64
        } else {
            0.0
        },
        extraordinary: referenced - ideal_count,
        worst: worst.map_or(0, |(_, k)| k),
    };
    ValenceReport {
        stats,
        histogram,
        valence,
        ideal,
    }
}
