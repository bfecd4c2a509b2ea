//! Triangle pairing: a triangle (or triangle-and-quad) mesh made quad-only
//! by joining adjacent triangles two by two, with no new vertex.
//!
//! The other way to make such a mesh quad-only is the linear split
//! ([`crate::subdivide::catmull_clark_split`]): every triangle becomes three
//! quads around new edge and face points, so the quad mesh has about six
//! times the input's vertices and three times its triangles. Pairing keeps
//! the input's vertices, ids and positions, and each quad is two input
//! triangles, which a renderer splitting the quad along that shared edge
//! draws again exactly: the finest level of a progressive file is the
//! input. A pairing is a perfect matching of the triangles' dual graph; a
//! closed manifold triangle mesh always has one (Petersen's theorem: the
//! dual is cubic and bridgeless), a mesh with boundary or an odd number of
//! triangles in a part may not.
//!
//! # What [`pair_triangles`] does
//!
//! 1. **Candidates.** Two triangles can pair across an edge that exactly
//!    these two share, in opposite directions (consistent orientation),
//!    when their far corners differ, they are in the same face group, and
//!    their corner attributes (texture coordinate and normal indices, where
//!    the mesh has them) agree at the edge's two ends, so the quad carries
//!    no seam inside it. The quad of triangles `(a, b, c)` and `(b, a, d)`
//!    is `(a, d, b, c)`, oriented as they are.
//! 2. **Greedy by shape.** Candidates sorted by the quad's quality — the
//!    smallest scaled Jacobian of its four corners against its mean normal
//!    (1 for a rectangle, ≤ 0 for a quad folded or not convex) — best
//!    first, ties by edge order; each joins two free triangles if its
//!    quality is positive.
//! 3. **Augmenting paths.** Each triangle left alone looks for a path of
//!    candidate edges, alternately unpaired and paired, to another one
//!    (breadth first, within [`SEARCH_BUDGET_PER_TRIANGLE`] visits per
//!    triangle over all searches), and flips the path: one more pair. First over candidates of
//!    positive quality, then over any candidate. (No blossom contraction:
//!    the search can miss a path that exists, never finds a wrong one.)
//! 4. **Output.** Faces in input order: a quad stays as it is, a paired
//!    triangle's quad takes the place of the pair's first triangle.
//!
//! If triangles stay unpaired, or a face has more than four corners, the
//! result is an error, and the caller splits instead.
//!
//! Measured (the shared meshes, `pqm encode --triangles pair` against the
//! default split; `docs/figures-history.md`, session 24): fandisk and
//! fertility pair completely, their `.pqm` files 4.2–5.1× smaller.

use crate::indexed::IndexedMesh;
use glam::DVec3;
use std::collections::{HashMap, VecDeque};
use thiserror::Error;

/// Budget of the augmenting-path searches, in triangles visited, per
/// triangle of the mesh (plus a fixed 2^20): past it the searches stop and
/// the triangles left alone are reported. A search may cross the whole
/// mesh (the skull's longest do), but few do: the shared meshes use at
/// most a few visits per triangle in all.
pub const SEARCH_BUDGET_PER_TRIANGLE: usize = 256;

/// Why a mesh cannot be paired into quads.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum PairingError {
    /// `face_starts` is not an offset table of `indices`, or a per-corner
    /// table is not one entry per corner.
    #[error("malformed mesh: {0}")]
    Malformed(String),
    /// A face with other than three or four corners.
    #[error("face {face} has {len} vertices (pairing joins triangles; quads stay as they are)")]
    FaceSize {
        /// The face.
        face: usize,
        /// Its number of corners.
        len: usize,
    },
    /// A face names a vertex that does not exist.
    #[error("face {face} references vertex {vertex}, but the mesh has {vertex_count} vertices")]
    VertexOutOfRange {
        /// The face.
        face: usize,
        /// The vertex index.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// Triangles no pairing found a partner for.
    #[error("{unpaired} of {triangles} triangles have no partner (the first: face {first_face})")]
    Unpaired {
        /// How many.
        unpaired: usize,
        /// Triangles in the mesh.
        triangles: usize,
        /// The first of them, as an input face index.
        first_face: usize,
    },
}

