//! Hausdorff distance: exact cases and properties.

mod metrics_util;
use metrics_util as common;

use glam::DVec3;
use pqm_core::metrics::hausdorff::{hausdorff, triangulate, HausdorffOptions};
use pqm_core::IndexedMesh;

fn translated(m: &IndexedMesh, by: DVec3) -> IndexedMesh {
    let mut out = m.clone();
    for p in &mut out.positions {
        *p += by;
    }
    out
}

#[test]
fn mesh_against_itself_is_zero() {
    let m = common::load_shared("quad/suzanne.obj");
    let r = hausdorff(&m, &m, &HausdorffOptions::default());
    assert!(r.symmetric.max < 1e-12, "{r:?}");
    assert!(r.symmetric.mean < 1e-12);
    // Metro's default: 10 × triangles (quads count twice), per direction.
    let tris = triangulate(&m).len();
    assert_eq!(tris, 468 * 2 + 32);
    assert_eq!(r.forward_samples, 10 * tris);
    assert_eq!(r.backward_samples, 10 * tris);
    assert!((r.unit - m.bbox_diagonal()).abs() < 1e-15);
}

#[test]
fn plane_against_translated_plane_is_the_offset() {
    let plane = common::grid(20, 10, |_, _| 0.0);
    let d = 0.37;
    let lifted = translated(&plane, DVec3::new(0.0, 0.0, d));
    let r = hausdorff(&lifted, &plane, &HausdorffOptions::default());
    let diag = plane.bbox_diagonal();
    for s in [r.forward, r.backward, r.symmetric] {
        assert!((s.max - d / diag).abs() < 1e-12, "{s:?}");
        assert!((s.mean - d / diag).abs() < 1e-12, "{s:?}");
    }
}

#[test]
fn pyramid_apex_gives_the_height() {
    // A flat 2x2 patch whose centre vertex is raised by h: the farthest point of
    // the raised surface from the plane is the apex, exactly h away (it is a
    // vertex sample); the plane is within h of the raised surface everywhere.
    let h = 0.5;
    let flat = common::grid(2, 2, |_, _| 0.0);
    let raised = common::grid(2, 2, |x, y| if x == 1.0 && y == 1.0 { h } else { 0.0 });
    let r = hausdorff(&raised, &flat, &HausdorffOptions::default());
    let diag = flat.bbox_diagonal();
    assert!((r.forward.max - h / diag).abs() < 1e-12, "{r:?}");
    assert!(r.backward.max <= r.forward.max + 1e-12);
    assert!(r.forward.mean > 0.0 && r.forward.mean < r.forward.max);
}

#[test]
fn swapping_the_meshes_swaps_directions() {
    let a = common::grid(12, 9, |x, y| 0.3 * (x * 0.7).sin() + 0.2 * (y * 0.5).cos());
    let b = common::grid(12, 9, |x, y| {
        0.25 * (x * 0.6).sin() + 0.2 * (y * 0.55).cos()
    });
    let b = translated(&b, DVec3::new(0.5, 0.5, 0.5)); // different bounding box too
    let opts = HausdorffOptions::default();
    let ab = hausdorff(&a, &b, &opts);
    let ba = hausdorff(&b, &a, &opts);
    // Same samples both ways; only the unit (reference diagonal) differs.
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x.abs().max(y.abs());
    assert!(close(ab.forward.max * ab.unit, ba.backward.max * ba.unit));
    assert!(close(ab.backward.max * ab.unit, ba.forward.max * ba.unit));
    assert!(close(
        ab.symmetric.max * ab.unit,
        ba.symmetric.max * ba.unit
    ));
    assert!(close(
        ab.symmetric.mean * ab.unit,
        ba.symmetric.mean * ba.unit
    ));
    assert!(ab.symmetric.max > 0.0 && ab.forward_samples == ba.backward_samples);
    assert_eq!(ab.symmetric.max, ab.forward.max.max(ab.backward.max));
    // The symmetric mean is the sample-weighted mean of both directions.
    let weighted = (ab.forward.mean * ab.forward_samples as f64
        + ab.backward.mean * ab.backward_samples as f64)
        / (ab.forward_samples + ab.backward_samples) as f64;
    assert!((ab.symmetric.mean - weighted).abs() < 1e-12);
}

