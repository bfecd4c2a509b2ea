//! The vertex-order sections (spec §8): `VNBR` (3.1, coded against the
//! finest level's adjacency) and `VORD` (3.0, deltas) both give back the
//! mesh's permutation exactly, through every way of feeding the decoder; a
//! hand-made `VNBR` breaking each reject rule is refused with a clear error
//! (the cheap rules when the section arrives, the payload's when the order
//! is first asked for: the levels stay usable then, spec §8).

mod common;

use common::{header_len, patch_header};
use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_core::ProgressiveMesh;
use pqm_format::varint::{put_s, put_u};
use pqm_format::*;
use proptest::prelude::*;

fn encode(pm: &ProgressiveMesh, opts: &EncodeOptions) -> Vec<u8> {
    write_to_vec(pm, opts).expect("encode").0
}

/// The box grid (no 3.2 header bounds), so that the version fields say
/// which vertex-order section a file holds: 3.1 with `VNBR`, 3.0 without.
/// A 3.x file (3.0 with VORD, 3.1 with VNBR) on the box grid.
fn boxed(vertex_order_code: VertexOrderCode) -> EncodeOptions {
    EncodeOptions {
        vertex_order_code,
        grid: Grid::Box,
        version_major: 3,
        ..EncodeOptions::default()
    }
}

fn deltas() -> EncodeOptions {
    boxed(VertexOrderCode::Deltas)
}

/// Offset of the first optional section (right after the last chunk).
fn sections_start(bytes: &[u8]) -> usize {
    let dec = decode_all(bytes, Limits::default()).unwrap();
    let c = dec.chunks().last().unwrap();
    (c.offset + c.compressed_len as u64) as usize
}

/// One optional section: `tag`, a zstd frame of `payload` (stated length
/// `ulen`), its CRC.
fn section(tag: &[u8; 4], payload: &[u8], ulen: u32) -> Vec<u8> {
    use zstd::zstd_safe::CParameter;
    let mut c = zstd::bulk::Compressor::new(3).unwrap();
    c.set_parameter(CParameter::ContentSizeFlag(true)).unwrap();
    let z = c.compress(payload).unwrap();
    let mut s = tag.to_vec();
    s.extend_from_slice(&(z.len() as u32).to_le_bytes());
    s.extend_from_slice(&ulen.to_le_bytes());
    s.extend_from_slice(&crc32fast::hash(&z).to_le_bytes());
    s.extend_from_slice(&z);
    s
}

/// `bytes` with its sections replaced by `sections`, header flags `flags`
/// (the bounds flag, bit 2, kept as it was).
fn with_sections(bytes: &[u8], flags: u32, sections: &[Vec<u8>]) -> Vec<u8> {
    let mut b = bytes[..sections_start(bytes)].to_vec();
    patch_header(&mut b, |h| {
        let flags = flags | (h[16] as u32 & 4);
        h[16..20].copy_from_slice(&flags.to_le_bytes());
        h[48..52].copy_from_slice(&(sections.len() as u32).to_le_bytes());
    });
    for s in sections {
        b.extend_from_slice(s);
    }
    b
}

fn invalid_message<T: std::fmt::Debug>(r: Result<T, DecodeError>) -> (Section, String) {
    match r {
        Err(DecodeError::Format(FormatError::Invalid { section, message })) => (section, message),
        other => panic!("expected an invalid-input error, got {other:?}"),
    }
}

/// The VNBR payload the encoder wrote into `bytes`.
fn vnbr_payload(bytes: &[u8]) -> Vec<u8> {
    let at = sections_start(bytes);
    assert_eq!(&bytes[at..at + 4], b"VNBR");
    let clen = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
    zstd::stream::decode_all(&bytes[at + 16..at + 16 + clen]).unwrap()
}

fn assert_order(bytes: &[u8], pm: &ProgressiveMesh, tag: &[u8; 4]) {
    let at = sections_start(bytes);
    assert_eq!(&bytes[at..at + 4], tag);
    let dec = decode_all(bytes, Limits::default()).unwrap();
    assert_eq!(dec.vertex_order().unwrap(), Some(&pm.vertex_order[..]));
}

