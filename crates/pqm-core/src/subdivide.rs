//! Catmull-Clark split of an [`IndexedMesh`]: one step turns any polygon mesh
//! (triangles, quads, n-gons, mixed) into a pure quad mesh.
//!
//! # What one step does
//!
//! Every face with `n` corners `v_0 … v_{n-1}` (counter-clockwise) becomes `n`
//! quads. With `e_i` the point on the edge `v_i → v_{i+1}` and `f` the face
//! point, quad `i` is `(v_i, e_i, f, e_{i-1})` (indices mod `n`), which keeps
//! the orientation of the input face.
//!
//! Positions depend on [`SplitMode`]:
//!
//! * [`SplitMode::Linear`]: edge point = edge midpoint, face point = centroid
//!   of the face's vertices, original vertices keep their positions. For planar
//!   faces the surface does not change (every new point lies in its face).
//! * [`SplitMode::CatmullClark`]: the classic rules of Catmull & Clark (1978):
//!   face point = centroid; interior edge point = average of its two endpoints
//!   and the two adjacent face points; interior vertex
//!   `v' = (F + 2R + (n − 3)·P) / n` with `P` the old position, `n` the number
//!   of incident edges, `F` the average of the incident face points and `R` the
//!   average of the incident edge midpoints.
//!
//! # Boundary, crease and corner rules (CatmullClark mode)
//!
//! * A boundary edge (one incident face) gets its midpoint.
//! * A boundary vertex with exactly two boundary edges and at least two incident
//!   faces follows the cubic B-spline curve rule `3/4·P + 1/8·(a + b)`, where `a`
//!   and `b` are its two boundary neighbours, so a boundary curve only depends on
//!   boundary vertices and two meshes sharing a boundary stay watertight.
//! * A **corner** keeps its position: a boundary vertex with exactly one
//!   incident face (for example the corners of a grid), or a boundary vertex
//!   with more than two boundary edges (a non-manifold "bow-tie" vertex, for
//!   which the curve rule has no single pair of neighbours).
//! * There are no other creases: the mesh carries no sharpness tags.
//! * Vertices used by no face keep their position.
//!
//! # Numbering of the output (other code relies on it)
//!
//! With `V` input vertices, `E` undirected edges and `F` faces:
//!
//! * vertices `0..V` are the input vertices, in input order;
//! * vertices `V..V + E` are the edge points. The edge of flat corner `c`
//!   (corner `i` of face `f`, `c = face_starts[f] + i`) is the edge
//!   `face[i] → face[(i + 1) % n]`. Edges are numbered by the first corner, in
//!   flat `indices` order, that uses them: scanning faces in order and the
//!   corners of each face in order, each not-yet-seen edge takes the next
//!   number;
//! * vertices `V + E..V + E + F` are the face points, in face order;
//! * output face `c` is the quad of flat input corner `c`: all quads of face 0
//!   (in corner order), then those of face 1, … So input face `f` becomes the
//!   output faces `face_starts[f]..face_starts[f + 1]`, and a group starting at
//!   input face `f` starts at output face `face_starts[f]`.
//!
//! # Attributes
//!
//! * `texcoords` (per corner) are carried through with face-varying linear
//!   interpolation in both modes: output texcoords are the input ones (same
//!   indices), then one per input corner `c` (index `T + c`, midpoint of the
//!   texcoords of corners `c` and its successor in the same face), then one per
//!   face (index `T + C + f`, average of the face's corner texcoords), with
//!   `T` = number of input texcoords and `C` = number of input corners. Seams
//!   therefore stay seams. Nothing is deduplicated.
//! * `normals` / `corner_normals` are dropped: the split changes the surface,
//!   so callers recompute normals.
//! * `vertex_scalars` are carried: an edge point gets the average of its two
//!   endpoints, a face point the average of its face's vertices, original
//!   vertices keep their values (linear in both modes).
//! * `groups` are remapped as above.
//!
//! Orientation is never checked: each face is split on its own, so an input
//! with consistently oriented faces gives a consistently oriented output, and
//! an inconsistent input stays just as inconsistent.
//!
//! # Cost
//!
//! O(C log k) time and O(V + C) memory for `C` corners and maximum vertex
//! valence `k`: edges are found without hashing, by bucketing each corner's
//! edge under its smaller endpoint (a CSR over vertices) and sorting each
//! (valence-sized) bucket.

use crate::indexed::IndexedMesh;
use glam::DVec3;
use thiserror::Error;