/// What [`pair_triangles`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PairingReport {
    /// Triangles in the input.
    pub triangles: usize,
    /// Quads made (each of two triangles).
    pub pairs: usize,
    /// Pairs the greedy pass made (the rest came from augmenting paths).
    pub greedy_pairs: usize,
    /// Quads whose quality is not positive (folded or not convex): pairs
    /// only the second augmenting pass could make.
    pub folded: usize,
}

/// A pair of triangles across one edge: the quad and its quality.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    quality: f64,
    t: [u32; 2],
    quad: [u32; 4],
}

/// The quality of quad `q`: the smallest scaled Jacobian of its corners
/// against the quad's mean normal (the sum of its corners' cross
/// products); −1 when a corner or the normal is degenerate.
pub fn quad_quality(positions: &[DVec3], q: [u32; 4]) -> f64 {
    let p = q.map(|i| positions[i as usize]);
    let cross = |k: usize| (p[(k + 1) & 3] - p[k]).cross(p[(k + 3) & 3] - p[k]);
    let n = cross(0) + cross(1) + cross(2) + cross(3);
    let ln = n.length();
    // (`ln` may be NaN: only a positive length passes.)
    if ln.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return -1.0;
    }
    let mut worst = f64::INFINITY;
    for k in 0..4 {
        let (e1, e2) = (p[(k + 1) & 3] - p[k], p[(k + 3) & 3] - p[k]);
        let d = e1.length() * e2.length();
        if d.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return -1.0;
        }
        worst = worst.min(e1.cross(e2).dot(n) / (d * ln));
    }
    worst
}