fn gen(seed: u64, splits: usize, coherent: Option<usize>) -> ProgressiveMesh {
    let mut pm = testgen::generate_with(&GenOptions {
        base: if seed.is_multiple_of(2) {
            BaseShape::Box { n: 2 }
        } else {
            BaseShape::Grid { nx: 3, ny: 2 }
        },
        ..GenOptions::new(seed, splits)
    });
    if let Some(swaps) = coherent {
        pqm_format::vectors::coherent_vertex_order(&mut pm, seed, swaps);
    }
    pm
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random and coherent orders round-trip through VNBR and VORD; the
    /// file is 3.1 with flag bit 1 for VNBR, 3.0 with bit 0 for VORD; VNBR
    /// is never larger than VORD by more than its worst case; the default
    /// writes the smaller file of the two, VORD on a tie (tiny meshes
    /// often get VORD, so the VNBR half asks for it).
    #[test]
    fn vnbr_and_vord_round_trip(
        seed in 0u64..10_000,
        splits in 1usize..120,
        coherent in prop::option::of(0usize..40),
    ) {
        let pm = gen(seed, splits, coherent);
        let v = encode(&pm, &boxed(VertexOrderCode::Neighbours));
        assert_order(&v, &pm, b"VNBR");
        prop_assert_eq!(&v[8..12], &[3, 0, 1, 0]);
        prop_assert_eq!(Header::parse(&v[..120]).flags, 2);
        let d = encode(&pm, &deltas());
        assert_order(&d, &pm, b"VORD");
        prop_assert_eq!(&d[8..12], &[3, 0, 0, 0]);
        prop_assert_eq!(Header::parse(&d[..120]).flags, 1);
        // Everything but the section is the same bytes.
        let (sv, sd) = (sections_start(&v), sections_start(&d));
        prop_assert_eq!(&v[20..116], &d[20..116]);
        prop_assert_eq!(&v[120..sv], &d[120..sd]);
        let smaller = if d.len() <= v.len() { &d } else { &v };
        prop_assert_eq!(&encode(&pm, &boxed(VertexOrderCode::Smaller)), smaller);
        // With the cube grid: a 3.2 file, the same section choice, the
        // bounds flag beside the section's; the default (4.0) likewise,
        // with minor 0 whatever it holds.
        let cube = encode(&pm, &EncodeOptions { version_major: 3, ..EncodeOptions::default() });
        prop_assert_eq!(&cube[8..12], &[3, 0, 2, 0]);
        let section_flag = if d.len() <= v.len() { 1 } else { 2 };
        prop_assert_eq!(Header::parse(&cube[..168]).flags, section_flag | 4);
        assert_order(&cube, &pm, if section_flag == 1 { b"VORD" } else { b"VNBR" });
        let v4 = encode(&pm, &EncodeOptions::default());
        prop_assert_eq!(&v4[8..12], &[4, 0, 0, 0]);
        prop_assert!(Header::parse(&v4[..168]).flags & 4 == 4);
        assert_order(&v4, &pm, if Header::parse(&v4[..168]).flags & 1 == 1 { b"VORD" } else { b"VNBR" });
        // 2.0 and 1.1 files keep VORD (their minors have no VNBR).
        for major in [1, 2] {
            let old = encode(&pm, &EncodeOptions { version_major: major, ..EncodeOptions::default() });
            assert_order(&old, &pm, b"VORD");
        }
    }

    /// A caller at a coarse level when the section arrives still gets the
    /// finest level's permutation (the section is coded against it).
    #[test]
    fn vnbr_decodes_whatever_level_the_caller_is_at(
        seed in 0u64..10_000,
        splits in 1usize..80,
        swaps in 0usize..20,
        piece in 1usize..200,
    ) {
        let pm = gen(seed, splits, Some(swaps));
        let bytes = encode(&pm, &EncodeOptions { chunk_records: Some(7), ..EncodeOptions::default() });
        for forward_only in [false, true] {
            let mut dec = if forward_only {
                Decoder::forward_only(Limits::default())
            } else {
                Decoder::new(Limits::default())
            };
            for p in bytes.chunks(piece) {
                for e in dec.push(p).unwrap() {
                    if let Event::ChunkReady(i) = e {
                        // Stay at level 0 (general) or follow (forward-only).
                        if forward_only || i == 0 {
                            dec.set_level(Target::Level(if forward_only { usize::MAX } else { 0 })).unwrap();
                        }
                    }
                }
            }
            prop_assert!(dec.status().finished);
            prop_assert_eq!(dec.vertex_order().unwrap(), Some(&pm.vertex_order[..]));
            // Asked for again: the cached order.
            prop_assert_eq!(dec.vertex_order().unwrap(), Some(&pm.vertex_order[..]));
        }
    }
}

