//! The edge-split form (spec §7.10, format 3): the spec's worked example,
//! every reject rule on hand-made records, and real qeMerge records of the
//! coarsener coded in it and decoded back exactly.

use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm_core::{shapes, Mesh, OpKind};
use pqm_format::codec::{decode_record, Cursors, MeshState, QRecord};
use pqm_format::varint::{put_s, put_u, Reader};
use pqm_format::*;

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

const EXAMPLE: [u64; 9] = [2, 0, 0, 0, 0, 0, 0, 0, 0];

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
        let e = run(&st, &s, max_v, max_f, major).unwrap_err();
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
    let run = |c: &[u64]| run(&st, &streams(0x11, c, 0, &[0; 12]), 30, 30, 3);
    // Fan of 0 = slot 2 (n1 = 1, m = 1); at 1, slot 2 is in the second
    // sector (n1 = 0) or the fan (n1 = 1).
    for n1_d in [0, 1] {
        let e = run(&[0, 1, 0, n1_d, 0, 0, 0, 0, 0]).unwrap_err();
        assert!(e.contains("slot 2 is a fan face"), "{e}");
    }
    // Elsewhere (fan of 0 = slot 1) the same stars build a record.
    assert!(run(&[0, 0, 0, 0, 0, 0, 0, 0, 0]).is_ok());
}

/// Real qeMerge records (the coarsener on a closed surface, subset
/// placement as `pqm encode`) are coded in the edge-split form, and every
/// level decodes to the progressive mesh's level id for id.
#[test]
fn coarsener_qe_merges_use_the_edge_split_form_and_decode_exactly() {
    let src = shapes::bumpy_torus(40, 24, 3.0, 1.0, 0.05, 7);
    let mesh = Mesh::from_indexed(&src).unwrap();
    let opts = CoarsenOptions {
        target_faces: Some(150),
        placement: Placement::Subset,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
    c.run(&mut |_| {});
    let pm = c.to_progressive();
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
    let q = dec.quantizer().unwrap();
    let n = pm.records.len();
    for k in (0..=n).rev().chain(0..=n) {
        dec.set_level(Target::Level(k)).unwrap();
        let (pos, quads) = pm.level_quads(k);
        assert_eq!(dec.quads(), &quads[..], "level {k}");
        let want: Vec<[u32; 3]> = pos.iter().map(|p| q.quantize(*p)).collect();
        assert_eq!(dec.position_codes(), &want[..], "level {k}");
    }
}