#[test]
fn more_samples_never_lower_much_and_converge() {
    // A bumpy surface against a flat one: the max converges from below as the
    // sampling gets denser (vertices are always sampled, so it is already good).
    let bumpy = common::grid(10, 10, |x, y| 0.2 * (x * 1.3).sin() * (y * 0.9).cos());
    let flat = common::grid(3, 3, |_, _| 0.0);
    let flat = IndexedMesh::from_faces(
        flat.positions.iter().map(|p| *p * 10.0 / 3.0).collect(),
        flat.faces().map(|f| f.to_vec()).collect::<Vec<_>>(),
    );
    let coarse = hausdorff(
        &bumpy,
        &flat,
        &HausdorffOptions {
            samples: Some(100),
            ..Default::default()
        },
    );
    let fine = hausdorff(
        &bumpy,
        &flat,
        &HausdorffOptions {
            samples: Some(100_000),
            ..Default::default()
        },
    );
    // The exact forward maximum is max |z| = 0.2 · max|sin| · max|cos| over the grid points.
    let exact = bumpy
        .positions
        .iter()
        .map(|p| p.z.abs())
        .fold(0.0, f64::max)
        / flat.bbox_diagonal();
    assert!(fine.forward.max >= coarse.forward.max - 1e-15);
    assert!(
        (fine.forward.max - exact).abs() < 1e-12,
        "{} vs {exact}",
        fine.forward.max
    );
    assert!(fine.forward_samples > coarse.forward_samples);
}

#[test]
fn sampling_flags_and_degenerate_inputs() {
    let m = common::grid(4, 4, |_, _| 0.0);
    let only_vertices = HausdorffOptions {
        sample_edges: false,
        sample_faces: false,
        ..Default::default()
    };
    let r = hausdorff(&m, &m, &only_vertices);
    assert_eq!(r.forward_samples, 25);
    let only_edges = HausdorffOptions {
        sample_vertices: false,
        sample_faces: false,
        ..Default::default()
    };
    // Metro's edge density: √(target / area) samples per unit length, here
    // target = 10 × 32 triangles over area 16, on 40 unit edges.
    let per_length = (320.0f64 / 16.0).sqrt();
    let expected = (40.0 * per_length).floor() as usize;
    assert_eq!(hausdorff(&m, &m, &only_edges).forward_samples, expected);
    // A small target leaves one sample (the midpoint) per edge.
    let few = HausdorffOptions {
        samples: Some(40),
        ..only_edges
    };
    assert_eq!(hausdorff(&m, &m, &few).forward_samples, 40);
    // Vertices + edges + faces always add up to the target when it is large enough.
    let r = hausdorff(&m, &m, &HausdorffOptions::default());
    assert_eq!(r.forward_samples, 320);

    // Empty reference: infinitely far. Empty both: zero.
    let empty = IndexedMesh::new();
    let r = hausdorff(&m, &empty, &HausdorffOptions::default());
    assert_eq!(r.forward.max, f64::INFINITY);
    assert_eq!((r.backward_samples, r.backward.max), (0, 0.0));
    assert_eq!(r.unit, 1.0);
    let r = hausdorff(&empty, &empty, &HausdorffOptions::default());
    assert_eq!((r.symmetric.max, r.symmetric.mean), (0.0, 0.0));

    // NaN positions and broken faces are skipped, not a panic.
    let mut bad = m.clone();
    bad.positions.push(DVec3::new(f64::NAN, 0.0, 0.0));
    bad.push_face(&[0, 1, 25]);
    bad.push_face(&[0, 1, 999]);
    let r = hausdorff(&bad, &m, &HausdorffOptions::default());
    assert!(r.symmetric.max < 1e-12, "{r:?}");
}

#[test]
fn triangulation_splits_quads_on_the_shorter_diagonal() {
    let positions = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(3.0, 0.0, 0.0),
        DVec3::new(3.5, 1.0, 0.0),
        DVec3::new(0.5, 1.0, 0.0),
    ];
    // Diagonal 0-2 is long (√13.25), 1-3 short (√7.25): split on 1-3.
    let m = IndexedMesh::from_faces(positions.clone(), [[0u32, 1, 2, 3]]);
    assert_eq!(triangulate(&m), vec![[0, 1, 3], [1, 2, 3]]);
    let pent = IndexedMesh::from_faces(positions, [[0u32, 1, 2, 3, 0]]);
    assert_eq!(triangulate(&pent).len(), 3);
}
