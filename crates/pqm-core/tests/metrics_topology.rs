//! Topology figures against `shared/meshes/MANIFEST.md` and small known cases.

mod metrics_util;
use metrics_util as common;

use glam::DVec3;
use pqm_core::metrics::topology::topology;
use pqm_core::IndexedMesh;

/// (file, V, F, chi, genus, components, boundary loops) from MANIFEST.md.
const MANIFEST: &[(&str, usize, usize, i64, i64, usize, usize)] = &[
    ("quad/fandisk_quads.off", 766, 764, 2, 0, 1, 0),
    ("quad/suzanne.obj", 507, 500, 2, 0, 3, 4),
    ("quad/spot_quadrangulated.obj", 2930, 2928, 2, 0, 1, 0),
    ("quad/spot_control_mesh.obj", 188, 180, 2, 0, 1, 0),
    ("quad/loki.obj", 27514, 27352, -2, 0, 1, 4),
    ("quad/makehuman_base.obj", 19158, 18486, 280, 0, 154, 28),
    ("quad/sword-quad-dominant.obj", 22293, 22465, 2, 0, 1, 0),
    ("tri/bunny.off", 34835, 69666, 2, 0, 1, 0),
    ("tri/fertility.off", 4494, 9000, -6, 4, 1, 0),
    ("tri/fandisk.off", 6475, 12946, 2, 0, 1, 0),
    ("large/amo.off", 90112, 180220, 2, 0, 1, 0),
    ("large/skull.obj", 49999, 100002, -2, 2, 1, 0),
];

#[test]
fn every_shared_mesh_matches_the_manifest() {
    for &(name, v, f, chi, genus, comps, loops) in MANIFEST {
        let m = common::load_shared(name);
        assert_eq!(
            (m.vertex_count(), m.face_count()),
            (v, f),
            "{name}: file counts"
        );
        let t = topology(&m);
        assert_eq!(t.vertices, v, "{name}: every vertex is used");
        assert_eq!(t.faces, f, "{name}");
        assert_eq!(t.euler, chi, "{name}: chi");
        assert_eq!(t.components, comps, "{name}: components");
        assert_eq!(t.boundary_loops, loops, "{name}: boundary loops");
        assert_eq!(t.genus, genus, "{name}: genus");
        assert_eq!(t.nonmanifold_edges, 0, "{name}");
        assert_eq!(t.boundary_edges == 0, loops == 0, "{name}");
    }
}

#[test]
fn small_known_surfaces() {
    let cube = topology(&common::cube());
    assert_eq!((cube.vertices, cube.edges, cube.faces), (8, 12, 6));
    assert_eq!(
        (cube.euler, cube.genus, cube.components, cube.boundary_loops),
        (2, 0, 1, 0)
    );

    let torus = topology(&common::torus(10, 6));
    assert_eq!(
        (
            torus.euler,
            torus.genus,
            torus.components,
            torus.boundary_loops
        ),
        (0, 1, 1, 0)
    );

    let disk = topology(&common::grid(4, 3, |_, _| 0.0));
    assert_eq!(
        (
            disk.euler,
            disk.genus,
            disk.boundary_loops,
            disk.boundary_edges
        ),
        (1, 0, 1, 14)
    );
}

#[test]
fn cylinder_has_two_loops_and_genus_zero() {
    // The torus grid with its last ring of quads removed is an open tube.
    let t = common::torus(10, 6);
    let faces: Vec<Vec<u32>> = t.faces().take(9 * 6).map(|f| f.to_vec()).collect();
    let tube = topology(&IndexedMesh::from_faces(t.positions.clone(), faces));
    assert_eq!(
        (tube.euler, tube.genus, tube.components, tube.boundary_loops),
        (0, 0, 1, 2)
    );
}

#[test]
fn components_genus_sum_and_unreferenced_vertices() {
    // Cube + torus + a lone unused vertex: χ adds up, genus adds up.
    let cube = common::cube();
    let torus = common::torus(8, 5);
    let mut positions = cube.positions.clone();
    positions.extend(&torus.positions);
    positions.push(DVec3::splat(99.0));
    let off = cube.positions.len() as u32;
    let mut faces: Vec<Vec<u32>> = cube.faces().map(|f| f.to_vec()).collect();
    faces.extend(
        torus
            .faces()
            .map(|f| f.iter().map(|&v| v + off).collect::<Vec<_>>()),
    );
    let m = IndexedMesh::from_faces(positions, faces);
    let t = topology(&m);
    assert_eq!(t.vertices, m.vertex_count() - 1);
    assert_eq!(
        (t.components, t.euler, t.genus, t.boundary_loops),
        (2, 2, 1, 0)
    );
}

#[test]
fn bad_faces_are_skipped() {
    let mut m = common::cube();
    m.push_face(&[0, 1]); // too short
    m.push_face(&[0, 1, 42]); // out of range
    let t = topology(&m);
    assert_eq!((t.faces, t.euler, t.genus), (6, 2, 0));
    let empty = topology(&IndexedMesh::new());
    assert_eq!(
        (empty.vertices, empty.components, empty.genus, empty.euler),
        (0, 0, 0, 0)
    );
}

/// `forced_irregular` is the Euler-characteristic bound: 8 per closed
/// sphere, none on a torus or a surface with a boundary — and no mesh has
/// fewer irregular vertices than it says (doublet-free quad meshes).
#[test]
fn forced_irregular_vertices_bound_the_extraordinary_count() {
    use pqm_core::metrics::valence::valence;
    use pqm_core::shapes;
    let cases = [
        (shapes::cube(1.0), 8),
        (shapes::quad_sphere(5, 1.0), 8),
        (shapes::torus(12, 8, 2.0, 0.5), 0),
        (shapes::grid(4, 3, 1.0, 1.0), 0),
        (
            shapes::concat(&[shapes::cube(1.0), shapes::quad_sphere(3, 1.0)]),
            16,
        ),
        (
            shapes::concat(&[shapes::cube(1.0), shapes::grid(2, 2, 1.0, 1.0)]),
            8,
        ),
    ];
    for (i, (m, forced)) in cases.iter().enumerate() {
        let t = topology(m);
        assert_eq!(t.forced_irregular, *forced, "case {i}");
        assert!(
            valence(m).stats.extraordinary >= t.forced_irregular,
            "case {i}"
        );
    }
    // the shared quad meshes: a real bound, met with equality by none but
    // never undercut (makehuman's 129 closed joint pieces force 1,032)
    for &(name, ..) in MANIFEST.iter().filter(|m| m.0.starts_with("quad/")) {
        let m = common::load_shared(name);
        let t = topology(&m);
        let v = valence(&m).stats;
        assert!(v.extraordinary >= t.forced_irregular, "{name}");
        if name.ends_with("makehuman_base.obj") {
            assert_eq!(t.forced_irregular, 1032, "{name}");
        }
    }
}
