//! Symmetric Hausdorff distance between two polygon meshes, by surface sampling
//! (the Metro approach: Cignoni, Rocchini, Scopigno 1998).
//!
//! ## Method
//!
//! 1. Both meshes are triangulated by [`triangulate`]: quads are split along
//!    their shorter diagonal, other polygons are fanned from their first corner.
//!    Triangles with a non-finite corner are ignored on both sides.
//! 2. Each direction `A → B` samples the surface of `A` deterministically:
//!    * every referenced vertex of `A` (option `sample_vertices`);
//!    * the midpoint of every edge of `A`'s polygons (option `sample_edges`;
//!      quad diagonals and fan edges are not polygon edges);
//!    * face samples (option `sample_faces`): the budget left after the vertex
//!      and edge samples, `max(0, target − vertex samples − edge samples)`, is
//!      shared among the triangles in proportion to their area (running
//!      cumulative rounding, so the counts sum exactly to the budget). A
//!      triangle with `n` samples is cut into `k² ≥ n` congruent sub-triangles
//!      (`k = ⌈√n⌉`) and samples the centroids of `n` of them at evenly spaced
//!      positions of a row-by-row enumeration — a stratified pattern that puts
//!      a single sample at the centroid.
//!
//!    The default `target` is Metro's: **10 × the larger triangle count of the
//!    two meshes**, the same target in both directions
//!    ([`HausdorffOptions::samples`] overrides it).
//! 3. Each sample's distance to the surface of `B` is exact (closest point on
//!    `B`'s triangles through a [`Bvh`]), computed in parallel with rayon.
//!    Consecutive samples of a chunk reuse the previous answer as a hint.
//!
//! ## Output and units
//!
//! For each direction, `max` and `mean` of the sample distances; the symmetric
//! `max` is the larger of the two maxima and the symmetric `mean` is the mean
//! over *all samples of both directions* (sum of distances / total sample
//! count). Every figure is divided by the **reference mesh's bounding-box
//! diagonal** (`reference.bbox_diagonal()`, over all its positions); if that
//! diagonal is zero or not finite, figures are absolute (unit 1).
//!
//! Edge cases: a direction with no sample reports `{max: 0, mean: 0}`; samples
//! taken towards a mesh with no triangle are infinitely far (`max = mean = ∞`).
//! Results are bit-for-bit deterministic (per-chunk partial sums are added in
//! order), independent of the thread count.

use super::{referenced_vertices, usable_faces, EdgeTable};
use crate::bvh::Bvh;
use crate::IndexedMesh;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

/// Sampling options for [`hausdorff`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HausdorffOptions {
    /// Target number of samples per direction. `None` (the default) means
    /// Metro's default, 10 × the larger triangle count of the two meshes.
    /// Vertex and edge samples are always all taken when enabled, so the real
    /// count can exceed a small target.
    pub samples: Option<usize>,
    /// Sample every referenced vertex (default `true`).
    pub sample_vertices: bool,
    /// Sample every polygon edge at its midpoint (default `true`).
    pub sample_edges: bool,
    /// Sample the triangle interiors with the remaining budget (default `true`).
    pub sample_faces: bool,
}

impl Default for HausdorffOptions {
    fn default() -> Self {
        HausdorffOptions {
            samples: None,
            sample_vertices: true,
            sample_edges: true,
            sample_faces: true,
        }
    }
}

/// Maximum and mean distance, in units of the reference bounding-box diagonal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HausdorffStats {
    /// Largest sample distance.
    pub max: f64,
    /// Mean sample distance.
    pub mean: f64,
}

/// Result of [`hausdorff`]; all distances are in units of `unit`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HausdorffReport {
    /// Samples on `mesh`, distances to `reference`.
    pub forward: HausdorffStats,
    /// Samples on `reference`, distances to `mesh`.
    pub backward: HausdorffStats,
    /// `max` of both maxima; `mean` over all samples of both directions.
    pub symmetric: HausdorffStats,
    /// Number of samples taken on `mesh`.
    pub forward_samples: usize,
    /// Number of samples taken on `reference`.
    pub backward_samples: usize,
    /// The length unit: the reference's bounding-box diagonal (1 if it is 0).
    pub unit: f64,
}

