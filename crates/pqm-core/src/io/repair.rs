//! [`repair`]: fixes what [`super::check`] reports, where that is possible.
//!
//! Steps, in order (each one can create work for the later ones):
//!
//! 1. drop faces that cannot be kept at all: fewer than 3 vertices, an index
//!    out of range, or a vertex with a non-finite coordinate;
//! 2. weld vertices with bit-identical positions (`-0.0` equals `0.0`) into
//!    the one with the lowest index;
//! 3. drop faces that now repeat a vertex;
//! 4. drop faces of zero area (same relative test as `check`);
//! 5. on every edge used by more than two faces, keep the two faces with the
//!    lowest indices and drop the others;
//! 6. re-orient faces per connected component (faces joined by two-face
//!    edges): a breadth-first search from the component's lowest face flips
//!    faces to agree with their neighbours; when that flips more than half of
//!    the component, the component's other faces are flipped instead, so the
//!    fewest faces change. A flip reverses the corner order but keeps the
//!    first corner. Non-orientable components (a Möbius band) are left with
//!    the search's result and counted;
//! 7. split non-manifold vertices: a vertex whose faces form k > 1 fans gets
//!    k − 1 copies (same position and scalar properties), one per extra fan;
//! 8. drop vertices that no face uses, renumbering the rest in order.
//!
//! Per-corner texture-coordinate and normal indices travel with their
//! corners (dropped with their face, reversed with a flip); per-vertex scalar
//! properties follow their vertex (copied on a split, compacted on a drop).
//! Groups keep pointing at their first surviving face; groups whose faces were
//! all dropped disappear.
//!
//! After `repair`, [`super::check`] passes unless the mesh has no faces left
//! or a component is not orientable (`unorientable_components > 0`).
//!
//! Cost: a few sorts of vertex and edge keys, O(n log n).

use super::check::{fan_roots, is_zero_area, repeated_vertex, EdgeTable};
use crate::IndexedMesh;
use std::collections::VecDeque;
use std::fmt;

/// What [`repair`] changed (all counts; zero means that step did nothing).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RepairReport {
    /// Faces dropped for having fewer than 3 vertices, an out-of-range index or
    /// a vertex with a non-finite coordinate.
    pub dropped_invalid_faces: usize,
    /// Vertices merged into an earlier vertex with an identical position.
    pub welded_vertices: usize,
    /// Faces dropped because they repeat a vertex (after welding).
    pub dropped_repeated_vertex_faces: usize,
    /// Faces dropped for zero area.
    pub dropped_zero_area_faces: usize,
    /// Faces dropped from edges shared by more than two faces.
    pub dropped_nonmanifold_faces: usize,
    /// Faces whose orientation was reversed.
    pub flipped_faces: usize,
    /// Connected components that cannot be oriented consistently.
    pub unorientable_components: usize,
    /// Vertex copies created to split non-manifold vertices.
    pub split_vertices: usize,
    /// Vertices removed because no face used them.
    pub dropped_unreferenced_vertices: usize,
}

impl RepairReport {
    /// True when `repair` changed anything.
    pub fn changed(&self) -> bool {
        *self
            != RepairReport {
                unorientable_components: self.unorientable_components,
                ..Default::default()
            }
    }
}

impl fmt::Display for RepairReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // (count, verb, singular, plural)
        let items = [
            (
                self.dropped_invalid_faces,
                "dropped",
                "invalid face",
                "invalid faces",
            ),
            (
                self.welded_vertices,
                "welded",
                "duplicate vertex",
                "duplicate vertices",
            ),
            (
                self.dropped_repeated_vertex_faces,
                "dropped",
                "face repeating a vertex",
                "faces repeating a vertex",
            ),
            (
                self.dropped_zero_area_faces,
                "dropped",
                "zero-area face",
                "zero-area faces",
            ),
            (
                self.dropped_nonmanifold_faces,
                "dropped",
                "face on a non-manifold edge",
                "faces on non-manifold edges",
            ),
            (self.flipped_faces, "flipped", "face", "faces"),
            (
                self.split_vertices,
                "split off",
                "vertex copy at a non-manifold vertex",
                "vertex copies at non-manifold vertices",
            ),
            (
                self.dropped_unreferenced_vertices,
                "dropped",
                "unreferenced vertex",
                "unreferenced vertices",
            ),
            (
                self.unorientable_components,
                "could not orient",
                "component",
                "components",
            ),
        ];
        let parts: Vec<String> = items
            .iter()
            .filter(|item| item.0 > 0)
            .map(|&(n, verb, one, many)| format!("{verb} {n} {}", if n == 1 { one } else { many }))
            .collect();
        if parts.is_empty() {
            write!(f, "no changes")
        } else {
            write!(f, "{}", parts.join(", "))
        }
    }
}