/// Coherent orders cost a few bits per vertex; random ones about what VORD
/// costs (the escapes' ranks).
#[test]
fn coherent_orders_are_cheaper_than_deltas() {
    let pm = gen(3, 600, Some(0));
    let n = pm.final_vertex_count();
    assert!(n > 600);
    let v = encode(&pm, &EncodeOptions::default());
    let d = encode(&pm, &deltas());
    let (sv, sd) = (v.len() - sections_start(&v), d.len() - sections_start(&d));
    let bits = |s: usize| 8.0 * s as f64 / n as f64;
    assert!(
        bits(sv) < 0.5 * bits(sd) && bits(sv) < 4.0,
        "VNBR {:.2} vs VORD {:.2} bits per vertex",
        bits(sv),
        bits(sd)
    );
}

#[test]
fn one_byte_at_a_time_equals_all_at_once_and_every_prefix_is_safe() {
    let pm = gen(4, 60, Some(10));
    let bytes = encode(
        &pm,
        &EncodeOptions {
            chunk_records: Some(9),
            ..EncodeOptions::default()
        },
    );
    let mut whole = Decoder::new(Limits::default());
    let ev_whole = whole.push(&bytes).unwrap();
    let mut single = Decoder::new(Limits::default());
    let mut ev_single = Vec::new();
    for b in bytes.chunks(1) {
        ev_single.extend(single.push(b).unwrap());
    }
    assert_eq!(ev_whole, ev_single);
    assert_eq!(
        whole.vertex_order().unwrap(),
        single.vertex_order().unwrap()
    );
    assert_eq!(whole.vertex_order().unwrap(), Some(&pm.vertex_order[..]));
    // Every prefix: no error, no order before the section is whole, every
    // chunk it holds decoded.
    let at = sections_start(&bytes);
    for len in 0..bytes.len() {
        let mut d = Decoder::new(Limits::default());
        d.push(&bytes[..len]).unwrap();
        assert_eq!(d.vertex_order().unwrap(), None, "prefix {len}");
        assert!(!d.status().finished);
        if len >= at {
            assert_eq!(d.deepest_level(), Some(pm.records.len()));
        }
    }
}