/// The mesh with its triangles joined in pairs (see the module
/// documentation), or why not. Positions, vertex ids, per-vertex scalars
/// and the texture coordinate and normal tables are kept; faces keep their
/// input order (a pair at its first triangle's place), groups their names.
pub fn pair_triangles(mesh: &IndexedMesh) -> Result<(IndexedMesh, PairingReport), PairingError> {
    check_tables(mesh)?;
    let nv = mesh.vertex_count();
    let nf = mesh.face_count();
    let mut tri_index = vec![u32::MAX; nf];
    let mut tris: Vec<u32> = Vec::new();
    for (f, ti) in tri_index.iter_mut().enumerate() {
        let face = mesh.face(f);
        if let Some(&v) = face.iter().find(|&&v| v as usize >= nv) {
            return Err(PairingError::VertexOutOfRange {
                face: f,
                vertex: v,
                vertex_count: nv,
            });
        }
        match face.len() {
            3 => {
                *ti = tris.len() as u32;
                tris.push(f as u32);
            }
            4 => {}
            len => return Err(PairingError::FaceSize { face: f, len }),
        }
    }
    let group_of = face_groups(mesh);
    // Directed edges of the triangles, by undirected key: `(tri, corner)`
    // of each use; a candidate is an edge with exactly two opposite uses.
    let mut uses: HashMap<(u32, u32), Vec<(u32, u8)>> = HashMap::with_capacity(tris.len() * 2);
    let mut keys: Vec<(u32, u32)> = Vec::with_capacity(tris.len() * 3 / 2);
    for (t, &f) in tris.iter().enumerate() {
        let face = mesh.face(f as usize);
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let e = uses.entry(key).or_default();
            if e.is_empty() {
                keys.push(key);
            }
            e.push((t as u32, k as u8));
        }
    }
    // Also the quads' edges: a triangle edge a quad shares is not a
    // manifold interior edge between two triangles.
    for f in 0..nf {
        let face = mesh.face(f);
        if face.len() == 4 {
            for k in 0..4 {
                let (a, b) = (face[k], face[(k + 1) % 4]);
                if let Some(e) = uses.get_mut(&(a.min(b), a.max(b))) {
                    e.push((u32::MAX, k as u8));
                }
            }
        }
    }
    let corner = |f: u32, k: usize| mesh.face_starts[f as usize] as usize + k;
    let attrs_agree = |f1: u32, k1: usize, f2: u32, k2: usize| {
        let (c1, c2) = (corner(f1, k1), corner(f2, k2));
        (mesh.corner_texcoords.is_empty() || mesh.corner_texcoords[c1] == mesh.corner_texcoords[c2])
            && (mesh.corner_normals.is_empty()
                || mesh.corner_normals[c1] == mesh.corner_normals[c2])
    };
    let mut cands: Vec<Candidate> = Vec::new();
    for key in &keys {
        let u = &uses[key];
        let [(t1, k1), (t2, k2)] = u[..] else {
            continue;
        };
        if t1 == u32::MAX || t2 == u32::MAX {
            continue;
        }
        let (f1, f2) = (tris[t1 as usize], tris[t2 as usize]);
        if group_of[f1 as usize] != group_of[f2 as usize] {
            continue;
        }
        let (k1, k2) = (k1 as usize, k2 as usize);
        let (x, y) = (mesh.face(f1 as usize), mesh.face(f2 as usize));
        let (a, b, c) = (x[k1], x[(k1 + 1) % 3], x[(k1 + 2) % 3]);
        let d = y[(k2 + 2) % 3];
        // `y` must run b → a.
        if y[k2] != b || y[(k2 + 1) % 3] != a || c == d || a == b {
            continue;
        }
        if !attrs_agree(f1, k1, f2, (k2 + 1) % 3) || !attrs_agree(f1, (k1 + 1) % 3, f2, k2) {
            continue;
        }
        let quad = [a, d, b, c];
        cands.push(Candidate {
            quality: quad_quality(&mesh.positions, quad),
            t: [t1, t2],
            quad,
        });
    }
    // Best first; the sort is stable, so ties keep edge order.
    let mut order: Vec<u32> = (0..cands.len() as u32).collect();
    order.sort_by(|&i, &j| {
        cands[j as usize]
            .quality
            .total_cmp(&cands[i as usize].quality)
    });
    let mut mate = vec![u32::MAX; tris.len()];
    let mut report = PairingReport {
        triangles: tris.len(),
        ..PairingReport::default()
    };
    for &i in &order {
        let c = cands[i as usize];
        let [t1, t2] = c.t;
        if c.quality > 0.0 && mate[t1 as usize] == u32::MAX && mate[t2 as usize] == u32::MAX {
            mate[t1 as usize] = t2;
            mate[t2 as usize] = t1;
            report.greedy_pairs += 1;
        }
    }
    // Adjacency over candidates: `(other triangle, candidate)` per triangle.
    let mut adj: Vec<Vec<(u32, u32)>> = vec![Vec::new(); tris.len()];
    for (i, c) in cands.iter().enumerate() {
        adj[c.t[0] as usize].push((c.t[1], i as u32));
        adj[c.t[1] as usize].push((c.t[0], i as u32));
    }
    let mut budget = SEARCH_BUDGET_PER_TRIANGLE
        .saturating_mul(tris.len())
        .saturating_add(1 << 20);
    for positive_only in [true, false] {
        augment(&mut mate, &adj, &mut budget, |i| {
            !positive_only || cands[i as usize].quality > 0.0
        });
    }
    let unpaired: Vec<usize> = (0..tris.len()).filter(|&t| mate[t] == u32::MAX).collect();
    if let Some(&t) = unpaired.first() {
        return Err(PairingError::Unpaired {
            unpaired: unpaired.len(),
            triangles: tris.len(),
            first_face: tris[t] as usize,
        });
    }
    // The candidate of each pair, found from its first triangle.
    let mut quad_of = vec![u32::MAX; tris.len()];
    for (t, list) in adj.iter().enumerate() {
        for &(o, i) in list {
            if mate[t] == o {
                quad_of[t] = i;
            }
        }
    }
    let mut out = IndexedMesh {
        positions: mesh.positions.clone(),
        texcoords: mesh.texcoords.clone(),
        normals: mesh.normals.clone(),
        vertex_scalars: mesh.vertex_scalars.clone(),
        ..IndexedMesh::new()
    };
    let mut out_group_first: Vec<(usize, u32)> = Vec::new();
    for f in 0..nf {
        let face = mesh.face(f);
        let (verts, corners): ([u32; 4], [usize; 4]) = if face.len() == 4 {
            (
                [face[0], face[1], face[2], face[3]],
                [0, 1, 2, 3].map(|k| corner(f as u32, k)),
            )
        } else {
            let t = tri_index[f] as usize;
            let o = mate[t] as usize;
            if tris[o] < f as u32 {
                continue; // emitted with the pair's first triangle
            }
            let c = cands[quad_of[t] as usize];
            let q = c.quad;
            // Each corner's attributes from the triangle that has it (the
            // shared corners agree).
            let pick = |v: u32| {
                for tf in [tris[t], tris[o]] {
                    if let Some(k) = mesh.face(tf as usize).iter().position(|&x| x == v) {
                        return corner(tf, k);
                    }
                }
                unreachable!("a quad corner is a corner of its triangles")
            };
            (q, q.map(pick))
        };
        let new_face = out.face_count() as u32;
        if out_group_first.last().map(|g| g.0) != Some(group_of[f]) && !mesh.groups.is_empty() {
            out_group_first.push((group_of[f], new_face));
        }
        out.push_face(&verts);
        if !mesh.corner_texcoords.is_empty() {
            out.corner_texcoords
                .extend(corners.map(|c| mesh.corner_texcoords[c]));
        }
        if !mesh.corner_normals.is_empty() {
            out.corner_normals
                .extend(corners.map(|c| mesh.corner_normals[c]));
        }
    }
    out.groups = out_group_first
        .into_iter()
        .map(|(g, first)| (mesh.groups[g].0.clone(), first))
        .collect();
    report.pairs = tris.len() / 2;
    report.folded = (0..tris.len())
        .filter(|&t| (mate[t] as usize) > t && cands[quad_of[t] as usize].quality <= 0.0)
        .count();
    Ok((out, report))
}