/// Repairs `mesh` in place (see the module docs for the steps) and reports
/// what changed.
pub fn repair(mesh: &mut IndexedMesh) -> RepairReport {
    let mut r = RepairReport::default();
    normalize_layout(mesh);

    // 1. Faces that cannot be kept.
    let nv = mesh.positions.len();
    let keep: Vec<bool> = mesh
        .faces()
        .map(|f| {
            f.len() >= 3
                && f.iter()
                    .all(|&i| (i as usize) < nv && mesh.positions[i as usize].is_finite())
        })
        .collect();
    r.dropped_invalid_faces = retain_faces(mesh, &keep);

    // 2. Weld identical positions.
    r.welded_vertices = weld(mesh);

    // 3. + 4. Repeated vertices, then zero area.
    let keep: Vec<bool> = mesh.faces().map(|f| repeated_vertex(f).is_none()).collect();
    r.dropped_repeated_vertex_faces = retain_faces(mesh, &keep);
    let keep: Vec<bool> = mesh
        .faces()
        .map(|f| !is_zero_area(&mesh.positions, f))
        .collect();
    r.dropped_zero_area_faces = retain_faces(mesh, &keep);

    // 5. Non-manifold edges.
    r.dropped_nonmanifold_faces = drop_nonmanifold_faces(mesh);

    // 6. Orientation.
    let (flipped, bad) = orient(mesh);
    r.flipped_faces = flipped;
    r.unorientable_components = bad;

    // 7. Non-manifold vertices.
    r.split_vertices = split_fans(mesh);

    // 8. Unreferenced vertices.
    r.dropped_unreferenced_vertices = drop_unreferenced(mesh);
    r
}

/// Makes `face_starts` usable (a `Default` mesh has it empty) and drops
/// per-corner arrays that are not aligned with the corners, or that point out
/// of range, since they cannot be kept consistent; likewise vertex scalar
/// arrays of the wrong length.
fn normalize_layout(m: &mut IndexedMesh) {
    if m.face_starts.is_empty() {
        m.face_starts.push(0);
    }
    let fs = &m.face_starts;
    let ok = fs[0] == 0
        && fs.last().map(|&l| l as usize) == Some(m.indices.len())
        && fs.windows(2).all(|w| w[0] <= w[1]);
    if !ok {
        // Keep the faces that are well-formed prefixes; the rest is unknowable.
        let mut starts = vec![0u32];
        for w in fs.windows(2) {
            if w[0] <= w[1]
                && w[1] as usize <= m.indices.len()
                && w[0] == *starts.last().unwrap_or(&0)
            {
                starts.push(w[1]);
            } else {
                break;
            }
        }
        let end = *starts.last().unwrap_or(&0) as usize;
        m.indices.truncate(end);
        m.face_starts = starts;
    }
    let nc = m.indices.len();
    if m.corner_texcoords.len() != nc
        || m.corner_texcoords
            .iter()
            .any(|&i| i as usize >= m.texcoords.len())
    {
        m.corner_texcoords.clear();
    }
    if m.corner_normals.len() != nc
        || m.corner_normals
            .iter()
            .any(|&i| i as usize >= m.normals.len())
    {
        m.corner_normals.clear();
    }
    let nv = m.positions.len();
    m.vertex_scalars.retain(|_, v| v.len() == nv);
}

