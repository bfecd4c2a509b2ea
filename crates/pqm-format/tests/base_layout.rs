//! The base section's traversal layout (spec §6.1): bases numbered in the
//! walk's order round-trip through it, every level of their files decodes
//! as the progressive mesh says, and hostile payloads are refused with an
//! error (never a panic), at every truncation and under byte changes.

mod common;

use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_core::ProgressiveMesh;
use pqm_format::{base, decode_all, vectors, write_to_vec, EncodeOptions, Limits};
use proptest::prelude::*;

/// The base payload of `bytes`, decompressed.
fn base_payload(bytes: &[u8]) -> Vec<u8> {
    let dec = decode_all(bytes, Limits::default()).unwrap();
    let h = dec.header().unwrap();
    let at = h.header_len as usize + h.chunk_count as usize * h.chunk_entry_len as usize + 4;
    zstd::stream::decode_all(&bytes[at..at + h.base_compressed_len as usize]).unwrap()
}

fn gen(seed: u64, splits: usize, shape: u8) -> ProgressiveMesh {
    let base = match shape % 3 {
        0 => BaseShape::Box {
            n: 2 + (seed % 3) as u32,
        },
        1 => BaseShape::Grid {
            nx: 2 + (seed % 4) as u32,
            ny: 1 + (seed % 3) as u32,
        },
        _ => BaseShape::Box { n: 3 },
    };
    let mut pm = testgen::generate_with(&GenOptions {
        base,
        ..GenOptions::new(seed, splits)
    });
    vectors::add_face_splits(&mut pm, splits / 8, seed);
    vectors::add_edge_splits(&mut pm, splits / 10, seed);
    pm
}

/// The base codes and quads of `pm` on the grid of the file `bytes`.
fn quantized_base(pm: &ProgressiveMesh, bytes: &[u8]) -> (Vec<[u32; 3]>, Vec<[u32; 4]>, u32) {
    let dec = decode_all(bytes, Limits::default()).unwrap();
    let q = dec.quantizer().unwrap();
    let codes = pm.base.positions.iter().map(|p| q.quantize(*p)).collect();
    let quads = pm.base.faces().map(|f| [f[0], f[1], f[2], f[3]]).collect();
    (codes, quads, q.qmax())
}

/// `base::decode` (with its shortcuts: half-edges known from how the
/// corners were named, not looked up) gives what `decode_reference` (every
/// half-edge looked up) gives: the same base or the same error.
fn same_as_reference(p: &[u8], nv: u32, nf: u32, qmax: u32) {
    let fast = base::decode(p, nv, nf, qmax, 4).map(|st| (st.q, st.quads));
    let reference = base::decode_reference(p, nv, nf, qmax, 4).map(|st| (st.q, st.quads));
    assert_eq!(fast, reference);
}

