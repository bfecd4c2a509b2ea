//! The qCoarsen operators on tiny procedural meshes: counts, invariants,
//! exact undo, and property tests over random operator sequences.

mod common;
use common::{grid, quad_sphere, torus};
use glam::DVec3;
use pqm_core::ops::{self, qe_merge::qe_merge_patch, qv_merge::qv_merge_patch, Reject};
use pqm_core::{FaceId, IndexedMesh, Mesh, VertexId};
use proptest::prelude::*;

fn counts(m: &Mesh) -> (usize, usize, usize) {
    (m.vertex_count(), m.edge_count(), m.face_count())
}

fn quad_only(m: &Mesh) -> bool {
    m.faces().all(|f| m.face_degree(f) == 4)
}

fn canon(im: &IndexedMesh) -> Vec<Vec<u32>> {
    let mut fs: Vec<Vec<u32>> = im
        .faces()
        .map(|f| {
            let k = (0..f.len()).min_by_key(|&i| f[i]).unwrap();
            (0..f.len()).map(|i| f[(k + i) % f.len()]).collect()
        })
        .collect();
    fs.sort();
    fs
}

fn midpoint(m: &Mesh, a: VertexId, b: VertexId) -> DVec3 {
    (m.position(a) + m.position(b)) * 0.5
}

#[test]
fn qv_merge_on_a_torus() {
    let src = torus(24, 16);
    let mut m = Mesh::from_indexed(&src).unwrap();
    let f = FaceId(30);
    let q = m.quad_vertices(f).unwrap();
    let patch = ops::can_qv_merge(&m, f, 0, false, midpoint(&m, q[0], q[2])).unwrap();
    let (v, e, fc) = counts(&m);
    ops::qv_merge(&mut m, &patch).unwrap();
    m.validate().unwrap();
    assert_eq!(counts(&m), (v - 1, e - 2, fc - 1));
    assert!(quad_only(&m));
    // on a regular grid the merged vertex gets valence 6, the wings 3
    assert_eq!(m.valence(q[0]), 6);
    assert_eq!((m.valence(q[1]), m.valence(q[3])), (3, 3));
    assert!(!m.is_vertex_alive(q[2]));
    let expect = (src.positions[q[0].idx()] + src.positions[q[2].idx()]) * 0.5;
    assert_eq!(m.position(q[0]), expect);
}

#[test]
fn qe_merge_on_a_torus() {
    let mut m = Mesh::from_indexed(&torus(24, 16)).unwrap();
    let h = m.face_halfedge(FaceId(33));
    let site = ops::qe_merge::qe_site(&m, h).unwrap();
    let [a, _, _, d, _, _] = site.v;
    let (pa, pd) = (m.position(a), m.position(d));
    let patch = ops::can_qe_merge(&m, h, pa, pd).unwrap();
    let (v, e, fc) = counts(&m);
    ops::qe_merge(&mut m, &patch).unwrap();
    m.validate().unwrap();
    assert_eq!(counts(&m), (v - 4, e - 8, fc - 4));
    assert!(quad_only(&m));
    assert_eq!(m.genus(), 1);
    // on a regular grid both endpoints get valence 5 (one zipper step: the
    // qvMerges that follow bring them back to 4, paper Fig. 3)
    assert_eq!((m.valence(a), m.valence(d)), (5, 5));
}

/// The crossing-side re-fan (operators.md: "also legal; a candidate the
/// cost can choose"): on a regular torus each one-sided crossing variant is
/// a valid qeMerge with the same counts as the plain one but a different
/// result; both crossing is rejected (the fans would share faces).
#[test]
fn qe_merge_crossing_refans_on_a_torus() {
    let src = torus(24, 16);
    let m0 = Mesh::from_indexed(&src).unwrap();
    let h = m0.face_halfedge(FaceId(33));
    let site = ops::qe_merge::qe_site(&m0, h).unwrap();
    let [a, _, _, d, _, _] = site.v;
    let (pa, pd) = (m0.position(a), m0.position(d));
    let result = |cross: [bool; 2]| {
        let mut m = m0.clone();
        let patch = ops::qe_merge::can_qe_merge_with(&m, h, pa, pd, cross).unwrap();
        ops::qe_merge(&mut m, &patch).unwrap();
        m.validate().unwrap();
        assert_eq!(
            counts(&m),
            (
                m0.vertex_count() - 4,
                m0.edge_count() - 8,
                m0.face_count() - 4
            )
        );
        assert!(quad_only(&m));
        assert_eq!(m.genus(), 1);
        canon(&m.to_indexed().0)
    };
    let plain = result([false, false]);
    let cross_a = result([true, false]);
    let cross_d = result([false, true]);
    assert_ne!(plain, cross_a);
    assert_ne!(plain, cross_d);
    assert_ne!(cross_a, cross_d);
    assert!(ops::qe_merge::can_qe_merge_with(&m0, h, pa, pd, [true, true]).is_err());
}

