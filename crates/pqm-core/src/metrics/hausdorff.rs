//! Symmetric Hausdorff distance between two polygon meshes, by surface sampling
//! (the Metro approach: Cignoni, Rocchini, Scopigno 1998).
//!
//! ## Method
//!
//! 1. Both meshes are triangulated like [`triangulate`]: quads are split along
//!    their shorter diagonal, other polygons are fanned from their first
//!    corner. Faces with a non-finite corner are left out of the surface.
//! 2. Each direction `A → B` samples the surface of `A` deterministically:
//!    * every vertex of `A`'s faces (option `sample_vertices`);
//!    * points on every edge of `A`'s polygons (option `sample_edges`; quad
//!      diagonals and fan edges are not polygon edges), spaced like Metro's:
//!      with `ρ = target / area(A)` face samples per unit area, edges get
//!      `√ρ` samples per unit length (the face samples' linear spacing),
//!      edge by edge with the fractional part carried over, but at least
//!      one — the midpoint — per edge (and at most `target` in all). An edge
//!      with `m` samples takes the points at `j/(m+1)`, `j = 1..=m`, of its
//!      length. On a mesh much coarser than the other one this samples its
//!      edges densely, where the error of a simplified mesh often peaks;
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
//!    ([`HausdorffOptions::samples`] overrides it). For a quad mesh that is
//!    about 20 samples per quad.
//! 3. Each sample's distance to the surface of `B` is exact: the closest point
//!    on `B`'s triangles through a [`Bvh`]. Samples are processed triangle by
//!    triangle (vertex and edge samples are attributed to the first triangle
//!    containing them), sharing one candidate search per triangle (see
//!    `Batch`), in parallel over chunks of triangles with rayon.
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
//! Results are deterministic: per-chunk partial sums are added in a fixed
//! order, independent of the thread count.

use super::usable_faces;
use crate::bvh::{closest_point_on_triangle, Bvh};
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
    let (surf_mesh, surf_ref) = rayon::join(|| Surface::new(mesh), || Surface::new(reference));
    let (bvh_mesh, bvh_ref) = rayon::join(
        || Bvh::build(&mesh.positions, &surf_mesh.tris).ok(),
        || Bvh::build(&reference.positions, &surf_ref.tris).ok(),
    );
    let reference = HausdorffReference {
        positions: std::borrow::Cow::Borrowed(&reference.positions),
        surface: surf_ref,
        bvh: bvh_ref,
        unit: unit_of(reference),
    };
    reference.report(&mesh.positions, &surf_mesh, bvh_mesh.as_ref(), opts)
}

/// A reference surface prepared once — its triangles, its vertex and edge
/// samples and its BVH — for measuring many meshes against it with
/// [`HausdorffReference::measure`] (the levels of one progressive mesh
/// against its finest level, say). `measure(mesh)` gives exactly what
/// [`hausdorff`]`(mesh, reference)` gives; only the reference's share of
/// the work is not repeated.
pub struct HausdorffReference<'a> {
    positions: std::borrow::Cow<'a, [DVec3]>,
    surface: Surface,
    bvh: Option<Bvh>,
    unit: f64,
}

impl HausdorffReference<'static> {
    /// Prepares `reference` (its positions are copied).
    pub fn new(reference: &IndexedMesh) -> Self {
        let surface = Surface::new(reference);
        let bvh = Bvh::build(&reference.positions, &surface.tris).ok();
        HausdorffReference {
            positions: std::borrow::Cow::Owned(reference.positions.clone()),
            surface,
            bvh,
            unit: unit_of(reference),
        }
    }
}

impl HausdorffReference<'_> {
    /// The length unit of every report: the reference's bounding-box
    /// diagonal (1 if it is 0 or not finite).
    pub fn unit(&self) -> f64 {
        self.unit
    }

    /// Symmetric sampled Hausdorff distance between `mesh` and the
    /// reference, as [`hausdorff`] gives it.
    pub fn measure(&self, mesh: &IndexedMesh, opts: &HausdorffOptions) -> HausdorffReport {
        let surf_mesh = Surface::new(mesh);
        let bvh_mesh = Bvh::build(&mesh.positions, &surf_mesh.tris).ok();
        self.report(&mesh.positions, &surf_mesh, bvh_mesh.as_ref(), opts)
    }

    fn report(
        &self,
        positions: &[DVec3],
        surf_mesh: &Surface,
        bvh_mesh: Option<&Bvh>,
        opts: &HausdorffOptions,
    ) -> HausdorffReport {
        let target = opts
            .samples
            .unwrap_or(10 * surf_mesh.tris.len().max(self.surface.tris.len()));
        let forward = one_sided(positions, surf_mesh, self.bvh.as_ref(), target, opts);
        let backward = one_sided(&self.positions, &self.surface, bvh_mesh, target, opts);
        let unit = self.unit;
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
}

