//! Fuzz the push decoder.
//!
//! * Mode 0 (raw bytes): the input is a `.pqm` file; pushing it whole and
//!   pushing it split at one point chosen by the input must give the same
//!   outcome, the same events and the same deepest level and mesh, and so
//!   must a `Decoder::forward_only` decoder fed the two pieces
//!   (`split_check.rs`; the `buf_independent` target cuts in many places).
//! * Mode 1 (record streams): the input is the five record streams of a
//!   chunk, decoded against a valid generated mesh under the 1.x, 2.0 or
//!   3.0 rules (bypasses CRCs so the record decoder itself is exercised),
//!   both by the explicit record then `apply` and by the decoder's fused
//!   path (`decode_apply_record`): both refuse the record, or both give
//!   the same mesh — codes, quads and every vertex's star, so corner
//!   lists that differ are caught at the record that made them. (Modes 1
//!   and 3 mod 8 with bit 7 set are mode 2.)
//! * Mode 2 (a base payload, spec §6 and §6.1: odd modes with bit 7 set):
//!   two bytes give the vertex and face counts, the rest is a 4.0 base
//!   payload (layout byte first). It decodes as `base::decode_reference`
//!   does (the same base or the same error). A base it decodes to is
//!   valid (distinct corners, ids and codes in range), and written again
//!   in the traversal layout (when it can be) it decodes to the same base.
//!
//! `cargo +nightly fuzz run decode` (or `cargo fuzz run decode -s none` on
//! stable) from `crates/pqm-format`; seed corpus: `spec/vectors/*.pqm`.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "split_check.rs"]
mod split_check;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode & 0x81 == 0x81 {
        use pqm_format::base;
        let [nv, nf, payload @ ..] = rest else {
            return;
        };
        let (nv, nf, qmax) = (*nv as u32, *nf as u32, 1023);
        // The walk's shortcuts change nothing: the same base, or the same
        // error, as the reference decoder (every shortcut off).
        let fast = base::decode(payload, nv, nf, qmax, 4);
        match (&fast, base::decode_reference(payload, nv, nf, qmax, 4)) {
            (Ok(a), Ok(b)) => assert_eq!((&a.q[..], &a.quads[..]), (&b.q[..], &b.quads[..])),
            (Err(a), Err(b)) => assert_eq!(a, &b),
            (a, b) => panic!("fast {:?} / reference {:?}", a.as_ref().err(), b.err()),
        }
        let Ok(st) = fast else {
            return;
        };
        assert_eq!((st.q.len(), st.quads.len()), (nv as usize, nf as usize));
        for q in &st.quads {
            assert!(q.iter().all(|&v| v < nv));
            assert!((0..4).all(|i| (i + 1..4).all(|j| q[i] != q[j])));
        }
        assert!(st.q.iter().flatten().all(|&c| c <= qmax));
        if let Some(p) = base::encode_traversal(&st.q, &st.quads, qmax) {
            let again = base::decode(&p.payload, nv, nf, qmax, 4).expect("re-encoded base");
            assert_eq!((again.q, again.quads), (st.q, st.quads));
        }
    } else if mode & 1 == 0 {
        let at = if rest.len() >= 2 {
            (rest[0] as usize | (rest[1] as usize) << 8) % (rest.len() + 1)
        } else {
            0
        };
        split_check::check_pieces(rest, &[at]);
    } else {
        use pqm_format::codec::{
            decode_apply_record, decode_record, Cursors, DecodeScratch, MeshState, QRecord, Star,
        };
        use pqm_format::varint::Reader;
        // Bits 1-2 pick the rules (1.x, 2.0, 3.0, 4.0), the rest the mesh.
        let major = 1 + ((mode >> 1) & 3) as u16;
        let seed = (mode >> 3) as u64;
        let pm = pqm_core::progressive::testgen::generate(seed, 30);
        let (pos, quads) = pm.level_quads(pm.records.len());
        let q = pqm_format::Quantizer::new([-2.0; 3], [6.0; 3], 12);
        let mut st = MeshState::new(
            q.qmax(),
            pos.iter().map(|p| q.quantize(*p)).collect(),
            quads,
        );
        let mut fused = st.clone();
        let n = rest.len() / 5;
        let streams = || [0, 1, 2, 3, 4].map(|k| Reader::new(&rest[k * n..(k + 1) * n], "s"));
        let (mut rd, mut rd_fused) = (streams(), streams());
        let (mut cur, mut cur_fused) = (Cursors::default(), Cursors::default());
        let (mut scratch, mut sc) = (QRecord::default(), DecodeScratch::new());
        let (mut moved, mut rw) = (Vec::new(), Vec::new());
        let (mv, mf) = (st.q.len() as u32 + 50, st.quads.len() as u32 + 50);
        for _ in 0..20 {
            let explicit = decode_record(&st, &mut rd, &mut cur, mv, mf, major);
            let got = decode_apply_record(
                &mut fused,
                &mut rd_fused,
                &mut cur_fused,
                mv,
                mf,
                major,
                &mut scratch,
                &mut sc,
                &mut moved,
                &mut rw,
                None,
            );
            match explicit {
                Ok(r) => {
                    assert_eq!(got, Ok(()));
                    st.apply(&r);
                    assert!(st
                        .quads
                        .iter()
                        .flatten()
                        .all(|&v| (v as usize) < st.q.len()));
                    assert_eq!(fused.q, st.q);
                    assert_eq!(fused.quads, st.quads);
                    // The corner lists too, through every vertex's
                    // canonical star (spec §7.5): a fused apply that
                    // leaves the same quads but other corner lists
                    // decodes later records differently.
                    for v in 0..st.q.len() as u32 {
                        let (mut a, mut b) = (Star::default(), Star::default());
                        let (ra, rb) = (st.star_into(v, &mut a), fused.star_into(v, &mut b));
                        assert_eq!(ra, rb, "vertex {v}");
                        assert_eq!((a.faces, a.link), (b.faces, b.link), "vertex {v}");
                    }
                }
                Err(e) => {
                    // refused too, nothing applied (the message may name
                    // another element of the same defect: the fused path
                    // checks a record's slots in star order, the explicit
                    // one in slot order)
                    assert!(got.is_err(), "fused path accepted: {e}");
                    assert_eq!(fused.q, st.q);
                    assert_eq!(fused.quads, st.quads);
                    break;
                }
            }
        }
    }
});
