//! Scaled Jacobian of polygon faces.
//!
//! ## Definition
//!
//! For a face with corners `p0 … p(n-1)` in counter-clockwise order, corner `i`
//! has the two edges leaving it, `e1 = p(i+1) − p(i)` and `e2 = p(i−1) − p(i)`
//! (indices mod `n`), and the corner cross product `c = e1 × e2`. With `N` the
//! face's Newell normal (its vector area; the average normal of a non-planar
//! polygon), the corner value is
//!
//! ```text
//!     sj(i) = sign(c · N) · |c| / (|e1| |e2|)          ∈ [−1, 1]
//! ```
//!
//! i.e. `dot(e1 × e2, n) / (|e1| |e2|)` with `n = c / |c|` the *corner* normal,
//! signed against the face normal. For a planar face `c` is parallel to `N`, so
//! this is exactly `dot(e1 × e2, N/|N|) / (|e1| |e2|)` with the face normal, the
//! textbook definition; for a non-planar face it still measures `sin` of the
//! corner angle, and a corner that is folded over (its cross product points
//! against the average normal, e.g. the reflex corner of a dart) is negative.
//! The face value is the minimum over its corners: 1 for a rectangle, `sin θ`
//! for a rhombus of angle `θ`, `≤ 0` for non-convex or folded quads.
//!
//! Degenerate cases (never NaN):
//! * a corner with a zero-length edge (coincident vertices) scores **0** — the
//!   element's Jacobian vanishes there, which is the standard convention;
//! * a corner with `c ⟂ N` exactly scores 0;
//! * a face whose Newell normal vanishes (`|N| ≤ 1e-12 · Σ|e|²`, e.g. a
//!   symmetric bow-tie or a flat-folded face) has no orientation; every
//!   non-degenerate corner is then counted as folded, `−|c| / (|e1| |e2|)`;
//! * non-finite coordinates, faces with fewer than three corners and faces
//!   with out-of-range indices score 0.
//!
//! Triangles and n-gons use the same per-corner formula. Note that this is the
//! *unnormalised* value: an equilateral triangle scores `sin 60° ≈ 0.866`, not 1
//! (some tools rescale triangles by `2/√3`; we do not, so values from mixed
//! meshes are comparable corner by corner). The summary covers every face of
//! the mesh (not only quads); filter `per_face` yourself for a quads-only figure.

use crate::IndexedMesh;
use glam::DVec3;
use serde::Serialize;

/// Summary of the per-face Scaled Jacobians: `median` and `worst` (the minimum).
///
/// For an even number of faces the median is the mean of the two middle
/// values. An empty mesh reports `{median: 0, worst: 0}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ScaledJacobianStats {
    /// Median of the per-face values.
    pub median: f64,
    /// Minimum of the per-face values.
    pub worst: f64,
}

/// Per-face Scaled Jacobians (aligned with the mesh's faces) and their summary.
#[derive(Clone, Debug, PartialEq)]
pub struct ScaledJacobianReport {
    /// One value per face of the mesh, in face order, each in `[−1, 1]`.
    pub per_face: Vec<f64>,
    /// `{median, worst}` over `per_face`.
    pub stats: ScaledJacobianStats,
}

/// Scaled Jacobian of every face of `mesh` and their `{median, worst}` summary.
pub fn scaled_jacobian(mesh: &IndexedMesh) -> ScaledJacobianReport {
    let mut corners: Vec<DVec3> = Vec::with_capacity(8);
    let per_face: Vec<f64> = (0..mesh.face_count())
        .map(|f| match super::usable_face(mesh, f) {
            Some(face) => {
                corners.clear();
                corners.extend(face.iter().map(|&v| mesh.positions[v as usize]));
                polygon_scaled_jacobian(&corners)
            }
            None => 0.0,
        })
        .collect();
    let stats = summarize(&per_face);
    ScaledJacobianReport { per_face, stats }
}

/// Scaled Jacobian of one polygon given by its corner positions in
/// counter-clockwise order (see the module documentation). Fewer than three
/// corners score 0.
pub fn polygon_scaled_jacobian(corners: &[DVec3]) -> f64 {
    // The coarsener's shape checks call this for quads millions of times:
    // inlined with the corner count known, its loops unroll and the `% n`
    // index arithmetic folds (the same operations in the same order, so
    // the same bits).
    match corners.len() {
        4 => scaled_jacobian_of(corners, 4),
        n => scaled_jacobian_of(corners, n),
    }
}

/// [`polygon_scaled_jacobian`] of `corners`, whose length is `n`.
#[inline(always)]
fn scaled_jacobian_of(corners: &[DVec3], n: usize) -> f64 {
    if n < 3 || !corners.iter().all(|p| p.is_finite()) {
        return 0.0;
    }
    let normal = newell_normal(corners, n);
    let scale: f64 = (0..n)
        .map(|i| (corners[(i + 1) % n] - corners[i]).length_squared())
        .sum();
    let oriented = normal.length() > 1e-12 * scale;
    let mut worst = f64::INFINITY;
    for i in 0..n {
        let p = corners[i];
        let e1 = corners[(i + 1) % n] - p;
        let e2 = corners[(i + n - 1) % n] - p;
        let lengths = e1.length() * e2.length();
        let value = if lengths > 0.0 {
            let c = e1.cross(e2);
            let s = (c.length() / lengths).min(1.0);
            if !oriented {
                -s
            } else {
                let d = c.dot(normal);
                if d > 0.0 {
                    s
                } else if d < 0.0 {
                    -s
                } else {
                    0.0
                }
            }
        } else {
            0.0
        };
        // Overflow (huge coordinates) could still produce NaN; never report it.
        let value = if value.is_finite() { value } else { 0.0 };
        worst = worst.min(value);
    }
    worst
}

/// Newell's normal of a polygon: twice its vector area, robust for non-planar
/// and non-convex polygons.
/// `n` is `corners.len()` (inlined, see [`polygon_scaled_jacobian`]).
#[inline(always)]
fn newell_normal(corners: &[DVec3], n: usize) -> DVec3 {
    let mut acc = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (corners[i], corners[(i + 1) % n]);
        acc += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    acc
}

/// `{median, worst}` of a list of values (see [`ScaledJacobianStats`]).
pub fn summarize(values: &[f64]) -> ScaledJacobianStats {
    if values.is_empty() {
        return ScaledJacobianStats {
            median: 0.0,
            worst: 0.0,
        };
    }
    let mut sorted = values.to_vec();
    sorted.sort_unstable_by(f64::total_cmp);
    let m = sorted.len() / 2;
    let median = if sorted.len() % 2 == 1 {
        sorted[m]
    } else {
        0.5 * (sorted[m - 1] + sorted[m])
    };
    ScaledJacobianStats {
        median,
        worst: sorted[0],
    }
}
