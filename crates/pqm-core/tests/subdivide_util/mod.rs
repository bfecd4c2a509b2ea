//! Small topology helpers shared by the `subdivide_*` and `shapes_*` tests.
//! They are written independently of the code under test (plain sorting and
//! union-find, no shared logic with `subdivide.rs`).
#![allow(dead_code)]

use glam::DVec3;
use pqm_core::IndexedMesh;
use std::path::PathBuf;

/// All directed edges `(a, b)` of the faces, sorted.
pub fn directed_edges(m: &IndexedMesh) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for f in m.faces() {
        for i in 0..f.len() {
            out.push((f[i], f[(i + 1) % f.len()]));
        }
    }
    out.sort_unstable();
    out
}

/// Undirected edges `(min, max)`, sorted and deduplicated.
pub fn undirected_edges(m: &IndexedMesh) -> Vec<(u32, u32)> {
    let mut e: Vec<_> = directed_edges(m)
        .into_iter()
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

/// χ = V − E + F (V counts every position, used or not).
pub fn euler(m: &IndexedMesh) -> i64 {
    m.vertex_count() as i64 - undirected_edges(m).len() as i64 + m.face_count() as i64
}

/// No directed edge is used twice (consistent orientation on a manifold).
pub fn orientation_consistent(m: &IndexedMesh) -> bool {
    let d = directed_edges(m);
    d.windows(2).all(|w| w[0] != w[1])
}

/// Directed edges whose reverse is not present (the boundary).
pub fn boundary_edges(m: &IndexedMesh) -> Vec<(u32, u32)> {
    let d = directed_edges(m);
    d.iter()
        .copied()
        .filter(|&(a, b)| d.binary_search(&(b, a)).is_err())
        .collect()
}

pub fn is_closed(m: &IndexedMesh) -> bool {
    boundary_edges(m).is_empty()
}

/// Number of boundary loops (boundary vertices assumed to have one outgoing
/// boundary edge each, which holds for the manifold meshes tested here).
pub fn boundary_loops(m: &IndexedMesh) -> usize {
    let b = boundary_edges(m);
    let mut next = std::collections::BTreeMap::new();
    for &(a, c) in &b {
        assert!(
            next.insert(a, c).is_none(),
            "vertex {a} has two outgoing boundary edges"
        );
    }
    let mut seen = std::collections::BTreeSet::new();
    let mut loops = 0;
    for &(start, _) in &b {
        if seen.contains(&start) {
            continue;
        }
        loops += 1;
        let mut v = start;
        while seen.insert(v) {
            v = next[&v];
        }
    }
    loops
}

/// Connected components over face adjacency (vertices used by no face ignored).
pub fn components(m: &IndexedMesh) -> usize {
    let mut parent: Vec<usize> = (0..m.vertex_count()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut used = vec![false; m.vertex_count()];
    for f in m.faces() {
        for i in 0..f.len() {
            used[f[i] as usize] = true;
            let (a, b) = (
                find(&mut parent, f[i] as usize),
                find(&mut parent, f[0] as usize),
            );
            parent[a] = b;
        }
    }
    (0..m.vertex_count())
        .filter(|&v| used[v] && find(&mut parent, v) == v)
        .count()
}

/// Number of undirected edges at each vertex.
pub fn valences(m: &IndexedMesh) -> Vec<usize> {
    let mut val = vec![0; m.vertex_count()];
    for (a, b) in undirected_edges(m) {
        val[a as usize] += 1;
        val[b as usize] += 1;
    }
    val
}

/// Newell normal (area-weighted, not normalised) of a polygon.
pub fn face_normal(m: &IndexedMesh, f: &[u32]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..f.len() {
        let (p, q) = (
            m.positions[f[i] as usize],
            m.positions[f[(i + 1) % f.len()] as usize],
        );
        n += p.cross(q);
    }
    n * 0.5
}

pub fn centroid(m: &IndexedMesh, f: &[u32]) -> DVec3 {
    f.iter().map(|&v| m.positions[v as usize]).sum::<DVec3>() / f.len() as f64
}

pub fn shared_mesh(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel)
}

/// Minimal OBJ reader for tests (the real reader lives in the io module):
/// `v x y z`, `vt u v`, `f a/b/c ...` with 1-based or negative indices.
pub fn load_obj(path: &std::path::Path) -> IndexedMesh {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut m = IndexedMesh::new();
    let mut tex_ok = true;
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(|s| s.parse().expect("number")).collect();
                m.positions.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("vt") => {
                let c: Vec<f64> = it.take(2).map(|s| s.parse().expect("number")).collect();
                m.texcoords.push([c[0], c[1]]);
            }
            Some("f") => {
                let mut face = Vec::new();
                for tok in it {
                    let mut parts = tok.split('/');
                    let resolve = |s: &str, n: usize| -> u32 {
                        let i: i64 = s.parse().expect("index");
                        (if i < 0 { n as i64 + i } else { i - 1 }) as u32
                    };
                    face.push(resolve(parts.next().expect("vertex"), m.positions.len()));
                    match parts.next() {
                        Some(t) if !t.is_empty() => {
                            let t = resolve(t, m.texcoords.len());
                            m.corner_texcoords.push(t);
                        }
                        _ => tex_ok = false,
                    }
                }
                m.push_face(&face);
            }
            _ => {}
        }
    }
    if !tex_ok {
        m.corner_texcoords.clear();
    }
    m
}