/// Symmetric sampled Hausdorff distance between `mesh` and `reference`, in
/// units of the reference's bounding-box diagonal (see the module documentation).
pub fn hausdorff(
    mesh: &IndexedMesh,
    reference: &IndexedMesh,
    opts: &HausdorffOptions,
) -> HausdorffReport {
    let tris_mesh = finite_triangles(mesh);
    let tris_ref = finite_triangles(reference);
    let target = opts
        .samples
        .unwrap_or(10 * tris_mesh.len().max(tris_ref.len()));
    let bvh_mesh = Bvh::build(&mesh.positions, &tris_mesh).ok();
    let bvh_ref = Bvh::build(&reference.positions, &tris_ref).ok();

    let forward = one_sided(mesh, &tris_mesh, bvh_ref.as_ref(), target, opts);
    let backward = one_sided(reference, &tris_ref, bvh_mesh.as_ref(), target, opts);

    let diag = reference.bbox_diagonal();
    let unit = if diag.is_finite() && diag > 0.0 {
        diag
    } else {
        1.0
    };
    let all = Accumulator::merge(forward, backward);
    HausdorffReport {
        forward: forward.stats(unit),
        backward: backward.stats(unit),
        symmetric: all.stats(unit),
        forward_samples: forward.count,
        backward_samples: backward.count,
        unit,
    }
}

/// Splits the usable faces of `mesh` into triangles (vertex index triples):
/// triangles are kept, quads are split along the shorter diagonal (`v0–v2`
/// on ties), larger polygons are fanned from their first corner.
pub fn triangulate(mesh: &IndexedMesh) -> Vec<[u32; 3]> {
    let mut out = Vec::with_capacity(mesh.indices.len());
    for (_, f) in usable_faces(mesh) {
        match f.len() {
            3 => out.push([f[0], f[1], f[2]]),
            4 => {
                let p = |i: usize| mesh.positions[f[i] as usize];
                if (p(0) - p(2)).length_squared() <= (p(1) - p(3)).length_squared() {
                    out.push([f[0], f[1], f[2]]);
                    out.push([f[0], f[2], f[3]]);
                } else {
                    out.push([f[0], f[1], f[3]]);
                    out.push([f[1], f[2], f[3]]);
                }
            }
            _ => {
                for i in 1..f.len() - 1 {
                    out.push([f[0], f[i], f[i + 1]]);
                }
            }
        }
    }
    out
}

fn finite_triangles(mesh: &IndexedMesh) -> Vec<[u32; 3]> {
    let mut tris = triangulate(mesh);
    tris.retain(|t| t.iter().all(|&v| mesh.positions[v as usize].is_finite()));
    tris
}

/// Running max / sum / count of sample distances (absolute units).
#[derive(Clone, Copy, Debug, Default)]
struct Accumulator {
    max: f64,
    sum: f64,
    count: usize,
}

impl Accumulator {
    fn add(&mut self, d: f64) {
        self.max = self.max.max(d);
        self.sum += d;
        self.count += 1;
    }
    fn merge(a: Accumulator, b: Accumulator) -> Accumulator {
        Accumulator {
            max: a.max.max(b.max),
            sum: a.sum + b.sum,
            count: a.count + b.count,
        }
    }
    fn stats(&self, unit: f64) -> HausdorffStats {
        if self.count == 0 {
            return HausdorffStats {
                max: 0.0,
                mean: 0.0,
            };
        }
        HausdorffStats {
            max: self.max / unit,
            mean: self.sum / self.count as f64 / unit,
        }
    }
}

/// Points per parallel task; consecutive points share the closest-point hint.
const CHUNK: usize = 2048;

/// Distances from the samples of `from` to `to` (absolute units).
fn one_sided(
    from: &IndexedMesh,
    from_tris: &[[u32; 3]],
    to: Option<&Bvh>,
    target: usize,
    opts: &HausdorffOptions,
) -> Accumulator {
    let pos = &from.positions;
    let measure = |points: &mut dyn Iterator<Item = DVec3>| -> Accumulator {
        let mut acc = Accumulator::default();
        let mut hint = None;
        for p in points {
            if !p.is_finite() {
                continue;
            }
            match to.and_then(|bvh| bvh.search(p, hint)) {
                Some((_, slot, d2)) => {
                    hint = Some(slot);
                    acc.add(d2.sqrt());
                }
                None => acc.add(f64::INFINITY),
            }
        }
        acc
    };
    let mut partial: Vec<Accumulator> = Vec::new();
    let mut used_samples = 0usize;

    if opts.sample_vertices {
        let used = referenced_vertices(from);
        let verts: Vec<u32> = (0..pos.len() as u32)
            .filter(|&v| used[v as usize])
            .collect();
        used_samples += verts.len();
        partial.par_extend(
            verts
                .par_chunks(CHUNK)
                .map(|chunk| measure(&mut chunk.iter().map(|&v| pos[v as usize]))),
        );
    }
    if opts.sample_edges {
        let edges = EdgeTable::new(from).edges;
        used_samples += edges.len();
        partial.par_extend(edges.par_chunks(CHUNK).map(|chunk| {
            measure(
                &mut chunk
                    .iter()
                    .map(|&[a, b]| 0.5 * (pos[a as usize] + pos[b as usize])),
            )
        }));
    }
    if opts.sample_faces {
        let budget = target.saturating_sub(used_samples);
        let counts = face_sample_counts(pos, from_tris, budget);
        // Chunks of triangles holding about CHUNK samples each.
        let tris_per_chunk = (CHUNK * from_tris.len() / budget.max(1)).clamp(1, CHUNK);
        partial.par_extend(
            from_tris
                .par_chunks(tris_per_chunk)
                .zip(counts.par_chunks(tris_per_chunk))
                .map(|(tris, counts)| {
                    let mut it = tris.iter().zip(counts).flat_map(|(t, &n)| {
                        let [a, b, c] = t.map(|v| pos[v as usize]);
                        TriangleSamples::new(a, b, c, n as usize)
                    });
                    measure(&mut it)
                }),
        );
    }
    partial
        .into_iter()
        .fold(Accumulator::default(), Accumulator::merge)
}