/// The byte range of a traversal payload's gates, corners and escapes (its
/// streams before the positions).
fn symbol_streams(p: &[u8]) -> std::ops::Range<usize> {
    let mut at = 1;
    for _ in 0..3 {
        let (mut len, mut shift) = (0usize, 0);
        loop {
            let b = p[at];
            at += 1;
            len |= ((b & 0x7f) as usize) << shift;
            shift += 7;
            if b < 0x80 {
                break;
            }
        }
        at += len;
    }
    1..at
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A base renumbered in the walk's order is written in the traversal
    /// layout, and every level of the file decodes to the mesh's own, up
    /// and down; the renumbering keeps every level's geometry.
    #[test]
    fn walk_ordered_bases_round_trip_in_the_traversal_layout(
        seed in any::<u64>(),
        splits in 0usize..120,
        shape in any::<u8>(),
    ) {
        let mut pm = gen(seed, splits, shape);
        let before = pm.level_quads(pm.records.len());
        pm.renumber_base_in_walk_order();
        prop_assert!(pm.validate().is_ok(), "{:?}", pm.validate());
        let after = pm.level_quads(pm.records.len());
        // the same faces by position, whatever the ids
        let corners = |(pos, quads): &(Vec<glam::DVec3>, Vec<[u32; 4]>)| {
            let mut f: Vec<Vec<[u64; 3]>> = quads
                .iter()
                .map(|q| q.iter().map(|&v| pos[v as usize].to_array().map(f64::to_bits)).collect())
                .collect();
            f.sort();
            f
        };
        prop_assert_eq!(corners(&before), corners(&after));
        let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
        // the layout alone, straight through its functions
        let (codes, quads, qmax) = quantized_base(&pm, &bytes);
        let p = base::encode_traversal(&codes, &quads, qmax).expect("walk-ordered");
        let st = base::decode(&p.payload, codes.len() as u32, quads.len() as u32, qmax, 4).unwrap();
        same_as_reference(&p.payload, codes.len() as u32, quads.len() as u32, qmax);
        prop_assert_eq!(&st.q, &codes);
        prop_assert_eq!(&st.quads, &quads);
        let mut dec = decode_all(&bytes, Limits::default()).unwrap();
        common::assert_every_level_down_and_up(&mut dec, &pm);
    }

    /// A base whose ids are not in the walk's order cannot be written in
    /// the traversal layout; the writer uses the delta layout, which
    /// decodes all the same.
    #[test]
    fn other_orders_fall_back_to_the_delta_layout(seed in any::<u64>(), splits in 0usize..60) {
        let mut pm = gen(seed, splits, 1);
        pm.renumber_base_in_walk_order();
        vectors::reverse_base_vertices(&mut pm);
        let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
        let (codes, quads, qmax) = quantized_base(&pm, &bytes);
        prop_assert!(base::encode_traversal(&codes, &quads, qmax).is_none());
        prop_assert_eq!(base_payload(&bytes)[0], base::LAYOUT_DELTA);
        let mut dec = decode_all(&bytes, Limits::default()).unwrap();
        common::assert_every_level_down_and_up(&mut dec, &pm);
    }

    /// Changed bytes anywhere in a traversal payload give a base or an
    /// error, never a panic; a base they give is valid (distinct corners,
    /// ids and codes in range).
    #[test]
    fn damaged_traversal_payloads_are_refused_or_valid(
        seed in any::<u64>(),
        changes in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
    ) {
        let mut pm = gen(seed, 0, 0);
        pm.renumber_base_in_walk_order();
        let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
        let (codes, quads, qmax) = quantized_base(&pm, &bytes);
        let mut p = base::encode_traversal(&codes, &quads, qmax).unwrap().payload;
        for (i, b) in changes {
            let i = i.index(p.len());
            p[i] = b;
        }
        let (nv, nf) = (codes.len() as u32, quads.len() as u32);
        same_as_reference(&p, nv, nf, qmax);
        if let Ok(st) = base::decode(&p, nv, nf, qmax, 4) {
            prop_assert_eq!(st.q.len(), nv as usize);
            prop_assert_eq!(st.quads.len(), nf as usize);
            for q in &st.quads {
                prop_assert!(q.iter().all(|&v| v < nv));
                prop_assert!((0..4).all(|i| (i + 1..4).all(|j| q[i] != q[j])));
            }
            prop_assert!(st.q.iter().all(|c| c.iter().all(|&x| x <= qmax)));
        }
    }

    /// Corner symbols and gates changed to other small symbols (new,
    /// candidates 1–4, an escape) — faces that name the wrong candidate,
    /// repeat half-edges, close fans twice: the decoder's shortcuts give
    /// the same base or the same error as looking every half-edge up.
    #[test]
    fn changed_symbols_decode_as_the_reference_does(
        seed in any::<u64>(),
        splits in 0usize..120,
        shape in any::<u8>(),
        changes in proptest::collection::vec((any::<prop::sample::Index>(), 0usize..8), 1..6),
    ) {
        let mut pm = gen(seed, splits, shape);
        pm.renumber_base_in_walk_order();
        let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
        let (codes, quads, qmax) = quantized_base(&pm, &bytes);
        let mut p = base::encode_traversal(&codes, &quads, qmax).unwrap().payload;
        let streams = symbol_streams(&p);
        for (i, b) in changes {
            let i = streams.start + i.index(streams.len());
            p[i] = [0, 1, 2, 3, 4, 5, 254, 255][b];
        }
        same_as_reference(&p, codes.len() as u32, quads.len() as u32, qmax);
    }
}

/// The coarsener numbers its base in the walk's order, so a coarsened
/// mesh's file holds the traversal layout, and it is smaller there than
/// the deltas (by 15–25 bits per base vertex on real meshes).
#[test]
fn coarsened_bases_are_written_in_the_traversal_layout() {
    let pm = common::coarsened_torus(None);
    let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
    assert_eq!(base_payload(&bytes)[0], base::LAYOUT_TRAVERSAL);
    let (codes, quads, qmax) = quantized_base(&pm, &bytes);
    let z = |b: &[u8]| zstd::bulk::compress(b, 19).unwrap().len();
    let traversal = z(&base::encode_traversal(&codes, &quads, qmax)
        .unwrap()
        .payload);
    let delta = z(&base::encode_delta(&codes, &quads, 4).payload);
    assert!(
        traversal < delta,
        "traversal {traversal} bytes, deltas {delta}"
    );
    let mut dec = decode_all(&bytes, Limits::default()).unwrap();
    common::assert_every_level_down_and_up(&mut dec, &pm);
}

