//! Subset placement (`pqm encode`'s default) keeps every level's vertices at
//! input positions, so a client sees them snapped to the file's grid. Every
//! level between whole coarsening steps, decoded, has no inverted quad: the
//! coarsener's corner margin keeps straight and twisted corners (whose
//! Scaled Jacobian sign the snapping flips) out of its levels.

use pqm::core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm::core::progressive::OpKind;
use pqm::core::{io, ops, Mesh};
use pqm::format::{decode_all, write_to_vec, EncodeOptions, Limits, Target};

#[test]
fn no_decoded_whole_step_level_of_spot_has_an_inverted_quad() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = io::read_mesh(&root.join("../shared/meshes/quad/spot_quadrangulated.obj")).unwrap();
    let opts = CoarsenOptions {
        placement: Placement::Subset,
        ..Default::default()
    };
    let mut c =
        Coarsener::with_defaults(Mesh::from_indexed(&src).unwrap(), 60.0, &[], opts).unwrap();
    c.run(&mut |_| {});
    let pm = c.into_progressive();
    let n = pm.records.len();
    assert!(
        n > 1000,
        "spot coarsens deep enough to be a test: {n} records"
    );
    let (bytes, _) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
    let mut dec = decode_all(&bytes, Limits::default()).unwrap();
    let mut checked = 0;
    for k in 0..=n {
        // after a doublet re-insertion its step is half done: such levels
        // never end a chunk, and their quads may fold
        if k > 0 && pm.records[k - 1].op == OpKind::Doublet {
            continue;
        }
        dec.set_level(Target::Level(k)).unwrap();
        let pos = dec.positions_f64();
        for (i, q) in dec.quads().iter().enumerate() {
            let sj = ops::quad_scaled_jacobian(q.map(|v| pos[v as usize]));
            assert!(sj > 0.0, "level {k}: quad {i} is inverted ({sj:.4})");
        }
        checked += 1;
    }
    assert!(checked > n / 2, "{checked} whole-step levels of {n}");
}