/// The reference's bounding-box diagonal, or 1 where it is 0 or not finite.
fn unit_of(reference: &IndexedMesh) -> f64 {
    let diag = reference.bbox_diagonal();
    if diag.is_finite() && diag > 0.0 {
        diag
    } else {
        1.0
    }
}

/// Splits the usable faces of `mesh` into triangles (vertex index triples):
/// triangles are kept, quads are split along the shorter diagonal (`v0–v2`
/// on ties), larger polygons are fanned from their first corner.
pub fn triangulate(mesh: &IndexedMesh) -> Vec<[u32; 3]> {
    let mut out = Vec::with_capacity(mesh.indices.len());
    for (_, f) in usable_faces(mesh) {
        split_face(&mesh.positions, f, |t, _| out.push(t));
    }
    out
}

/// Triangulates one face, calling `emit(triangle, polygon_edges)` where bit
/// `k` of `polygon_edges` says that the triangle's edge `k → k+1` is one of the
/// polygon's own edges (not a diagonal).
fn split_face(pos: &[DVec3], f: &[u32], mut emit: impl FnMut([u32; 3], u8)) {
    let n = f.len();
    match n {
        3 => emit([f[0], f[1], f[2]], 0b111),
        4 => {
            let p = |i: usize| pos[f[i] as usize];
            if (p(0) - p(2)).length_squared() <= (p(1) - p(3)).length_squared() {
                emit([f[0], f[1], f[2]], 0b011);
                emit([f[0], f[2], f[3]], 0b110);
            } else {
                emit([f[0], f[1], f[3]], 0b101);
                emit([f[1], f[2], f[3]], 0b011);
            }
        }
        _ => {
            for i in 1..n - 1 {
                // Edge 0: (0, i) is a polygon edge for i = 1; edge 1: (i, i+1)
                // always; edge 2: (i+1, 0) for the last triangle.
                let mask = (i == 1) as u8 | 0b010 | (((i + 1 == n - 1) as u8) << 2);
                emit([f[0], f[i], f[i + 1]], mask);
            }
        }
    }
}

/// The sampled surface of one mesh: its triangles (faces with a non-finite
/// corner are left out) and, per triangle, the vertex and edge-midpoint
/// samples it owns (each vertex and each edge is owned by the first triangle
/// that contains it, so every one is sampled exactly once).
struct Surface {
    tris: Vec<[u32; 3]>,
    /// Vertex samples owned by triangle `t`: `vertices[vertex_start[t] .. vertex_start[t + 1]]`.
    vertex_start: Vec<u32>,
    vertices: Vec<DVec3>,
    /// Edges (end points) owned by triangle `t`, likewise.
    edge_start: Vec<u32>,
    edges: Vec<[DVec3; 2]>,
}

impl Surface {
    fn new(mesh: &IndexedMesh) -> Surface {
        let pos = &mesh.positions;
        let mut tris: Vec<[u32; 3]> = Vec::with_capacity(mesh.indices.len());
        // (lo, hi, owning triangle) for every polygon edge.
        let mut edge_keys: Vec<(u32, u32, u32)> = Vec::with_capacity(mesh.indices.len());
        for (_, f) in usable_faces(mesh) {
            if !f.iter().all(|&v| pos[v as usize].is_finite()) {
                continue;
            }
            split_face(pos, f, |t, mask| {
                let id = tris.len() as u32;
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if mask & (1 << k) != 0 && a != b {
                        edge_keys.push((a.min(b), a.max(b), id));
                    }
                }
                tris.push(t);
            });
        }
        edge_keys.par_sort_unstable();
        edge_keys.dedup_by_key(|e| (e.0, e.1)); // keeps the first = lowest owner
        let mut vertex_owner = vec![u32::MAX; pos.len()];
        for (t, tri) in tris.iter().enumerate() {
            for &v in tri {
                if vertex_owner[v as usize] == u32::MAX {
                    vertex_owner[v as usize] = t as u32;
                }
            }
        }
        let vertex_items = vertex_owner
            .iter()
            .enumerate()
            .filter(|(_, &o)| o != u32::MAX)
            .map(|(v, &o)| (o, pos[v]));
        let (vertex_start, vertices) = bucket(tris.len(), vertex_items);
        let edge_items = edge_keys
            .iter()
            .map(|&(a, b, o)| (o, [pos[a as usize], pos[b as usize]]));
        let (edge_start, edges) = bucket(tris.len(), edge_items);
        Surface {
            tris,
            vertex_start,
            vertices,
            edge_start,
            edges,
        }
    }
}