/// The shape checks that make every index below safe: offsets from 0 to
/// `indices.len()`, never decreasing; per-corner tables empty or one entry
/// per corner.
fn check_tables(mesh: &IndexedMesh) -> Result<(), PairingError> {
    let fs = &mesh.face_starts;
    let n = mesh.indices.len();
    if fs.first() != Some(&0)
        || fs.last().map(|&l| l as usize) != Some(n)
        || fs.windows(2).any(|w| w[0] > w[1])
    {
        return Err(PairingError::Malformed(
            "face_starts is not an offset table of the indices".into(),
        ));
    }
    for (name, t) in [
        ("corner_texcoords", &mesh.corner_texcoords),
        ("corner_normals", &mesh.corner_normals),
    ] {
        if !t.is_empty() && t.len() != n {
            return Err(PairingError::Malformed(format!(
                "{name} has {} entries for {n} corners",
                t.len()
            )));
        }
    }
    Ok(())
}

/// Per face, the index of its group in `mesh.groups` (0 for every face
/// when the mesh has none; faces before the first group share the first).
fn face_groups(mesh: &IndexedMesh) -> Vec<usize> {
    let mut out = vec![0usize; mesh.face_count()];
    for (g, w) in mesh.groups.iter().enumerate() {
        let start = w.1 as usize;
        let end = mesh
            .groups
            .get(g + 1)
            .map_or(mesh.face_count(), |n| n.1 as usize);
        for o in out.iter_mut().take(end.min(mesh.face_count())).skip(start) {
            *o = g;
        }
    }
    out
}