/// The worked example of spec §6.1, byte for byte: two quads side by side.
#[test]
fn the_spec_example_is_these_bytes() {
    let codes = vec![
        [0, 0, 0],
        [10, 0, 0],
        [10, 10, 0],
        [0, 10, 0],
        [20, 0, 0],
        [20, 10, 0],
    ];
    let quads = vec![[0, 1, 2, 3], [1, 4, 5, 2]];
    let expected: Vec<u8> = vec![
        1, // layout
        2, 0, 4, // gates
        6, 0, 0, 0, 0, 0, 0, // corners
        0, // escapes
        18, 0, 0, 0, 20, 0, 0, 0, 20, 0, 5, 8, 0, 20, 0, 0, 8, 8, 0, // pos
    ];
    let p = base::encode_traversal(&codes, &quads, 1023).unwrap();
    assert_eq!(p.payload, expected);
    let st = base::decode(&expected, 6, 2, 1023, 4).unwrap();
    assert_eq!((&st.q[..], &st.quads[..]), (&codes[..], &quads[..]));
}

/// Every truncation of a traversal payload is an error naming the base,
/// and so are trailing bytes, an unknown layout byte and wrong counts.
#[test]
fn truncated_or_padded_traversal_payloads_are_errors() {
    let mut pm = gen(3, 40, 0);
    pm.renumber_base_in_walk_order();
    let bytes = write_to_vec(&pm, &EncodeOptions::default()).unwrap().0;
    let (codes, quads, qmax) = quantized_base(&pm, &bytes);
    let p = base::encode_traversal(&codes, &quads, qmax)
        .unwrap()
        .payload;
    let (nv, nf) = (codes.len() as u32, quads.len() as u32);
    assert!(base::decode(&p, nv, nf, qmax, 4).is_ok());
    for n in 0..p.len() {
        assert!(
            base::decode(&p[..n], nv, nf, qmax, 4).is_err(),
            "prefix {n}"
        );
    }
    let mut longer = p.clone();
    longer.push(0);
    assert!(base::decode(&longer, nv, nf, qmax, 4).is_err());
    let mut unknown = p.clone();
    unknown[0] = 2;
    let e = base::decode(&unknown, nv, nf, qmax, 4).unwrap_err();
    assert!(e.contains("layout 2"), "{e}");
    assert!(base::decode(&p, nv + 1, nf, qmax, 4).is_err());
    assert!(base::decode(&p, nv, nf.saturating_sub(1), qmax, 4).is_err());
    // a 3.x reader reads a delta payload: the layout byte is not its
    assert!(base::decode(&p, nv, nf, qmax, 3).is_err());
}

/// A base the traversal layout cannot hold — a face naming a vertex
/// twice, or a vertex that does not exist — is no traversal payload (the
/// writer keeps the delta layout, whose checks refuse such a base).
#[test]
fn bases_with_bad_faces_have_no_traversal_payload() {
    let codes = vec![[0u32; 3]; 4];
    assert!(base::encode_traversal(&codes, &[[0, 1, 2, 3]], 255).is_some());
    assert!(base::encode_traversal(&codes[..3], &[[0, 1, 1, 2]], 255).is_none());
    assert!(base::encode_traversal(&codes, &[[0, 1, 2, 4]], 255).is_none());
    assert!(base::encode_traversal(&codes[..3], &[[0, 1, 2, 3]], 255).is_none());
}

/// A face that repeats a half-edge of an earlier one (here: the same face
/// twice, as a component start) is refused, as is a vertex in more than
/// 255 faces.
#[test]
fn repeated_half_edges_and_crowded_vertices_are_refused() {
    let codes = vec![[0u32; 3]; 4];
    let quads = vec![[0u32, 1, 2, 3], [0, 1, 2, 3]];
    assert!(base::encode_traversal(&codes, &quads, 255).is_none());
    // by hand: two component starts, the second repeating the first's
    // corners through escapes
    let mut p = vec![base::LAYOUT_TRAVERSAL];
    let gates = [0u8; 4];
    let corners = [0u8, 0, 0, 0, 255, 255, 255, 255];
    let escapes = [3u8, 2, 1, 0];
    let pos = [0u8; 12];
    for part in [&gates[..], &corners[..], &escapes[..], &pos[..]] {
        p.push(part.len() as u8);
        p.extend_from_slice(part);
    }
    let e = base::decode(&p, 4, 2, 255, 4).unwrap_err();
    assert!(e.contains("half-edge"), "{e}");

    // a fan of 256 quads around vertex 0 (each its own component start,
    // sharing only vertex 0): fine for the delta layout, not this one
    let n = 256u32;
    let quads: Vec<[u32; 4]> = (0..n)
        .map(|i| [0, 1 + 3 * i, 2 + 3 * i, 3 + 3 * i])
        .collect();
    let codes = vec![[0u32; 3]; 1 + 3 * n as usize];
    assert!(base::encode_traversal(&codes[..1 + 3 * 255], &quads[..255], 255).is_some());
    assert!(base::encode_traversal(&codes, &quads, 255).is_none());
}