/// Groups `(owner, item)` pairs by owner `0..n` (counting sort, stable):
/// returns the `n + 1` offsets and the items.
fn bucket<T: Copy + Default>(
    n: usize,
    items: impl Iterator<Item = (u32, T)> + Clone,
) -> (Vec<u32>, Vec<T>) {
    let mut start = vec![0u32; n + 1];
    for (o, _) in items.clone() {
        start[o as usize + 1] += 1;
    }
    for t in 0..n {
        start[t + 1] += start[t];
    }
    let mut fill = start.clone();
    let mut out = vec![T::default(); start[n] as usize];
    for (o, item) in items {
        out[fill[o as usize] as usize] = item;
        fill[o as usize] += 1;
    }
    (start, out)
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

/// Samples per parallel task (approximately; tasks are whole triangles).
const CHUNK: usize = 4096;
/// Triangles with fewer samples than this query the BVH once per sample.
const BATCH_MIN: usize = 4;
/// Largest candidate list for a batch before falling back to per-sample queries.
const BATCH_CANDIDATES: usize = 48;

/// Distances from the samples of `from` to `to` (absolute units).
fn one_sided(
    pos: &[DVec3],
    from: &Surface,
    to: Option<&Bvh>,
    target: usize,
    opts: &HausdorffOptions,
) -> Accumulator {
    let mut used = 0;
    if opts.sample_vertices {
        used += from.vertices.len();
    }
    let edge_counts: Vec<u32> = if opts.sample_edges {
        let counts = edge_sample_counts(pos, from, target);
        used += counts.iter().map(|&n| n as usize).sum::<usize>();
        counts
    } else {
        Vec::new()
    };
    let budget = if opts.sample_faces {
        target.saturating_sub(used)
    } else {
        0
    };
    let counts = face_sample_counts(pos, &from.tris, budget);
    let total = used + budget;
    let n = from.tris.len();
    let tris_per_chunk = (CHUNK * n / total.max(1)).clamp(1, CHUNK);
    let ranges: Vec<(usize, usize)> = (0..n)
        .step_by(tris_per_chunk)
        .map(|s| (s, (s + tris_per_chunk).min(n)))
        .collect();
    let partial: Vec<Accumulator> = ranges
        .par_iter()
        .map(|&(start, end)| {
            let mut batch = Batch::default();
            let mut acc = Accumulator::default();
            for (t, &count) in counts.iter().enumerate().take(end).skip(start) {
                batch.points.clear();
                if opts.sample_vertices {
                    let r = from.vertex_start[t] as usize..from.vertex_start[t + 1] as usize;
                    batch.points.extend_from_slice(&from.vertices[r]);
                }
                if opts.sample_edges {
                    let r = from.edge_start[t] as usize..from.edge_start[t + 1] as usize;
                    for (&[a, b], &m) in from.edges[r.clone()].iter().zip(&edge_counts[r]) {
                        let step = 1.0 / (m as f64 + 1.0);
                        batch
                            .points
                            .extend((1..=m).map(|j| a + (b - a) * (j as f64 * step)));
                    }
                }
                let [a, b, c] = from.tris[t].map(|v| pos[v as usize]);
                batch
                    .points
                    .extend(TriangleSamples::new(a, b, c, count as usize));
                match to {
                    Some(bvh) if !bvh.is_empty() => batch.measure(bvh, &mut acc),
                    _ => batch.points.iter().for_each(|_| acc.add(f64::INFINITY)),
                }
            }
            acc
        })
        .collect();
    partial
        .into_iter()
        .fold(Accumulator::default(), Accumulator::merge)
}

/// Reusable buffers for measuring the samples of one triangle.
///
/// All samples of a triangle lie in (or, by rounding, next to) it, so they
/// share their candidate triangles: with `T*` the triangle closest to the
/// samples' centroid and `R` the largest sample distance to `T*`, every
/// sample's closest triangle is within `R` of the samples' bounding box. One
/// BVH box query collects those candidates; each sample then starts from its
/// distance to `T*` and scans the candidates, skipping those whose box is
/// already too far. This replaces a full BVH descent per sample. When the
/// candidate list would be long (a coarse mesh sampled against a fine one),
/// each sample gets its own BVH query instead.
#[derive(Default)]
struct Batch {
    points: Vec<DVec3>,
    /// Leaf-order slot of the last closest triangle (a hint for the next query).
    hint: Option<u32>,
    best: Vec<f64>,
    slots: Vec<u32>,
    candidates: Vec<([DVec3; 3], DVec3, DVec3)>,
}

impl Batch {
    fn measure(&mut self, bvh: &Bvh, acc: &mut Accumulator) {
        let k = self.points.len();
        if k < BATCH_MIN {
            for i in 0..k {
                self.measure_one(bvh, self.points[i], acc);
            }
            return;
        }
        let centroid = self.points.iter().copied().sum::<DVec3>() / k as f64;
        let Some((_, star, _)) = bvh.search(centroid, self.hint) else {
            // Only for a non-finite centroid (overflow): measure one by one.
            for i in 0..k {
                self.measure_one(bvh, self.points[i], acc);
            }
            return;
        };
        self.hint = Some(star);
        let [a, b, c] = bvh.slot_corners(star);
        self.best.clear();
        let (mut lo, mut hi, mut r2) = (self.points[0], self.points[0], 0.0f64);
        for &p in &self.points {
            let d2 = (p - closest_point_on_triangle(p, a, b, c)).length_squared();
            self.best.push(d2);
            r2 = r2.max(d2);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        self.slots.clear();
        if !(r2.is_finite()
            && bvh.collect_near_box(lo, hi, r2.sqrt(), BATCH_CANDIDATES, &mut self.slots))
        {
            for i in 0..k {
                self.measure_one(bvh, self.points[i], acc);
            }
            return;
        }
        self.candidates.clear();
        for &s in &self.slots {
            let t = bvh.slot_corners(s);
            self.candidates
                .push((t, t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])));
        }
        for (i, &p) in self.points.iter().enumerate() {
            let mut best = self.best[i];
            for (t, tlo, thi) in &self.candidates {
                let gap = (*tlo - p).max(p - *thi).max(DVec3::ZERO);
                if gap.length_squared() < best {
                    let d2 = (p - closest_point_on_triangle(p, t[0], t[1], t[2])).length_squared();
                    best = best.min(d2);
                }
            }
            acc.add(best.sqrt());
        }
    }

    /// One sample through a full (hinted) BVH query; non-finite samples are skipped.
    fn measure_one(&mut self, bvh: &Bvh, p: DVec3, acc: &mut Accumulator) {
        if let Some((_, slot, d2)) = bvh.search(p, self.hint) {
            self.hint = Some(slot);
            acc.add(d2.sqrt());
        }
    }
}

