//! Chord collapses (`coarsen::chord`): a whole closed quad strip removed as
//! one logged step; the mesh stays valid and the records still replay to
//! the input exactly.

mod common;
use common::{grid, quad_sphere, torus};
use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::mesh::FaceId;
use pqm_core::{IndexedMesh, Mesh};
use proptest::prelude::*;

fn canon(pos: &[glam::DVec3], faces: &[[u32; 4]]) -> Vec<Vec<[u64; 3]>> {
    let key = |p: glam::DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let mut out: Vec<Vec<[u64; 3]>> = faces
        .iter()
        .map(|f| {
            let ks: Vec<[u64; 3]> = f.iter().map(|&v| key(pos[v as usize])).collect();
            let m = (0..4).min_by_key(|&i| ks[i]).unwrap();
            (0..4).map(|i| ks[(m + i) % 4]).collect()
        })
        .collect();
    out.sort();
    out
}

fn quads(m: &IndexedMesh) -> Vec<[u32; 4]> {
    m.faces().map(|f| [f[0], f[1], f[2], f[3]]).collect()
}

/// Collapses the chords named by `picks` (face index, corner) one after the
/// other; checks validity after each and that the records replay: the
/// base is the coarsener's mesh, every level is a valid quad mesh, the
/// finest is the input bit for bit. Returns the collapses made.
fn collapse_and_replay(src: &IndexedMesh, picks: &[(usize, u8)]) -> usize {
    let mesh = Mesh::from_indexed(src).unwrap();
    let genus = mesh.genus();
    let opts = CoarsenOptions {
        target_faces: Some(1),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 180.0, &[], opts).unwrap();
    let mut done = 0;
    for &(fi, corner) in picks {
        let faces: Vec<FaceId> = c.mesh().faces().collect();
        let f = faces[fi % faces.len()];
        let before = c.mesh().face_count();
        if c.collapse_chord(f, corner % 4) {
            done += 1;
            assert!(c.mesh().face_count() < before);
        } else {
            assert_eq!(
                c.mesh().face_count(),
                before,
                "a refused collapse changed the mesh"
            );
        }
        let m = c.mesh();
        m.validate().unwrap();
        assert!(m.faces().all(|f| m.face_degree(f) == 4));
        assert!(m.faces().all(|f| m.check_dual_chords(f).is_ok()));
        assert_eq!(m.genus(), genus);
    }
    let pm = c.to_progressive();
    pm.validate().unwrap();
    let (out, _) = c.mesh().to_indexed();
    let (p0, q0) = pm.level_quads(0);
    assert_eq!(canon(&p0, &q0), canon(&out.positions, &quads(&out)));
    for k in 0..=pm.records.len() {
        Mesh::from_indexed(&pm.level(k))
            .unwrap()
            .validate()
            .unwrap();
    }
    let (pos, faces) = pm.level_quads(pm.records.len());
    assert_eq!(canon(&pos, &faces), canon(&src.positions, &quads(src)));
    done
}

#[test]
fn torus_ring_collapses_and_replays() {
    // every chord of a torus grid is a closed ring: removing one leaves a
    // regular torus one ring thinner
    let src = torus(64, 48);
    let n = src.face_count();
    let mesh = Mesh::from_indexed(&src).unwrap();
    let mut c = Coarsener::with_defaults(mesh, 180.0, &[], CoarsenOptions::default()).unwrap();
    let f = c.mesh().faces().next().unwrap();
    assert!(c.collapse_chord(f, 0));
    let m = c.mesh();
    assert!(m.face_count() == n - 64 || m.face_count() == n - 48);
    assert!(m.vertices().all(|v| m.valence(v) == 4));
    assert_eq!(collapse_and_replay(&src, &[(0, 0), (5, 1), (17, 0)]), 3);
}

#[test]
fn sphere_ring_collapse_replays() {
    // a cube-sphere's chords are rings of 4n quads crossing the cube's
    // corners' neighbourhoods: collapsed whole, the valence-3 corners stay
    let src = quad_sphere(24);
    assert!(collapse_and_replay(&src, &[(0, 0), (100, 1), (2000, 0)]) >= 2);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn chord_collapses_keep_validity_and_replay(
        shape in 0u8..3,
        size in 4u32..9,
        picks in proptest::collection::vec((0usize..400, 0u8..4), 1..5),
    ) {
        let src = match shape {
            // (fine enough that a ring's collapse stays within the 0.7 %
            // surface-deviation limit, so most picks commit)
            0 => torus(8 * size, 6 * size),
            1 => quad_sphere(3 * size + 10),
            // open chords only: every collapse is refused, nothing changes
            _ => grid(size, size + 2),
        };
        collapse_and_replay(&src, &picks);
    }
}