/// A strip of quads around vertex 0, each face coded across the edge it
/// shares with the one before (not as a component start): 255 decode, and
/// the 256th is refused as the reference refuses it.
#[test]
fn a_vertex_crowded_across_edges_is_refused() {
    let strip = |f: usize| {
        // face 0 = [0, 1, 2, 3]; face i + 1 = [0, v, m, w] across face
        // i's half-edge `v → 0` (gate 1 at its k = 3), `m` and `w` new
        let mut gates = vec![0u8, 0, 0, 1];
        for _ in 1..f - 1 {
            gates.extend_from_slice(&[0, 0, 1]);
        }
        let corners = [vec![0u8; 4], vec![0u8; 2 * (f - 1)]].concat();
        let nv = 4 + 2 * (f - 1);
        let mut p = vec![base::LAYOUT_TRAVERSAL];
        for part in [gates, corners, vec![], vec![0u8; 3 * nv]] {
            pqm_format::varint::put_u(&mut p, part.len() as u64);
            p.extend_from_slice(&part);
        }
        (p, nv as u32, f as u32)
    };
    let (p, nv, nf) = strip(255);
    let st = base::decode(&p, nv, nf, 255, 4).unwrap();
    assert!(st.quads[254].contains(&0));
    same_as_reference(&p, nv, nf, 255);
    let (p, nv, nf) = strip(256);
    let e = base::decode(&p, nv, nf, 255, 4).unwrap_err();
    assert!(e.contains("vertex 0 is in more than 255 faces"), "{e}");
    same_as_reference(&p, nv, nf, 255);
}

/// A face coded across an edge whose two other corners are both
/// candidates (`x` from `X`, `y` from `Y`): the one half-edge neither
/// candidate vouches for, `x → y`, is looked up — as the reverse of an
/// earlier `y → x` (which closes it: the walk reads no gate across it)
/// and as a repeat of an earlier `x → y` (an error) — and the two may be
/// one vertex (an error).
#[test]
fn faces_across_two_candidates_look_up_their_middle_half_edge() {
    let payload = |gates: &[u8], corners: &[u8], nv: usize| {
        let mut p = vec![base::LAYOUT_TRAVERSAL];
        for part in [gates, corners, &[], &vec![0u8; 3 * nv][..]] {
            pqm_format::varint::put_u(&mut p, part.len() as u64);
            p.extend_from_slice(part);
        }
        p
    };
    // face 0 = [0, 1, 2, 3] and across its 2 → 3 the same four corners
    // reversed, [3, 2, 1, 0] (x = 1 candidate 1 into 2, y = 0 candidate
    // 1 out of 3): every edge of face 1 is closed, so the walk goes on
    // to a component start, face 2
    let p = payload(&[0, 0, 1], &[0, 0, 0, 0, 1, 1, 0, 0, 0, 0], 8);
    let st = base::decode(&p, 8, 3, 255, 4).unwrap();
    assert_eq!(st.quads, [[0, 1, 2, 3], [3, 2, 1, 0], [4, 5, 6, 7]]);
    same_as_reference(&p, 8, 3, 255);
    // face 1 = [1, 0, 4, 5] across face 0's 0 → 1 holds 1 → 0 first:
    // face 2 = [3, 2, 1, 0] repeats it
    let p = payload(&[1, 0, 1], &[0, 0, 0, 0, 0, 0, 1, 1], 6);
    let e = base::decode(&p, 6, 3, 255, 4).unwrap_err();
    assert!(
        e.contains("face 2: half-edge 1 -> 0 is in two faces"),
        "{e}"
    );
    same_as_reference(&p, 6, 3, 255);
    // face 0 = [0, 1, 2, 3]; across its 0 → 1, face 1 = [1, 0, 2, 4] (2
    // by an escape) holds 0 → 2; across 2 → 3, x = 0 (candidate 2 into
    // 2: after 1) and y = 0 (candidate 1 out of 3): one vertex twice
    let p = {
        let mut p = vec![base::LAYOUT_TRAVERSAL];
        let corners = [0u8, 0, 0, 0, 255, 0, 2, 1];
        for part in [&[1u8, 0, 1][..], &corners, &[1], &[0; 15]] {
            pqm_format::varint::put_u(&mut p, part.len() as u64);
            p.extend_from_slice(part);
        }
        p
    };
    let e = base::decode(&p, 5, 3, 255, 4).unwrap_err();
    assert!(e.contains("face 2 repeats vertex 0"), "{e}");
    same_as_reference(&p, 5, 3, 255);
}