/// Step 3: for each unpaired triangle, a breadth-first search over the
/// candidates `allowed` keeps for an alternating path to another unpaired
/// one, flipped when found; each visit spends one of `budget`, and none is
/// left, no search starts or goes on. Every triangle is in the tree once (`seen`),
/// so a found path is simple and the flip keeps `mate` a matching.
fn augment(
    mate: &mut [u32],
    adj: &[Vec<(u32, u32)>],
    budget: &mut usize,
    allowed: impl Fn(u32) -> bool,
) {
    const NONE: u32 = u32::MAX;
    let n = mate.len();
    // `seen` stamps per search, so no clearing between searches.
    let mut seen = vec![u32::MAX; n];
    let mut parent = vec![NONE; n];
    let mut queue = VecDeque::new();
    for root in 0..n {
        if mate[root] != NONE {
            continue;
        }
        if *budget == 0 {
            return;
        }
        let stamp = root as u32;
        seen[root] = stamp;
        parent[root] = NONE;
        queue.clear();
        queue.push_back(root as u32);
        let mut found = NONE;
        'search: while let Some(x) = queue.pop_front() {
            for &(y, i) in &adj[x as usize] {
                if seen[y as usize] == stamp || !allowed(i) {
                    continue;
                }
                if mate[y as usize] == NONE {
                    parent[y as usize] = x;
                    found = y;
                    break 'search;
                }
                let z = mate[y as usize];
                if seen[z as usize] == stamp {
                    continue;
                }
                seen[y as usize] = stamp;
                seen[z as usize] = stamp;
                parent[y as usize] = x;
                queue.push_back(z);
                *budget = budget.saturating_sub(2);
                if *budget == 0 {
                    break 'search;
                }
            }
        }
        if found == NONE {
            continue;
        }
        // Flip: `f` pairs with its parent `x`; `x`'s old partner (through
        // which the search reached `x`) continues the path.
        let mut f = found;
        loop {
            let x = parent[f as usize];
            let old = mate[x as usize];
            mate[f as usize] = x;
            mate[x as usize] = f;
            if old == NONE {
                break;
            }
            f = old;
        }
    }
}

