//! `Placement::Subset`: every level's vertices sit exactly at input
//! positions, no record moves a vertex, the records still replay to the
//! input, and the mesh stays valid and un-inverted (straight corners are the
//! only shape defect the placement allows).

use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement, Smoothing, StopReason};
use pqm_core::{ops, shapes, IndexedMesh, Mesh};

fn coarsen(src: &IndexedMesh, target: usize) -> (Coarsener, pqm_core::coarsen::CoarsenReport) {
    let mesh = Mesh::from_indexed(src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        placement: Placement::Subset,
        smoothing: Smoothing::None,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let r = c.run(&mut |_| {});
    (c, r)
}

#[test]
fn every_level_sits_at_input_positions() {
    let src = shapes::noisy(&shapes::bumpy_torus(40, 16, 2.0, 0.6, 0.4, 7), 0.004, 3);
    let (c, r) = coarsen(&src, 120);
    assert!(
        r.qv_merges + r.qe_merges > 50,
        "the placement leaves steps to take: {r:?}"
    );
    let pm = c.into_progressive();
    pm.validate().expect("valid progressive mesh");
    assert!(
        pm.records.iter().all(|rec| rec.moved.is_empty()),
        "no record moves a vertex"
    );
    let n = pm.records.len();
    for k in [0, n / 3, 2 * n / 3, n] {
        let level = pm.level(k);
        for (id, p) in level.positions.iter().enumerate() {
            let input = pm.vertex_order[id] as usize;
            assert_eq!(
                *p, src.positions[input],
                "level {k}: vertex {id} is not at input vertex {input}'s position"
            );
        }
    }
    let finest = pm.level(n);
    assert_eq!(finest.face_count(), src.face_count());
}

#[test]
fn coarse_mesh_is_valid_and_not_inverted() {
    let src = shapes::noisy(&shapes::quad_sphere(10, 1.0), 0.002, 5);
    let (c, r) = coarsen(&src, 60);
    assert_eq!(r.stop, Some(StopReason::TargetReached), "{r:?}");
    let m = c.mesh();
    m.validate().expect("valid mesh");
    for f in m.faces() {
        let q = m.quad_vertices(f).expect("quad-only");
        let sj = ops::quad_scaled_jacobian(q.map(|v| m.position(v)));
        assert!(sj >= -1e-6, "face {f} is inverted (Scaled Jacobian {sj})");
    }
}

#[test]
fn subset_is_smaller_work_for_a_record_than_qem() {
    // The point of the placement: records carry only new positions.
    let src = shapes::noisy(&shapes::bumpy_torus(32, 12, 2.0, 0.6, 0.4, 3), 0.004, 9);
    let (c, _) = coarsen(&src, 100);
    let subset = c.into_progressive();
    let mesh = Mesh::from_indexed(&src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(100),
        ..Default::default()
    };
    let mut q = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    q.run(&mut |_| {});
    let qem = q.into_progressive();
    let positions = |pm: &pqm_core::progressive::ProgressiveMesh| -> f64 {
        let (mut p, mut v) = (0usize, 0usize);
        for r in &pm.records {
            p += r.new_vertices.len() + r.moved.len();
            v += r.new_vertices.len();
        }
        p as f64 / v.max(1) as f64
    };
    assert_eq!(positions(&subset), 1.0);
    assert!(
        positions(&qem) > 1.5,
        "qem records move vertices too: {}",
        positions(&qem)
    );
}

/// The corner margin: no quad of a whole-step level of spot has a twisted
/// corner (`ops::quad_twist` below 0 at `SUBSET_CORNER_MARGIN`), whose
/// Scaled Jacobian sign a file's grid flips. Without the margin 49 of spot's 14-bit levels had one (worst
/// −0.11 after quantization; `tests/subset_quantized_levels.rs` at the root
/// checks the decoded file).
#[test]
fn spot_levels_have_no_twisted_corner() {
    use pqm_core::coarsen::SUBSET_CORNER_MARGIN;
    use pqm_core::io;
    use pqm_core::progressive::OpKind;
    let spot = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes/quad/spot_quadrangulated.obj");
    let src = io::read_mesh(&spot).unwrap();
    let twist = |p| ops::quad_twist(p, SUBSET_CORNER_MARGIN);
    let input_worst = src
        .faces()
        .map(|f| twist([0, 1, 2, 3].map(|i| src.positions[f[i] as usize])))
        .fold(0.0, f64::min);
    assert_eq!(input_worst, 0.0, "spot's input has no twisted corner");
    let (c, r) = coarsen(&src, 300);
    assert!(r.qv_merges + r.qe_merges > 500, "{r:?}");
    let pm = c.into_progressive();
    let n = pm.records.len();
    for k in (0..=n).filter(|&k| k == 0 || pm.records[k - 1].op != OpKind::Doublet) {
        let (pos, quads) = pm.level_quads(k);
        for q in &quads {
            let p = q.map(|v| pos[v as usize]);
            assert!(
                twist(p) >= 0.0,
                "level {k}: a twisted corner (projected sine {}, Scaled Jacobian {})",
                ops::quad_projected_corner_sine(p),
                ops::quad_scaled_jacobian(p)
            );
        }
    }
}

#[test]
fn projected_corner_sine_of_square_and_straight_corners() {
    use glam::DVec3;
    let d = |x, y, z| DVec3::new(x, y, z);
    let square = [d(0., 0., 0.), d(1., 0., 0.), d(1., 1., 0.), d(0., 1., 0.)];
    assert!((ops::quad_projected_corner_sine(square) - 1.0).abs() < 1e-12);
    // a straight corner at (1, 0, 0)
    let straight = [d(0., 0., 0.), d(1., 0., 0.), d(2., 0., 0.), d(1., 1., 0.)];
    assert!(ops::quad_projected_corner_sine(straight).abs() < 1e-12);
    // (spot's twisted corners — projected sine 0.0065 at a Scaled Jacobian
    // of 0.11 — are in `spot_levels_have_no_twisted_corner`)
    assert!(!ops::quad_twisted(square, 0.02));
    assert!(!ops::quad_twisted(straight, 0.02));
}
