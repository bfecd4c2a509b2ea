//! The coarsener scores candidates in parallel; its output must not depend
//! on how many threads do it (or on how rayon splits the work): the same
//! input gives the same records, the same coarsest mesh and the same report
//! with 1, 2 and 3 threads.

use pqm_core::coarsen::{CoarsenOptions, CoarsenReport, Coarsener, Smoothing};
use pqm_core::progressive::ProgressiveMesh;
use pqm_core::{io, shapes, IndexedMesh, Mesh};
use std::path::Path;

fn coarsen_with_threads(
    src: &IndexedMesh,
    opts: &CoarsenOptions,
    threads: usize,
) -> (ProgressiveMesh, CoarsenReport) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let mesh = Mesh::from_indexed(src).expect("valid quad mesh");
        let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts.clone()).expect("features");
        let report = c.run(&mut |_| {});
        (c.to_progressive(), report)
    })
}

fn assert_thread_count_invariant(src: &IndexedMesh, opts: CoarsenOptions) {
    let (pm1, r1) = coarsen_with_threads(src, &opts, 1);
    assert!(
        !pm1.records.is_empty(),
        "the coarsener must take steps for the comparison to mean anything"
    );
    for threads in [2, 3] {
        let (pm, r) = coarsen_with_threads(src, &opts, threads);
        assert_eq!(r, r1, "report differs with {threads} threads");
        assert_eq!(pm.records.len(), pm1.records.len());
        assert!(pm == pm1, "progressive mesh differs with {threads} threads");
    }
}

#[test]
fn spot_is_the_same_with_any_thread_count() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/spot_quadrangulated.obj");
    let src = io::read_mesh(&path).expect("read spot");
    assert_thread_count_invariant(
        &src,
        CoarsenOptions {
            target_faces: Some(900),
            ..Default::default()
        },
    );
}

#[test]
fn noisy_torus_with_local_smoothing_is_the_same_with_any_thread_count() {
    let src = shapes::noisy(&shapes::bumpy_torus(48, 20, 2.0, 0.6, 0.4, 5), 0.004, 9);
    assert_thread_count_invariant(
        &src,
        CoarsenOptions {
            target_faces: Some(200),
            smoothing: Smoothing::Local,
            ..Default::default()
        },
    );
}