/// Each reject rule of spec §8.2, as a hand-made section on a real file.
#[test]
fn hostile_vnbr_sections_are_rejected() {
    let pm = gen(6, 40, Some(5));
    let bytes = encode(&pm, &EncodeOptions::default());
    let h = Header::parse(&bytes[..header_len(&bytes)]);
    let n = h.final_vertex_count;
    let base = h.base_vertex_count;
    assert!(base > 0 && base < n);
    let good = vnbr_payload(&bytes);
    // The helpers rebuild a file that decodes.
    let ok = with_sections(&bytes, 2, &[section(b"VNBR", &good, good.len() as u32)]);
    assert_eq!(
        decode_all(&ok, Limits::default())
            .unwrap()
            .vertex_order()
            .unwrap(),
        Some(&pm.vertex_order[..])
    );
    // A bad payload: the file decodes, every level is reachable, and the
    // order is the error naming the section, on every call.
    let reject = |payload: &[u8], ulen: u32, want: &str| {
        let b = with_sections(&bytes, 2, &[section(b"VNBR", payload, ulen)]);
        for forward_only in [false, true] {
            let mut dec = if forward_only {
                Decoder::forward_only(Limits::default())
            } else {
                Decoder::new(Limits::default())
            };
            dec.push(&b).unwrap();
            assert!(dec.status().finished && !dec.status().failed);
            for _ in 0..2 {
                let (s, m) = invalid_message(dec.vertex_order());
                assert_eq!(s, Section::Optional(0), "{m}");
                assert!(m.contains(want), "want {want:?}, got {m:?}");
            }
            let last = pm.records.len();
            let levels: Vec<usize> = if forward_only {
                vec![last]
            } else {
                vec![last, 0, last]
            };
            for k in levels {
                dec.set_level(Target::Level(k)).unwrap();
                assert_eq!(dec.level(), k);
                assert_eq!(dec.quads(), &pm.level_quads(k).1[..]);
            }
            // The records are whole; only the order is left out.
            if !forward_only {
                let back = dec.to_progressive_mesh().unwrap();
                assert_eq!(back.records.len(), pm.records.len());
                assert!(back.vertex_order.is_empty());
            }
        }
    };
    // Bounds checked when the section arrives: the push fails, naming it.
    let reject_early = |payload: &[u8], ulen: u32, want: &str| {
        let b = with_sections(&bytes, 2, &[section(b"VNBR", payload, ulen)]);
        let (s, m) = invalid_message(Decoder::new(Limits::default()).push(&b));
        assert_eq!(s, Section::Optional(0), "{m}");
        assert!(m.contains(want), "want {want:?}, got {m:?}");
    };
    let len = |p: &[u8]| p.len() as u32;
    // Symbol 0 at the first input vertex: its list is empty.
    let mut p = good.clone();
    p[0] = 0;
    reject(&p, len(&p), "candidates");
    // Symbol 254 once every base vertex is assigned.
    let p = vec![254u8; n as usize];
    reject(&p, len(&p), "no base vertex is left");
    // An escape whose rank is out of range, or missing.
    let mut p = vec![254u8; base as usize];
    p.resize(n as usize, 255);
    let mut q = p.clone();
    put_s(&mut q, n as i64);
    reject(&q, len(&q), "rank");
    let mut q = p.clone();
    put_s(&mut q, -1);
    reject(&q, len(&q), "rank");
    reject(&p, len(&p), "ends early");
    // An escape naming a vertex that has a symbol: the first input vertex
    // by rank 0 is base vertex 0, which symbol 254 names.
    let mut p = vec![255u8];
    p.resize(n as usize, 0);
    put_u(&mut p, 0);
    reject(&p, len(&p), "which symbol 254 names");
    // Bytes left over.
    let mut p = good.clone();
    p.push(0);
    reject(&p, len(&p), "unused bytes");
    // Fewer bytes than symbols (within the stated length's bounds the
    // frame's real size must match: checked by the frame rule).
    let p = good[..n as usize - 1].to_vec();
    let b = with_sections(&bytes, 2, &[section(b"VNBR", &p, n)]);
    assert!(Decoder::new(Limits::default()).push(&b).is_err());
    // Stated uncompressed length outside n..=11n, before decompressing.
    for claim in [n - 1, 11 * n + 1, u32::MAX] {
        reject_early(&good, claim, "uncompressed length");
    }
    // Flag bit 1 clear, VNBR with VORD, two VNBR, flag without a section.
    let vnbr = section(b"VNBR", &good, len(&good));
    let d = encode(&pm, &deltas());
    let vord = d[sections_start(&d)..].to_vec();
    for (flags, secs, want) in [
        (0, vec![vnbr.clone()], "flag bit 1 is clear"),
        (1, vec![vnbr.clone()], "flag bit 1 is clear"),
        (3, vec![vord.clone(), vnbr.clone()], "at most one"),
        (3, vec![vnbr.clone(), vord.clone()], "at most one"),
        (2, vec![vnbr.clone(), vnbr.clone()], "at most one"),
    ] {
        let b = with_sections(&bytes, flags, &secs);
        let (_, m) = invalid_message(Decoder::new(Limits::default()).push(&b));
        assert!(m.contains(want), "flags {flags}: want {want:?}, got {m:?}");
    }
    for (flags, secs) in [
        (2, vec![]),
        (3, vec![vnbr.clone()]),
        (3, vec![vord.clone()]),
    ] {
        let b = with_sections(&bytes, flags, &secs);
        let (s, m) = invalid_message(Decoder::new(Limits::default()).push(&b));
        assert_eq!(s, Section::Trailer, "{m}");
        assert!(m.contains("announces"), "{m}");
    }
    // A 3.0 reader's view: an unknown tag is skipped. Renamed, the section
    // leaves the file valid without an order.
    let b = with_sections(&bytes, 0, &[section(b"XNBR", &good, len(&good))]);
    let dec = decode_all(&b, Limits::default()).unwrap();
    assert_eq!(dec.vertex_order().unwrap(), None);
    assert!(dec.status().finished);
}

