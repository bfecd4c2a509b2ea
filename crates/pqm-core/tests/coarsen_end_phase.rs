//! The end phase (`coarsen::end_phase`): near the face target, on the
//! CAD-like meshes that get chord phases, each step is chosen by playing
//! alternatives out on copies. Its result is never less ideal than the
//! ordinary run's, its steps are logged like any other (the records replay
//! to the input exactly), and it is deterministic.

use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::{shapes, IndexedMesh, Mesh};

fn ideal(m: &Mesh) -> (usize, usize) {
    let d = m
        .vertices()
        .filter(|&v| m.valence(v) != m.ideal_valence(v))
        .count();
    (d, m.vertex_count())
}

fn coarsen(src: &IndexedMesh, target: usize, end_phase: bool) -> Coarsener {
    let mesh = Mesh::from_indexed(src).unwrap();
    let opts = CoarsenOptions {
        target_faces: Some(target),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
    c.set_end_phase(end_phase);
    c.run(&mut |_| {});
    c
}

#[test]
fn end_phase_is_never_less_ideal_and_replays() {
    let src = shapes::box_grid(6, glam::DVec3::new(2.0, 1.3, 0.7));
    for target in [60, 100, 150] {
        let on = coarsen(&src, target, true);
        let off = coarsen(&src, target, false);
        assert_eq!(off.end_phase_steps(), 0);
        assert!(on.end_phase_steps() > 0, "target {target}: no end phase");
        let (m_on, m_off) = (on.mesh(), off.mesh());
        m_on.validate().unwrap();
        assert!(m_on.face_count() <= target && m_off.face_count() <= target);
        let ((d1, n1), (d0, n0)) = (ideal(m_on), ideal(m_off));
        println!("target {target}: end phase {d1} of {n1} non-ideal, without {d0} of {n0}");
        // d1 / n1 <= d0 / n0
        assert!(
            d1 * n0 <= d0 * n1,
            "target {target}: {d1}/{n1} vs {d0}/{n0}"
        );
        // the records replay to the input, every level a valid quad mesh
        // (a level between a step and its doublet removal has the doublet:
        // the structure is checked there, the dual chords at both ends)
        let pm = on.to_progressive();
        pm.validate().unwrap();
        for k in 0..=pm.records.len() {
            Mesh::from_indexed(&pm.level(k))
                .unwrap()
                .validate_structure()
                .unwrap();
        }
        let (base, _) = on.mesh().to_indexed();
        assert_eq!(pm.level(0).indices.len(), base.indices.len());
        Mesh::from_indexed(&pm.level(0))
            .unwrap()
            .validate()
            .unwrap();
        let fine = pm.level(pm.records.len());
        assert_eq!(fine.face_count(), src.face_count());
        Mesh::from_indexed(&fine).unwrap().validate().unwrap();
        // deterministic: the same input gives the same records
        let again = coarsen(&src, target, true).to_progressive();
        assert_eq!(format!("{:?}", again), format!("{:?}", pm));
    }
}