#[test]
fn doublet_is_found_and_removed() {
    // qvMerge twice around one vertex of a grid leaves it with valence 2
    let mut m = Mesh::from_indexed(&torus(8, 8)).unwrap();
    let v = VertexId(27);
    let star: Vec<FaceId> = m.vertex_faces(v).collect();
    // merge the diagonals through v's two opposite faces, keeping the far vertex
    for &f in &[star[0], star[2]] {
        let q = m.quad_vertices(f).unwrap();
        let k = q.iter().position(|&x| x == v).unwrap();
        // diagonal not through v: vertices k+1 and k+3
        let diag = (k + 1) % 2;
        let p = midpoint(&m, q[(k + 1) % 4], q[(k + 3) % 4]);
        let patch = qv_merge_patch(&m, f, diag, false, p).unwrap();
        m.can_replace_patch(&patch.remove, &patch.add).unwrap();
        ops::apply_patch(&mut m, &patch).unwrap();
        m.validate_structure().unwrap();
    }
    assert_eq!(ops::find_doublets(&m, &[v]), vec![v]);
    assert!(
        m.validate().is_err(),
        "a doublet breaks the dual-chord rule"
    );
    let patch = ops::can_remove_doublet(&m, v).unwrap();
    let before = counts(&m);
    ops::remove_doublet(&mut m, &patch).unwrap();
    assert_eq!(counts(&m), (before.0 - 1, before.1 - 2, before.2 - 1));
    m.validate().unwrap();
    assert!(quad_only(&m));
}

#[test]
fn boundary_qv_merge_of_two_boundary_diagonal_vertices_pinches() {
    // corner quad of a grid: vertices 0 and (1,1); 0 is a corner, fine to
    // merge topologically; but the 1×1 grid's quad has all four on the boundary.
    let m = Mesh::from_indexed(&grid(1, 1)).unwrap();
    let r = ops::can_qv_merge(&m, FaceId(0), 0, false, DVec3::ZERO);
    assert!(matches!(r, Err(Reject::Invalid(_))), "{r:?}");
}

#[test]
fn valence_three_endpoint_is_rejected() {
    // the quad sphere's cube corners have valence 3
    let m = Mesh::from_indexed(&quad_sphere(2)).unwrap();
    let mut rejected = 0;
    for h in m.halfedges() {
        let Ok(site) = ops::qe_merge::qe_site(&m, h) else {
            continue;
        };
        if m.valence(site.v[0]) == 3 || m.valence(site.v[3]) == 3 {
            let r = qe_merge_patch(&m, h, m.position(site.v[0]), m.position(site.v[3]));
            assert!(r.is_err());
            rejected += 1;
        }
    }
    assert!(rejected > 0);
}

#[test]
fn undo_restores_ids_and_positions() {
    let src = quad_sphere(4);
    let mut m = Mesh::from_indexed(&src).unwrap();
    let h = m.face_halfedge(FaceId(40));
    let site = ops::qe_merge::qe_site(&m, h).unwrap();
    let patch = ops::can_qe_merge(
        &m,
        h,
        midpoint(&m, site.v[0], site.v[1]),
        m.position(site.v[3]),
    )
    .unwrap();
    let applied = ops::apply_undoable(&mut m, &patch).unwrap();
    m.validate_structure().unwrap();
    ops::undo(&mut m, &applied).unwrap();
    m.validate().unwrap();
    let (back, ren) = m.to_indexed();
    assert!(ren
        .vertices
        .iter()
        .enumerate()
        .all(|(i, r)| *r == Some(i as u32)));
    assert!(ren
        .faces
        .iter()
        .enumerate()
        .all(|(i, r)| *r == Some(i as u32)));
    assert_eq!(back.positions, src.positions);
    assert_eq!(canon(&back), canon(&src));
}