/// Keeps the faces with `keep[f]`, with their corner data; fixes groups.
/// Returns the number of faces dropped.
fn retain_faces(m: &mut IndexedMesh, keep: &[bool]) -> usize {
    let dropped = keep.iter().filter(|k| !**k).count();
    if dropped == 0 {
        return 0;
    }
    let nf = m.face_count();
    let (has_t, has_n) = (!m.corner_texcoords.is_empty(), !m.corner_normals.is_empty());
    let mut new_index = vec![0u32; nf + 1]; // kept faces before f
    let mut w = 0usize;
    let mut starts = Vec::with_capacity(nf + 1 - dropped);
    starts.push(0u32);
    for f in 0..nf {
        new_index[f] = (starts.len() - 1) as u32;
        if !keep[f] {
            continue;
        }
        let (s, e) = (m.face_starts[f] as usize, m.face_starts[f + 1] as usize);
        for c in s..e {
            m.indices[w] = m.indices[c];
            if has_t {
                m.corner_texcoords[w] = m.corner_texcoords[c];
            }
            if has_n {
                m.corner_normals[w] = m.corner_normals[c];
            }
            w += 1;
        }
        starts.push(w as u32);
    }
    new_index[nf] = (starts.len() - 1) as u32;
    m.indices.truncate(w);
    if has_t {
        m.corner_texcoords.truncate(w);
    }
    if has_n {
        m.corner_normals.truncate(w);
    }
    m.face_starts = starts;
    // Groups: new first face; drop groups left without faces.
    let new_nf = m.face_count() as u32;
    let mut groups: Vec<(String, u32)> = std::mem::take(&mut m.groups)
        .into_iter()
        .map(|(n, first)| (n, new_index[(first as usize).min(nf)]))
        .collect();
    // A group is empty when the next group (or the end) starts at the same face.
    let mut out: Vec<(String, u32)> = Vec::with_capacity(groups.len());
    for k in 0..groups.len() {
        let next = groups.get(k + 1).map_or(new_nf, |g| g.1);
        if next > groups[k].1 {
            out.push(std::mem::take(&mut groups[k]));
        }
    }
    m.groups = out;
    dropped
}

/// Merges vertices with identical positions into the lowest-index one.
fn weld(m: &mut IndexedMesh) -> usize {
    let key = |v: usize| {
        let p = m.positions[v];
        // `+ 0.0` turns -0.0 into 0.0 so that both weld.
        [
            (p.x + 0.0).to_bits(),
            (p.y + 0.0).to_bits(),
            (p.z + 0.0).to_bits(),
        ]
    };
    let mut order: Vec<u32> = (0..m.positions.len() as u32)
        .filter(|&v| m.positions[v as usize].is_finite())
        .collect();
    order.sort_unstable_by_key(|&v| (key(v as usize), v));
    let mut map: Vec<u32> = (0..m.positions.len() as u32).collect();
    let mut welded = 0;
    for run in order.chunk_by(|&a, &b| key(a as usize) == key(b as usize)) {
        for &v in &run[1..] {
            map[v as usize] = run[0];
            welded += 1;
        }
    }
    if welded > 0 {
        for i in &mut m.indices {
            *i = map[*i as usize];
        }
    }
    welded
}

fn drop_nonmanifold_faces(m: &mut IndexedMesh) -> usize {
    let edges = EdgeTable::new(m);
    let mut keep = vec![true; m.face_count()];
    let mut any = false;
    for g in edges.groups() {
        if g.len() <= 2 {
            continue;
        }
        let mut faces: Vec<u32> = g
            .iter()
            .map(|e| super::check::face_of_corner(m, e.1))
            .filter(|&f| keep[f as usize])
            .collect();
        faces.sort_unstable();
        for &f in faces.iter().skip(2) {
            keep[f as usize] = false;
            any = true;
        }
    }
    if any {
        retain_faces(m, &keep)
    } else {
        0
    }
}

/// Reverses face `f`'s corners after the first (with its corner data).
fn flip_face(m: &mut IndexedMesh, f: usize) {
    let (s, e) = (m.face_starts[f] as usize + 1, m.face_starts[f + 1] as usize);
    m.indices[s..e].reverse();
    if !m.corner_texcoords.is_empty() {
        m.corner_texcoords[s..e].reverse();
    }
    if !m.corner_normals.is_empty() {
        m.corner_normals[s..e].reverse();
    }
}

