//! Feature edges: sharp-edge detection, feature files and polylines, and the
//! split of the feature graph into curves.

mod attributes_shapes;
use attributes_shapes::*;

use pqm_core::features::{
    feature_edges_from_polylines, load_features, parse_features, sharp_edges, FeatureCurves,
    DEFAULT_SHARP_ANGLE_DEG,
};
use pqm_core::VertexId;

#[test]
fn cube_sharp_edges_form_twelve_curves_between_eight_corners() {
    let n = 3;
    let m = mesh(&cube_lattice(n, |p| p));
    let edges = sharp_edges(&m, DEFAULT_SHARP_ANGLE_DEG);
    assert_eq!(edges.len(), 12 * n as usize);
    for &(a, b) in &edges {
        assert!(a < b);
        // both ends on a cube edge: at least two coordinates at ±1
        for v in [a, b] {
            let p = m.position(v);
            let on = p
                .abs()
                .cmpgt(glam::DVec3::splat(0.999))
                .bitmask()
                .count_ones();
            assert!(on >= 2, "{p:?}");
        }
    }
    assert!(edges.windows(2).all(|w| w[0] < w[1]), "sorted and unique");
    assert!(sharp_edges(&m, 180.0).is_empty());
    assert!(
        sharp_edges(&m, 91.0).is_empty(),
        "the cube's dihedral angles are 90°"
    );
    assert_eq!(sharp_edges(&m, 89.0).len(), 12 * n as usize);

    let fc = FeatureCurves::new(&m, &edges, false).unwrap();
    assert_eq!(fc.curve_count(), 12);
    assert_eq!(fc.curve_edge_counts(), vec![n as usize; 12]);
    let corners: Vec<VertexId> = m.vertices().filter(|&v| fc.is_corner(v)).collect();
    assert_eq!(corners.len(), 8);
    for &c in &corners {
        assert_eq!(fc.degree(c), 3);
    }
    for c in &fc.curves {
        assert!(!c.closed);
        assert_eq!(c.vertices.len(), c.edge_count + 1);
        assert!(fc.is_corner(c.vertices[0]) && fc.is_corner(*c.vertices.last().unwrap()));
        // consecutive vertices are joined by feature edges of this curve
        for w in c.vertices.windows(2) {
            assert_eq!(
                fc.curve_of(w[0], w[1]),
                fc.curve_of(c.vertices[0], c.vertices[1])
            );
        }
    }
    check_invariants(&m, &fc);
}

/// Properties every `FeatureCurves` has.
fn check_invariants(m: &pqm_core::Mesh, fc: &FeatureCurves) {
    assert_eq!(fc.edges.len(), fc.edge_curve.len());
    assert!(fc.edges.windows(2).all(|w| w[0] < w[1]));
    let total: usize = fc.curves.iter().map(|c| c.edge_count).sum();
    assert_eq!(total, fc.edges.len(), "every edge in exactly one curve");
    for (k, c) in fc.curves.iter().enumerate() {
        let owned = fc.edge_curve.iter().filter(|&&id| id as usize == k).count();
        assert_eq!(owned, c.edge_count);
        let walk = if c.closed {
            c.vertices.len()
        } else {
            c.vertices.len() - 1
        };
        assert_eq!(walk, c.edge_count);
        if c.closed {
            assert!(c.vertices.iter().all(|&v| fc.degree(v) == 2));
        } else {
            // interior vertices of an open curve are not corners
            for &v in &c.vertices[1..c.vertices.len() - 1] {
                assert_eq!(fc.degree(v), 2);
            }
        }
    }
    for v in m.vertices() {
        let d = fc.edges.iter().filter(|&&(a, b)| a == v || b == v).count();
        assert_eq!(fc.degree(v) as usize, d);
        assert_eq!(fc.is_feature_vertex(v), d > 0);
    }
}

#[test]
fn grid_boundary_is_one_closed_loop() {
    let (nx, ny) = (5, 3);
    let m = mesh(&grid(nx, ny));
    assert!(
        sharp_edges(&m, 1.0).is_empty(),
        "a plane has no sharp edges"
    );
    let fc = FeatureCurves::new(&m, &[], true).unwrap();
    assert_eq!(fc.curve_count(), 1);
    assert!(fc.curves[0].closed);
    assert_eq!(fc.curves[0].edge_count, 2 * (nx + ny) as usize);
    check_invariants(&m, &fc);

    // add an interior polyline from one side to the other: the loop is cut
    // into curves at the two junctions (degree 3)
    let line: Vec<u32> = (0..=ny).map(|j| grid_id(nx, 2, j)).collect();
    let edges = feature_edges_from_polylines(&m, &[line]).unwrap();
    let fc = FeatureCurves::new(&m, &edges, true).unwrap();
    assert_eq!(fc.curve_count(), 3);
    let mut counts = fc.curve_edge_counts();
    counts.sort();
    assert_eq!(
        counts,
        vec![ny as usize, (2 + ny + 2) as usize, (3 + ny + 3) as usize]
    );
    check_invariants(&m, &fc);
}

