//! `Coarsener::into_progressive` frees the step logs while it builds the
//! records; it must give exactly what `to_progressive` gives.

use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::{shapes, Mesh};

#[test]
fn into_progressive_equals_to_progressive() {
    let src = shapes::noisy(&shapes::bumpy_torus(48, 20, 2.0, 0.6, 0.4, 11), 0.004, 2);
    let mesh = Mesh::from_indexed(&src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(150),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    c.run(&mut |_| {});
    let borrowed = c.to_progressive();
    assert!(
        borrowed.records.len() > 100,
        "enough records that the log array shrinks while it is drained"
    );
    let consumed = c.into_progressive();
    assert!(consumed == borrowed);
    // and the records still replay to the input's face count
    consumed.validate().expect("valid progressive mesh");
    let finest = consumed.level(consumed.records.len());
    assert_eq!(finest.face_count(), src.face_count());
}