/// Checks that `paired` is a pairing of `input` (callable from tests): all
/// quads; the same positions; `input`'s quads kept; every other quad two
/// of `input`'s triangles across its diagonal from corner 0, all of them
/// once; and, when `input` is a valid half-edge mesh, a valid one too.
pub fn check_pairing(input: &IndexedMesh, paired: &IndexedMesh) -> Result<(), String> {
    let rotations = |tris: Vec<[u32; 3]>| {
        let mut v: Vec<[u32; 3]> = tris
            .into_iter()
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        v.sort_unstable();
        v
    };
    if !paired.is_quad_only() {
        return Err("a face is not a quad".into());
    }
    if paired.positions != input.positions {
        return Err("the positions differ".into());
    }
    let mut quads_in: Vec<&[u32]> = input.faces().filter(|f| f.len() == 4).collect();
    quads_in.sort_unstable();
    let want = rotations(
        input
            .faces()
            .filter(|f| f.len() == 3)
            .map(|f| [f[0], f[1], f[2]])
            .collect(),
    );
    let mut kept = Vec::new();
    let mut halves = Vec::new();
    for q in paired.faces() {
        if quads_in.binary_search(&q).is_ok() {
            kept.push(q);
        } else {
            halves.push([q[0], q[1], q[2]]);
            halves.push([q[2], q[3], q[0]]);
        }
    }
    kept.sort_unstable();
    if kept != quads_in {
        return Err(format!(
            "{} of the input's {} quads kept",
            kept.len(),
            quads_in.len()
        ));
    }
    if rotations(halves) != want {
        return Err("the quads are not the input's triangles in pairs".into());
    }
    if crate::mesh::Mesh::from_indexed(input).is_err() {
        return Ok(());
    }
    crate::mesh::Mesh::from_indexed(paired)
        .map(|_| ())
        .map_err(|e| format!("not a valid mesh (the input is): {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    fn check_pairing(input: &IndexedMesh, out: &IndexedMesh) {
        super::check_pairing(input, out).unwrap();
    }

    #[test]
    fn two_triangles_make_one_quad() {
        let m = IndexedMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            [[0u32, 1, 2], [0, 2, 3]],
        );
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!(out.face_count(), 1);
        assert_eq!(r.pairs, 1);
        assert_eq!(r.folded, 0);
        // The quad runs around the square once, counter-clockwise.
        assert_eq!(
            quad_quality(&out.positions, {
                let f = out.face(0);
                [f[0], f[1], f[2], f[3]]
            }),
            1.0
        );
        check_pairing(&m, &out);
    }

    #[test]
    fn a_lone_triangle_is_refused_by_name() {
        let m = IndexedMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], [[0u32, 1, 2]]);
        let e = pair_triangles(&m).unwrap_err();
        assert_eq!(
            e,
            PairingError::Unpaired {
                unpaired: 1,
                triangles: 1,
                first_face: 0
            }
        );
        assert!(e.to_string().contains("face 0"));
    }

    #[test]
    fn malformed_tables_are_refused_not_a_panic() {
        let mut m = IndexedMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], [[0u32, 1, 2]]);
        m.corner_normals = vec![0];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Malformed(_))
        ));
        m.corner_normals.clear();
        m.face_starts = vec![0, 4];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Malformed(_))
        ));
        m.face_starts = vec![0, 3];
        m.indices[2] = 7;
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::VertexOutOfRange {
                face: 0,
                vertex: 7,
                ..
            })
        ));
    }

    #[test]
    fn a_pentagon_is_refused() {
        let p: Vec<DVec3> = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let m = IndexedMesh::from_faces(p, [[0u32, 1, 2, 3, 4]]);
        assert_eq!(
            pair_triangles(&m).unwrap_err(),
            PairingError::FaceSize { face: 0, len: 5 }
        );
    }

    #[test]
    fn quads_stay_and_triangles_beside_them_pair() {
        // A strip: quad, then two triangles.
        let p = (0..6)
            .map(|i| DVec3::new((i / 2) as f64, (i % 2) as f64, 0.0))
            .collect();
        let m = IndexedMesh::from_faces(p, [&[0u32, 2, 3, 1][..], &[2, 4, 5], &[2, 5, 3]]);
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!(out.face(0), &[0, 2, 3, 1]);
        assert_eq!(r.pairs, 1);
        check_pairing(&m, &out);
    }

    #[test]
    fn triangulated_quad_shapes_pair_completely() {
        for (name, shape) in [
            ("sphere", shapes::quad_sphere(6, 1.0)),
            ("torus", shapes::torus(12, 8, 2.0, 0.6)),
            ("grid", shapes::grid(7, 5, 1.0, 1.0)),
            ("box", shapes::box_grid(3, DVec3::new(1.0, 2.0, 0.5))),
        ] {
            for seed in 0..4u64 {
                let tri = shapes::triangulated(&shape, seed);
                let (out, r) =
                    pair_triangles(&tri).unwrap_or_else(|e| panic!("{name}, seed {seed}: {e}"));
                assert_eq!(r.pairs, shape.face_count(), "{name}");
                check_pairing(&tri, &out);
            }
        }
    }

    #[test]
    fn greedy_leftovers_are_paired_by_augmenting_paths() {
        // A strip of four triangles whose middle two make a square (the
        // best pair) and whose ends make convex but skewed quads with
        // their neighbours: greedy takes the square and strands the ends;
        // the path end – middle = middle – end flips to two pairs.
        let p = vec![
            DVec3::new(0.0, 0.3, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(3.0, 0.7, 0.0),
        ];
        let m = IndexedMesh::from_faces(p, [[1u32, 2, 0], [1, 4, 2], [1, 3, 4], [4, 3, 5]]);
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!((r.pairs, r.greedy_pairs, r.folded), (2, 1, 0));
        check_pairing(&m, &out);
    }

    #[test]
    fn seams_and_groups_are_not_crossed() {
        // Two triangles of one square in two groups: no pair.
        let mut m = IndexedMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            [[0u32, 1, 2], [0, 2, 3]],
        );
        m.groups = vec![("a".into(), 0), ("b".into(), 1)];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Unpaired { unpaired: 2, .. })
        ));
        // One group, but a texture seam along the diagonal: no pair.
        m.groups = vec![("a".into(), 0)];
        m.texcoords = vec![[0.0, 0.0]; 6];
        m.corner_texcoords = vec![0, 1, 2, 3, 4, 5];
        assert!(pair_triangles(&m).is_err());
        // Shared texture coordinates at the diagonal's ends: one quad that
        // keeps each corner's.
        m.corner_texcoords = vec![0, 1, 2, 0, 2, 5];
        let (out, _) = pair_triangles(&m).unwrap();
        assert_eq!(out.groups, vec![("a".to_string(), 0)]);
        let f = out.face(0);
        for (k, &v) in f.iter().enumerate() {
            let want = [0, 1, 2, 5][v as usize];
            assert_eq!(out.corner_texcoords[k], want);
        }
    }
}