#[test]
fn torus_loops_and_a_dangling_curve() {
    let (nu, nv) = (8, 6);
    let m = mesh(&torus(nu, nv, 3.0, 1.0));
    // the outer equator (closed) and a piece of a meridian ending in the open
    let equator: Vec<u32> = (0..=nu).map(|i| i % nu).collect();
    let meridian: Vec<u32> = (0..3).map(|j| j * nu + 4).collect();
    let edges = feature_edges_from_polylines(&m, &[equator, meridian]).unwrap();
    let fc = FeatureCurves::new(&m, &edges, false).unwrap();
    // vertex 4 has degree 3: the equator becomes one curve from 4 back to 4
    assert_eq!(fc.degree(VertexId(4)), 3);
    assert_eq!(fc.degree(VertexId(2 * nu + 4)), 1);
    assert_eq!(fc.curve_count(), 2);
    let eq = fc
        .curves
        .iter()
        .find(|c| c.edge_count == nu as usize)
        .expect("equator curve");
    assert_eq!(eq.vertices.first(), eq.vertices.last());
    check_invariants(&m, &fc);

    // just the equator: one closed loop without corners
    let equator: Vec<u32> = (0..=nu).map(|i| i % nu).collect();
    let edges = feature_edges_from_polylines(&m, &[equator]).unwrap();
    let fc = FeatureCurves::new(&m, &edges, false).unwrap();
    assert_eq!(fc.curve_count(), 1);
    assert!(fc.curves[0].closed && fc.curves[0].vertices.len() == nu as usize);
    check_invariants(&m, &fc);
}

#[test]
fn curves_do_not_depend_on_input_order() {
    let m = mesh(&cube_lattice(2, |p| p));
    let mut edges = sharp_edges(&m, 60.0);
    let a = FeatureCurves::new(&m, &edges, false).unwrap();
    edges.reverse();
    let mut swapped: Vec<_> = edges.iter().map(|&(a, b)| (b, a)).collect();
    swapped.extend_from_slice(&edges); // duplicates too
    let b = FeatureCurves::new(&m, &swapped, false).unwrap();
    assert_eq!(a, b);
}

#[test]
fn feature_file_parsing_and_errors() {
    let text = "# features\n0 1 2\n\n5 4 # comment\n";
    assert_eq!(
        parse_features(text, "feat.txt", 6).unwrap(),
        vec![vec![0, 1, 2], vec![5, 4]]
    );
    let err = |t: &str| parse_features(t, "feat.txt", 6).unwrap_err().to_string();
    let e = err("0 1\n2 x\n");
    assert!(e.contains("feat.txt line 2") && e.contains("'x'"), "{e}");
    let e = err("0 -1\n");
    assert!(e.contains("line 1") && e.contains("'-1'"), "{e}");
    let e = err("0 1\n# c\n3 6\n");
    assert!(
        e.contains("line 3") && e.contains("vertex 6 is out of range"),
        "{e}"
    );
    let e = err("3\n");
    assert!(e.contains("at least two vertices"), "{e}");
    let e = err("1 2 2 3\n");
    assert!(e.contains("vertex 2 is repeated"), "{e}");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("feat.txt");
    std::fs::write(&path, "0 1\n").unwrap();
    assert_eq!(load_features(&path, 2).unwrap(), vec![vec![0, 1]]);
    let e = load_features(&dir.path().join("x.txt"), 2)
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.txt"), "{e}");
}

#[test]
fn polylines_must_follow_mesh_edges() {
    let m = mesh(&grid(3, 3));
    let diag = vec![grid_id(3, 0, 0), grid_id(3, 1, 0), grid_id(3, 2, 1)];
    let e = feature_edges_from_polylines(&m, &[vec![0, 1], diag])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("feature polyline 1") && e.contains("vertices 1 and 6 are not joined"),
        "{e}"
    );
    let e = feature_edges_from_polylines(&m, &[vec![0, 99]])
        .unwrap_err()
        .to_string();
    assert!(e.contains("99"), "{e}");
    let e = FeatureCurves::new(&m, &[(VertexId(0), VertexId(5))], false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertices 0 and 5"), "{e}");
}

#[test]
fn fandisk_quads_sharp_edges_form_consistent_curves() {
    let path = shared_mesh("quad/fandisk_quads.off");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let m = mesh(&read_off(&path));
    let edges = sharp_edges(&m, DEFAULT_SHARP_ANGLE_DEG);
    // MANIFEST.md (computed by inspect.py, independently of this code)
    assert_eq!(edges.len(), 246);
    let fc = FeatureCurves::new(&m, &edges, true).unwrap();
    check_invariants(&m, &fc);
    assert!(
        fc.curve_count() >= 10,
        "fandisk has many creases: {}",
        fc.curve_count()
    );
    // a lower threshold finds a superset
    let more = sharp_edges(&m, 30.0);
    assert!(edges.iter().all(|e| more.binary_search(e).is_ok()));
    eprintln!(
        "fandisk_quads: {} sharp edges (60°), {} (30°), {} curves, {} corners",
        edges.len(),
        more.len(),
        fc.curve_count(),
        m.vertices().filter(|&v| fc.is_corner(v)).count()
    );
}

#[test]
fn fandisk_triangles_sharp_edge_count_matches_the_manifest() {
    let path = shared_mesh("tri/fandisk.off");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let m = mesh(&read_off(&path));
    assert_eq!(sharp_edges(&m, DEFAULT_SHARP_ANGLE_DEG).len(), 700);
    let fc = FeatureCurves::new(&m, &sharp_edges(&m, 60.0), false).unwrap();
    check_invariants(&m, &fc);
}