/// Runs random qvMerge / qeMerge steps (each followed by every doublet it
/// made) on `src`: after each accepted step the mesh is structurally valid,
/// quad-only and keeps its Euler characteristic; undoing every step in
/// reverse gives the input back exactly. `kind` 0–1 is a qvMerge diagonal,
/// then qeMerges: edge `(kind − 2) % 4` re-fanned on side combination
/// `(kind − 2) / 4` (0 = neither endpoint crossing; 3 = both, which must be
/// rejected).
fn run_operator_sequence(src: &IndexedMesh, steps: &[(u32, usize)]) -> Result<(), TestCaseError> {
    let mut m = Mesh::from_indexed(src).unwrap();
    let chi = m.euler_characteristic();
    let mut log = Vec::new();
    for &(pick, kind) in steps {
        let fs: Vec<FaceId> = m.faces().collect();
        let f = fs[pick as usize % fs.len()];
        let patch = if kind < 2 {
            let q = m.quad_vertices(f).unwrap();
            let p = midpoint(&m, q[kind], q[kind + 2]);
            ops::can_qv_merge(&m, f, kind, false, p)
        } else {
            let (edge, side) = ((kind - 2) % 4, (kind - 2) / 4);
            let cross = [side & 1 == 1, side & 2 == 2];
            let h = m.face_halfedges(f).nth(edge).unwrap();
            match ops::qe_merge::qe_site(&m, h) {
                Ok(site) => {
                    let pa = midpoint(&m, site.v[0], site.v[1]);
                    let pd = midpoint(&m, site.v[3], site.v[2]);
                    let r = if side == 0 {
                        ops::can_qe_merge(&m, h, pa, pd)
                    } else {
                        ops::qe_merge::can_qe_merge_with(&m, h, pa, pd, cross)
                    };
                    prop_assert!(!(cross == [true, true] && r.is_ok()));
                    r
                }
                Err(e) => Err(e),
            }
        };
        let Ok(patch) = patch else { continue };
        let before = m.face_count();
        log.push(ops::apply_undoable(&mut m, &patch).unwrap());
        prop_assert_eq!(m.face_count(), before - if kind < 2 { 1 } else { 4 });
        // then every doublet it made
        let touched: Vec<VertexId> = patch.add.iter().flatten().copied().collect();
        for v in ops::find_doublets(&m, &touched) {
            if let Ok(d) = ops::can_remove_doublet(&m, v) {
                log.push(ops::apply_undoable(&mut m, &d).unwrap());
            }
        }
        m.validate_structure().unwrap();
        prop_assert!(quad_only(&m));
        prop_assert_eq!(m.euler_characteristic(), chi);
    }
    while let Some(a) = log.pop() {
        ops::undo(&mut m, &a).unwrap();
    }
    m.validate().unwrap();
    let (back, _) = m.to_indexed();
    prop_assert_eq!(&back.positions, &src.positions);
    prop_assert_eq!(canon(&back), canon(src));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// As `random_operator_sequences`, with qeMerges re-fanning on any side
    /// combination (including the rejected "both crossing").
    #[test]
    fn random_sequences_with_crossing_refans(
        shape in 0usize..2,
        steps in prop::collection::vec((0u32..400, 0usize..18), 1..30),
    ) {
        let src = if shape == 0 { quad_sphere(5) } else { torus(20, 14) };
        run_operator_sequence(&src, &steps)?;
    }

    /// Random qvMerge / qeMerge / doublet sequences on a quad sphere and a
    /// torus (see `run_operator_sequence`).
    #[test]
    fn random_operator_sequences(
        shape in 0usize..2,
        steps in prop::collection::vec((0u32..400, 0usize..6), 1..30),
    ) {
        let src = if shape == 0 { quad_sphere(5) } else { torus(20, 14) };
        run_operator_sequence(&src, &steps)?;
    }
}
