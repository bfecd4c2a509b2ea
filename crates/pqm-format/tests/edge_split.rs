//! The edge-split form (spec §7.10, format 3): the spec's worked example,
//! every reject rule on hand-made records, and real qeMerge records of the
//! coarsener coded in it and decoded back exactly.

use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm_core::{shapes, Mesh, OpKind, ProgressiveMesh};
use pqm_format::codec::{
    decode_apply_record, decode_record, Cursors, DecodeScratch, MeshState, QRecord,
};
use pqm_format::varint::{put_s, put_u, Reader};
use pqm_format::*;

mod common;

/// The spec's example mesh: the 5 × 4 grid, vertex `i + 5j` at `(i, j)`,
/// slot `i + 4j` = `(v(i,j), v(i+1,j), v(i+1,j+1), v(i,j+1))`; codes are
/// `10 ×` the grid position.
fn grid() -> MeshState {
    let v = |i: u32, j: u32| i + 5 * j;
    let q: Vec<[u32; 3]> = (0..20).map(|k| [k % 5 * 10, k / 5 * 10, 0]).collect();
    let mut quads = Vec::new();
    for j in 0..3 {
        for i in 0..4 {
            quads.push([v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    MeshState::new((1 << 14) - 1, q, quads)
}

/// One record's streams: symbol, `conn` varints, one anchor delta, `pos`.
fn streams(sym: u8, conn: &[u64], anchor: i64, pos: &[i64]) -> [Vec<u8>; 5] {
    let mut s: [Vec<u8>; 5] = Default::default();
    s[0].push(sym);
    conn.iter().for_each(|&x| put_u(&mut s[1], x));
    put_s(&mut s[2], anchor);
    pos.iter().for_each(|&x| put_s(&mut s[4], x));
    s
}

fn run(
    st: &MeshState,
    s: &[Vec<u8>; 5],
    max_v: u32,
    max_f: u32,
    major: u16,
) -> Result<QRecord, String> {
    let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let r = decode_record(st, &mut rd, &mut Cursors::default(), max_v, max_f, major)?;
    assert!(
        rd.iter().all(|x| x.remaining() == 0),
        "streams not consumed"
    );
    Ok(r)
}

/// The decoder's path on one record: decoded and applied at once
/// (`decode_apply_record`, the edge split fused when both stars are on the
/// fast path). It must give what `run` then `apply` give — the same
/// vertices, quads and corner lists, the same log entries (up to their
/// order), the same new codes and appended quads kept — and on error the
/// same message, with the state untouched.
fn run_apply(
    st: &MeshState,
    s: &[Vec<u8>; 5],
    max_v: u32,
    max_f: u32,
    major: u16,
) -> Result<MeshState, String> {
    let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let mut fused = st.clone();
    let (mut moved, mut rw) = (Vec::new(), Vec::new());
    let (mut new_pos, mut appended) = (Vec::new(), Vec::new());
    let got = decode_apply_record(
        &mut fused,
        &mut rd,
        &mut Cursors::default(),
        max_v,
        max_f,
        major,
        &mut QRecord::default(),
        &mut DecodeScratch::new(),
        &mut moved,
        &mut rw,
        Some((&mut new_pos, &mut appended)),
    );
    match run(st, s, max_v, max_f, major) {
        Err(e) => {
            assert_eq!(got, Err(e.clone()));
            assert_eq!(fused.q, st.q);
            assert_eq!(fused.quads, st.quads);
            Err(e)
        }
        Ok(r) => {
            got.unwrap();
            assert!(rd.iter().all(|x| x.remaining() == 0));
            assert_eq!((new_pos, appended), (r.new_pos.clone(), r.appended.clone()));
            let mut want = st.clone();
            let (m0, rw0) = want.apply(&r);
            assert_eq!(fused.q, want.q);
            assert_eq!(fused.quads, want.quads);
            for v in 0..want.q.len() as u32 {
                let mut a: Vec<_> = fused.corners(v).collect();
                let mut b: Vec<_> = want.corners(v).collect();
                a.sort_unstable();
                b.sort_unstable();
                assert_eq!(a, b, "corners of vertex {v}");
            }
            // Old values back from the deltas, by slot.
            assert_eq!(moved.len(), m0.len());
            let mut old: Vec<(u32, [u32; 4])> = rw
                .iter()
                .map(|&(s, d)| {
                    let q = fused.quads[s as usize];
                    (s, [0, 1, 2, 3].map(|k| q[k] ^ d[k]))
                })
                .collect();
            old.sort_unstable();
            let want_old: Vec<(u32, [u32; 4])> = r.rewritten.iter().map(|w| w.0).zip(rw0).collect();
            assert_eq!(old, want_old);
            Ok(fused)
        }
    }
}

const EXAMPLE: [u64; 9] = [2, 0, 0, 0, 0, 0, 0, 0, 0];

/// Every field value of the worked example's record (anchors 6 and 7, all
/// link indices, sectors, fans, 24 × 24 permutations sampled, rotations):
/// the fused decoder path equals the explicit record applied, errors
/// included.
#[test]
fn fused_edge_split_equals_build() {
    let st = grid();
    let mut n_ok = 0;
    for (anchor, r) in [
        (6, 0),
        (6, 1),
        (6, 2),
        (6, 3),
        (7, 0),
        (7, 1),
        (7, 3),
        (12, 0),
    ] {
        for n1a in 0..2 {
            for ea in 0..2 {
                for n1b in 0..2 {
                    for eb in 0..2 {
                        for p in [0, 1, 25, 300, 575] {
                            for ra in [0, 4, 0x93, 255] {
                                let rots = [p % 4, ra % 4, 3, 1];
                                let mut c = vec![r, n1a, ea, n1b, eb, p, ra];
                                c.extend_from_slice(&rots[..(2 + ea + eb) as usize]);
                                let s = streams(0x11, &c, anchor, &[1; 12]);
                                // Version 3's parallelograms and version
                                // 4's stencil (spec §7.6).
                                for major in [3, 4] {
                                    n_ok += run_apply(&st, &s, 24, 16, major).is_ok() as u32;
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(n_ok > 100, "{n_ok} records built");
}

#[test]
fn the_worked_example_of_the_spec_decodes_as_written() {
    let st = grid();
    let r = run(&st, &streams(0x11, &EXAMPLE, 6, &[0; 12]), 24, 16, 3).unwrap();
    assert_eq!(r.op, OpKind::QeMerge);
    assert!(r.moved.is_empty());
    assert_eq!(
        r.rewritten,
        vec![
            (0, [0, 1, 21, 5]),
            (1, [1, 2, 22, 21]),
            (2, [7, 3, 8, 23]),
            (4, [6, 10, 5, 21]),
            (5, [20, 23, 12, 11]),
            (6, [23, 8, 13, 12]),
        ]
    );
    assert_eq!(
        r.appended,
        vec![
            [6, 21, 22, 7],
            [6, 7, 23, 20],
            [6, 20, 11, 10],
            [7, 22, 2, 3]
        ]
    );
    // The refined mesh is oriented and manifold: every directed edge once.
    let mut st2 = st.clone();
    let mut r4 = r.clone();
    r4.new_pos = vec![[0; 3]; 4];
    st2.apply(&r4);
    let mut edges: Vec<(u32, u32)> = st2
        .quads
        .iter()
        .flat_map(|q| (0..4).map(move |k| (q[k], q[(k + 1) % 4])))
        .collect();
    let n = edges.len();
    edges.sort_unstable();
    edges.dedup();
    assert_eq!(edges.len(), n);
    // p = 1: π_f = (0, 1, 3, 2) swaps the corner quads.
    let mut c = EXAMPLE;
    c[5] = 1;
    let r1 = run(&st, &streams(0x11, &c, 6, &[0; 12]), 24, 16, 3).unwrap();
    assert_eq!(r1.appended[2], [7, 22, 2, 3]);
    assert_eq!(r1.appended[3], [6, 20, 11, 10]);
    // ra = 4: C_1 rotated by one.
    let mut c = EXAMPLE;
    c[6] = 4;
    let r2 = run(&st, &streams(0x11, &c, 6, &[0; 12]), 24, 16, 3).unwrap();
    assert_eq!(r2.appended[1], [7, 23, 20, 6]);
    // Anchoring 7 (r = 0 names 6) is the same record.
    let mut c = EXAMPLE;
    c[0] = 0;
    let r3 = run(&st, &streams(0x11, &c, 7, &[0; 12]), 24, 16, 3).unwrap();
    assert_eq!(r3, r);
    // Positions are residuals against §7.6, in id order: a residual moves
    // exactly its vertex.
    let mut pos = [0i64; 12];
    pos[3] = 5;
    let r5 = run(&st, &streams(0x11, &EXAMPLE, 6, &pos), 24, 16, 3).unwrap();
    assert_eq!(r5.new_pos[0], r.new_pos[0]);
    assert_eq!(r5.new_pos[1][0], r.new_pos[1][0] + 5);
}

#[test]
fn every_reject_rule_of_the_form_is_enforced() {
    let st = grid();
    let ok = |conn: &[u64], anchor: i64| streams(0x11, conn, anchor, &[0; 12]);
    let err = |s: [Vec<u8>; 5], max_v: u32, max_f: u32, major: u16, want: &str| {
        let e = run_apply(&st, &s, max_v, max_f, major).unwrap_err();
        assert!(e.contains(want), "wanted {want:?}, got {e:?}");
    };
    assert!(run(&st, &ok(&EXAMPLE, 6), 24, 16, 3).is_ok());
    // Form 4 only in version 3 files; symbol bits 4-7 beyond 1 are unknown.
    err(ok(&EXAMPLE, 6), 24, 16, 2, "version 3 only");
    err(ok(&EXAMPLE, 6), 24, 16, 1, "version 3 only");
    err(
        streams(0x21, &EXAMPLE, 6, &[0; 12]),
        24,
        16,
        3,
        "unknown record form",
    );
    // Room for 4 vertices and 4 quads.
    err(ok(&EXAMPLE, 6), 23, 16, 3, "exceeds");
    err(ok(&EXAMPLE, 6), 24, 15, 3, "exceeds");
    // Anchor out of range; a boundary anchor; a boundary other endpoint
    // (6's link is 5, 1, 7, 11: r = 0 names the boundary vertex 5).
    err(ok(&EXAMPLE, 20), 24, 16, 3, "references vertex 20");
    err(ok(&EXAMPLE, 0), 24, 16, 3, "boundary");
    let mut c = EXAMPLE;
    c[0] = 0;
    err(ok(&c, 6), 24, 16, 3, "boundary");
    // r beyond the 4 faces of 6.
    c[0] = 4;
    err(ok(&c, 6), 24, 16, 3, "link index");
    // n1 ≤ K − 3 = 1, then e ≤ K − 3 − n1.
    let mut c = EXAMPLE;
    c[1] = 2;
    err(ok(&c, 6), 24, 16, 3, "first sector");
    c[1] = 1;
    c[2] = 1;
    err(ok(&c, 6), 24, 16, 3, "fan length");
    let mut c = EXAMPLE;
    c[4] = 2;
    err(ok(&c, 6), 24, 16, 3, "fan length");
    // p ≤ 575, ra ≤ 255, fan rotations ≤ 3.
    let mut c = EXAMPLE;
    c[5] = 576;
    err(ok(&c, 6), 24, 16, 3, "permutations");
    let mut c = EXAMPLE;
    c[6] = 256;
    err(ok(&c, 6), 24, 16, 3, "appended rotations");
    let mut c = EXAMPLE;
    c[8] = 4;
    err(ok(&c, 6), 24, 16, 3, "fan rotation");
    // Truncated fields and positions; codes off the grid.
    assert!(run(&st, &ok(&EXAMPLE[..8], 6), 24, 16, 3).is_err());
    assert!(run(&st, &streams(0x11, &EXAMPLE, 6, &[0; 11]), 24, 16, 3).is_err());
    let mut pos = [0i64; 12];
    pos[0] = -1_000_000;
    err(
        streams(0x11, &EXAMPLE, 6, &pos),
        24,
        16,
        3,
        "outside the grid",
    );
}

/// A slot in one endpoint's fan and in the other endpoint's fan or sector
/// is refused. Interior vertices 0 and 1 share, besides the two faces on
/// the edge 0–1, the face (0, 3, 1, 4), where they are opposite corners —
/// not a manifold, but both stars are closed fans, so only this rule stops
/// the record.
#[test]
fn a_fan_face_shared_with_the_other_endpoint_is_refused() {
    let quads = vec![
        [0, 1, 5, 2],
        [0, 2, 6, 3],
        [0, 3, 1, 4],
        [0, 4, 7, 1],
        [1, 7, 8, 4],
        [1, 3, 9, 5],
    ];
    let st = MeshState::new((1 << 14) - 1, vec![[0; 3]; 10], quads);
    assert_eq!(st.star(0).unwrap().link, vec![1, 2, 3, 4]);
    assert_eq!(st.star(1).unwrap().faces.len(), 5);
    let run = |c: &[u64]| run_apply(&st, &streams(0x11, c, 0, &[0; 12]), 30, 30, 3);
    // Fan of 0 = slot 2 (n1 = 1, m = 1); at 1, slot 2 is in the second
    // sector (n1 = 0) or the fan (n1 = 1).
    for n1_d in [0, 1] {
        let e = run(&[0, 1, 0, n1_d, 0, 0, 0, 0, 0]).unwrap_err();
        assert!(e.contains("slot 2 is a fan face"), "{e}");
    }
    // Elsewhere (fan of 0 = slot 1) the same stars build a record.
    assert!(run(&[0, 0, 0, 0, 0, 0, 0, 0, 0]).is_ok());
}

/// A bumpy torus coarsened to 150 quads as `pqm encode` does (subset
/// placement): every operator, vertices of valence 3 to 8 on its levels.
fn coarsened_torus_mesh() -> ProgressiveMesh {
    let src = shapes::bumpy_torus(40, 24, 3.0, 1.0, 0.05, 7);
    let mesh = Mesh::from_indexed(&src).unwrap();
    let opts = CoarsenOptions {
        target_faces: Some(150),
        placement: Placement::Subset,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
    c.run(&mut |_| {});
    c.into_progressive()
}

/// Real qeMerge records (the coarsener on a closed surface, subset
/// placement as `pqm encode`) are coded in the edge-split form, and every
/// level decodes to the progressive mesh's level id for id.
#[test]
fn coarsener_qe_merges_use_the_edge_split_form_and_decode_exactly() {
    let pm = coarsened_torus_mesh();
    let qe = pm
        .records
        .iter()
        .filter(|r| r.op == OpKind::QeMerge)
        .count();
    assert!(qe > 20, "the test needs qeMerge records: {qe}");
    let (bytes, report) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
    let forms = report.per_op[OpKind::QeMerge as usize].forms;
    // A closed torus has no boundary endpoint; only crossing-side fans fall
    // back to the local form.
    assert!(
        forms[4] * 10 >= qe * 9,
        "edge-split form for {} of {qe} qeMerge records: {forms:?}",
        forms[4]
    );
    let (v2, r2) = write_to_vec(
        &pm,
        &EncodeOptions {
            version_major: 2,
            ..EncodeOptions::default()
        },
    )
    .unwrap();
    assert_eq!(r2.edge_split_records, 0);
    assert!(
        bytes.len() < v2.len(),
        "3.0 {} bytes vs 2.0 {}",
        bytes.len(),
        v2.len()
    );
    let mut dec = decode_all(&bytes, Limits::default()).unwrap();
    common::assert_every_level_down_and_up(&mut dec, &pm);
}

/// The generator of the edge-split vector and proptests
/// (`vectors::add_edge_splits`: random fields on random interior edges)
/// keeps every level a closed, oriented, manifold quad mesh — the fields
/// may be anything in range, the result is always a valid refinement
/// (`validate_structure`: unconstrained fields can make two faces share two
/// edges, a doublet, which the coarsener would not leave but the format
/// does not care about).
#[test]
fn random_edge_splits_keep_the_mesh_valid() {
    use pqm_core::progressive::testgen::{generate_with, BaseShape, GenOptions};
    for seed in 0..6 {
        let mut pm = generate_with(&GenOptions {
            base: BaseShape::Box { n: 2 },
            ..GenOptions::new(seed, 10)
        });
        let before = pm.records.len();
        vectors::add_edge_splits(&mut pm, 25, seed);
        assert_eq!(pm.records.len(), before + 25);
        pm.validate().unwrap();
        for k in before..=pm.records.len() {
            let m = Mesh::from_indexed(&pm.level(k)).unwrap();
            m.validate_structure()
                .unwrap_or_else(|e| panic!("seed {seed} level {k}: {e:?}"));
            assert_eq!(m.genus(), 0);
        }
    }
}

/// The split form (spec §7.5) through the decoder's fused path equals the
/// explicit record applied (`run_apply`): every anchor of the grid
/// (interior stars take the fused path, boundary ones the explicit
/// record), every pair of wings, rotation, moved and reflected vertex, in
/// every version; out-of-range wings and equal wings rejected alike.
#[test]
fn fused_split_equals_explicit() {
    let st = grid();
    let (mut n_ok, mut n_err) = (0, 0);
    for anchor in 0..20i64 {
        for i in 0..5u64 {
            for e in 0..4u64 {
                for flags in [0x04u8, 0x15, 0x24, 0x35, 0x44, 0x74, 0x84, 0xc5] {
                    for major in 1..=4u16 {
                        let n_pos = if flags & 0x40 != 0 { 6 } else { 3 };
                        let pos = [3, -2, 1, 0, 5, -7];
                        let s = streams(flags, &[i, e], anchor, &pos[..n_pos]);
                        match run_apply(&st, &s, 21, 13, major) {
                            Ok(_) => n_ok += 1,
                            Err(_) => n_err += 1,
                        }
                    }
                }
            }
        }
    }
    assert!(n_ok > 500 && n_err > 500, "{n_ok} built, {n_err} refused");
}

/// The face-split form (spec §7.9) through the decoder's fused path equals
/// the explicit record applied: every anchor of the grid (corners in 1, 2
/// or 4 faces), every face index and diagonal, all rotations; indices
/// past the anchor's faces and version-1 files rejected alike.
#[test]
fn fused_face_split_equals_explicit() {
    let st = grid();
    let (mut n_ok, mut n_err) = (0, 0);
    for anchor in 0..20i64 {
        for x in 0..9u64 {
            for rot in [0x0cu8, 0x1d, 0x6c, 0xbd, 0xfc] {
                for major in 1..=4u16 {
                    let s = streams(rot, &[x], anchor, &[4, -3, 2]);
                    match run_apply(&st, &s, 21, 13, major) {
                        Ok(_) => n_ok += 1,
                        Err(_) => n_err += 1,
                    }
                }
            }
        }
    }
    assert!(n_ok > 300 && n_err > 300, "{n_ok} built, {n_err} refused");
}

/// A decoder of [`coarsened_torus_mesh`]: the real levels the fused-path
/// tests run on.
fn coarsened_torus() -> Decoder {
    let (bytes, _) = write_to_vec(&coarsened_torus_mesh(), &EncodeOptions::default()).unwrap();
    decode_all(&bytes, Limits::default()).unwrap()
}

/// Random record streams (every form, fields mostly small and in range,
/// sometimes not; the edge split's fields often valid) on a real level —
/// the coarsened torus, vertices of valence 3 to 8 — through the decoder's
/// fused path and through the explicit record: the same result or the
/// same error, the same state, never a panic.
#[test]
fn random_records_fused_equals_explicit() {
    let mut dec = coarsened_torus();
    dec.set_level(Target::Level(40)).unwrap();
    let st = MeshState::new(
        (1 << 14) - 1,
        dec.position_codes().to_vec(),
        dec.quads().to_vec(),
    );
    let nv = st.q.len() as u64;
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let forms = [0x10u8, 0x11, 0x04, 0x45, 0x84, 0x0c, 0x3d, 0x00, 0x08, 0x21];
    let mut ok = [0u32; 5];
    for it in 0..60_000 {
        let mut s: [Vec<u8>; 5] = Default::default();
        let sym = if rnd() % 8 == 0 {
            rnd() as u8
        } else if rnd() % 2 == 0 {
            0x10 | (rnd() & 1) as u8
        } else {
            forms[(rnd() % forms.len() as u64) as usize] | (rnd() as u8 & 0xc0)
        };
        s[0].push(sym);
        let edge = sym & 0xfc == 0x10;
        if edge && rnd() % 4 != 0 {
            let (e0, e1) = (rnd() % 3, rnd() % 3);
            let mut c = vec![
                rnd() % 6,
                rnd() % 3,
                e0,
                rnd() % 3,
                e1,
                rnd() % 576,
                rnd() % 256,
            ];
            c.extend((0..2 + e0 + e1).map(|_| rnd() % 4));
            if rnd() % 8 == 0 {
                c.pop();
            }
            c.iter().for_each(|&x| put_u(&mut s[1], x));
        } else {
            for _ in 0..rnd() % 14 {
                let x = [rnd() % 3, rnd() % 8, rnd() % 600, rnd()][(rnd() % 4) as usize];
                put_u(&mut s[1], x);
            }
        }
        put_s(&mut s[2], (rnd() % nv) as i64);
        let npos = if edge && rnd() % 2 == 0 {
            12
        } else {
            rnd() % 14
        };
        (0..npos).for_each(|_| put_s(&mut s[4], (rnd() % 200) as i64 - 100));
        let major = [1u16, 2, 3, 4][(rnd() % 4) as usize];
        let (max_v, max_f) = (st.q.len() as u32 + 10, st.quads.len() as u32 + 10);
        let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
        let mut fused = st.clone();
        let (mut moved, mut rw, mut kept_v, mut kept_f) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let got = decode_apply_record(
            &mut fused,
            &mut rd,
            &mut Cursors::default(),
            max_v,
            max_f,
            major,
            &mut QRecord::default(),
            &mut DecodeScratch::new(),
            &mut moved,
            &mut rw,
            Some((&mut kept_v, &mut kept_f)),
        );
        let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
        let want = decode_record(&st, &mut rd, &mut Cursors::default(), max_v, max_f, major);
        match (got, want) {
            (Err(a), Err(b)) => {
                assert_eq!(a, b, "record {it}");
                assert_eq!(fused.quads, st.quads, "record {it}");
            }
            (Ok(()), Ok(r)) => {
                let mut w = st.clone();
                w.apply(&r);
                assert_eq!(fused.q, w.q, "record {it}");
                assert_eq!(fused.quads, w.quads, "record {it}");
                assert_eq!((kept_v, kept_f), (r.new_pos.clone(), r.appended.clone()));
                for v in 0..w.q.len() as u32 {
                    let mut a: Vec<_> = fused.corners(v).collect();
                    let mut b: Vec<_> = w.corners(v).collect();
                    a.sort_unstable();
                    b.sort_unstable();
                    assert_eq!(a, b, "record {it}: corners of vertex {v}");
                }
                let form = if edge { 4 } else { (sym >> 2) as usize & 3 };
                ok[form] += 1;
            }
            (a, b) => panic!("record {it}: fused {a:?}, explicit {:?}", b.map(|_| ())),
        }
    }
    // Enough records of the fused forms were built to mean something.
    assert!(
        ok[1] > 300 && ok[3] > 300 && ok[4] > 30,
        "built by form: {ok:?}"
    );
}

/// Edge splits at every interior edge of `st` with an endpoint in
/// `anchors`, both anchors, with sectors and fans from the shortest to the
/// longest the stars allow, several permutations and rotations, through
/// `run_apply`; `n` counts `[built, refused, built with an endpoint of 7
/// faces and a fan of 5]`. With `deeper`, each built record that leaves an
/// endpoint in 7 faces is followed by the same at that endpoint. `major`
/// picks the prediction rule (spec §7.6).
fn sweep_edge_splits(st: &MeshState, anchors: &[u32], deeper: bool, major: u16, n: &mut [u32; 3]) {
    let (max_v, max_f) = (st.q.len() as u32 + 8, st.quads.len() as u32 + 8);
    for &a in anchors {
        let Ok(sa) = st.star(a) else { continue };
        for (r, &d) in sa.link.iter().enumerate() {
            let Ok(sd) = st.star(d) else { continue };
            let (ka, kd) = (sa.faces.len() as u64, sd.faces.len() as u64);
            // Fields per endpoint in the order X0, X1.
            let (ends, k0, k1) = if a < d {
                ([a, d], ka, kd)
            } else {
                ([d, a], kd, ka)
            };
            let fields = |k: u64| {
                let mut f = vec![(0, 0)];
                if k >= 3 {
                    f.push((0, k - 3));
                    f.push((k - 3, 0));
                    f.push((1.min(k - 3), (k - 3).saturating_sub(2)));
                }
                f
            };
            for (i, &(n1a, ea)) in fields(k0).iter().enumerate() {
                for (j, &(n1b, eb)) in fields(k1).iter().enumerate() {
                    let p = [0, 77, 300, 575][(i + j) % 4];
                    let ra = [0, 0x93, 0x4e, 255][(i + 2 * j) % 4];
                    let mut conn = vec![r as u64, n1a, ea, n1b, eb, p, ra];
                    conn.extend((0..2 + ea + eb).map(|t| (t + i as u64) % 4));
                    let pos = [3, -1, 2, 0, 1, -4, 2, 2, 0, -3, 1, 1];
                    let s = streams(0x11, &conn, a as i64, &pos);
                    match run_apply(st, &s, max_v, max_f, major) {
                        Ok(next) => {
                            n[0] += 1;
                            n[2] += (k0 == 7 && ea == 4 || k1 == 7 && eb == 4) as u32;
                            if deeper {
                                let seven: Vec<u32> =
                                    ends.into_iter().filter(|&x| next.valence(x) == 7).collect();
                                sweep_edge_splits(&next, &seven, false, major, n);
                            }
                        }
                        Err(_) => n[1] += 1,
                    }
                }
            }
        }
    }
}

/// [`sweep_edge_splits`] on real levels (the coarsened torus, vertices of
/// valence 3 to 8), then at each endpoint that a built record left in 7
/// faces (a fan of 5 there ends in 8 corners, one past its block): the
/// decoder's fused path equals the explicit record applied — the same
/// quads, codes, corner lists and log entries, or the same error with
/// nothing applied.
#[test]
fn fused_edge_split_equals_build_on_every_edge_of_real_levels() {
    let mut dec = coarsened_torus();
    let mut n = [0u32; 3];
    for level in [0, 40] {
        dec.set_level(Target::Level(level)).unwrap();
        let st = MeshState::new(
            (1 << 14) - 1,
            dec.position_codes().to_vec(),
            dec.quads().to_vec(),
        );
        let all: Vec<u32> = (0..st.q.len() as u32).collect();
        // Level 0 with version 3's rule, level 40 with version 4's too.
        sweep_edge_splits(&st, &all, true, 3, &mut n);
        if level == 40 {
            sweep_edge_splits(&st, &all, true, 4, &mut n);
        }
    }
    let [built, refused, full] = n;
    assert!(
        built > 1000 && refused > 100 && full > 100,
        "{built} built, {refused} refused, {full} with a fan of 5 at 7 faces"
    );
}
