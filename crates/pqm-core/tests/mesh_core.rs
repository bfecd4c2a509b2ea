//! Mesh core: building, validation, topology queries and local patch
//! replacement on tiny hand-made meshes and a property test.

use glam::DVec3;
use pqm_core::{FaceId, IndexedMesh, Mesh, VertexId};
use proptest::prelude::*;

mod common;
use common::{cube, grid, torus};

#[test]
fn cube_topology() {
    let m = Mesh::from_indexed(&cube()).unwrap();
    m.validate().unwrap();
    assert_eq!(
        (m.vertex_count(), m.edge_count(), m.face_count()),
        (8, 12, 6)
    );
    assert_eq!(m.euler_characteristic(), 2);
    assert_eq!(m.genus(), 0);
    assert!(m.boundary_loops().is_empty());
    assert_eq!(m.components().1, 1);
    for v in m.vertices() {
        assert_eq!(m.valence(v), 3);
        assert_eq!(m.ideal_valence(v), 4);
        assert_eq!(m.vertex_faces(v).count(), 3);
    }
}

#[test]
fn grid_boundary_and_rings() {
    let m = Mesh::from_indexed(&grid(3, 2)).unwrap();
    m.validate().unwrap();
    assert_eq!(m.boundary_loops().len(), 1);
    assert_eq!(m.boundary_loops()[0].len(), 10);
    assert_eq!(m.genus(), 0);
    // corner vertex 0: one face, valence 2, ideal 2 (90° corner)
    let v0 = VertexId(0);
    assert!(m.is_boundary_vertex(v0));
    assert_eq!((m.valence(v0), m.ideal_valence(v0)), (2, 2));
    // boundary middle vertex 1: valence 3, ideal 3
    assert_eq!(
        (m.valence(VertexId(1)), m.ideal_valence(VertexId(1))),
        (3, 3)
    );
    // interior vertex 5 = (1,1): valence 4, ring starts anywhere but visits 4
    let ring: Vec<_> = m.vertex_ring(VertexId(5)).collect();
    assert_eq!(ring.len(), 4);
    // boundary ring walks start at the boundary half-edge
    let first = m.outgoing(VertexId(1)).next().unwrap();
    assert!(m.is_boundary_halfedge(first));
}

#[test]
fn torus_and_components() {
    let t = Mesh::from_indexed(&torus(6, 4)).unwrap();
    t.validate().unwrap();
    assert_eq!(t.euler_characteristic(), 0);
    assert_eq!(t.genus(), 1);
    // two components: cube + translated cube
    let mut two = cube();
    let c = cube();
    let off = two.positions.len() as u32;
    two.positions
        .extend(c.positions.iter().map(|p| *p + DVec3::X * 3.0));
    for f in c.faces() {
        let g: Vec<u32> = f.iter().map(|i| i + off).collect();
        two.push_face(&g);
    }
    let m = Mesh::from_indexed(&two).unwrap();
    assert_eq!(m.components().1, 2);
    assert_eq!(m.genus(), 0);
}

#[test]
fn round_trip_through_indexed() {
    let src = torus(5, 3);
    let m = Mesh::from_indexed(&src).unwrap();
    let (back, _) = m.to_indexed();
    assert_eq!(back.positions, src.positions);
    // same faces up to the starting corner
    for (a, b) in back.faces().zip(src.faces()) {
        let k = a.iter().position(|&x| x == b[0]).unwrap();
        let rot: Vec<u32> = (0..4).map(|i| a[(k + i) % 4]).collect();
        assert_eq!(rot, b);
    }
}

#[test]
fn input_errors_name_the_element() {
    let bad = |faces: Vec<Vec<u32>>, n: usize| {
        let p = (0..n)
            .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
            .collect();
        Mesh::from_indexed(&IndexedMesh::from_faces(p, faces))
            .unwrap_err()
            .0
    };
    assert_eq!(bad(vec![vec![0, 1, 2, 1]], 3), "face 0 repeats vertex 1");
    assert_eq!(
        bad(vec![vec![0, 1, 5]], 3),
        "face 0 uses vertex 5, but there are only 3"
    );
    assert_eq!(
        bad(vec![vec![0, 1, 2]], 4),
        "vertex 3 is not used by any face"
    );
    assert!(bad(vec![vec![0, 1, 2], vec![0, 1, 3]], 4).contains("same direction"));
    assert!(bad(vec![vec![0, 1, 2], vec![1, 0, 3], vec![0, 1, 4]], 5).contains("more than two"));
    // bow-tie: two triangles sharing only vertex 0
    assert!(bad(vec![vec![0, 1, 2], vec![0, 3, 4]], 5).contains("vertex 0 is non-manifold"));
    // two quads sharing two edges load (doublets are removable) but fail validate()
    let p = (0..5)
        .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
        .collect();
    let doublet = IndexedMesh::from_faces(p, [[0u32, 1, 2, 3], [0, 3, 4, 1]]);
    let m = Mesh::from_indexed(&doublet).unwrap();
    m.validate_structure().unwrap();
    assert!(m
        .validate()
        .unwrap_err()
        .0
        .contains("share more than one edge"));
    let mut nan = cube();
    nan.positions[3].y = f64::NAN;
    assert_eq!(
        Mesh::from_indexed(&nan).unwrap_err().0,
        "vertex 3 has a non-finite coordinate"
    );
}