/// Samples per owned edge of `from` (see the module documentation): `√ρ` per
/// unit length with `ρ = target / area`, the fraction carried from edge to
/// edge as Metro does, at least 1 per edge, at most `target` in all.
fn edge_sample_counts(pos: &[DVec3], from: &Surface, target: usize) -> Vec<u32> {
    let area: f64 = from
        .tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let lengths: Vec<f64> = from.edges.iter().map(|[a, b]| (*b - *a).length()).collect();
    let total_length: f64 = lengths.iter().sum();
    let mut per_length = (target as f64 / area).sqrt();
    per_length = per_length.min(target as f64 / total_length);
    if !per_length.is_finite() {
        per_length = 0.0;
    }
    let mut carry = 0.0f64;
    lengths
        .iter()
        .map(|&l| {
            carry += l * per_length;
            let n = carry.floor();
            carry -= n;
            (n as u32).max(1)
        })
        .collect()
}

/// Number of face samples per triangle: `budget` shared in proportion to area.
fn face_sample_counts(pos: &[DVec3], tris: &[[u32; 3]], budget: usize) -> Vec<u32> {
    let areas: Vec<f64> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    distribute(&areas, budget)
}

/// Shares `budget` among items in proportion to `weights` by cumulative
/// rounding, so the counts sum exactly to `budget` (all zero when the total
/// weight is zero or not finite).
fn distribute(weights: &[f64], budget: usize) -> Vec<u32> {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) || budget == 0 {
        return vec![0; weights.len()];
    }
    let mut cumulative = 0.0;
    let mut emitted = 0u64;
    weights
        .iter()
        .map(|&w| {
            cumulative += w;
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
        let off = if pos & 1 == 0 { 1.0 / 3.0 } else { 2.0 / 3.0 };
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
    fn a_prepared_reference_measures_as_hausdorff_does() {
        let reference = crate::shapes::torus(24, 12, 2.0, 0.5);
        let prepared = HausdorffReference::new(&reference);
        for mesh in [
            crate::shapes::torus(12, 6, 2.0, 0.5),
            crate::shapes::torus(8, 4, 2.1, 0.4),
            crate::shapes::quad_sphere(3, 1.0),
            reference.clone(),
        ] {
            for opts in [
                HausdorffOptions::default(),
                HausdorffOptions {
                    samples: Some(500),
                    sample_edges: false,
                    ..Default::default()
                },
            ] {
                assert_eq!(
                    prepared.measure(&mesh, &opts),
                    hausdorff(&mesh, &reference, &opts)
                );
            }
        }
        assert_eq!(prepared.unit(), reference.bbox_diagonal());
        // closest points are rounded: a mesh's distance to itself is ~1e-16
        assert!(
            prepared
                .measure(&reference, &HausdorffOptions::default())
                .symmetric
                .max
                < 1e-12
        );
    }

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

#[cfg(test)]
mod batch_tests {
    use super::*;

    fn bumpy(nx: usize, ny: usize, phase: f64) -> IndexedMesh {
        let mut positions = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                let (x, y) = (i as f64 / nx as f64, j as f64 / ny as f64);
                let z = 0.1 * (x * 9.0 + phase).sin() * (y * 7.0).cos();
                positions.push(DVec3::new(x, y, z));
            }
        }
        let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
        let mut faces = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        IndexedMesh::from_faces(positions, faces)
    }

    /// The shared-candidate batch must give exactly the per-sample BVH answers.
    #[test]
    fn batches_match_per_sample_queries() {
        for (from, to) in [
            (bumpy(7, 5, 0.0), bumpy(40, 33, 0.3)),
            (bumpy(30, 30, 0.0), bumpy(9, 11, 0.5)),
        ] {
            let surface = Surface::new(&from);
            let target_tris = triangulate(&to);
            let bvh = Bvh::build(&to.positions, &target_tris).unwrap();
            let counts =
                face_sample_counts(&from.positions, &surface.tris, 20 * surface.tris.len());
            let (mut batched, mut single) = (Accumulator::default(), Accumulator::default());
            let mut batch = Batch::default();
            let mut reference = Batch::default();
            let mut batches = 0;
            for (t, tri) in surface.tris.iter().enumerate() {
                let [a, b, c] = tri.map(|v| from.positions[v as usize]);
                batch.points.clear();
                batch
                    .points
                    .extend(TriangleSamples::new(a, b, c, counts[t] as usize));
                let mut one = Accumulator::default();
                batch.measure(&bvh, &mut one);
                let mut expected = Accumulator::default();
                for &p in &batch.points {
                    reference.measure_one(&bvh, p, &mut expected);
                }
                assert_eq!(one.count, expected.count);
                assert!(
                    (one.max - expected.max).abs() <= 1e-12,
                    "{one:?} {expected:?}"
                );
                assert!(
                    (one.sum - expected.sum).abs() <= 1e-9,
                    "{one:?} {expected:?}"
                );
                batched = Accumulator::merge(batched, one);
                single = Accumulator::merge(single, expected);
                batches += (batch.points.len() >= BATCH_MIN) as usize;
            }
            assert!(
                batches > surface.tris.len() / 2,
                "the batch path was exercised"
            );
            assert!(batched.max > 0.0 && (batched.max - single.max).abs() <= 1e-12);
        }
    }

    #[test]
    fn every_vertex_and_edge_is_owned_once() {
        let m = bumpy(6, 4, 0.0);
        let s = Surface::new(&m);
        assert_eq!(s.vertices.len(), 7 * 5);
        assert_eq!(s.edges.len(), 6 * 5 + 7 * 4);
        assert_eq!(*s.vertex_start.last().unwrap() as usize, s.vertices.len());
        assert_eq!(*s.edge_start.last().unwrap() as usize, s.edges.len());
        let mut pts: Vec<[u64; 3]> = s
            .edges
            .iter()
            .map(|[a, b]| (0.5 * (*a + *b)).to_array().map(f64::to_bits))
            .collect();
        pts.sort_unstable();
        pts.dedup();
        assert_eq!(pts.len(), s.edges.len(), "edge midpoints are distinct");
    }
}
