//! When the coarsener prunes stale entries from its queue must not change
//! what it does: pruning after every commit, at the default slack, and
//! almost never (only when the buffer is full) give the same records, the
//! same coarsest mesh and the same report (but for `peak_queue`, the
//! queue's size, which is what the schedule is for).
//!
//! The inputs are chosen so that steps get rejected and undone: an undo
//! is what once renumbered half-edges under queued candidates and made the
//! result depend on the schedule.

use pqm_core::coarsen::{CoarsenOptions, CoarsenReport, Coarsener, Placement, Smoothing};
use pqm_core::progressive::ProgressiveMesh;
use pqm_core::{io, shapes, IndexedMesh, Mesh};
use std::path::Path;

fn coarsen_with_slack(
    src: &IndexedMesh,
    opts: &CoarsenOptions,
    slack: f64,
) -> (ProgressiveMesh, IndexedMesh, CoarsenReport) {
    let mesh = Mesh::from_indexed(src).expect("valid quad mesh");
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts.clone()).expect("features");
    c.set_prune_slack(slack);
    let report = c.run(&mut |_| {});
    let coarsest = c.mesh().to_indexed().0;
    (c.into_progressive(), coarsest, report)
}

fn assert_schedule_invariant(src: &IndexedMesh, opts: CoarsenOptions) {
    let (pm0, mesh0, r0) = coarsen_with_slack(src, &opts, 0.0);
    assert!(
        !pm0.records.is_empty() && r0.rejected > 0,
        "the comparison needs committed and rejected steps ({} records, {} rejected)",
        pm0.records.len(),
        r0.rejected
    );
    let mut peaks = vec![r0.peak_queue];
    for slack in [2.0, 1e9] {
        let (pm, mesh, r) = coarsen_with_slack(src, &opts, slack);
        peaks.push(r.peak_queue);
        let strip = |r: &CoarsenReport| CoarsenReport {
            peak_queue: 0,
            ..r.clone()
        };
        assert_eq!(strip(&r), strip(&r0), "report differs at slack {slack}");
        assert!(mesh == mesh0, "coarsest mesh differs at slack {slack}");
        assert_eq!(pm.records.len(), pm0.records.len());
        assert!(pm == pm0, "progressive mesh differs at slack {slack}");
    }
    // the schedules really differ: pruning after every commit keeps the
    // queue smallest
    assert!(
        peaks[0] < peaks[2],
        "pruning after every commit should keep the queue smaller: {peaks:?}"
    );
}

#[test]
fn spot_is_the_same_under_any_pruning_schedule() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/spot_quadrangulated.obj");
    let src = io::read_mesh(&path).expect("read spot");
    assert_schedule_invariant(
        &src,
        CoarsenOptions {
            target_faces: Some(700),
            ..Default::default()
        },
    );
}

#[test]
fn noisy_torus_is_the_same_under_any_pruning_schedule() {
    let src = shapes::noisy(&shapes::bumpy_torus(48, 20, 2.0, 0.6, 0.4, 5), 0.004, 9);
    for placement in [Placement::Qem, Placement::Subset] {
        assert_schedule_invariant(
            &src,
            CoarsenOptions {
                target_faces: Some(120),
                smoothing: Smoothing::Local,
                placement,
                ..Default::default()
            },
        );
    }
}