/// Number of face samples per triangle: `budget` shared in proportion to area
/// by cumulative rounding (counts sum to `budget` unless the area is zero).
fn face_sample_counts(pos: &[DVec3], tris: &[[u32; 3]], budget: usize) -> Vec<u32> {
    let areas: Vec<f64> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    let total: f64 = areas.iter().sum();
    if !(total > 0.0 && total.is_finite()) || budget == 0 {
        return vec![0; tris.len()];
    }
    let mut cumulative = 0.0;
    let mut emitted = 0u64;
    areas
        .iter()
        .map(|&a| {
            cumulative += a;
            let upto = ((cumulative / total) * budget as f64)
                .round()
                .min(budget as f64) as u64;
            let n = upto.saturating_sub(emitted);
            emitted = emitted.max(upto);
            n.min(u32::MAX as u64) as u32
        })
        .collect()
}

/// Stratified samples of one triangle: centroids of `n` of the `k²` congruent
/// sub-triangles (`k = ⌈√n⌉`), at evenly spaced positions in a row-by-row
/// enumeration (row `r` along `ac` holds `2(k−r)−1` sub-triangles,
/// alternating upright and inverted).
pub(crate) struct TriangleSamples {
    a: DVec3,
    ab: DVec3,
    ac: DVec3,
    n: usize,
    k: usize,
    i: usize,
    row: usize,
    row_start: usize,
}

impl TriangleSamples {
    pub(crate) fn new(a: DVec3, b: DVec3, c: DVec3, n: usize) -> Self {
        let mut k = (n as f64).sqrt().ceil() as usize;
        while k * k < n {
            k += 1;
        }
        TriangleSamples {
            a,
            ab: b - a,
            ac: c - a,
            n,
            k,
            i: 0,
            row: 0,
            row_start: 0,
        }
    }
}

impl Iterator for TriangleSamples {
    type Item = DVec3;
    fn next(&mut self) -> Option<DVec3> {
        if self.i >= self.n {
            return None;
        }
        let k = self.k;
        // Evenly spaced pick among k² sub-triangles (strictly increasing in i).
        let j = ((2 * self.i + 1) * k * k) / (2 * self.n);
        self.i += 1;
        while j >= self.row_start + 2 * (k - self.row) - 1 {
            self.row_start += 2 * (k - self.row) - 1;
            self.row += 1;
        }
        let pos = j - self.row_start;
        let off = if pos % 2 == 0 { 1.0 / 3.0 } else { 2.0 / 3.0 };
        let u = ((pos / 2) as f64 + off) / k as f64;
        let v = (self.row as f64 + off) / k as f64;
        Some(self.a + self.ab * u + self.ac * v)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.n - self.i, Some(self.n - self.i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_samples_are_inside_and_distinct() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        for n in 1..60 {
            let pts: Vec<DVec3> = TriangleSamples::new(a, b, c, n).collect();
            assert_eq!(pts.len(), n);
            for p in &pts {
                assert!(p.x > 0.0 && p.y > 0.0 && p.x + p.y < 1.0, "n={n} {p:?}");
            }
            for i in 0..n {
                for j in 0..i {
                    assert!((pts[i] - pts[j]).length() > 1e-9, "n={n} repeats a sample");
                }
            }
        }
        let centroid: Vec<DVec3> = TriangleSamples::new(a, b, c, 1).collect();
        assert!((centroid[0] - DVec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn face_counts_sum_to_budget_and_follow_area() {
        let pos = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        ];
        let tris = [[0, 1, 2], [0, 3, 4]]; // areas 0.5 and 4.5
        let counts = face_sample_counts(&pos, &tris, 100);
        assert_eq!(counts.iter().sum::<u32>(), 100);
        assert_eq!(counts, vec![10, 90]);
    }
}