/// Within its bounds, the VNBR state counts against the memory budget.
#[test]
fn vnbr_memory_is_budgeted() {
    let pm = gen(8, 80, Some(3));
    let bytes = encode(&pm, &EncodeOptions::default());
    let dec = decode_all(&bytes, Limits::default()).unwrap();
    let h = dec.header().unwrap().clone();
    let payload = h.base_uncompressed_len as u64
        + dec
            .chunks()
            .iter()
            .map(|c| c.uncompressed_len as u64)
            .sum::<u64>();
    let before = Limits::estimate(
        h.final_vertex_count as u64,
        h.final_face_count as u64,
        h.record_count as u64,
        payload,
    );
    let mut d = Decoder::new(Limits {
        max_memory_bytes: before,
        ..Limits::default()
    });
    assert!(matches!(d.push(&bytes), Err(DecodeError::LimitsExceeded(m)) if m.contains("VNBR")));
    assert_eq!(d.status().chunks_ready, h.chunk_count);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random VNBR payloads over a real mesh never panic and, when they
    /// decode, give a permutation.
    #[test]
    fn random_vnbr_payloads_never_panic(seed in 0u64..1000, bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let pm = gen(seed % 4, 30, Some(2));
        let file = encode(&pm, &EncodeOptions::default());
        let n = pm.final_vertex_count();
        let mut p = bytes;
        // Mostly small symbols, so the walk gets somewhere.
        for b in p.iter_mut().take(n) {
            if *b < 250 { *b %= 6; }
        }
        let b = with_sections(&file, 2, &[section(b"VNBR", &p, p.len() as u32)]);
        if let Ok(dec) = decode_all(&b, Limits::default()) {
            // Decoded on access: an error or a permutation.
            let Ok(Some(o)) = dec.vertex_order() else { return Ok(()) };
            let mut o = o.to_vec();
            o.sort_unstable();
            prop_assert!(o.iter().enumerate().all(|(i, &v)| v as usize == i));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// `vertex_order_keep`: the input indices below `keep` stay with their
    /// vertices, the rest are a permutation of `keep..n`; the decoder gives
    /// back exactly the order `write_stored` reports, whatever section the
    /// writer picks; the records are untouched (the same bytes up to the
    /// sections); and the section is no larger than the whole order's (the
    /// writer prices both; random orders: far smaller).
    #[test]
    fn a_free_tail_keeps_the_kept_indices_and_codes_smaller(
        seed in 0u64..10_000,
        splits in 1usize..150,
        coherent in prop::option::of(0usize..40),
        keep_frac in 0.0f64..1.0,
    ) {
        let pm = gen(seed, splits, coherent);
        let n = pm.final_vertex_count();
        let keep = (keep_frac * n as f64) as usize;
        let whole = encode(&pm, &boxed(VertexOrderCode::Neighbours));
        let opts = EncodeOptions { vertex_order_keep: Some(keep), ..boxed(VertexOrderCode::Neighbours) };
        let mut bytes = Vec::new();
        let (_, stored) = write_stored(&pm, &opts, &mut bytes).unwrap();
        let kept = |order: &[u32]| -> Result<(), TestCaseError> {
            prop_assert_eq!(order.len(), n);
            let mut seen = vec![false; n];
            for (c, (&o, &was)) in order.iter().zip(&pm.vertex_order).enumerate() {
                prop_assert!(!std::mem::replace(&mut seen[o as usize], true), "index {} twice", o);
                if (was as usize) < keep || (o as usize) < keep {
                    prop_assert_eq!(o, was, "vertex {} moved from kept index {}", c, was);
                }
            }
            Ok(())
        };
        kept(&stored.vertex_order)?;
        assert_order(&bytes, &stored, b"VNBR");
        let (sb, sw) = (sections_start(&bytes), sections_start(&whole));
        prop_assert_eq!(&bytes[..sb], &whole[..sw]);
        prop_assert!(bytes.len() - sb <= whole.len() - sw, "{} vs {} section bytes", bytes.len() - sb, whole.len() - sw);
        // The default section choice reads the same order back.
        let smaller = EncodeOptions { vertex_order_keep: Some(keep), ..EncodeOptions::default() };
        let mut b = Vec::new();
        let (_, again) = write_stored(&pm, &smaller, &mut b).unwrap();
        kept(&again.vertex_order)?;
        let dec = decode_all(&b, Limits::default()).unwrap();
        prop_assert_eq!(dec.vertex_order().unwrap(), Some(&again.vertex_order[..]));
    }
}

/// A random order past `keep` costs about what VORD costs; given out anew
/// it costs almost nothing.
#[test]
fn a_free_tail_costs_almost_nothing() {
    let pm = gen(5, 600, None);
    let n = pm.final_vertex_count();
    let keep = n / 5;
    let size = |keep| {
        let b = encode(
            &pm,
            &EncodeOptions {
                vertex_order_keep: keep,
                ..boxed(VertexOrderCode::Neighbours)
            },
        );
        8.0 * (b.len() - sections_start(&b)) as f64 / n as f64
    };
    let (whole, free, none) = (size(None), size(Some(keep)), size(Some(0)));
    assert!(
        free < 0.4 * whole,
        "free tail {free:.2} vs whole {whole:.2} bits per vertex"
    );
    assert!(
        none < 1.5,
        "everything given out anew: {none:.2} bits per vertex"
    );
}