/// Removes the star of an interior valence-4 vertex (an octagon) and fills
/// the octagon with three quads, rotated by `r` — a vertex removal. Returns
/// the data needed to undo it.
#[allow(clippy::type_complexity)]
fn remove_star(
    m: &mut Mesh,
    v: VertexId,
    r: usize,
) -> Option<(Vec<FaceId>, Vec<[VertexId; 4]>, Vec<FaceId>)> {
    if m.is_boundary_vertex(v) || m.valence(v) != 4 {
        return None;
    }
    let star: Vec<FaceId> = m.vertex_faces(v).collect();
    let old: Vec<[VertexId; 4]> = star.iter().map(|&f| m.quad_vertices(f).unwrap()).collect();
    // octagon boundary of the star in order: for each outgoing half-edge h
    // (clockwise), the face on its left contributes its two far vertices.
    let mut oct = Vec::new();
    for h in m.outgoing(v).collect::<Vec<_>>().into_iter().rev() {
        let f = m.face(h)?;
        let q = m.quad_vertices(f)?;
        let k = q.iter().position(|&x| x == v)?;
        oct.push(q[(k + 1) % 4]);
        oct.push(q[(k + 2) % 4]);
    }
    let o: Vec<VertexId> = (0..8).map(|i| oct[(i + r) % 8]).collect();
    let add = [
        [o[0], o[1], o[2], o[3]],
        [o[3], o[4], o[5], o[6]],
        [o[0], o[3], o[6], o[7]],
    ];
    m.can_replace_patch(&star, &add).ok()?;
    let res = m.replace_patch(&star, &add).unwrap();
    assert_eq!(res.removed_vertices, vec![v]);
    Some((res.faces, old, res.removed_faces))
}

#[test]
fn rejected_patches_leave_the_mesh_alone() {
    let m = Mesh::from_indexed(&grid(2, 2)).unwrap();
    let f0 = FaceId(0);
    // a new face reusing a directed edge of a kept face → third face on an edge
    let q = m.quad_vertices(FaceId(1)).unwrap();
    assert!(m.can_replace_patch(&[f0], &[q]).is_err());
    // removing an inner face and adding nothing opens a hole → Euler changes
    let g = Mesh::from_indexed(&grid(3, 3)).unwrap();
    assert!(g
        .can_replace_patch::<[VertexId; 4]>(&[FaceId(4)], &[])
        .is_err());
    // removing a corner face keeps a disk: allowed
    assert!(g
        .can_replace_patch::<[VertexId; 4]>(&[FaceId(0)], &[])
        .is_ok());
    m.validate().unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random vertex removals on a torus, each checked with validate(), then
    /// undone in reverse order: the mesh comes back face for face.
    #[test]
    fn patch_replacement_round_trip(picks in prop::collection::vec((0u32..64, 0usize..8), 1..12)) {
        let src = torus(8, 8);
        let mut m = Mesh::from_indexed(&src).unwrap();
        let chi = m.euler_characteristic();
        let mut undo = Vec::new();
        for (v, r) in picks {
            let v = VertexId(v);
            if !m.is_vertex_alive(v) { continue; }
            if let Some(step) = remove_star(&mut m, v, r % 2) {
                // a removal may leave two quads sharing two edges; the
                // structure must stay sound regardless
                m.validate_structure().unwrap();
                prop_assert_eq!(m.euler_characteristic(), chi);
                undo.push(step);
            }
        }
        // the first pick on an untouched torus always applies
        prop_assert!(!undo.is_empty());
        while let Some((faces, old, dead)) = undo.pop() {
            m.can_replace_patch(&faces, &old).unwrap();
            m.replace_patch_reviving(&faces, &old, &dead).unwrap();
            m.validate_structure().unwrap();
        }
        m.validate().unwrap();
        let (back, _) = m.to_indexed();
        prop_assert_eq!(back.positions.len(), src.positions.len());
        let canon = |im: &IndexedMesh| {
            let mut fs: Vec<Vec<u32>> = im.faces().map(|f| {
                let k = (0..f.len()).min_by_key(|&i| f[i]).unwrap();
                (0..f.len()).map(|i| f[(k + i) % f.len()]).collect()
            }).collect();
            fs.sort();
            fs
        };
        prop_assert_eq!(canon(&back), canon(&src));
    }
}

/// What `valence` and `is_boundary_vertex` must say, from a walk of the
/// half-edge records (the mesh answers both from a per-vertex byte it
/// updates where rings change).
fn assert_vertex_info_walks(m: &Mesh) {
    for i in 0..m.vertex_capacity() as u32 {
        let v = VertexId(i);
        let walked = m.outgoing(v).count();
        let boundary = m.outgoing(v).any(|h| m.is_boundary_halfedge(h));
        assert_eq!(m.valence(v), walked, "valence of vertex {v}");
        assert_eq!(
            m.is_boundary_vertex(v),
            boundary,
            "boundary flag of vertex {v}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random vertex removals on an open grid and their undos (which bring
    /// dead vertices back): after each, every vertex id's valence and
    /// boundary flag equal a walk of its ring (interior, boundary and
    /// deleted vertices alike).
    #[test]
    fn valence_and_boundary_flags_follow_patches(picks in prop::collection::vec((0u32..49, 0usize..8), 1..16)) {
        let mut m = Mesh::from_indexed(&grid(6, 6)).unwrap();
        assert_vertex_info_walks(&m);
        let mut undo = Vec::new();
        for (v, r) in picks {
            let v = VertexId(v);
            if !m.is_vertex_alive(v) { continue; }
            if let Some(step) = remove_star(&mut m, v, r % 2) {
                assert_vertex_info_walks(&m);
                undo.push(step);
            }
        }
        while let Some((faces, old, dead)) = undo.pop() {
            m.replace_patch_reviving(&faces, &old, &dead).unwrap();
            assert_vertex_info_walks(&m);
        }
        m.validate().unwrap();
    }
}