/// How new points are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SplitMode {
    /// Midpoints and centroids; original vertices do not move. The surface of
    /// planar faces is unchanged.
    Linear,
    /// Catmull-Clark smoothing rules (see the module documentation).
    CatmullClark,
}

/// Why a mesh cannot be split.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum SubdivideError {
    /// `face_starts` is not a valid offset table for `indices`.
    #[error("malformed face table: {0}")]
    MalformedFaces(String),
    /// A face has fewer than three corners.
    #[error("face {face} has {len} vertices (a polygon needs at least 3)")]
    DegenerateFace {
        /// The face.
        face: usize,
        /// Its number of corners.
        len: usize,
    },
    /// A face references a vertex that does not exist.
    #[error("face {face} references vertex {vertex}, but the mesh has {vertex_count} vertices")]
    VertexOutOfRange {
        /// The face.
        face: usize,
        /// The bad index.
        vertex: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} repeats vertex {vertex}")]
    RepeatedVertex {
        /// The face.
        face: usize,
        /// The repeated vertex.
        vertex: u32,
    },
    /// An edge is used by more than two faces.
    #[error("non-manifold edge {a}-{b}: used by {count} face sides (at most 2 allowed)")]
    NonManifoldEdge {
        /// Smaller endpoint.
        a: u32,
        /// Larger endpoint.
        b: u32,
        /// Number of face sides using the edge.
        count: usize,
    },
    /// Texture coordinate data is inconsistent.
    #[error("texture coordinates: {0}")]
    BadTexcoords(String),
    /// A per-vertex scalar has the wrong length.
    #[error("vertex scalar '{name}' has {len} values for {vertex_count} vertices")]
    BadVertexScalar {
        /// Name of the property.
        name: String,
        /// Its length.
        len: usize,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// The output would need more than `u32::MAX` vertices or corners.
    #[error("output too large: {0}")]
    TooLarge(String),
}

const NONE: u32 = u32::MAX;

/// Edge structure of an input mesh, computed once per split.
struct Topology {
    /// Edge id of each flat corner (the edge from that corner to the next).
    corner_edge: Vec<u32>,
    /// Endpoints of each edge, in the direction of its first use.
    edge_verts: Vec<[u32; 2]>,
    /// The one or two faces of each edge (`NONE` for a missing second face).
    edge_faces: Vec<[u32; 2]>,
}

/// Calls `visit(corner, from, to, face)` for every face side `from → to`, in
/// flat corner order.
#[inline]
fn for_each_side(mesh: &IndexedMesh, mut visit: impl FnMut(usize, u32, u32, u32)) {
    let idx = &mesh.indices;
    for (f, w) in mesh.face_starts.windows(2).enumerate() {
        let (s, e) = (w[0] as usize, w[1] as usize);
        for c in s..e - 1 {
            visit(c, idx[c], idx[c + 1], f as u32);
        }
        visit(e - 1, idx[e - 1], idx[s], f as u32);
    }
}

/// Checks the face table and indices; returns the number of corners.
fn validate(mesh: &IndexedMesh) -> Result<usize, SubdivideError> {
    let fs = &mesh.face_starts;
    let corners = mesh.indices.len();
    if fs.is_empty() {
        if corners == 0 {
            return Ok(0);
        }
        return Err(SubdivideError::MalformedFaces(
            "face_starts is empty but indices is not".into(),
        ));
    }
    if fs[0] != 0 {
        return Err(SubdivideError::MalformedFaces(format!(
            "face_starts[0] is {}, expected 0",
            fs[0]
        )));
    }
    if *fs.last().unwrap_or(&0) as usize != corners {
        return Err(SubdivideError::MalformedFaces(format!(
            "last face_starts entry is {}, but there are {} indices",
            fs[fs.len() - 1],
            corners
        )));
    }
    if corners >= NONE as usize {
        return Err(SubdivideError::TooLarge(format!("{corners} corners")));
    }
    let vc = mesh.positions.len();
    for f in 0..fs.len() - 1 {
        let (s, e) = (fs[f] as usize, fs[f + 1] as usize);
        if e < s || e > corners {
            return Err(SubdivideError::MalformedFaces(format!(
                "face {f} spans corners {s}..{e}, outside 0..{corners} or reversed"
            )));
        }
        if e - s < 3 {
            return Err(SubdivideError::DegenerateFace {
                face: f,
                len: e - s,
            });
        }
        let face = &mesh.indices[s..e];
        for (i, &v) in face.iter().enumerate() {
            if v as usize >= vc {
                return Err(SubdivideError::VertexOutOfRange {
                    face: f,
                    vertex: v,
                    vertex_count: vc,
                });
            }
            // Faces are small, so the quadratic scan is cheaper than any set.
            if face[..i].contains(&v) {
                return Err(SubdivideError::RepeatedVertex { face: f, vertex: v });
            }
        }
    }
    Ok(corners)
}

