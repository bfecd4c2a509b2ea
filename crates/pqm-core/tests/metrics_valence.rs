//! Valence statistics on hand-made meshes with known structure.

mod metrics_util;
use metrics_util as common;

use glam::DVec3;
use pqm_core::metrics::valence::{boundary_ideal_valence, valence};
use pqm_core::IndexedMesh;

#[test]
fn cube_has_eight_valence_three_vertices() {
    let r = valence(&common::cube());
    assert_eq!(r.stats.extraordinary, 8);
    assert_eq!(r.stats.worst, 3);
    assert_eq!(r.stats.ideal_fraction, 0.0);
    assert_eq!(r.histogram, vec![0, 0, 0, 8]);
}

#[test]
fn grid_with_boundary_is_all_ideal() {
    for (nx, ny) in [(1, 1), (1, 5), (6, 4)] {
        let g = common::grid(nx, ny, |x, y| 0.05 * (x * y).sin());
        let r = valence(&g);
        assert_eq!(r.stats.extraordinary, 0, "{nx}x{ny}");
        assert_eq!(r.stats.ideal_fraction, 1.0);
        // All deviations are 0, so the largest valence present wins the tie.
        let expected_worst = match (nx, ny) {
            (1, 1) => 2,
            (1, _) | (_, 1) => 3,
            _ => 4,
        };
        assert_eq!(r.stats.worst, expected_worst, "{nx}x{ny}");
        // Corners have ideal 2, other boundary vertices 3, interior 4.
        let corner = 0;
        assert_eq!((r.valence[corner], r.ideal[corner]), (2, 2));
        let total: usize = r.histogram.iter().sum();
        assert_eq!(total, (nx + 1) * (ny + 1));
    }
}

#[test]
fn torus_is_all_ideal_with_worst_four() {
    let r = valence(&common::torus(12, 8));
    assert_eq!(r.stats.extraordinary, 0);
    assert_eq!(r.stats.worst, 4);
    assert_eq!(r.histogram[4], 96);
}

#[test]
fn concave_boundary_corner_has_ideal_four() {
    // An L-shaped 2x2 grid with the (1,1) quad removed: the inner corner at
    // (1,1) spans 270°, three quads, valence 4, which is ideal there.
    let mut g = common::grid(2, 2, |_, _| 0.0);
    let keep: Vec<Vec<u32>> = g
        .faces()
        .enumerate()
        .filter(|(f, _)| *f != 3)
        .map(|(_, f)| f.to_vec())
        .collect();
    g = IndexedMesh::from_faces(g.positions.clone(), keep);
    let r = valence(&g);
    let inner = 4; // vertex (1,1)
    assert_eq!((r.valence[inner], r.ideal[inner]), (4, 4));
    assert_eq!(r.stats.extraordinary, 0);
    // The removed quad's far corner (2,2) is no longer referenced.
    assert_eq!(r.valence[8], 0);
    assert_eq!(r.histogram.iter().sum::<usize>(), 8);
}

#[test]
fn extraordinary_vertex_is_found_and_worst_prefers_larger_valence() {
    // A fan of 5 quads around a centre: centre valence 5 (interior, off by 1).
    let n = 5;
    let mut positions = vec![DVec3::ZERO];
    for i in 0..2 * n {
        let a = std::f64::consts::TAU * i as f64 / (2 * n) as f64;
        let r = if i % 2 == 0 { 1.0 } else { 1.4 };
        positions.push(DVec3::new(r * a.cos(), r * a.sin(), 0.0));
    }
    let ring = |i: usize| (1 + i % (2 * n)) as u32;
    let faces: Vec<[u32; 4]> = (0..n)
        .map(|k| [0, ring(2 * k), ring(2 * k + 1), ring(2 * k + 2)])
        .collect();
    let r = valence(&IndexedMesh::from_faces(positions, faces));
    assert_eq!(r.valence[0], 5);
    assert_eq!(r.ideal[0], 4);
    // Rim vertices at radius 1 lie in two quads with corner angles of about
    // 99° each (198° → smooth boundary, ideal 3 = their valence); those at
    // radius 1.4 lie in one quad with a corner of about 90° (corner, ideal 2 =
    // their valence). Only the centre is extraordinary.
    for k in 0..n {
        assert_eq!((r.valence[1 + 2 * k], r.ideal[1 + 2 * k]), (3, 3));
        assert_eq!((r.valence[2 + 2 * k], r.ideal[2 + 2 * k]), (2, 2));
    }
    assert_eq!(r.stats.extraordinary, 1);
    assert_eq!(r.stats.worst, 5);
}

#[test]
fn corner_threshold_is_135_degrees() {
    let deg = |d: f64| d.to_radians();
    assert_eq!(boundary_ideal_valence(deg(90.0)), 2);
    assert_eq!(boundary_ideal_valence(deg(134.9)), 2);
    assert_eq!(boundary_ideal_valence(deg(135.1)), 3);
    assert_eq!(boundary_ideal_valence(deg(180.0)), 3);
    assert_eq!(boundary_ideal_valence(deg(270.0)), 4);
    assert_eq!(boundary_ideal_valence(deg(10.0)), 2);
    assert_eq!(boundary_ideal_valence(f64::NAN), 2);
}

#[test]
fn shared_quad_meshes_match_manifest_irregular_counts() {
    // MANIFEST "irreg" = interior vertices with valence != 4; closed meshes have
    // no boundary, so that is exactly our extraordinary count.
    for (name, irregular) in [
        ("quad/fandisk_quads.off", 30),
        ("quad/spot_quadrangulated.obj", 100),
        ("quad/spot_control_mesh.obj", 80),
    ] {
        let m = common::load_shared(name);
        let r = valence(&m);
        assert_eq!(r.stats.extraordinary, irregular, "{name}");
        assert!(r.stats.ideal_fraction > 0.0 && r.stats.ideal_fraction < 1.0);
        let sum: usize = r.histogram.iter().sum();
        assert_eq!(sum, m.vertex_count(), "{name}");
    }
}

#[test]
fn malformed_faces_do_not_panic() {
    let mut m = common::grid(2, 2, |_, _| 0.0);
    m.push_face(&[0, 100, 2]);
    m.push_face(&[1, 1]);
    m.face_starts.push(9999); // a face range past the end of `indices`
    let r = valence(&m);
    assert_eq!(r.stats.extraordinary, 0);
}
