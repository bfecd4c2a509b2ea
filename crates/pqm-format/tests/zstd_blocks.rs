//! The zstd block layouts of `EncodeOptions::zstd_blocks`: every layout
//! decodes to the same levels, `Auto` never makes a section's frame larger
//! than one block does (it charges each extra block `BLOCK_PENALTY_BYTES`),
//! and `PerPart` really cuts each frame into its parts. The minimum match
//! lengths of `EncodeOptions::zstd_min_match` likewise decode alike, and
//! `Auto` (which tries the level's own among others) never makes a chunk's
//! frame cost more than `Level` does.

use pqm_core::progressive::testgen;
use pqm_format::*;
use proptest::prelude::*;

/// Blocks of the zstd frame `f` (walks its block headers to its end).
fn block_count(f: &[u8]) -> usize {
    let fhd = f[4];
    let single = (fhd >> 5) & 1 == 1;
    let mut p = 5 + usize::from(!single) + [0, 1, 2, 4][usize::from(fhd & 3)];
    p += match fhd >> 6 {
        0 => usize::from(single),
        1 => 2,
        2 => 4,
        _ => 8,
    };
    let mut n = 0;
    loop {
        let bh = u32::from(f[p]) | u32::from(f[p + 1]) << 8 | u32::from(f[p + 2]) << 16;
        n += 1;
        p += 3 + if (bh >> 1) & 3 == 1 {
            1
        } else {
            (bh >> 3) as usize
        };
        if bh & 1 == 1 {
            break;
        }
    }
    assert_eq!(p, f.len(), "the frame ends with its last block");
    n
}

/// The base frame and every chunk frame of a file, with the chunk table.
fn sections(bytes: &[u8]) -> (Vec<&[u8]>, Vec<ChunkInfo>) {
    let dec = decode_all(bytes, Limits::default()).unwrap();
    let h = dec.header().unwrap().clone();
    let chunks = dec.chunks().to_vec();
    let base_at = h.header_len as usize + h.chunk_count as usize * h.chunk_entry_len as usize + 4;
    let mut out = vec![&bytes[base_at..base_at + h.base_compressed_len as usize]];
    for c in &chunks {
        out.push(&bytes[c.offset as usize..c.offset as usize + c.compressed_len as usize]);
    }
    (out, chunks)
}

/// The first of levels `0..=records` at which the files do not decode to
/// the same positions and quads, if any.
fn first_level_unlike(files: &[&[u8]], records: usize) -> Option<usize> {
    let mut ds: Vec<Decoder> = files
        .iter()
        .map(|b| decode_all(b, Limits::default()).unwrap())
        .collect();
    (0..=records).find(|&k| {
        let got: Vec<_> = ds
            .iter_mut()
            .map(|d| {
                d.set_level(Target::Level(k)).unwrap();
                (d.positions().to_vec(), d.quads().to_vec())
            })
            .collect();
        got.iter().any(|g| *g != got[0])
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn block_layouts_decode_alike_and_auto_never_grows_a_section(
        seed in any::<u64>(),
        splits in 1usize..200,
        chunk_records in 1usize..60,
        edge_splits in 0usize..10,
    ) {
        let mut pm = testgen::generate(seed, splits);
        vectors::add_edge_splits(&mut pm, edge_splits, seed);
        let enc = |zstd_blocks| {
            let opts = EncodeOptions { chunk_records: Some(chunk_records), zstd_blocks, ..Default::default() };
            write_to_vec(&pm, &opts).unwrap().0
        };
        let single = enc(ZstdBlocks::Single);
        let auto = enc(ZstdBlocks::Auto);
        let per_part = enc(ZstdBlocks::PerPart);
        let (s_sec, s_chunks) = sections(&single);
        let (a_sec, a_chunks) = sections(&auto);
        let (p_sec, p_chunks) = sections(&per_part);
        prop_assert_eq!(s_sec.len(), a_sec.len());
        for ((s, a), p) in s_sec.iter().zip(&a_sec).zip(&p_sec) {
            // generated payloads are far below zstd's 128 KiB block size
            prop_assert_eq!(block_count(s), 1);
            prop_assert!(
                a.len() + BLOCK_PENALTY_BYTES * (block_count(a) - 1) <= s.len(),
                "auto {} bytes in {} blocks vs one block {}", a.len(), block_count(a), s.len()
            );
            prop_assert!(block_count(p) >= block_count(a));
        }
        // per part: the base in layout byte and corners | codes (delta
        // layout) or gates | corners | escapes | positions (traversal
        // layout, spec §6.1), every chunk with at least ops | conn | refs
        // (each non-empty here: every chunk has records)
        let layout = zstd::stream::decode_all(p_sec[0]).unwrap()[0];
        prop_assert_eq!(block_count(p_sec[0]), if layout == base::LAYOUT_TRAVERSAL { 4 } else { 2 });
        for p in &p_sec[1..] {
            prop_assert!(block_count(p) >= 3);
        }
        // the same chunks (records, counts, errors) and the same levels
        for (x, y) in s_chunks.iter().zip(&a_chunks).chain(s_chunks.iter().zip(&p_chunks)) {
            prop_assert_eq!(
                (x.record_count, x.vertex_count, x.face_count, x.uncompressed_len, x.error.to_bits()),
                (y.record_count, y.vertex_count, y.face_count, y.uncompressed_len, y.error.to_bits())
            );
        }
        if let Some(k) = first_level_unlike(&[&single, &auto, &per_part], pm.records.len()) {
            prop_assert!(false, "level {}", k);
        }
    }
}

/// A chunk frame's cost in the writer's choice: its bytes plus
/// `BLOCK_PENALTY_BYTES` per block past the first.
fn cost(f: &[u8]) -> usize {
    f.len() + BLOCK_PENALTY_BYTES * (block_count(f) - 1)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn min_match_choices_decode_alike_and_auto_never_costs_more(
        seed in any::<u64>(),
        splits in 1usize..300,
        chunk_records in 1usize..80,
        edge_splits in 0usize..10,
        fixed in 3u32..=7,
    ) {
        let mut pm = testgen::generate(seed, splits);
        vectors::add_edge_splits(&mut pm, edge_splits, seed);
        let enc = |zstd_min_match| {
            let opts = EncodeOptions { chunk_records: Some(chunk_records), zstd_min_match, ..Default::default() };
            write_to_vec(&pm, &opts).unwrap().0
        };
        let files = [
            enc(ZstdMinMatch::Level),
            enc(ZstdMinMatch::Auto),
            enc(ZstdMinMatch::Fixed(fixed)),
        ];
        let (l_sec, l_chunks) = sections(&files[0]);
        let (a_sec, a_chunks) = sections(&files[1]);
        prop_assert_eq!(l_chunks.len(), a_chunks.len());
        for (l, a) in l_sec[1..].iter().zip(&a_sec[1..]) {
            prop_assert!(cost(a) <= cost(l), "auto costs {} against {}", cost(a), cost(l));
        }
        let files: Vec<&[u8]> = files.iter().map(Vec::as_slice).collect();
        if let Some(k) = first_level_unlike(&files, pm.records.len()) {
            prop_assert!(false, "level {}", k);
        }
    }
}
