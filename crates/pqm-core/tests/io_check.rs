//! `check` names each defect with the right element on tiny hand-made meshes;
//! `repair` fixes it and `check` then passes.

mod io_util;

use glam::DVec3;
use io_util::{cube, faces, shared};
use pqm_core::io::{check, read_mesh, repair, Defect, Element};
use pqm_core::IndexedMesh;

fn square_grid() -> Vec<DVec3> {
    // 3 x 3 points in the plane z = 0, index = x + 3 y.
    (0..9)
        .map(|i| DVec3::new((i % 3) as f64, (i / 3) as f64, 0.0))
        .collect()
}

fn expect(m: &IndexedMesh, defect: Defect, element: Element) {
    let e = check(m).expect_err("check must fail");
    assert_eq!((e.defect, e.element), (defect, element), "{e}");
}

/// Repairs and requires a clean `check` afterwards; returns the report.
fn repaired(mut m: IndexedMesh) -> (IndexedMesh, pqm_core::io::RepairReport) {
    let r = repair(&mut m);
    if let Err(e) = check(&m) {
        panic!("still invalid after repair ({r}): {e}");
    }
    (m, r)
}

#[test]
fn no_faces() {
    let m = IndexedMesh::from_faces(square_grid(), Vec::<[u32; 3]>::new());
    expect(&m, Defect::NoFaces, Element::Mesh);
    assert_eq!(check(&m).unwrap_err().to_string(), "mesh has no faces");
}

#[test]
fn non_finite_coordinate() {
    let mut p = square_grid();
    p[4].y = f64::NAN;
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6]]);
    expect(&m, Defect::NonFiniteCoordinate, Element::Vertex(4));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "vertex 4 has a non-finite coordinate"
    );
    // With the NaN vertex in only one face, the other faces survive.
    let mut p = square_grid();
    p[8].z = f64::INFINITY;
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 4, 3], [4, 5, 8, 7]]);
    expect(&m, Defect::NonFiniteCoordinate, Element::Vertex(8));
    let (m, r) = repaired(m);
    assert_eq!(
        (r.dropped_invalid_faces, m.face_count(), m.vertex_count()),
        (1, 1, 4)
    );
}

#[test]
fn too_few_vertices_and_out_of_range() {
    let m = IndexedMesh::from_faces(
        square_grid(),
        [&[0u32, 1, 4, 3][..], &[1, 2], &[3, 4, 7, 6]],
    );
    expect(&m, Defect::TooFewVertices, Element::Face(1));
    let (m, r) = repaired(m);
    assert_eq!(r.dropped_invalid_faces, 1);
    assert_eq!(m.face_count(), 2);

    let m = IndexedMesh::from_faces(square_grid(), [[0u32, 1, 4, 3], [1, 2, 9, 4]]);
    expect(&m, Defect::IndexOutOfRange, Element::Face(1));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "face 1 references vertex 9 but the mesh has 9 vertices"
    );
    repaired(m);
}

#[test]
fn repeated_vertex() {
    let m = IndexedMesh::from_faces(square_grid(), [[0u32, 1, 4, 3], [1, 2, 5, 2]]);
    expect(&m, Defect::RepeatedVertex, Element::Face(1));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "face 1 repeats vertex 2"
    );
    let (_, r) = repaired(m);
    assert_eq!(r.dropped_repeated_vertex_faces, 1);
}

#[test]
fn zero_area() {
    // Face 1 has distinct but collinear vertices (0, 1, 2 lie on y = 0).
    let m = IndexedMesh::from_faces(square_grid(), [&[0u32, 1, 4, 3][..], &[0, 1, 2]]);
    expect(&m, Defect::ZeroArea, Element::Face(1));
    let (_, r) = repaired(m);
    assert_eq!(r.dropped_zero_area_faces, 1);
    // Coincident positions under distinct indices: zero area too.
    let mut p = square_grid();
    p.push(p[4]);
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 4], [4, 9, 3]]);
    expect(&m, Defect::ZeroArea, Element::Face(1));
    let (m, r) = repaired(m);
    // Welding 9 into 4 makes face 1 repeat a vertex; it is dropped.
    assert_eq!((r.welded_vertices, r.dropped_repeated_vertex_faces), (1, 1));
    assert_eq!(faces(&m), vec![vec![0, 1, 2]]);
}

#[test]
fn unreferenced_vertex() {
    let m = IndexedMesh::from_faces(square_grid(), [[0u32, 1, 4, 3], [1, 2, 5, 4]]);
    expect(&m, Defect::UnreferencedVertex, Element::Vertex(6));
    let (m, r) = repaired(m);
    assert_eq!(r.dropped_unreferenced_vertices, 3);
    assert_eq!(m.vertex_count(), 6);
    // The kept vertices keep their order and positions.
    assert_eq!(m.positions, square_grid()[..6].to_vec());
}

#[test]
fn non_manifold_edge() {
    // Three triangles on edge 0-1: two in the plane, one standing up.
    let mut p = vec![
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(0.5, 1.0, 0.0),
        DVec3::new(0.5, -1.0, 0.0),
    ];
    p.push(DVec3::new(0.5, 0.0, 1.0));
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 2], [1, 0, 3], [0, 1, 4]]);
    expect(&m, Defect::NonManifoldEdge, Element::Edge(0, 1));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "edge 0-1 is shared by 3 faces (0, 1, 2)"
    );
    let (m, r) = repaired(m);
    assert_eq!(r.dropped_nonmanifold_faces, 1);
    assert_eq!(m.face_count(), 2);
}

