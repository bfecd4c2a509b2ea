//! `io::triangulate` (property tests): on random quad shapes with noise,
//! whatever corner each quad's list starts at, the triangles cover each
//! quad exactly once along one of its diagonals — `First` along `v0–v2` as
//! listed, `Shorter` along the same diagonal whatever the start — and keep
//! the mesh's vertices, edges and Euler characteristic; hostile face lists
//! give no panic.

use glam::DVec3;
use pqm_core::io::{quad_split_diagonal, triangulate, QuadSplit};
use pqm_core::{shapes, IndexedMesh};
use proptest::prelude::*;
use std::collections::BTreeSet;

fn shape(kind: u8, n: u32) -> IndexedMesh {
    match kind % 3 {
        0 => shapes::quad_sphere(n.max(2), 1.0),
        1 => shapes::torus(3 * n.max(2), n.max(3), 2.0, 0.7),
        _ => shapes::grid(n.max(1), n.max(1) + 2, 1.0, 1.5),
    }
}

/// Undirected edges of a mesh's faces.
fn edges(m: &IndexedMesh) -> BTreeSet<(u32, u32)> {
    m.faces()
        .flat_map(|f| (0..f.len()).map(move |k| (f[k], f[(k + 1) % f.len()])))
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn quads_split_along_one_diagonal_whatever_their_start(
        kind in 0u8..3, n in 2u32..6, seed in 0u64..1000, turns in proptest::collection::vec(0usize..4, 1..64),
    ) {
        let m = shapes::noisy(&shape(kind, n), 0.05, seed);
        let turned = {
            let mut t = m.clone();
            for f in 0..t.face_count() {
                let (a, b) = (t.face_starts[f] as usize, t.face_starts[f + 1] as usize);
                t.indices[a..b].rotate_left(turns[f % turns.len()]);
            }
            t
        };
        for split in [QuadSplit::First, QuadSplit::Shorter] {
            let t = triangulate(&turned, split);
            prop_assert_eq!(t.face_count(), 2 * turned.face_count());
            prop_assert_eq!(t.vertex_count(), turned.vertex_count());
            prop_assert!(t.faces().all(|f| f.len() == 3));
            // V - E + F: each quad adds one edge (its diagonal) and one face
            let (e_q, e_t) = (edges(&turned).len(), edges(&t).len());
            prop_assert_eq!(e_t, e_q + turned.face_count());
            for (f, q) in turned.faces().enumerate() {
                let (t0, t1) = (t.face(2 * f), t.face(2 * f + 1));
                // the two triangles share the diagonal from their first corner
                prop_assert_eq!(t0[0], t1[0]);
                prop_assert_eq!(t0[2], t1[1]);
                let q4 = [q[0], q[1], q[2], q[3]];
                let r = match split {
                    QuadSplit::First => 0,
                    QuadSplit::Shorter => quad_split_diagonal(&turned.positions, q4),
                };
                prop_assert_eq!([t0[0], t0[2]], [q4[r], q4[r + 2]]);
            }
        }
        // `Shorter` draws the same triangles whatever the start.
        let tri_set = |m: &IndexedMesh| {
            m.faces()
                .map(|f| {
                    let k = (0..3).min_by_key(|&k| f[k]).unwrap();
                    [f[k], f[(k + 1) % 3], f[(k + 2) % 3]]
                })
                .collect::<BTreeSet<_>>()
        };
        prop_assert_eq!(
            tri_set(&triangulate(&turned, QuadSplit::Shorter)),
            tri_set(&triangulate(&m, QuadSplit::Shorter))
        );
    }

    #[test]
    fn hostile_face_lists_do_not_panic(
        faces in proptest::collection::vec(proptest::collection::vec(0u32..12, 0..7), 0..20),
        corner_table in 0usize..40,
    ) {
        let mut m = IndexedMesh::from_faces(
            (0..8).map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0)).collect(),
            faces.iter(),
        );
        m.texcoords = vec![[0.0, 0.0]];
        m.corner_texcoords = vec![0; corner_table];
        for split in [QuadSplit::First, QuadSplit::Shorter] {
            let t = triangulate(&m, split);
            let want: usize = m.faces().map(|f| f.len().saturating_sub(2)).sum();
            prop_assert_eq!(t.face_count(), want);
        }
    }
}