/// Builds corner → edge numbering without hashing (see the module docs).
fn topology(mesh: &IndexedMesh, corners: usize) -> Result<Topology, SubdivideError> {
    let vc = mesh.positions.len();

    // CSR bucket of every corner's edge under its smaller endpoint; an entry
    // packs (larger endpoint, corner) so one sort groups equal edges and puts
    // the earliest corner of each edge first. Memory is the main cost at this
    // size, so scratch arrays are few and reused.
    let mut end = vec![0u32; vc + 1];
    for_each_side(mesh, |_, a, b, _| end[a.min(b) as usize + 1] += 1);
    for v in 0..vc {
        end[v + 1] += end[v];
    }
    let mut entries = vec![0u64; corners];
    // Filling advances end[v] from the start of bucket v to its end, so
    // afterwards bucket v is end[v - 1]..end[v] (with end[-1] = 0).
    for_each_side(mesh, |c, a, b, _| {
        let lo = a.min(b) as usize;
        entries[end[lo] as usize] = ((a.max(b) as u64) << 32) | c as u64;
        end[lo] += 1;
    });

    // First holds, for every corner, the first corner (in flat order) that
    // uses the same edge; the numbering pass below overwrites it with ids.
    let mut corner_edge = vec![0u32; corners];
    let mut begin = 0usize;
    for v in 0..vc {
        let bucket = &mut entries[begin..end[v] as usize];
        begin = end[v] as usize;
        bucket.sort_unstable();
        let mut i = 0;
        while i < bucket.len() {
            let hi = bucket[i] >> 32;
            let mut j = i + 1;
            while j < bucket.len() && bucket[j] >> 32 == hi {
                j += 1;
            }
            if j - i > 2 {
                return Err(SubdivideError::NonManifoldEdge {
                    a: v as u32,
                    b: hi as u32,
                    count: j - i,
                });
            }
            let first = bucket[i] as u32;
            for &entry in &bucket[i..j] {
                corner_edge[entry as u32 as usize] = first;
            }
            i = j;
        }
    }
    drop(entries);
    drop(end);

    // Number edges in order of their first corner.
    let mut edge_verts = Vec::with_capacity(corners / 2 + 1);
    let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(corners / 2 + 1);
    for_each_side(mesh, |c, a, b, f| {
        let first = corner_edge[c] as usize;
        if first == c {
            corner_edge[c] = edge_verts.len() as u32;
            edge_verts.push([a, b]);
            edge_faces.push([f, NONE]);
        } else {
            // first < c, so corner_edge[first] already holds the edge id.
            let e = corner_edge[first];
            corner_edge[c] = e;
            edge_faces[e as usize][1] = f;
        }
    });
    Ok(Topology {
        corner_edge,
        edge_verts,
        edge_faces,
    })
}

