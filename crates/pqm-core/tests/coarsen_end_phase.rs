//! The end phase (`coarsen::end_phase`): near the face target, on the
//! CAD-like meshes that get chord phases, each step is chosen by playing
//! alternatives out on copies. Its result is never less ideal than the
//! ordinary run's, its steps are logged like any other (the records replay
//! to the input exactly), and it is deterministic.

use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::{IndexedMesh, Mesh};

/// A box `sx × sy × sz` whose sides are grids of `n × m` quads (`n` along
/// the longest side): 96–97 % ideal (its eight corners have valence 3),
/// one edge in `n` or `m` on a sharp crease — the block layout of a CAD
/// part, so the chord phases (and so the end phase) run.
fn box_grid(n: u32, size: glam::DVec3) -> IndexedMesh {
    use glam::DVec3;
    let mut p: Vec<DVec3> = Vec::new();
    let mut faces = Vec::new();
    let mut index = std::collections::BTreeMap::new();
    let axes = [
        (DVec3::X, DVec3::Y, DVec3::Z),
        (-DVec3::X, DVec3::Z, DVec3::Y),
        (DVec3::Y, DVec3::Z, DVec3::X),
        (-DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::Z, DVec3::X, DVec3::Y),
        (-DVec3::Z, DVec3::Y, DVec3::X),
    ];
    for (nrm, u, v) in axes {
        let mut id = |i: u32, j: u32| {
            let q =
                nrm + u * (2.0 * i as f64 / n as f64 - 1.0) + v * (2.0 * j as f64 / n as f64 - 1.0);
            let key = (q * n as f64).round();
            let key = (key.x as i64, key.y as i64, key.z as i64);
            *index.entry(key).or_insert_with(|| {
                p.push(q * size);
                (p.len() - 1) as u32
            })
        };
        for j in 0..n {
            for i in 0..n {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    for f in faces.iter_mut() {
        let c: DVec3 = f.iter().map(|&i| p[i as usize]).sum::<DVec3>() / 4.0;
        let nrm = (p[f[1] as usize] - p[f[0] as usize]).cross(p[f[2] as usize] - p[f[0] as usize]);
        if nrm.dot(c) < 0.0 {
            f.reverse();
        }
    }
    IndexedMesh::from_faces(p, faces)
}

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
    let src = box_grid(6, glam::DVec3::new(2.0, 1.3, 0.7));
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