/// Breadth-first re-orientation per component; returns (flipped, non-orientable components).
fn orient(m: &mut IndexedMesh) -> (usize, usize) {
    let nf = m.face_count();
    let edges = EdgeTable::new(m);
    // Adjacency in CSR form: (neighbour, traversed in the same direction?).
    let mut deg = vec![0u32; nf + 1];
    let mut pairs = Vec::new();
    for g in edges.groups() {
        if let [(_, c1), (_, c2)] = *g {
            let f1 = super::check::face_of_corner(m, c1);
            let f2 = super::check::face_of_corner(m, c2);
            let same = m.indices[c1 as usize] == m.indices[c2 as usize];
            pairs.push((f1, f2, same));
            deg[f1 as usize] += 1;
            deg[f2 as usize] += 1;
        }
    }
    let mut start = vec![0u32; nf + 1];
    for f in 0..nf {
        start[f + 1] = start[f] + deg[f];
    }
    let mut fill = start.clone();
    let mut adj = vec![(0u32, false); pairs.len() * 2];
    for &(a, b, s) in &pairs {
        adj[fill[a as usize] as usize] = (b, s);
        fill[a as usize] += 1;
        adj[fill[b as usize] as usize] = (a, s);
        fill[b as usize] += 1;
    }
    const UNSEEN: u8 = 2;
    let mut flip = vec![UNSEEN; nf];
    let mut flipped = 0;
    let mut bad = 0;
    let mut queue = VecDeque::new();
    let mut comp = Vec::new();
    for seed in 0..nf {
        if flip[seed] != UNSEEN {
            continue;
        }
        flip[seed] = 0;
        queue.push_back(seed as u32);
        comp.clear();
        let mut conflict = false;
        while let Some(f) = queue.pop_front() {
            comp.push(f);
            let ff = flip[f as usize];
            for &(g, same) in &adj[start[f as usize] as usize..start[f as usize + 1] as usize] {
                // Same direction means exactly one of the two must flip.
                let want = ff ^ u8::from(same);
                match flip[g as usize] {
                    UNSEEN => {
                        flip[g as usize] = want;
                        queue.push_back(g);
                    }
                    have if have != want => conflict = true,
                    _ => {}
                }
            }
        }
        bad += usize::from(conflict);
        let n_flip = comp.iter().filter(|&&f| flip[f as usize] == 1).count();
        let invert = 2 * n_flip > comp.len();
        for &f in &comp {
            if (flip[f as usize] == 1) != invert {
                flip_face(m, f as usize);
                flipped += 1;
            }
        }
    }
    (flipped, bad)
}

/// Gives each extra fan of a vertex its own copy of the vertex.
fn split_fans(m: &mut IndexedMesh) -> usize {
    let edges = EdgeTable::new(m);
    let roots = fan_roots(m, &edges);
    let nv = m.positions.len();
    let mut first_root = vec![u32::MAX; nv];
    // (vertex, root) -> copy, for roots other than the vertex's first.
    let mut extra: Vec<(u32, u32, u32)> = Vec::new(); // (vertex, root, corner)
    for (c, &v) in m.indices.iter().enumerate() {
        let slot = &mut first_root[v as usize];
        if *slot == u32::MAX {
            *slot = roots[c];
        } else if *slot != roots[c] {
            extra.push((v, roots[c], c as u32));
        }
    }
    if extra.is_empty() {
        return 0;
    }
    extra.sort_unstable();
    let mut copies = 0;
    for run in extra.chunk_by(|a, b| a.0 == b.0 && a.1 == b.1) {
        let v = run[0].0 as usize;
        let new = m.positions.len() as u32;
        m.positions.push(m.positions[v]);
        for vals in m.vertex_scalars.values_mut() {
            vals.push(vals[v]);
        }
        for &(_, _, c) in run {
            m.indices[c as usize] = new;
        }
        copies += 1;
    }
    copies
}

fn drop_unreferenced(m: &mut IndexedMesh) -> usize {
    let nv = m.positions.len();
    let mut used = vec![false; nv];
    for &i in &m.indices {
        used[i as usize] = true;
    }
    let dropped = used.iter().filter(|u| !**u).count();
    if dropped == 0 {
        return 0;
    }
    let mut map = vec![u32::MAX; nv];
    let mut n = 0u32;
    for v in 0..nv {
        if used[v] {
            map[v] = n;
            n += 1;
        }
    }
    let mut k = 0;
    m.positions.retain(|_| {
        k += 1;
        used[k - 1]
    });
    for vals in m.vertex_scalars.values_mut() {
        let mut k = 0;
        vals.retain(|_| {
            k += 1;
            used[k - 1]
        });
    }
    for i in &mut m.indices {
        *i = map[*i as usize];
    }
    dropped
}