/// Splits every face of `mesh` into quads once (see the module documentation
/// for positions, numbering and attribute handling).
///
/// * `mesh` — any polygon mesh with faces of at least 3 distinct vertices and
///   no edge shared by more than two faces. Positions in any unit; the output
///   uses the same unit.
/// * `mode` — [`SplitMode::Linear`] or [`SplitMode::CatmullClark`].
///
/// Returns a quad-only mesh with `V + E + F` vertices and `C` faces (`C` =
/// number of input corners), or an error naming the offending face or edge.
pub fn catmull_clark_split(
    mesh: &IndexedMesh,
    mode: SplitMode,
) -> Result<IndexedMesh, SubdivideError> {
    let corners = validate(mesh)?;
    let vc = mesh.positions.len();
    let fcount = mesh.face_count();
    let has_tex = !mesh.corner_texcoords.is_empty();
    if has_tex {
        check_texcoords(mesh, corners)?;
    }
    for (name, vals) in &mesh.vertex_scalars {
        if vals.len() != vc {
            return Err(SubdivideError::BadVertexScalar {
                name: name.clone(),
                len: vals.len(),
                vertex_count: vc,
            });
        }
    }
    let topo = topology(mesh, corners)?;
    let ec = topo.edge_verts.len();
    let out_vc = vc as u64 + ec as u64 + fcount as u64;
    if out_vc >= NONE as u64 || corners as u64 * 4 >= NONE as u64 {
        return Err(SubdivideError::TooLarge(format!(
            "{out_vc} vertices and {} corners after the split",
            corners as u64 * 4
        )));
    }
    let (e0, f0) = (vc as u32, (vc + ec) as u32);
    let fs = &mesh.face_starts;
    let idx = &mesh.indices;
    let pos = &mesh.positions;

    // One output buffer, filled in place (verts | edge points | face points):
    // at this size, fresh memory and copies cost more than the arithmetic.
    let mut out_pos = vec![DVec3::ZERO; out_vc as usize];
    let (vert_out, rest) = out_pos.split_at_mut(vc);
    let (edge_out, face_points) = rest.split_at_mut(ec);
    // Face points: centroids in both modes.
    for (f, fp) in face_points.iter_mut().enumerate() {
        let face = &idx[fs[f] as usize..fs[f + 1] as usize];
        *fp = face.iter().map(|&v| pos[v as usize]).sum::<DVec3>() / face.len() as f64;
    }
    let face_points = &*face_points;
    match mode {
        SplitMode::Linear => {
            vert_out.copy_from_slice(pos);
            for (ep, &[a, b]) in edge_out.iter_mut().zip(&topo.edge_verts) {
                *ep = (pos[a as usize] + pos[b as usize]) * 0.5;
            }
        }
        SplitMode::CatmullClark => {
            smoothed_vertices(mesh, &topo, face_points, vert_out);
            let edges = topo.edge_verts.iter().zip(&topo.edge_faces);
            for (ep, (&[a, b], &[f1, f2])) in edge_out.iter_mut().zip(edges) {
                let mid = pos[a as usize] + pos[b as usize];
                *ep = if f2 == NONE {
                    mid * 0.5
                } else {
                    (mid + face_points[f1 as usize] + face_points[f2 as usize]) * 0.25
                };
            }
        }
    }

    // Quads: corner c of face f gives (v_c, e_c, f, e_prev(c)).
    let mut out_idx = Vec::with_capacity(corners * 4);
    let mut out_tc = Vec::with_capacity(if has_tex { corners * 4 } else { 0 });
    let tcount = mesh.texcoords.len() as u32;
    for f in 0..fcount {
        let (s, e) = (fs[f] as usize, fs[f + 1] as usize);
        let mut prev = e - 1;
        // `c` indexes three parallel per-corner arrays and is itself an id.
        #[allow(clippy::needless_range_loop)]
        for c in s..e {
            out_idx.extend_from_slice(&[
                idx[c],
                e0 + topo.corner_edge[c],
                f0 + f as u32,
                e0 + topo.corner_edge[prev],
            ]);
            if has_tex {
                let ct = tcount + corners as u32;
                out_tc.extend_from_slice(&[
                    mesh.corner_texcoords[c],
                    tcount + c as u32,
                    ct + f as u32,
                    tcount + prev as u32,
                ]);
            }
            prev = c;
        }
    }

    let mut texcoords = Vec::new();
    if has_tex {
        let t = |c: usize| mesh.texcoords[mesh.corner_texcoords[c] as usize];
        texcoords.reserve(mesh.texcoords.len() + corners + fcount);
        texcoords.extend_from_slice(&mesh.texcoords);
        for f in 0..fcount {
            let (s, e) = (fs[f] as usize, fs[f + 1] as usize);
            for c in s..e {
                let (a, b) = (t(c), t(if c + 1 == e { s } else { c + 1 }));
                texcoords.push([(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5]);
            }
        }
        for f in 0..fcount {
            let (s, e) = (fs[f] as usize, fs[f + 1] as usize);
            let mut acc = [0.0, 0.0];
            for c in s..e {
                let u = t(c);
                acc[0] += u[0];
                acc[1] += u[1];
            }
            let n = (e - s) as f64;
            texcoords.push([acc[0] / n, acc[1] / n]);
        }
    }

    let vertex_scalars = mesh
        .vertex_scalars
        .iter()
        .map(|(name, vals)| {
            let mut out = Vec::with_capacity(out_vc as usize);
            out.extend_from_slice(vals);
            out.extend(
                topo.edge_verts
                    .iter()
                    .map(|&[a, b]| (vals[a as usize] + vals[b as usize]) * 0.5),
            );
            out.extend((0..fcount).map(|f| {
                let face = &idx[fs[f] as usize..fs[f + 1] as usize];
                face.iter().map(|&v| vals[v as usize]).sum::<f64>() / face.len() as f64
            }));
            (name.clone(), out)
        })
        .collect();

    let groups = mesh
        .groups
        .iter()
        .map(|(name, first)| {
            // A group may start at face_count() (empty trailing group).
            let start = fs.get(*first as usize).copied().unwrap_or(corners as u32);
            (name.clone(), start)
        })
        .collect();

    Ok(IndexedMesh {
        positions: out_pos,
        face_starts: (0..=corners as u32).map(|i| i * 4).collect(),
        indices: out_idx,
        texcoords,
        corner_texcoords: out_tc,
        normals: Vec::new(),
        corner_normals: Vec::new(),
        groups,
        vertex_scalars,
    })
}

fn check_texcoords(mesh: &IndexedMesh, corners: usize) -> Result<(), SubdivideError> {
    if mesh.corner_texcoords.len() != corners {
        return Err(SubdivideError::BadTexcoords(format!(
            "{} corner texcoord indices for {} corners",
            mesh.corner_texcoords.len(),
            corners
        )));
    }
    let tc = mesh.texcoords.len();
    if tc as u64 + 2 * corners as u64 >= NONE as u64 {
        return Err(SubdivideError::TooLarge(format!("{tc} texcoords")));
    }
    if let Some(c) = mesh.corner_texcoords.iter().position(|&t| t as usize >= tc) {
        return Err(SubdivideError::BadTexcoords(format!(
            "corner {c} references texcoord {}, but there are {tc}",
            mesh.corner_texcoords[c]
        )));
    }
    Ok(())
}

/// New positions of the original vertices under the Catmull-Clark rules,
/// accumulated in one pass over corners and one over edges, written to `out`
/// (one entry per input vertex; also used as the face-point accumulator).
fn smoothed_vertices(
    mesh: &IndexedMesh,
    topo: &Topology,
    face_points: &[DVec3],
    out: &mut [DVec3],
) {
    let vc = mesh.positions.len();
    let pos = &mesh.positions;
    // Per vertex: incident face sides, incident edges, boundary edges.
    let mut counts = vec![[0u32; 3]; vc];
    let face_sum = out;
    face_sum.fill(DVec3::ZERO);
    for_each_side(mesh, |_, v, _, f| {
        face_sum[v as usize] += face_points[f as usize];
        counts[v as usize][0] += 1;
    });
    // Sum of neighbour positions over all edges, and over boundary edges.
    let mut nbr_sum = vec![DVec3::ZERO; vc];
    let mut bnd_sum = vec![DVec3::ZERO; vc];
    for (&[a, b], &[_, f2]) in topo.edge_verts.iter().zip(&topo.edge_faces) {
        let (a, b) = (a as usize, b as usize);
        nbr_sum[a] += pos[b];
        nbr_sum[b] += pos[a];
        counts[a][1] += 1;
        counts[b][1] += 1;
        if f2 == NONE {
            bnd_sum[a] += pos[b];
            bnd_sum[b] += pos[a];
            counts[a][2] += 1;
            counts[b][2] += 1;
        }
    }
    for v in 0..vc {
        let p = pos[v];
        let [fc, ec, bc] = counts[v];
        face_sum[v] = match (bc, fc) {
            (_, 0) => p,                                         // isolated vertex
            (2, fc) if fc >= 2 => p * 0.75 + bnd_sum[v] * 0.125, // boundary curve
            (0, _) => {
                let n = ec as f64;
                let f = face_sum[v] / fc as f64;
                // Average of the edge midpoints (p + q) / 2 over neighbours q.
                let r = (p + nbr_sum[v] / n) * 0.5;
                (f + 2.0 * r + (n - 3.0) * p) / n
            }
            _ => p, // corner: one face, or a non-manifold boundary vertex
        };
    }
}

/// Applies [`catmull_clark_split`] `levels` times (`levels == 0` returns a
/// copy of `mesh`). Each level multiplies the face count by about 4 (exactly
/// 4 once the mesh is quad-only), so memory grows as `4^levels`.
pub fn catmull_clark(
    mesh: &IndexedMesh,
    levels: u32,
    mode: SplitMode,
) -> Result<IndexedMesh, SubdivideError> {
    if levels == 0 {
        return Ok(mesh.clone());
    }
    let mut cur = catmull_clark_split(mesh, mode)?;
    for _ in 1..levels {
        cur = catmull_clark_split(&cur, mode)?;
    }
    Ok(cur)
}