#[test]
fn inconsistent_orientation() {
    let m = IndexedMesh::from_faces(square_grid()[..6].to_vec(), [[0u32, 1, 4, 3], [1, 4, 5, 2]]);
    expect(&m, Defect::InconsistentOrientation, Element::Edge(1, 4));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "edge 1-4 is traversed in the same direction by faces 0 and 1"
    );
    let (m, r) = repaired(m);
    assert_eq!(r.flipped_faces, 1);
    assert_eq!(faces(&m), vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]]);
}

#[test]
fn non_manifold_vertex() {
    // Two quads touching at vertex 2 only (a bow tie).
    let p = [[0, 0], [1, 0], [1, 1], [0, 1], [2, 1], [2, 2], [1, 2]]
        .map(|[x, y]| DVec3::new(x as f64, y as f64, 0.0))
        .to_vec();
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 2, 3], [2, 4, 5, 6]]);
    expect(&m, Defect::NonManifoldVertex, Element::Vertex(2));
    assert_eq!(
        check(&m).unwrap_err().to_string(),
        "vertex 2 has 2 separate fans of faces"
    );
    let (m, r) = repaired(m);
    assert_eq!(r.split_vertices, 1);
    assert_eq!(m.vertex_count(), 8);
    assert_eq!(m.positions[7], m.positions[2]);
    let shared: Vec<u32> = m
        .face(0)
        .iter()
        .filter(|v| m.face(1).contains(v))
        .copied()
        .collect();
    assert!(shared.is_empty(), "the fans no longer share a vertex");
}

#[test]
fn repair_keeps_attributes_consistent() {
    // Texcoords/normals per corner follow flipped faces; scalars follow split
    // and dropped vertices.
    let mut m = IndexedMesh::from_faces(
        square_grid(),
        [&[0u32, 1, 4, 3][..], &[4, 7, 8, 5], &[1, 2, 2]],
    );
    m.texcoords = (0..9).map(|i| [i as f64, 0.0]).collect();
    m.corner_texcoords = m.indices.clone();
    m.normals = vec![DVec3::Z];
    m.corner_normals = vec![0; m.indices.len()];
    m.vertex_scalars
        .insert("q".into(), (0..9).map(|i| i as f64).collect());
    m.groups = vec![("a".into(), 0), ("b".into(), 2)];
    let (m, r) = repaired(m);
    assert_eq!(r.dropped_repeated_vertex_faces, 1);
    assert_eq!(r.split_vertices, 1);
    assert_eq!(m.corner_texcoords.len(), m.indices.len());
    assert_eq!(m.corner_normals.len(), m.indices.len());
    // Every corner's texcoord still names its original vertex, whose position
    // and scalar are unchanged.
    let q = &m.vertex_scalars["q"];
    for (c, &v) in m.indices.iter().enumerate() {
        let orig = m.texcoords[m.corner_texcoords[c] as usize][0] as usize;
        assert_eq!(m.positions[v as usize], square_grid()[orig]);
        assert_eq!(q[v as usize], orig as f64);
    }
    // Group "b" lost its only face.
    assert_eq!(m.groups, vec![("a".to_string(), 0)]);
}

#[test]
fn repair_reorients_a_real_mesh_with_the_fewest_flips() {
    let orig = read_mesh(&shared("quad/fandisk_quads.off")).unwrap();
    let mut m = orig.clone();
    for f in [3usize, 100, 101, 500] {
        let (s, e) = (m.face_starts[f] as usize + 1, m.face_starts[f + 1] as usize);
        m.indices[s..e].reverse();
    }
    assert_eq!(
        check(&m).unwrap_err().defect,
        Defect::InconsistentOrientation
    );
    let (m, r) = repaired(m);
    assert_eq!(r.flipped_faces, 4);
    assert_eq!(m, orig);
}

#[test]
fn repair_welds_a_split_vertex_back() {
    // Detach one corner of the cube onto a duplicate vertex: the cube gets a
    // crack; welding closes it and the duplicate is dropped.
    let orig = cube();
    let mut m = orig.clone();
    m.positions.push(m.positions[7]);
    m.indices[m.face_starts[1] as usize + 2] = 8; // face 1 = [4, 5, 7, 6]
    check(&m).unwrap(); // an open crack is still a valid manifold with boundary
    let (m, r) = repaired(m);
    assert_eq!((r.welded_vertices, r.dropped_unreferenced_vertices), (1, 1));
    assert_eq!(m, orig);
}

#[test]
fn report_display_and_serialize() {
    let mut m = IndexedMesh::from_faces(square_grid(), [[0u32, 1, 4, 3], [1, 4, 5, 2]]);
    let r = repair(&mut m);
    assert_eq!(
        r.to_string(),
        "flipped 1 face, dropped 3 unreferenced vertices"
    );
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["flipped_faces"], 1);
    assert_eq!(json["dropped_unreferenced_vertices"], 3);
    let mut clean = cube();
    assert_eq!(repair(&mut clean).to_string(), "no changes");
}
