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