/// A torus grid (`n` around, `m` across) whose rows 0 and 1 are close
/// together (the strip between them is the chord to collapse), with two
/// hexagons re-split so that across that strip a valence-5 vertex faces a
/// valence-3 one twice: `A = (k−1, 1)` (5) over `Q = (k−1, 0)` (3) and
/// `B = (k, 1)` (3) over `R = (k, 0)` (5). The re-splits also leave a
/// 5 and a 3 on the far side of each hexagon (`D`, `E` above, `U`, `T`
/// below): eight defects, four of which the chord collapse cancels.
fn torus_with_defect_pairs(n: u32, m: u32, k: u32) -> IndexedMesh {
    let tau = std::f64::consts::TAU;
    let gap = 0.02;
    // minor angle of each row: row 1 just above row 0, the others even
    let row = |j: u32| -> f64 {
        match j {
            0 => 0.0,
            1 => gap,
            _ => gap + (j - 1) as f64 / (m - 1) as f64 * (tau - gap),
        }
    };
    let pos = |u: f64, v: f64| {
        let r = 3.0 + v.cos();
        glam::DVec3::new(r * u.cos(), r * u.sin(), v.sin())
    };
    let id = |i: u32, j: u32| (j % m) * n + (i % n);
    let mut p = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let u = i as f64 / n as f64 * tau;
            let mut v = row(j);
            // keep the re-split quads convex: B dips toward row 0, T away
            if (i, j) == (k, 1) {
                v = 0.6 * gap;
            }
            if (i, j) == (k - 1, m - 1) {
                v -= 0.3 * (tau - gap) / (m - 1) as f64;
            }
            p.push(pos(u, v));
        }
    }
    let (a, b, c) = (id(k - 1, 1), id(k, 1), id(k + 1, 1));
    let (d, e, f) = (id(k + 1, 2), id(k, 2), id(k - 1, 2));
    let (pp, q, r) = (id(k - 2, 0), id(k - 1, 0), id(k, 0));
    let (s, t, u) = (id(k, m - 1), id(k - 1, m - 1), id(k - 2, m - 1));
    let up = [[a, b, e, f], [b, c, d, e]];
    let down = [[u, t, q, pp], [t, s, r, q]];
    let mut faces = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let quad = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            if !up.contains(&quad) && !down.contains(&quad) {
                faces.push(quad);
            }
        }
    }
    // the hexagons a-b-c-d-e-f and u-t-s-r-q-p, split along a–d and u–r
    faces.extend([[a, b, c, d], [a, d, e, f], [u, t, s, r], [u, r, q, pp]]);
    IndexedMesh::from_faces(p, faces)
}

#[test]
fn chord_collapse_cancels_defect_pairs_no_local_step_does() {
    let (n, m, k) = (24, 16, 6);
    let src = torus_with_defect_pairs(n, m, k);
    let mesh = Mesh::from_indexed(&src).unwrap();
    mesh.validate().unwrap();
    let defects = |m: &Mesh| {
        m.vertices()
            .filter(|&v| m.valence(v) != m.ideal_valence(v))
            .count()
    };
    assert_eq!(defects(&mesh), 8);
    let mut c = Coarsener::with_defaults(mesh, 180.0, &[], CoarsenOptions::default()).unwrap();
    // no qvMerge or qeMerge around the four vertices of the pairs removes
    // a defect and is committed: the strip quad between the pairs has a
    // 3–3 diagonal whose qvMerge would remove all four, but it moves its
    // vertices across the strip's long side, off the surface; the other
    // steps move the defects or add some
    for v in [(k - 1, 1), (k, 1), (k - 1, 0), (k, 0)] {
        let v = pqm_core::VertexId(v.1 * n + v.0);
        for probe in c.probe_around(v) {
            assert!(
                probe.gain <= 0 || probe.verdict != "committed",
                "a local step removes a defect: {probe:?}"
            );
        }
    }
    // the strip between rows 0 and 1: entered across the rung (0,0)–(0,1)
    // of the quad (0,0)-(1,0)-(1,1)-(0,1) (its 4th edge, (0,1) → (0,0),
    // runs across the strip)
    let f = c
        .mesh()
        .faces()
        .find(|&f| c.mesh().face_vertices(f).next() == Some(pqm_core::VertexId(0)))
        .unwrap();
    let corner = c
        .mesh()
        .face_halfedges(f)
        .position(|h| {
            let m = c.mesh();
            (m.from_vertex(h), m.to_vertex(h)) == (pqm_core::VertexId(n), pqm_core::VertexId(0))
        })
        .unwrap() as u8;
    let ok = c.collapse_chord(f, corner);
    assert!(ok, "{:?}", c.report_so_far());
    assert_eq!(c.mesh().face_count(), src.face_count() - n as usize);
    assert_eq!(defects(c.mesh()), 4);
    c.mesh().validate().unwrap();
    // and it replays
    let pm = c.to_progressive();
    let (pos, faces) = pm.level_quads(pm.records.len());
    assert_eq!(canon(&pos, &faces), canon(&src.positions, &quads(&src)));
}
