//! Fuzz the push decoder.
//!
//! * Mode 0 (raw bytes): the input is a `.pqm` file; pushing it whole and
//!   pushing it split at a point chosen by the input must give the same
//!   outcome, the same events and the same deepest level and mesh; a
//!   [`Decoder::forward_only`] decoder fed the split input must reach the
//!   same outcome, deepest level and mesh.
//! * Mode 1 (record streams): the input is the five record streams of a
//!   chunk, decoded against a valid generated mesh under the 1.x, 2.0 or
//!   3.0 rules (bypasses CRCs so the record decoder itself is exercised),
//!   both by the explicit record then `apply` and by the decoder's fused
//!   path (`decode_apply_record`): both refuse the record, or both give
//!   the same mesh.
//!
//! `cargo +nightly fuzz run decode` (or `cargo fuzz run decode -s none` on
//! stable) from `crates/pqm-format`; seed corpus: `spec/vectors/*.pqm`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pqm_format::{Decoder, Limits, Target};

fn outcome(
    parts: &[&[u8]],
) -> (
    bool,
    Vec<pqm_format::Event>,
    Option<usize>,
    Vec<[u32; 4]>,
    Vec<[u32; 3]>,
) {
    let limits = Limits {
        max_vertices: 1 << 20,
        max_faces: 1 << 20,
        max_memory_bytes: 256 << 20,
    };
    let mut d = Decoder::new(limits);
    let mut events = Vec::new();
    let mut ok = true;
    for p in parts {
        match d.push(p) {
            Ok(e) => events.extend(e),
            Err(_) => {
                ok = false;
                break;
            }
        }
    }
    let _ = d.status();
    if d.deepest_level().is_some() {
        let c = d
            .set_level(Target::Level(usize::MAX))
            .expect("reachable level");
        assert_eq!(Some(c.to_level), d.deepest_level());
        let back = d.set_level(Target::Level(0)).expect("level 0");
        assert_eq!(back.to_level, 0);
        d.set_level(Target::Level(usize::MAX))
            .expect("refine again");
    }
    (
        ok,
        events,
        d.deepest_level(),
        d.quads().to_vec(),
        d.position_codes().to_vec(),
    )
}

/// [`Decoder::forward_only`] on the same parts: whether every push
/// succeeded, the deepest level and its mesh.
fn forward(parts: &[&[u8]]) -> (bool, Option<usize>, Vec<[u32; 4]>, Vec<[u32; 3]>) {
    let limits = Limits {
        max_vertices: 1 << 20,
        max_faces: 1 << 20,
        max_memory_bytes: 256 << 20,
    };
    let mut d = Decoder::forward_only(limits);
    let mut ok = true;
    for p in parts {
        if d.push(p).is_err() {
            ok = false;
            break;
        }
    }
    if d.deepest_level().is_some() {
        let c = d
            .refine_to(Target::Level(usize::MAX))
            .expect("deepest level");
        assert_eq!(Some(c.to_level), d.deepest_level());
    }
    (
        ok,
        d.deepest_level(),
        d.quads().to_vec(),
        d.position_codes().to_vec(),
    )
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode & 1 == 0 {
        let at = if rest.len() >= 2 {
            (rest[0] as usize | (rest[1] as usize) << 8) % (rest.len() + 1)
        } else {
            0
        };
        let whole = outcome(&[rest]);
        let split = outcome(&[&rest[..at], &rest[at..]]);
        // Once an error happened, events after it are lost either way; the
        // levels decoded before the error must agree.
        assert_eq!(whole.0, split.0);
        if whole.0 {
            assert_eq!(whole.1, split.1);
        }
        assert_eq!(whole.2, split.2);
        assert_eq!(whole.3, split.3);
        assert_eq!(whole.4, split.4);
        // The one-way decoder keeps the same deepest level, error or not.
        let fwd = forward(&[&rest[..at], &rest[at..]]);
        assert_eq!(whole.0, fwd.0);
        assert_eq!(whole.2, fwd.1);
        assert_eq!(whole.3, fwd.2);
        assert_eq!(whole.4, fwd.3);
    } else {
        use pqm_format::codec::{
            decode_apply_record, decode_record, Cursors, DecodeScratch, MeshState, QRecord,
        };
        use pqm_format::varint::Reader;
        // Bits 1-2 pick the rules (1.x, 2.0, 3.0), the rest the mesh.
        let major = 1 + ((mode >> 1) & 3).min(2) as u16;
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
