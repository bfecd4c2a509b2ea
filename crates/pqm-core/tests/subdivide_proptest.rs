//! Property tests: random polygon meshes (grids, spheres, tori with random
//! faces merged into n-gons and random quads cut into triangles) split into
//! quad-only, consistently oriented meshes with the same Euler characteristic.

mod subdivide_util;

use pqm_core::shapes::{grid, noisy, quad_sphere, torus};
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use pqm_core::IndexedMesh;
use proptest::prelude::*;
use subdivide_util::*;

/// Merges faces across random edges and cuts random quads into two
/// triangles, keeping orientation and manifoldness. `ops` drives the choices.
fn scramble(base: &IndexedMesh, ops: &[(u32, u8, bool)]) -> IndexedMesh {
    let mut faces: Vec<Vec<u32>> = base.faces().map(|f| f.to_vec()).collect();
    for &(pick, side, cut) in ops {
        if faces.len() < 2 {
            break;
        }
        let fi = pick as usize % faces.len();
        let f = faces[fi].clone();
        let i = side as usize % f.len();
        if cut {
            if f.len() != 4 {
                continue;
            }
            let r = (f[i], f[(i + 1) % 4], f[(i + 2) % 4], f[(i + 3) % 4]);
            // On tiny tori the diagonal may already be an edge elsewhere;
            // cutting there would make the mesh non-manifold.
            let exists = faces.iter().any(|g| {
                (0..g.len()).any(|k| {
                    let (x, y) = (g[k], g[(k + 1) % g.len()]);
                    (x, y) == (r.0, r.2) || (x, y) == (r.2, r.0)
                })
            });
            if !exists {
                faces[fi] = vec![r.0, r.1, r.2];
                faces.push(vec![r.0, r.2, r.3]);
            }
            continue;
        }
        let (a, b) = (f[i], f[(i + 1) % f.len()]);
        // The neighbour across a→b holds b→a.
        let Some(gi) = faces
            .iter()
            .position(|g| (0..g.len()).any(|k| g[k] == b && g[(k + 1) % g.len()] == a))
        else {
            continue;
        };
        let g = &faces[gi];
        // Only merge faces that share exactly this one edge, so the result
        // is a simple polygon without repeated vertices.
        if gi == fi || g.iter().filter(|v| f.contains(v)).count() != 2 {
            continue;
        }
        let rot = |p: &[u32], start: u32| {
            let s = p.iter().position(|&v| v == start).unwrap();
            p[s..].iter().chain(&p[..s]).copied().collect::<Vec<_>>()
        };
        let fr = rot(&f, b); // b … a
        let gr = rot(g, a); // a … b
        let mut merged = fr;
        merged.extend_from_slice(&gr[1..gr.len() - 1]);
        let (lo, hi) = (fi.min(gi), fi.max(gi));
        faces.swap_remove(hi);
        faces[lo] = merged;
    }
    IndexedMesh::from_faces(base.positions.clone(), faces)
}

fn base_mesh() -> impl Strategy<Value = IndexedMesh> {
    prop_oneof![
        (1u32..8, 1u32..8).prop_map(|(x, y)| grid(x, y, 2.0, 1.0)),
        (1u32..5).prop_map(|n| quad_sphere(n, 1.0)),
        (3u32..9, 3u32..7).prop_map(|(a, b)| torus(a, b, 2.0, 0.5)),
    ]
}

fn mesh() -> impl Strategy<Value = IndexedMesh> {
    (
        base_mesh(),
        prop::collection::vec((any::<u32>(), any::<u8>(), any::<bool>()), 0..40),
        any::<u64>(),
    )
        .prop_map(|(m, ops, seed)| noisy(&scramble(&m, &ops), 0.05, seed))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn split_is_quad_only_oriented_and_topology_preserving(m in mesh(), cc in any::<bool>()) {
        // The generator must keep its input valid.
        prop_assert!(orientation_consistent(&m), "generator broke orientation");
        let mode = if cc { SplitMode::CatmullClark } else { SplitMode::Linear };
        let s = catmull_clark_split(&m, mode).unwrap();
        prop_assert!(s.is_quad_only());
        prop_assert!(orientation_consistent(&s));
        prop_assert_eq!(euler(&s), euler(&m));
        prop_assert_eq!(s.face_count(), m.indices.len());
        prop_assert_eq!(
            s.vertex_count(),
            m.vertex_count() + undirected_edges(&m).len() + m.face_count()
        );
        prop_assert_eq!(is_closed(&s), is_closed(&m));
        prop_assert_eq!(boundary_loops(&s), boundary_loops(&m));
        prop_assert_eq!(components(&s), components(&m));
        // Output face c is a child of the face holding input corner c and
        // starts at that corner's vertex.
        for (c, q) in s.faces().enumerate() {
            prop_assert_eq!(q[0], m.indices[c]);
        }
    }
}

#[test]
fn scramble_produces_ngons_and_triangles() {
    // Guard against a generator that silently does nothing.
    let ops: Vec<(u32, u8, bool)> = (0..60u32)
        .map(|i| (i.wrapping_mul(2654435761), (i * 7) as u8, i % 3 == 0))
        .collect();
    let m = scramble(&quad_sphere(4, 1.0), &ops);
    let (q, t, o) = m.face_size_counts();
    assert!(t > 0 && o > 0 && q > 0, "quads {q}, tris {t}, other {o}");
    assert!(orientation_consistent(&m));
    assert_eq!(euler(&m), 2);
}
