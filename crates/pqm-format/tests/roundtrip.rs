//! Round trips: generated progressive meshes → `.pqm` → push decoder, at
//! every level, with random push sizes, random level walks, truncations and
//! corruptions.

mod common;

use common::{header_len, patch_header};
use glam::DVec3;
use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_core::ProgressiveMesh;
use pqm_format::*;
use proptest::prelude::*;

fn encode(pm: &ProgressiveMesh, opts: &EncodeOptions) -> Vec<u8> {
    write_to_vec(pm, opts).expect("encode").0
}

/// The grid every file must use (spec §5): the bounding box of every
/// position, for the cube grid with every axis as long as the longest.
fn expected_quantizer(pm: &ProgressiveMesh, bits: u8, grid: Grid) -> Quantizer {
    let mut all: Vec<DVec3> = pm.base.positions.clone();
    for r in &pm.records {
        all.extend(&r.new_vertices);
        all.extend(r.moved.iter().map(|m| m.1));
    }
    let lo = all.iter().fold(DVec3::INFINITY, |a, p| a.min(*p));
    let hi = all.iter().fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
    let hi = match grid {
        Grid::Box => hi,
        Grid::Cube => hi.max(lo + DVec3::splat((hi - lo).max_element())),
    };
    Quantizer::new(lo.to_array(), hi.to_array(), bits)
}

/// Asserts that the decoder's current level equals `pm.level(k)` with
/// quantized positions: indices exactly, positions bit for bit.
fn assert_level(dec: &Decoder, pm: &ProgressiveMesh, q: &Quantizer, k: usize) {
    assert_eq!(dec.level(), k);
    let (pos, quads) = pm.level_quads(k);
    assert_eq!(dec.quads(), &quads[..], "quads at level {k}");
    let want: Vec<DVec3> = pos
        .iter()
        .map(|p| q.dequantize_vec(q.quantize(*p)))
        .collect();
    let got = dec.positions_f64();
    assert_eq!(got.len(), want.len(), "vertex count at level {k}");
    for (i, (a, b)) in got.iter().zip(&want).enumerate() {
        assert!(
            a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits),
            "vertex {i} at level {k}: {a} vs {b}"
        );
    }
    let f32s: Vec<[f32; 3]> = want
        .iter()
        .map(|p| p.to_array().map(|x| x as f32))
        .collect();
    assert_eq!(dec.positions(), &f32s[..]);
}

fn push_in_pieces(bytes: &[u8], sizes: &[usize]) -> (Decoder, Vec<Event>) {
    let mut dec = Decoder::new(Limits::default());
    let mut events = Vec::new();
    let mut at = 0;
    let mut i = 0;
    while at < bytes.len() {
        let n = sizes
            .get(i % sizes.len().max(1))
            .copied()
            .unwrap_or(1)
            .max(1)
            .min(bytes.len() - at);
        events.extend(dec.push(&bytes[at..at + n]).expect("push"));
        at += n;
        i += 1;
    }
    (dec, events)
}

/// Simulated GPU buffers updated only through `Change` events.
struct Shadow {
    pos: Vec<[f32; 3]>,
    tris: Vec<u32>,
}

impl Shadow {
    fn apply(&mut self, dec: &Decoder, c: &Change) {
        let pos = dec.positions();
        self.pos.truncate(c.vertices_removed.start as usize);
        for r in c.moved_ranges() {
            for v in r {
                self.pos[v as usize] = pos[v as usize];
            }
        }
        for v in c.vertices_appended.clone() {
            assert_eq!(v as usize, self.pos.len());
            self.pos.push(pos[v as usize]);
        }
        self.tris.truncate(6 * c.faces_truncated.start as usize);
        for r in c.rewritten_ranges() {
            for f in r {
                self.tris[6 * f as usize..6 * f as usize + 6]
                    .copy_from_slice(&quad_triangles(dec.quads()[f as usize]));
            }
        }
        for f in c.faces_appended.clone() {
            assert_eq!(6 * f as usize, self.tris.len());
            self.tris.extend(quad_triangles(dec.quads()[f as usize]));
        }
    }
}

fn opts_strategy() -> impl Strategy<Value = EncodeOptions> {
    (
        8u8..=24,
        prop::option::of(1usize..40),
        64usize..4096,
        any::<bool>(),
        1i32..20,
        any::<bool>(),
        any::<bool>(),
        1u16..=4,
        any::<bool>(),
        0usize..3,
        any::<bool>(),
        prop::sample::select(vec![0.0, 0.1, 0.5, 3.0]),
    )
        .prop_map(
            |(
                bits,
                chunk_records,
                chunk_bytes,
                split_form,
                zstd_level,
                local_form,
                face_split_form,
                version_major,
                edge_split_form,
                blocks,
                cube,
                chunk_growth,
            )| {
                EncodeOptions {
                    bits,
                    chunk_records,
                    chunk_bytes,
                    chunk_growth,
                    zstd_level,
                    split_form,
                    local_form,
                    face_split_form,
                    edge_split_form,
                    version_major,
                    zstd_blocks: [ZstdBlocks::Single, ZstdBlocks::Auto, ZstdBlocks::PerPart]
                        [blocks],
                    grid: if cube { Grid::Cube } else { Grid::Box },
                    ..EncodeOptions::default()
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn every_level_decodes_to_the_quantized_reference(
        seed in any::<u64>(),
        splits in 0usize..150,
        opts in opts_strategy(),
        sizes in prop::collection::vec(1usize..300, 1..8),
        rotate in any::<bool>(),
        face_splits in 0usize..40,
        edge_splits in 0usize..12,
    ) {
        let mut pm = testgen::generate(seed, splits);
        if rotate {
            pqm_format::vectors::rotate_rewritten(&mut pm);
        }
        pqm_format::vectors::add_face_splits(&mut pm, face_splits, seed);
        pqm_format::vectors::add_edge_splits(&mut pm, edge_splits, seed);
        let (bytes, report) = write_to_vec(&pm, &opts).unwrap();
        // Every edge split (the only records with 4 new vertices here) is
        // coded in the edge-split form whenever the options allow it (no
        // earlier form applies to 4 new vertices); never below version 3.
        let edge = pm.records.iter().filter(|r| is_edge_split(r)).count();
        if opts.edge_split_form && opts.version_major >= 3 {
            prop_assert_eq!(report.edge_split_records, edge);
        } else {
            prop_assert_eq!(report.edge_split_records, 0);
        }
        // Every pure face split (the only `Doublet` records here) is coded
        // in the face-split form whenever the options allow it and the
        // split form (tried first, spec §7.9) does not apply; never in a
        // 1.x file.
        let pure = pm.records.iter().filter(|r| is_pure_face_split(r)).count();
        let doublet = report.per_op[pqm_core::OpKind::Doublet as usize].forms;
        if opts.face_split_form && opts.version_major >= 2 {
            let compact = doublet[3] + if opts.split_form { doublet[1] } else { 0 };
            prop_assert_eq!(compact, pure);
        } else {
            prop_assert_eq!(report.face_split_records, 0);
        }
        prop_assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), opts.version_major);
        let (mut dec, events) = push_in_pieces(&bytes, &sizes);
        prop_assert_eq!(events.last(), Some(&Event::Finished));
        let q = expected_quantizer(&pm, opts.bits, opts.grid);
        prop_assert_eq!(dec.quantizer(), Some(q));
        // The 3.2 bounds: with the cube grid (major 3), exactly the box of
        // the dequantized positions of every level; else none.
        let want_bounds = (opts.grid == Grid::Cube && opts.version_major >= 3).then(|| {
            let mut b = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
            let all = pm.base.positions.iter().chain(
                pm.records.iter().flat_map(|r| r.new_vertices.iter().chain(r.moved.iter().map(|m| &m.1))),
            );
            for p in all {
                let d = q.dequantize(q.quantize(*p));
                for k in 0..3 {
                    b[0][k] = b[0][k].min(d[k]);
                    b[1][k] = b[1][k].max(d[k]);
                }
            }
            b
        });
        prop_assert_eq!(dec.header().unwrap().bounds, want_bounds);
        prop_assert_eq!(header_len(&bytes), if want_bounds.is_some() { 168 } else { 120 });
        prop_assert_eq!(dec.bounds(), Some(want_bounds.unwrap_or([q.min, q.max])));
        for k in 0..=pm.records.len() {
            dec.set_level(Target::Level(k)).unwrap();
            assert_level(&dec, &pm, &q, k);
        }
        if !pm.vertex_order.is_empty() {
            prop_assert_eq!(dec.vertex_order().unwrap(), Some(&pm.vertex_order[..]));
        }
    }

    #[test]
    fn random_walks_match_direct_decoding_and_change_events(
        seed in any::<u64>(),
        walk in prop::collection::vec(0usize..200, 1..12),
        split_form in any::<bool>(),
        local_form in any::<bool>(),
        version_major in 1u16..=4,
    ) {
        let mut pm = testgen::generate(seed, 120);
        pqm_format::vectors::add_face_splits(&mut pm, 30, seed);
        pqm_format::vectors::add_edge_splits(&mut pm, 10, seed);
        let opts = EncodeOptions { chunk_records: Some(17), split_form, local_form, version_major, ..EncodeOptions::default() };
        let bytes = encode(&pm, &opts);
        let mut dec = decode_all(&bytes, Limits::default()).unwrap();
        let q = expected_quantizer(&pm, opts.bits, opts.grid);
        let mut shadow = Shadow { pos: dec.positions().to_vec(), tris: dec.triangle_indices() };
        for &t in &walk {
            let k = t.min(pm.records.len());
            let before = dec.level();
            let c = dec.set_level(Target::Level(k)).unwrap();
            prop_assert_eq!((c.from_level, c.to_level), (before, k));
            assert_level(&dec, &pm, &q, k);
            shadow.apply(&dec, &c);
            prop_assert_eq!(&shadow.pos[..], dec.positions());
            prop_assert_eq!(&shadow.tris, &dec.triangle_indices());
        }
    }

    #[test]
    fn corrupted_or_truncated_input_never_panics(
        seed in any::<u64>(),
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..4),
        cut in any::<prop::sample::Index>(),
        split in any::<prop::sample::Index>(),
    ) {
        let mut pm = testgen::generate(seed, 60);
        pqm_format::vectors::add_face_splits(&mut pm, 20, seed);
        let mut bytes = encode(&pm, &EncodeOptions { chunk_records: Some(9), ..EncodeOptions::default() });
        for (i, x) in &flips {
            let i = i.index(bytes.len());
            bytes[i] ^= x | 1;
        }
        bytes.truncate(cut.index(bytes.len() + 1));
        let at = split.index(bytes.len() + 1);
        let mut dec = Decoder::new(Limits::default());
        let a = dec.push(&bytes[..at]);
        let b = a.and_then(|_| dec.push(&bytes[at..]));
        let _ = dec.status();
        if b.is_ok() {
            if let Ok(c) = dec.set_level(Target::Level(usize::MAX)) {
                prop_assert_eq!(c.to_level, dec.deepest_level().unwrap());
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// A forward-only decoder and a general one, fed the same pieces (of a
    /// file that may be corrupted) and refined to the deepest level after
    /// some pushes, agree on every push result, every `Change`, every
    /// level and the status; the forward-only one refuses any other level
    /// with a parameter error (and stays usable), and keeps no records.
    #[test]
    fn forward_only_matches_the_general_decoder(
        seed in any::<u64>(),
        sizes in prop::collection::vec(1usize..400, 1..6),
        refine_every in 1usize..4,
        flip in prop::option::of((any::<prop::sample::Index>(), any::<u8>())),
        version_major in 1u16..=4,
        detour in any::<prop::sample::Index>(),
    ) {
        let mut pm = testgen::generate(seed, 120);
        pqm_format::vectors::add_face_splits(&mut pm, 30, seed);
        pqm_format::vectors::add_edge_splits(&mut pm, 10, seed);
        let opts = EncodeOptions { chunk_records: Some(11), version_major, ..EncodeOptions::default() };
        let mut bytes = encode(&pm, &opts);
        if let Some((i, x)) = flip {
            // In the second half: most flips hit a chunk (rolled back).
            let i = bytes.len() / 2 + i.index(bytes.len() / 2);
            bytes[i] ^= x | 1;
        }
        let mut general = Decoder::new(Limits::default());
        let mut forward = Decoder::forward_only(Limits::default());
        let (mut at, mut i) = (0usize, 0usize);
        while at < bytes.len() {
            let n = sizes[i % sizes.len()].min(bytes.len() - at);
            let a = general.push(&bytes[at..at + n]);
            let b = forward.push(&bytes[at..at + n]);
            prop_assert_eq!(format!("{a:?}"), format!("{b:?}"));
            at += n;
            i += 1;
            if i % refine_every == 0 || at == bytes.len() {
                let Some(deepest) = general.deepest_level() else { continue };
                let ca = general.refine_to(Target::Level(usize::MAX)).unwrap();
                let cb = forward.refine_to(Target::Level(usize::MAX)).unwrap();
                prop_assert_eq!(&ca, &cb);
                prop_assert_eq!(forward.level(), deepest);
                prop_assert_eq!(general.quads(), forward.quads());
                prop_assert_eq!(general.position_codes(), forward.position_codes());
                prop_assert_eq!(general.positions(), forward.positions());
                // Any other level is refused, and nothing changes.
                let k = detour.index(deepest + 1);
                if k != deepest {
                    let e = forward.set_level(Target::Level(k)).unwrap_err();
                    prop_assert!(matches!(e, DecodeError::Parameter(_)), "{e}");
                    prop_assert_eq!(forward.level(), deepest);
                }
                prop_assert!(forward.coarsen_to(Target::Level(deepest)).unwrap().is_empty());
            }
        }
        prop_assert_eq!(general.status(), forward.status());
        prop_assert!(forward.to_progressive_mesh().is_none());
        if flip.is_none() {
            prop_assert_eq!(forward.level(), pm.records.len());
            let q = expected_quantizer(&pm, opts.bits, opts.grid);
            assert_level(&forward, &pm, &q, pm.records.len());
        }
    }
}

/// The mesh of the streaming tests: 150 records with face splits and edge
/// splits mixed in.
fn streamed_mesh(seed: u64) -> ProgressiveMesh {
    let mut pm = testgen::generate(seed, 150);
    pqm_format::vectors::add_face_splits(&mut pm, 20, seed);
    pqm_format::vectors::add_edge_splits(&mut pm, 10, seed);
    pm
}

/// Levels below the deepest one while the file streams in: a replay there
/// uses the records' new codes and quads, which the decoder unwinds from
/// the frontier on the first such replay and again for the chunks decoded
/// after it (`Records::kept`); a refinement to the deepest level takes the
/// frontier's. Every level equals the reference, every `Change` keeps a
/// shadow of the buffers equal, and `to_progressive_mesh` rebuilds the
/// same levels at any point.
#[test]
fn replays_below_the_deepest_level_while_streaming() {
    for seed in 0..8u64 {
        let pm = streamed_mesh(seed);
        let opts = EncodeOptions {
            chunk_records: Some(13),
            ..EncodeOptions::default()
        };
        let bytes = encode(&pm, &opts);
        let q = expected_quantizer(&pm, opts.bits, opts.grid);
        let mut dec = Decoder::new(Limits::default());
        let mut shadow: Option<Shadow> = None;
        let mut rng = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut next = move |n: usize| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % n as u64) as usize
        };
        let step = 1 + seed as usize * 97 % 400;
        for at in (0..bytes.len()).step_by(step) {
            dec.push(&bytes[at..(at + step).min(bytes.len())]).unwrap();
            let Some(deepest) = dec.deepest_level() else {
                continue;
            };
            let sh = shadow.get_or_insert_with(|| Shadow {
                pos: dec.positions().to_vec(),
                tris: dec.triangle_indices(),
            });
            for k in [next(deepest + 1), next(deepest + 1), deepest] {
                let c = dec.set_level(Target::Level(k)).unwrap();
                assert_level(&dec, &pm, &q, k);
                sh.apply(&dec, &c);
                assert_eq!(&sh.pos[..], dec.positions(), "seed {seed} level {k}");
                assert_eq!(sh.tris, dec.triangle_indices(), "seed {seed} level {k}");
            }
            if next(4) == 0 {
                let back = dec.to_progressive_mesh().unwrap();
                assert_eq!(back.records.len(), deepest);
                for k in [0, deepest / 2, deepest] {
                    assert_eq!(back.level_quads(k).1, pm.level_quads(k).1, "seed {seed}");
                }
            }
        }
        assert!(dec.status().finished);
    }
}

/// A general decoder keeps no undo logs until a move other than a
/// refinement to the deepest level needs them: it streams as a forward-only
/// one does (refinements take the ids of each chunk's dropped log and the
/// frontier's values), then decodes the chunks again for the logs on the
/// first such move, at a random point of the stream (also after a chunk
/// that failed and was rolled back). Every level equals the reference and
/// every `Change` keeps a shadow of the buffers equal, before and after.
#[test]
fn undo_logs_are_rebuilt_on_the_first_move_below_the_deepest_level() {
    for seed in 0..12u64 {
        let pm = streamed_mesh(seed);
        let opts = EncodeOptions {
            chunk_records: Some(7 + seed as usize % 5),
            ..EncodeOptions::default()
        };
        let mut bytes = encode(&pm, &opts);
        if seed % 3 == 2 {
            // A flip in the second half: most hit a chunk (rolled back).
            let i = bytes.len() / 2 + (seed as usize * 7919) % (bytes.len() / 2);
            bytes[i] ^= 0x5a;
        }
        let q = expected_quantizer(&pm, opts.bits, opts.grid);
        let mut dec = Decoder::new(Limits::default());
        // Seeds 1, 5, 9 ask for the logs before any byte (written while
        // decoding), seeds 3, 7, 11 at a push of their own (decoded again
        // then), the others leave it to the first move below the deepest.
        let ask_logs_at = match seed % 4 {
            1 => Some(0),
            3 => Some(seed as usize * 13),
            _ => None,
        };
        let mut shadow: Option<Shadow> = None;
        let step = 1 + seed as usize * 61 % 300;
        // The push after which the decoder first leaves the deepest level.
        let pushes = bytes.len().div_ceil(step);
        let first_detour = (seed as usize * 31) % (pushes + 1);
        let mut failed = false;
        for (n, at) in (0..bytes.len()).step_by(step).enumerate() {
            if Some(n) == ask_logs_at.map(|p| p % pushes) {
                dec.keep_undo_logs().unwrap();
            }
            if dec.push(&bytes[at..(at + step).min(bytes.len())]).is_err() {
                failed = true;
            }
            let Some(deepest) = dec.deepest_level() else {
                continue;
            };
            let sh = shadow.get_or_insert_with(|| Shadow {
                pos: dec.positions().to_vec(),
                tris: dec.triangle_indices(),
            });
            let mut targets = vec![deepest];
            if n >= first_detour || failed {
                targets = vec![(n * 7 + seed as usize) % (deepest + 1), deepest];
            }
            for k in targets {
                let c = dec.set_level(Target::Level(k)).unwrap();
                assert_level(&dec, &pm, &q, k);
                sh.apply(&dec, &c);
                assert_eq!(&sh.pos[..], dec.positions(), "seed {seed} level {k}");
                assert_eq!(sh.tris, dec.triangle_indices(), "seed {seed} level {k}");
            }
            if failed {
                break;
            }
        }
        assert_eq!(dec.status().finished, !failed, "seed {seed}");
        let deepest = dec.deepest_level().unwrap();
        let back = dec.to_progressive_mesh().unwrap();
        assert_eq!(back.records.len(), deepest);
        for k in [0, deepest / 2, deepest] {
            assert_eq!(back.level_quads(k).1, pm.level_quads(k).1, "seed {seed}");
        }
    }
    // A forward-only decoder has no undo data to keep.
    let mut fwd = Decoder::forward_only(Limits::default());
    assert!(matches!(
        fwd.keep_undo_logs(),
        Err(DecodeError::Parameter(_))
    ));
}

#[test]
fn one_byte_at_a_time_equals_all_at_once() {
    for seed in 0..6 {
        let pm = testgen::generate(seed, 80);
        let bytes = encode(
            &pm,
            &EncodeOptions {
                chunk_records: Some(10),
                ..EncodeOptions::default()
            },
        );
        let (mut whole, ev_whole) = push_in_pieces(&bytes, &[bytes.len()]);
        let (mut single, ev_single) = push_in_pieces(&bytes, &[1]);
        assert_eq!(ev_whole, ev_single);
        assert_eq!(whole.status(), single.status());
        for k in [0, pm.records.len() / 3, pm.records.len()] {
            whole.set_level(Target::Level(k)).unwrap();
            single.set_level(Target::Level(k)).unwrap();
            assert_eq!(whole.quads(), single.quads());
            assert_eq!(whole.position_codes(), single.position_codes());
        }
    }
}

#[test]
fn every_prefix_yields_the_deepest_complete_level() {
    let pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Grid { nx: 3, ny: 3 },
        ..GenOptions::new(11, 25)
    });
    let opts = EncodeOptions {
        chunk_records: Some(6),
        ..EncodeOptions::default()
    };
    check_every_prefix(&pm, &opts);
    // Again with rotated faces, so that most records use the local form.
    let mut pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Box { n: 2 },
        ..GenOptions::new(12, 120)
    });
    pqm_format::vectors::rotate_rewritten(&mut pm);
    let opts = EncodeOptions {
        chunk_records: Some(20),
        ..EncodeOptions::default()
    };
    let (_, r) = write_to_vec(&pm, &opts).unwrap();
    assert!(
        r.local_records > pm.records.len() / 2,
        "{} local of {}",
        r.local_records,
        pm.records.len()
    );
    check_every_prefix(&pm, &opts);
    // Again with face splits (form 3) after the vertex splits.
    let mut pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Grid { nx: 2, ny: 3 },
        ..GenOptions::new(13, 10)
    });
    pqm_format::vectors::add_face_splits(&mut pm, 25, 13);
    let opts = EncodeOptions {
        chunk_records: Some(7),
        split_form: false,
        ..EncodeOptions::default()
    };
    let (_, r) = write_to_vec(&pm, &opts).unwrap();
    assert!(r.face_split_records >= 15, "{r:?}");
    check_every_prefix(&pm, &opts); // Again with edge splits (form 4) after the vertex splits.
    let mut pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Box { n: 2 },
        ..GenOptions::new(14, 10)
    });
    pqm_format::vectors::add_edge_splits(&mut pm, 12, 14);
    let opts = EncodeOptions {
        chunk_records: Some(5),
        ..EncodeOptions::default()
    };
    let (_, r) = write_to_vec(&pm, &opts).unwrap();
    assert_eq!(r.edge_split_records, 12, "{r:?}");
    check_every_prefix(&pm, &opts);
}

/// Whether `r` came from `vectors::add_edge_splits` (the generator's other
/// records have at most 2 new vertices).
fn is_edge_split(r: &pqm_core::SplitRecord) -> bool {
    r.new_vertices.len() == 4 && r.appended_faces.len() == 4 && r.moved.is_empty()
}

/// Whether `r` is exactly the inverse of a doublet removal (spec §7.9): one
/// new vertex, no move, one rewritten and one appended quad that together
/// are a quad `(m, p, o, q)` of the level before cut along `m–o` by the new
/// vertex. (Checked from the record alone: the two quads share `m`, `c`,
/// `o` and each has one other corner.)
fn is_pure_face_split(r: &pqm_core::SplitRecord) -> bool {
    if r.new_vertices.len() != 1
        || !r.moved.is_empty()
        || r.rewritten.len() != 1
        || r.appended_faces.len() != 1
    {
        return false;
    }
    let (x, y) = (r.rewritten[0].1, r.appended_faces[0]);
    let shared = x.iter().filter(|v| y.contains(v)).count();
    shared == 3
}

/// Every prefix of `pm` encoded with `opts` yields exactly the levels whose
/// chunks are complete.
fn check_every_prefix(pm: &ProgressiveMesh, opts: &EncodeOptions) {
    let bytes = encode(pm, opts);
    let full = decode_all(&bytes, Limits::default()).unwrap();
    let q = full.quantizer().unwrap();
    // Level reached after each chunk, and where each chunk ends.
    let ends: Vec<(u64, usize)> = full
        .chunks()
        .iter()
        .scan(0usize, |lvl, c| {
            *lvl += c.record_count as usize;
            Some((c.offset + c.compressed_len as u64, *lvl))
        })
        .collect();
    let h = full.header().unwrap();
    let base_end =
        h.header_len as u64 + full.chunks().len() as u64 * 36 + 4 + h.base_compressed_len as u64;
    for n in 0..=bytes.len() {
        let mut dec = Decoder::new(Limits::default());
        dec.push(&bytes[..n])
            .unwrap_or_else(|e| panic!("prefix {n}: {e}"));
        let s = dec.status();
        assert_eq!(s.bytes_consumed + s.bytes_buffered, n as u64);
        let expect = if (n as u64) < base_end {
            None
        } else {
            Some(
                ends.iter()
                    .filter(|(end, _)| *end <= n as u64)
                    .map(|e| e.1)
                    .max()
                    .unwrap_or(0),
            )
        };
        assert_eq!(s.deepest_level, expect, "prefix {n}");
        assert_eq!(s.finished, n == bytes.len());
        if let Some(k) = expect {
            dec.refine_to(Target::Level(usize::MAX)).unwrap();
            assert_level(&dec, pm, &q, k);
            if n < bytes.len() {
                assert!(
                    s.waiting_for.is_some() && s.bytes_needed.is_some_and(|b| b > 0),
                    "prefix {n}: {s:?}"
                );
            }
        } else {
            assert!(dec.refine_to(Target::Level(1)).is_err());
        }
    }
    assert!(matches!(
        decode_all(&bytes[..bytes.len() - 1], Limits::default()),
        Err(DecodeError::Format(FormatError::Truncated(_)))
    ));
}

#[test]
fn crc_mismatch_names_the_chunk() {
    let pm = testgen::generate(3, 100);
    let bytes = encode(
        &pm,
        &EncodeOptions {
            chunk_records: Some(20),
            ..EncodeOptions::default()
        },
    );
    let full = decode_all(&bytes, Limits::default()).unwrap();
    for (i, c) in full.chunks().iter().enumerate() {
        let mut bad = bytes.clone();
        bad[(c.offset + c.compressed_len as u64 / 2) as usize] ^= 0x40;
        let mut dec = Decoder::new(Limits::default());
        match dec.push(&bad) {
            Err(DecodeError::Format(FormatError::CrcMismatch { section, .. })) => {
                assert_eq!(section, Section::Chunk(i as u32))
            }
            other => panic!("chunk {i}: {other:?}"),
        }
        // Everything before the damaged chunk is still usable.
        assert_eq!(
            dec.deepest_level(),
            Some(
                full.chunks()[..i]
                    .iter()
                    .map(|c| c.record_count as usize)
                    .sum()
            )
        );
        assert!(dec.push(&[]).is_err(), "a failed decoder stays failed");
    }
    let mut bad = bytes.clone();
    bad[30] ^= 1;
    assert!(matches!(
        Decoder::new(Limits::default()).push(&bad),
        Err(DecodeError::Format(FormatError::CrcMismatch {
            section: Section::Header,
            ..
        }))
    ));
    bad = bytes.clone();
    bad[0] = b'X';
    assert!(matches!(
        Decoder::new(Limits::default()).push(&bad),
        Err(DecodeError::Format(FormatError::BadMagic))
    ));
}

/// Spec §3: the 3.2 bounds are read only with flag bit 2, which needs a
/// 168-byte header and finite, ordered values.
#[test]
fn header_bounds_are_checked() {
    let pm = testgen::generate(9, 40);
    let cube = encode(&pm, &EncodeOptions::default());
    let boxed = encode(
        &pm,
        &EncodeOptions {
            grid: Grid::Box,
            ..EncodeOptions::default()
        },
    );
    let refused = |b: &[u8], what: &str| match Decoder::new(Limits::default()).push(b) {
        Err(DecodeError::Format(FormatError::Invalid {
            section: Section::Header,
            message,
        })) => assert!(message.contains(what), "{message}"),
        other => panic!("{what}: {other:?}"),
    };
    // The flag on a 120-byte header.
    let mut b = boxed.clone();
    patch_header(&mut b, |h| h[16] |= 4);
    refused(&b, "flag bit 2");
    // A NaN, an infinity, a reversed axis.
    for (at, value, what) in [
        (116 + 8, f64::NAN, "bounds axis 1"),
        (140 + 16, f64::INFINITY, "bounds axis 2"),
        (140, -1e300, "bounds axis 0"),
    ] {
        let mut b = cube.clone();
        patch_header(&mut b, |h| {
            h[at..at + 8].copy_from_slice(&value.to_le_bytes())
        });
        refused(&b, what);
    }
    // Without the flag the same 168 bytes are a newer minor's: ignored, and
    // the grid is the bounding volume.
    let mut b = cube.clone();
    patch_header(&mut b, |h| h[16] &= !4);
    let dec = decode_all(&b, Limits::default()).unwrap();
    let h = dec.header().unwrap();
    assert_eq!(h.bounds, None);
    assert_eq!(dec.bounds(), Some([h.bbox_min, h.bbox_max]));
    let mut want = decode_all(&cube, Limits::default()).unwrap();
    let mut got = dec;
    want.set_level(Target::Level(usize::MAX)).unwrap();
    got.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(got.position_codes(), want.position_codes());
    // Both grids decode the same mesh, within half a step of the cube grid.
    let mut d = decode_all(&boxed, Limits::default()).unwrap();
    d.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(d.quads(), want.quads());
    let half = 0.5 * want.quantizer().unwrap().step()[0] * (1.0 + 1e-9);
    for (a, c) in d.positions_f64().iter().zip(want.positions_f64()) {
        assert!((*a - c).abs().max_element() <= 2.0 * half, "{a} vs {c}");
    }
}

/// Spec §5: the cube grid has one step on every axis (that of the largest
/// extent), and on a flat mesh it codes smaller than the box grid, which
/// spends more bits on the short axes.
#[test]
fn the_cube_grid_has_one_step_and_codes_flat_meshes_smaller() {
    let mut pm = testgen::generate(21, 300);
    pqm_format::vectors::stretch(&mut pm, [1.0, 0.25, 0.125], [3.0, -2.0, 0.5]);
    let size = |grid| {
        let opts = EncodeOptions {
            grid,
            ..EncodeOptions::default()
        };
        let bytes = encode(&pm, &opts);
        let dec = decode_all(&bytes, Limits::default()).unwrap();
        (bytes.len(), dec.quantizer().unwrap().step())
    };
    let (cube, s) = size(Grid::Cube);
    let (boxed, t) = size(Grid::Box);
    for k in 0..3 {
        assert!((s[k] - s[0]).abs() <= 1e-12 * s[0], "{s:?}");
        assert!(t[k] <= s[k] * (1.0 + 1e-12), "{t:?} vs {s:?}");
    }
    assert!(
        t[2] < 0.2 * s[2],
        "the box grid is finer on the short axis: {t:?}"
    );
    assert!(cube < boxed, "cube {cube} bytes, box {boxed}");
}

#[test]
fn versioning_newer_minor_is_read_newer_major_is_refused() {
    let pm = testgen::generate(5, 40);
    let bytes = encode(&pm, &EncodeOptions::default());
    let reference = decode_all(&bytes, Limits::default()).unwrap();

    // Newer major: clear error.
    let mut b = bytes.clone();
    patch_header(&mut b, |h| h[8..10].copy_from_slice(&5u16.to_le_bytes()));
    match Decoder::new(Limits::default()).push(&b) {
        Err(DecodeError::Format(FormatError::UnsupportedVersion { major: 5, .. })) => {}
        other => panic!("{other:?}"),
    }
    // Major 0 does not exist.
    let mut b = bytes.clone();
    patch_header(&mut b, |h| h[8..10].copy_from_slice(&0u16.to_le_bytes()));
    assert!(matches!(
        Decoder::new(Limits::default()).push(&b),
        Err(DecodeError::Format(FormatError::UnsupportedVersion {
            major: 0,
            ..
        }))
    ));
    // The writer writes 4.0 (the default; with the cube grid's bounds,
    // minor 0 all the same), and on request 3.2 with the bounds, 3.1 with
    // a VNBR section (the mesh has a vertex order) and the box grid, 3.0
    // where VORD is the smaller (the default picks), 2.0 or 1.1; all read
    // back to the same levels.
    assert_eq!(&bytes[8..12], &[4, 0, 0, 0]);
    assert_eq!(header_len(&bytes), 168);
    let v3 = encode(
        &pm,
        &EncodeOptions {
            version_major: 3,
            ..EncodeOptions::default()
        },
    );
    assert_eq!(&v3[8..12], &[3, 0, 2, 0]);
    assert_eq!(header_len(&v3), 168);
    let boxed = |vertex_order_code| EncodeOptions {
        vertex_order_code,
        grid: Grid::Box,
        version_major: 3,
        ..EncodeOptions::default()
    };
    let vnbr4 = encode(
        &pm,
        &EncodeOptions {
            vertex_order_code: VertexOrderCode::Neighbours,
            grid: Grid::Box,
            ..EncodeOptions::default()
        },
    );
    assert_eq!(&vnbr4[8..12], &[4, 0, 0, 0]);
    assert_eq!(header_len(&vnbr4), 120);
    let vnbr = encode(&pm, &boxed(VertexOrderCode::Neighbours));
    assert_eq!(&vnbr[8..12], &[3, 0, 1, 0]);
    assert_eq!(header_len(&vnbr), 120);
    let smaller = encode(&pm, &boxed(VertexOrderCode::Smaller));
    assert!(smaller[8..12] == [3, 0, 1, 0] || smaller[8..12] == [3, 0, 0, 0]);
    assert!(smaller.len() <= vnbr.len());
    let vord = encode(&pm, &boxed(VertexOrderCode::Deltas));
    assert_eq!(&vord[8..12], &[3, 0, 0, 0]);
    let v2 = encode(
        &pm,
        &EncodeOptions {
            version_major: 2,
            ..EncodeOptions::default()
        },
    );
    assert_eq!(&v2[8..12], &[2, 0, 0, 0]);
    let mut d = decode_all(&v2, Limits::default()).unwrap();
    d.set_level(Target::Level(usize::MAX)).unwrap();
    let mut d3 = decode_all(&bytes, Limits::default()).unwrap();
    d3.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(d.quads(), d3.quads());
    assert_eq!(d.position_codes(), d3.position_codes());
    let v1 = encode(
        &pm,
        &EncodeOptions {
            version_major: 1,
            ..EncodeOptions::default()
        },
    );
    assert_eq!(&v1[8..12], &[1, 0, 1, 0]);
    let mut d1 = decode_all(&v1, Limits::default()).unwrap();
    let mut d2 = decode_all(&bytes, Limits::default()).unwrap();
    d1.set_level(Target::Level(usize::MAX)).unwrap();
    d2.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(d1.quads(), d2.quads());
    assert_eq!(d1.position_codes(), d2.position_codes());
    let mut d3 = decode_all(&v3, Limits::default()).unwrap();
    d3.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(d1.quads(), d3.quads());
    assert_eq!(d1.position_codes(), d3.position_codes());
    assert!(write_to_vec(
        &pm,
        &EncodeOptions {
            version_major: 5,
            ..EncodeOptions::default()
        }
    )
    .is_err());

    // Newer minor: a longer header, longer chunk entries, an unknown section.
    let hl = header_len(&bytes);
    let h = Header::parse(&bytes[..hl]);
    let extra_h = 8usize;
    let extra_e = 4usize;
    let n = h.chunk_count as usize;
    let shift = (extra_h + n * extra_e) as u64;
    let mut out = bytes[..hl - 4].to_vec();
    out[10..12].copy_from_slice(&7u16.to_le_bytes());
    out[12..16].copy_from_slice(&((hl + extra_h) as u32).to_le_bytes());
    out[22..24].copy_from_slice(&(36 + extra_e as u16).to_le_bytes());
    out[48..52].copy_from_slice(&(h.section_count + 1).to_le_bytes());
    out.extend_from_slice(&[0xEE; 8]);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    let mut table = Vec::new();
    for c in reference.chunks() {
        let mut e = c.clone();
        e.offset += shift;
        table.extend_from_slice(&e.to_bytes());
        table.extend_from_slice(&[0xAB; 4]);
    }
    let tcrc = crc32fast::hash(&table);
    out.extend_from_slice(&table);
    out.extend_from_slice(&tcrc.to_le_bytes());
    out.extend_from_slice(&bytes[hl + n * 36 + 4..]);
    let payload = b"future data";
    out.extend_from_slice(b"XTRA");
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
    out.extend_from_slice(payload);
    let mut dec = Decoder::new(Limits::default());
    let events = dec.push(&out).unwrap();
    assert!(events.contains(&Event::SectionReady(*b"XTRA")));
    assert_eq!(events.last(), Some(&Event::Finished));
    let mut r = reference;
    r.set_level(Target::Level(usize::MAX)).unwrap();
    dec.set_level(Target::Level(usize::MAX)).unwrap();
    assert_eq!(dec.quads(), r.quads());
    assert_eq!(dec.position_codes(), r.position_codes());
    assert_eq!(dec.vertex_order().unwrap(), r.vertex_order().unwrap());
}

#[test]
fn limits_are_checked_from_the_header_before_allocating() {
    let pm = testgen::generate(8, 100);
    let bytes = encode(&pm, &EncodeOptions::default());
    let n = pm.final_vertex_count() as u32;
    for limits in [
        Limits {
            max_vertices: n - 1,
            ..Limits::default()
        },
        Limits {
            max_faces: pm.final_face_count() as u32 - 1,
            ..Limits::default()
        },
        Limits {
            max_memory_bytes: 1000,
            ..Limits::default()
        },
    ] {
        let mut dec = Decoder::new(limits);
        assert!(
            matches!(
                dec.push(&bytes[..header_len(&bytes)]),
                Err(DecodeError::LimitsExceeded(_))
            ),
            "{limits:?}"
        );
    }
    // A header claiming 4 billion vertices is refused by the default limits.
    let mut b = bytes.clone();
    patch_header(&mut b, |h| {
        h[32..36].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    assert!(matches!(
        Decoder::new(Limits::default()).push(&b),
        Err(DecodeError::LimitsExceeded(_))
    ));
}

#[test]
fn targets_by_faces_and_error() {
    let pm = testgen::generate(21, 200);
    let bytes = encode(
        &pm,
        &EncodeOptions {
            chunk_records: Some(25),
            ..EncodeOptions::default()
        },
    );
    let mut dec = decode_all(&bytes, Limits::default()).unwrap();
    let budget = pm.base.face_count() + 57;
    dec.set_level(Target::Faces(budget)).unwrap();
    assert!(dec.quads().len() <= budget);
    let (_, next_f) = dec.level_counts(dec.level() + 1).unwrap();
    assert!(
        next_f as usize > budget,
        "the finest level within the budget"
    );
    // Error targets land on chunk boundaries with error <= e.
    for c in dec.chunks().to_vec() {
        dec.set_level(Target::Error(c.error as f64)).unwrap();
        let k = dec.level();
        let reached = dec.chunks().iter().scan(0, |l, c| {
            *l += c.record_count as usize;
            Some((*l, c.error))
        });
        let e = reached
            .filter(|(l, _)| *l == k)
            .map(|x| x.1)
            .next()
            .unwrap_or(dec.header().unwrap().base_error);
        assert!(e <= c.error);
    }
    dec.set_level(Target::Error(0.0)).unwrap();
    assert_eq!(dec.level(), pm.records.len());
    // refine_to never coarsens, coarsen_to never refines.
    dec.set_level(Target::Level(50)).unwrap();
    assert!(dec.refine_to(Target::Level(10)).unwrap().is_empty());
    assert!(dec.coarsen_to(Target::Level(90)).unwrap().is_empty());
    assert_eq!(dec.level(), 50);
}

#[test]
fn to_progressive_mesh_round_trips_connectivity() {
    let pm = testgen::generate(2, 90);
    let bytes = encode(&pm, &EncodeOptions::default());
    let dec = decode_all(&bytes, Limits::default()).unwrap();
    let back = dec.to_progressive_mesh().unwrap();
    back.validate().unwrap();
    assert_eq!(back.records.len(), pm.records.len());
    for k in [0, 45, pm.records.len()] {
        assert_eq!(back.level_quads(k).1, pm.level_quads(k).1);
    }
    assert_eq!(back.vertex_order, pm.vertex_order);
    // Re-encoding the decoded mesh keeps every code (dequantized positions
    // lie on the grid; the stored bbox max may differ by an ulp).
    let mut again =
        decode_all(&encode(&back, &EncodeOptions::default()), Limits::default()).unwrap();
    let mut first = dec;
    first.set_level(Target::Level(usize::MAX)).unwrap();
    again.set_level(Target::Level(usize::MAX)).unwrap();
    assert!(again.position_codes() == first.position_codes());
    assert!(again.quads() == first.quads());
}

#[test]
fn split_form_covers_generated_splits_and_is_smaller() {
    let pm = testgen::generate(9, 2000);
    let (a, ra) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
    let (b, rb) = write_to_vec(
        &pm,
        &EncodeOptions {
            split_form: false,
            ..EncodeOptions::default()
        },
    )
    .unwrap();
    let splits = pm
        .records
        .iter()
        .filter(|r| r.op == pqm_core::OpKind::QvMerge)
        .count();
    assert_eq!(
        ra.split_records, splits,
        "every single split uses the split form"
    );
    assert_eq!(rb.split_records, 0);
    assert!(
        a.len() < b.len(),
        "split form {} vs general {}",
        a.len(),
        b.len()
    );
    assert!(ra.bits_per_vertex.connectivity < rb.bits_per_vertex.connectivity);
}

#[test]
fn local_form_is_used_and_never_larger() {
    // The generator's fused steps and smoothing touch random far-apart
    // places (the general form's case); its splits with a moved second
    // vertex fit the local form. Real coarsener records are local (see the
    // `streams` example): there nearly all records use it.
    let mut pm = testgen::generate(21, 3000);
    pqm_format::vectors::rotate_rewritten(&mut pm);
    let (a, ra) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
    let (b, rb) = write_to_vec(
        &pm,
        &EncodeOptions {
            local_form: false,
            ..EncodeOptions::default()
        },
    )
    .unwrap();
    assert_eq!(rb.local_records, 0);
    let n = pm.records.len();
    assert_eq!(ra.general_records + ra.split_records + ra.local_records, n);
    assert!(ra.split_records > 0 && ra.local_records > 0 && ra.general_records > 0);
    assert!(
        a.len() <= b.len(),
        "with local form {} vs without {}",
        a.len(),
        b.len()
    );
    let mut dec = decode_all(&a, Limits::default()).unwrap();
    let q = expected_quantizer(&pm, 14, Grid::Cube);
    for k in [n / 2, n] {
        dec.set_level(Target::Level(k)).unwrap();
        assert_level(&dec, &pm, &q, k);
    }
}

#[test]
fn per_op_stats_add_up_to_the_report() {
    let mut pm = testgen::generate(33, 800);
    pqm_format::vectors::rotate_rewritten(&mut pm);
    let (_, r) = write_to_vec(
        &pm,
        &EncodeOptions {
            chunk_bytes: 2048,
            ..EncodeOptions::default()
        },
    )
    .unwrap();
    let ops = &r.per_op;
    assert_eq!(
        ops.iter().map(|o| o.records).sum::<usize>(),
        pm.records.len()
    );
    for o in ops {
        assert_eq!(o.forms.iter().sum::<usize>(), o.records);
    }
    assert_eq!(
        ops.iter().map(|o| o.forms[0]).sum::<usize>(),
        r.general_records
    );
    assert_eq!(
        ops.iter().map(|o| o.forms[1]).sum::<usize>(),
        r.split_records
    );
    assert_eq!(
        ops.iter().map(|o| o.forms[2]).sum::<usize>(),
        r.local_records
    );
    let new: u64 = ops.iter().map(|o| o.new).sum();
    assert_eq!(new, r.refined_vertices);
    for t in 0..5 {
        let raw: u64 = ops.iter().map(|o| o.raw_bytes[t]).sum();
        assert_eq!(raw, r.stream_raw_bytes[t]);
        let bytes: f64 = ops.iter().map(|o| o.bytes[t]).sum();
        assert!((bytes - r.stream_bytes[t]).abs() < 1e-6 * r.stream_bytes[t].max(1.0));
    }
    let app: u64 = ops.iter().map(|o| o.appended).sum();
    assert_eq!(app as usize, pm.final_face_count() - pm.base.face_count());
}

/// A one-record chunk payload from raw streams.
fn payload(ops: &[u8], conn: &[u64], refs: &[i64], slots: &[u64], pos: &[i64]) -> [Vec<u8>; 5] {
    use pqm_format::varint::{put_s, put_u};
    let mut s: [Vec<u8>; 5] = Default::default();
    s[0] = ops.to_vec();
    conn.iter().for_each(|&x| put_u(&mut s[1], x));
    refs.iter().for_each(|&x| put_s(&mut s[2], x));
    slots.iter().for_each(|&x| put_u(&mut s[3], x));
    pos.iter().for_each(|&x| put_s(&mut s[4], x));
    s
}

#[test]
fn hostile_local_form_records_are_rejected() {
    use pqm_format::codec::{decode_record, Cursors, MeshState};
    use pqm_format::varint::Reader;
    // A 2×2 grid of quads: vertex 4 is interior (4 faces).
    let q: Vec<[u32; 3]> = (0..9).map(|i| [i % 3 * 10, i / 3 * 10, 0]).collect();
    let quads = vec![[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]];
    let st = MeshState::new((1 << 14) - 1, q, quads);
    let local = st.local(4).unwrap();
    assert_eq!(local.faces, vec![0, 1, 2, 3]);
    assert_eq!(local.verts, (0..9).collect::<Vec<u32>>());
    let run = |s: [Vec<u8>; 5]| {
        let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
        decode_record(&st, &mut rd, &mut Cursors::default(), 20, 20, 2)
    };
    let sym = 0x08 | 1; // local form, qeMerge
                        // Valid: move vertex 4 by (1, 0, 0).
    let ok = run(payload(&[sym], &[0, 1, 0, 0], &[4], &[4], &[1, 0, 0])).unwrap();
    assert_eq!(ok.moved, vec![(4, [11, 10, 0])]);
    // Anchor beyond the vertices.
    let e = run(payload(&[sym], &[0, 0, 0, 0], &[9], &[], &[])).unwrap_err();
    assert!(e.contains("anchor"), "{e}");
    // More moved vertices than the neighbourhood holds (bounded before any
    // allocation by |U| = 9).
    let e = run(payload(&[sym], &[0, 10, 0, 0], &[4], &[], &[])).unwrap_err();
    assert!(e.contains("moved vertex count"), "{e}");
    // Local index outside the neighbourhood.
    let e = run(payload(&[sym], &[0, 1, 0, 0], &[4], &[9], &[0, 0, 0])).unwrap_err();
    assert!(e.contains("local index 9"), "{e}");
    // Rewritten face index outside the 4 faces; gap overflow.
    let e = run(payload(&[sym], &[0, 0, 2, 0], &[4], &[1, u64::MAX], &[])).unwrap_err();
    assert!(e.contains("local index"), "{e}");
    // Explicit corner beyond the neighbourhood.
    let e = run(payload(&[sym], &[0, 0, 1, 0, 1, 0], &[4], &[0, 9], &[])).unwrap_err();
    assert!(e.contains("local corner index"), "{e}");
    // Split-form bits on a local-form symbol.
    let e = run(payload(&[sym | 0x40], &[0, 0, 0, 0], &[4], &[], &[])).unwrap_err();
    assert!(e.contains("split-form bits"), "{e}");
    // An isolated vertex has no neighbourhood.
    let st2 = MeshState::new((1 << 14) - 1, vec![[0, 0, 0]; 5], vec![[0, 1, 2, 3]]);
    let mut s = payload(&[sym], &[0, 0, 0, 0], &[4], &[], &[]);
    let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let e = decode_record(&st2, &mut rd, &mut Cursors::default(), 20, 20, 2).unwrap_err();
    assert!(e.contains("no face"), "{e}");
    // A fan of 300 faces around one vertex: refused (more than 255).
    let big = fan_of_300();
    s = payload(&[sym], &[0, 0, 0, 0], &[0], &[], &[]);
    rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let e = decode_record(&big, &mut rd, &mut Cursors::default(), 20_000, 20_000, 2).unwrap_err();
    assert!(e.contains("more than 255"), "{e}");
}

#[test]
fn face_split_records_decode_and_hostile_ones_are_rejected() {
    use pqm_format::codec::{decode_record, Cursors, MeshState};
    use pqm_format::varint::Reader;
    // The 2×2 grid again: vertex 4 is interior, in slots 0..4.
    let q: Vec<[u32; 3]> = (0..9).map(|i| [i % 3 * 10, i / 3 * 10, 0]).collect();
    let quads = vec![[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]];
    let st = MeshState::new((1 << 14) - 1, q, quads);
    let run = |s: [Vec<u8>; 5], max_v: u32, max_f: u32, major: u16| {
        let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
        decode_record(&st, &mut rd, &mut Cursors::default(), max_v, max_f, major)
    };
    let sym = (3 << 2) | 2; // face split, doublet
                            // Slot 0 = (0, 1, 4, 3) cut along 4–0 by vertex 9: halves (4, 3, 0, 9)
                            // and (4, 9, 0, 1). Both parallelograms around 9 average to the
                            // quad's centre (5, 5, 0).
    let r = run(payload(&[sym], &[0], &[4], &[], &[1, -2, 0]), 20, 20, 2).unwrap();
    assert_eq!(r.op, pqm_core::OpKind::Doublet);
    assert_eq!(r.rewritten, vec![(0, [4, 3, 0, 9])]);
    assert_eq!(r.appended, vec![[4, 9, 0, 1]]);
    assert_eq!(r.new_pos, vec![[6, 3, 0]]);
    assert!(r.moved.is_empty());
    // The same in a 1.x file: version-1 prediction (first quad only, the
    // appended one: 4 + 0 − 1 = (0, 10, 0)) — but form 3 does not exist there.
    let e = run(payload(&[sym], &[0], &[4], &[], &[0, 0, 0]), 20, 20, 1).unwrap_err();
    assert!(e.contains("form 3") && e.contains("version 1"), "{e}");
    // Swap and rotations: slot 2 = (3, 4, 7, 6), x = 2·2 + 1: X = B =
    // (4, 9, 6, 3) rotated by 1, Y = A = (4, 7, 6, 9) rotated by 3.
    let rs = sym | (1 << 4) | (3 << 6);
    let r = run(payload(&[rs], &[5], &[4], &[], &[0, 0, 0]), 20, 20, 2).unwrap();
    assert_eq!(r.rewritten, vec![(2, [9, 6, 3, 4])]);
    assert_eq!(r.appended, vec![[9, 4, 7, 6]]);
    assert_eq!(r.new_pos, vec![[5, 15, 0]]);
    // Index t out of range (|S| = 4, so x ≤ 7).
    let e = run(payload(&[sym], &[8], &[4], &[], &[0, 0, 0]), 20, 20, 2).unwrap_err();
    assert!(e.contains("face-split index"), "{e}");
    // Anchor outside the vertices.
    let e = run(payload(&[sym], &[0], &[9], &[], &[0, 0, 0]), 20, 20, 2).unwrap_err();
    assert!(e.contains("face split references vertex 9"), "{e}");
    // V = VF and NF = FF.
    let e = run(payload(&[sym], &[0], &[4], &[], &[0, 0, 0]), 9, 20, 2).unwrap_err();
    assert!(e.contains("exceeds"), "{e}");
    let e = run(payload(&[sym], &[0], &[4], &[], &[0, 0, 0]), 20, 4, 2).unwrap_err();
    assert!(e.contains("exceeds"), "{e}");
    // A residual leaving the grid.
    let e = run(payload(&[sym], &[0], &[4], &[], &[-6, 0, 0]), 20, 20, 2).unwrap_err();
    assert!(e.contains("outside the grid"), "{e}");
    // Truncated streams.
    assert!(run(payload(&[sym], &[], &[4], &[], &[]), 20, 20, 2).is_err());
    assert!(run(payload(&[sym], &[0], &[4], &[], &[0, 0]), 20, 20, 2).is_err());
    // |S| = 0: an isolated vertex.
    let st2 = MeshState::new((1 << 14) - 1, vec![[0, 0, 0]; 5], vec![[0, 1, 2, 3]]);
    let s = payload(&[sym], &[0], &[4], &[], &[0, 0, 0]);
    let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let e = decode_record(&st2, &mut rd, &mut Cursors::default(), 20, 20, 2).unwrap_err();
    assert!(e.contains("0 faces"), "{e}");
    // A fan of 300 faces: refused.
    let big = fan_of_300();
    let s = payload(&[sym], &[0], &[0], &[], &[0, 0, 0]);
    let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&s[k], "s"));
    let e = decode_record(&big, &mut rd, &mut Cursors::default(), 20_000, 20_000, 2).unwrap_err();
    assert!(e.contains("more than 255"), "{e}");
}

#[test]
fn a_1x_file_with_a_face_split_record_names_that_record() {
    // Only face splits, none moving a vertex: every record is form 3.
    let mut pm = testgen::generate(21, 0);
    pqm_format::vectors::add_face_splits(&mut pm, 12, 21);
    for r in &mut pm.records {
        r.moved.clear();
    }
    // a 3.0 file: its base section is what 1.x readers read (4.0 adds a
    // layout byte, spec §6)
    let opts = EncodeOptions {
        chunk_records: Some(4),
        split_form: false,
        version_major: 3,
        ..EncodeOptions::default()
    };
    let (mut bytes, report) = write_to_vec(&pm, &opts).unwrap();
    assert_eq!(report.face_split_records, 12);
    patch_header(&mut bytes, |h| h[8..12].copy_from_slice(&[1, 0, 1, 0]));
    let mut dec = Decoder::new(Limits::default());
    match dec.push(&bytes) {
        Err(DecodeError::Format(
            e @ FormatError::BadRecord {
                chunk: 0,
                record: 0,
                ..
            },
        )) => {
            let msg = e.to_string();
            assert!(msg.contains("record 0") && msg.contains("form 3"), "{msg}");
        }
        other => panic!("{other:?}"),
    }
    // The base mesh is still there.
    assert_eq!(dec.deepest_level(), Some(0));
    assert_eq!(dec.quads().len(), pm.base.face_count());
}

#[test]
fn face_split_form_shrinks_face_splits() {
    // The same records three ways: 2.0 with the face-split form, 2.0
    // without it (the split form off in both: it would take many of them,
    // spec §7.9), 1.1. The face-split form's connectivity must be clearly
    // smaller than the local/general coding of the same records. (Its
    // prediction is checked exactly in
    // `face_split_records_decode_and_hostile_ones_are_rejected`: random
    // jitter around centroids of ever thinner quads says nothing about it.)
    let mut pm = testgen::generate(31, 40);
    pqm_format::vectors::add_face_splits(&mut pm, 400, 31);
    let enc = |o: EncodeOptions| write_to_vec(&pm, &o).unwrap().1;
    let no_split = EncodeOptions {
        split_form: false,
        ..EncodeOptions::default()
    };
    let v2 = enc(no_split.clone());
    let no_fs = enc(EncodeOptions {
        face_split_form: false,
        ..no_split.clone()
    });
    let v1 = enc(EncodeOptions {
        version_major: 1,
        ..no_split.clone()
    });
    assert!(v2.face_split_records > 250, "{v2:?}");
    assert_eq!(no_fs.face_split_records + v1.face_split_records, 0);
    // Connectivity bytes of the face splits (the `Doublet` records).
    let conn = |r: &EncodeReport| -> f64 { r.per_op[2].bytes[..4].iter().sum() };
    assert!(
        conn(&v2) < 0.85 * conn(&no_fs),
        "{} vs {}",
        conn(&v2),
        conn(&no_fs)
    );
}

#[test]
fn empty_and_record_free_meshes() {
    let mut pm = testgen::generate(4, 0);
    pm.level_error = vec![0.0];
    let bytes = encode(&pm, &EncodeOptions::default());
    let dec = decode_all(&bytes, Limits::default()).unwrap();
    assert_eq!(dec.deepest_level(), Some(0));
    assert_eq!(dec.quads().len(), pm.base.face_count());
    let empty = ProgressiveMesh {
        base: pqm_core::IndexedMesh::new(),
        ..Default::default()
    };
    let bytes = encode(&empty, &EncodeOptions::default());
    let dec = decode_all(&bytes, Limits::default()).unwrap();
    assert!(dec.quads().is_empty() && dec.positions().is_empty());
    // no positions, no bounds to store (a 4.0 file all the same)
    assert_eq!(dec.header().unwrap().bounds, None);
    assert_eq!(&bytes[8..12], &[4, 0, 0, 0]);
}

/// Rebuilds `bytes` with chunk `i`'s uncompressed payload changed by `f`
/// (recompressed, table and CRCs fixed), so the damage reaches the record
/// decoder instead of being caught by a CRC.
fn repack_chunk(bytes: &[u8], i: usize, f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    repack_chunk_with(bytes, i, f, |p| zstd::bulk::compress(p, 3).unwrap())
}

/// [`repack_chunk`] with the compressed bytes made by `z` from the payload.
fn repack_chunk_with(
    bytes: &[u8],
    i: usize,
    f: impl FnOnce(&mut Vec<u8>),
    z: impl FnOnce(&[u8]) -> Vec<u8>,
) -> Vec<u8> {
    let hl = header_len(bytes);
    let h = Header::parse(&bytes[..hl]);
    let n = h.chunk_count as usize;
    let table_end = hl + n * 36 + 4;
    let mut chunks: Vec<ChunkInfo> = (0..n)
        .map(|c| ChunkInfo::parse(&bytes[hl + c * 36..]))
        .collect();
    let body = |c: &ChunkInfo| {
        bytes[c.offset as usize..(c.offset + c.compressed_len as u64) as usize].to_vec()
    };
    let mut bodies: Vec<Vec<u8>> = chunks.iter().map(body).collect();
    let tail_start = (chunks[n - 1].offset + chunks[n - 1].compressed_len as u64) as usize;
    let mut payload =
        zstd::bulk::decompress(&bodies[i], chunks[i].uncompressed_len as usize).unwrap();
    f(&mut payload);
    bodies[i] = z(&payload);
    chunks[i].uncompressed_len = payload.len() as u32;
    chunks[i].compressed_len = bodies[i].len() as u32;
    chunks[i].crc32 = crc32fast::hash(&bodies[i]);
    let mut off = chunks[0].offset;
    let mut out = bytes[..hl].to_vec();
    let mut table = Vec::new();
    for c in chunks.iter_mut() {
        c.offset = off;
        off += c.compressed_len as u64;
        table.extend_from_slice(&c.to_bytes());
    }
    out.extend_from_slice(&table);
    out.extend_from_slice(&crc32fast::hash(&table).to_le_bytes());
    out.extend_from_slice(&bytes[table_end..chunks[0].offset as usize]);
    for b in &bodies {
        out.extend_from_slice(b);
    }
    out.extend_from_slice(&bytes[tail_start..]);
    out
}

#[test]
fn bad_record_errors_name_the_record() {
    let pm = testgen::generate(12, 60);
    let opts = EncodeOptions {
        chunk_records: Some(20),
        ..EncodeOptions::default()
    };
    let bytes = encode(&pm, &opts);
    // Unchanged repack decodes (checks the helper itself).
    let same = repack_chunk(&bytes, 1, |_| {});
    decode_all(&same, Limits::default()).unwrap();
    // Make the first record of chunk 1 reference a far-away vertex: its refs
    // stream starts with the anchor delta; replace it by a huge svarint.
    let bad = repack_chunk(&bytes, 1, |p| {
        let mut r = pqm_format::varint::Reader::new(p, "t");
        let mut lens = Vec::new();
        let mut starts = Vec::new();
        for _ in 0..5 {
            let n = r.u().unwrap() as usize;
            starts.push(p.len() - r.remaining());
            lens.push(n);
            r.bytes(n).unwrap();
        }
        let refs_start = starts[2];
        // Rebuild the payload with a new first refs value (vertex 10^6).
        let mut rd = pqm_format::varint::Reader::new(&p[refs_start..refs_start + lens[2]], "refs");
        rd.s().unwrap();
        let rest = rd.bytes(rd.remaining()).unwrap().to_vec();
        let mut refs = Vec::new();
        pqm_format::varint::put_s(&mut refs, 1_000_000);
        refs.extend_from_slice(&rest);
        let mut out = Vec::new();
        for k in 0..5 {
            let s: &[u8] = if k == 2 {
                &refs
            } else {
                &p[starts[k]..starts[k] + lens[k]]
            };
            pqm_format::varint::put_u(&mut out, s.len() as u64);
            out.extend_from_slice(s);
        }
        *p = out;
    });
    let mut dec = Decoder::new(Limits::default());
    match dec.push(&bad) {
        Err(DecodeError::Format(FormatError::BadRecord {
            chunk: 1,
            record: 20,
            message,
        })) => {
            assert!(message.contains("1000000"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(dec.deepest_level(), Some(20));
}

/// Chunk `c` of `bytes` with the symbol of its record `k` made invalid
/// (form bits 0 with bits 4–7 = 2: no form, spec §7.3), re-CRC'd: records before `k`
/// decode, record `k` fails.
fn break_record(bytes: &[u8], c: usize, k: usize) -> Vec<u8> {
    use pqm_format::codec::{join_streams, split_streams};
    repack_chunk(bytes, c, |p| {
        let mut s: [Vec<u8>; 5] = split_streams(p)
            .unwrap()
            .map(|mut r| r.bytes(r.remaining()).unwrap().to_vec());
        s[0][k] = 0x20;
        *p = join_streams(&s);
    })
}

#[test]
fn a_failing_record_discards_its_whole_chunk() {
    let pm = testgen::generate(12, 60);
    let opts = EncodeOptions {
        chunk_records: Some(20),
        ..EncodeOptions::default()
    };
    let bytes = encode(&pm, &opts);
    let q = expected_quantizer(&pm, opts.bits, opts.grid);
    for (chunk, record, level) in [(0usize, 1usize, 0usize), (1, 7, 20)] {
        let bad = break_record(&bytes, chunk, record);
        let mut dec = Decoder::new(Limits::default());
        match dec.push(&bad) {
            Err(DecodeError::Format(FormatError::BadRecord {
                chunk: c,
                record: r,
                message,
            })) => {
                assert_eq!((c as usize, r as usize), (chunk, level + record));
                assert!(message.contains("unknown record form"), "{message}");
            }
            other => panic!("{other:?}"),
        }
        // Only whole chunks count: the records decoded before the bad one
        // in the same chunk are not available.
        assert_eq!(dec.deepest_level(), Some(level));
        assert_eq!(dec.status().chunks_ready, chunk as u32);
        assert_eq!(dec.resolve(Target::Level(usize::MAX)).unwrap(), level);
        // The frontier was rolled back too: rebuilding from it gives the
        // reference levels 0..=level exactly.
        let back = dec.to_progressive_mesh().unwrap();
        assert_eq!(back.records.len(), level);
        for k in [0, level] {
            assert_eq!(back.level_quads(k).1, pm.level_quads(k).1, "level {k}");
            let codes = |p: &[DVec3]| p.iter().map(|x| q.quantize(*x)).collect::<Vec<_>>();
            assert_eq!(
                codes(&back.level_quads(k).0),
                codes(&pm.level_quads(k).0),
                "level {k}"
            );
        }
        dec.set_level(Target::Level(usize::MAX)).unwrap();
        assert_level(&dec, &pm, &q, level);
        // A move below it decodes the committed chunks again for the undo
        // logs (the failed chunk's bytes are not among them).
        dec.set_level(Target::Level(level / 2)).unwrap();
        assert_level(&dec, &pm, &q, level / 2);
        dec.set_level(Target::Level(usize::MAX)).unwrap();
        assert_level(&dec, &pm, &q, level);
    }
}

/// Offset of the first optional section (right after the last chunk).
fn sections_start(bytes: &[u8]) -> usize {
    let dec = decode_all(bytes, Limits::default()).unwrap();
    let c = dec.chunks().last().unwrap();
    (c.offset + c.compressed_len as u64) as usize
}

/// Options writing the 3.0 `VORD` section (the default writes 3.1's
/// `VNBR`, tested in `tests/vertex_order.rs`).
fn vord_opts() -> EncodeOptions {
    EncodeOptions {
        vertex_order_code: VertexOrderCode::Deltas,
        ..EncodeOptions::default()
    }
}

#[test]
fn vord_length_is_bounded_before_allocating() {
    let pm = testgen::generate(9, 80);
    let bytes = encode(&pm, &vord_opts());
    let n = pm.final_vertex_count() as u32;
    assert!(n > 0 && !pm.vertex_order.is_empty());
    let at = sections_start(&bytes);
    assert_eq!(&bytes[at..at + 4], b"VORD");
    let ulen = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
    assert!((n..=10 * n).contains(&ulen));
    // The section header is not under a CRC: only the bound stops these.
    for claim in [u32::MAX, 10 * n + 1, n - 1] {
        let mut b = bytes.clone();
        b[at + 8..at + 12].copy_from_slice(&claim.to_le_bytes());
        match Decoder::new(Limits::none()).push(&b) {
            Err(DecodeError::Format(FormatError::Invalid {
                section: Section::Optional(0),
                message,
            })) => assert!(message.contains("uncompressed length"), "{message}"),
            other => panic!("claim {claim}: {other:?}"),
        }
    }
    // Within the bound, the VORD buffer counts against the memory budget:
    // a budget that fits everything before it refuses the section.
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
    assert!(matches!(d.push(&bytes), Err(DecodeError::LimitsExceeded(m)) if m.contains("VORD")));
    assert_eq!(
        d.status().chunks_ready,
        h.chunk_count,
        "every chunk still decoded"
    );
    let mut d = Decoder::new(Limits {
        max_memory_bytes: before + 20 * ulen as u64 + 5 * n as u64,
        ..Limits::default()
    });
    d.push(&bytes).unwrap();
    assert!(d.status().finished);
}

#[test]
fn vord_flag_must_match_the_section() {
    let pm = testgen::generate(10, 50);
    let with = encode(&pm, &vord_opts());
    let without = encode(
        &pm,
        &EncodeOptions {
            vertex_order: false,
            ..EncodeOptions::default()
        },
    );
    assert_eq!(Header::parse(&with).flags & 1, 1);
    assert_eq!(Header::parse(&without).flags & 1, 0);
    decode_all(&without, Limits::default()).unwrap();
    // Section without the flag.
    let mut b = with.clone();
    patch_header(&mut b, |h| h[16..20].copy_from_slice(&0u32.to_le_bytes()));
    match Decoder::new(Limits::default()).push(&b) {
        Err(DecodeError::Format(FormatError::Invalid {
            section: Section::Optional(0),
            message,
        })) => assert!(message.contains("flag"), "{message}"),
        other => panic!("{other:?}"),
    }
    // Flag without the section: known only at the end of the file.
    let mut b = without.clone();
    patch_header(&mut b, |h| h[16..20].copy_from_slice(&1u32.to_le_bytes()));
    let mut dec = Decoder::new(Limits::default());
    let last = b.len() - 1;
    dec.push(&b[..last]).unwrap();
    match dec.push(&b[last..]) {
        Err(DecodeError::Format(FormatError::Invalid {
            section: Section::Trailer,
            message,
        })) => assert!(message.contains("flag"), "{message}"),
        other => panic!("{other:?}"),
    }
    // Two VORD sections.
    let at = sections_start(&with);
    let mut b = with.clone();
    patch_header(&mut b, |h| h[48..52].copy_from_slice(&2u32.to_le_bytes()));
    b.extend_from_slice(&with[at..]);
    match Decoder::new(Limits::default()).push(&b) {
        Err(DecodeError::Format(FormatError::Invalid {
            section: Section::Optional(1),
            ..
        })) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_compressed_section_is_exactly_one_frame_with_its_size() {
    let pm = testgen::generate(11, 60);
    let opts = EncodeOptions {
        chunk_records: Some(20),
        ..EncodeOptions::default()
    };
    let bytes = encode(&pm, &opts);
    fn frame(p: &[u8], size_flag: bool) -> Vec<u8> {
        use zstd::zstd_safe::CParameter;
        let mut c = zstd::bulk::Compressor::new(3).unwrap();
        c.set_parameter(CParameter::ContentSizeFlag(size_flag))
            .unwrap();
        c.compress(p).unwrap()
    }
    // The helper itself makes valid files.
    decode_all(
        &repack_chunk_with(&bytes, 1, |_| {}, |p| frame(p, true)),
        Limits::default(),
    )
    .unwrap();
    type Compress = Box<dyn Fn(&[u8]) -> Vec<u8>>;
    let cases: [(&str, Compress); 6] = [
        (
            "content checksum",
            Box::new(|p| {
                use zstd::zstd_safe::CParameter;
                let mut c = zstd::bulk::Compressor::new(3).unwrap();
                c.set_parameter(CParameter::ChecksumFlag(true)).unwrap();
                c.compress(p).unwrap()
            }),
        ),
        (
            "after the zstd frame",
            Box::new(|p| [frame(p, true), frame(&[], true)].concat()),
        ),
        (
            "after the zstd frame",
            Box::new(|p| [frame(p, true), vec![0, 0, 0]].concat()),
        ),
        ("lacks the content size", Box::new(|p| frame(p, false))),
        (
            // Two frames whose sizes add up to the stated length: zstd alone
            // would decode them as one payload.
            "after the zstd frame",
            Box::new(|p| {
                let h = p.len() / 2;
                [frame(&p[..h], true), frame(&p[h..], true)].concat()
            }),
        ),
        (
            "zstd frame holds",
            Box::new(|p| frame(&[p, &[0]].concat(), true)),
        ),
    ];
    for (want, z) in cases {
        let bad = repack_chunk_with(&bytes, 1, |_| {}, z);
        let mut dec = Decoder::new(Limits::default());
        match dec.push(&bad) {
            Err(DecodeError::Format(FormatError::Invalid {
                section: Section::Chunk(1),
                message,
            })) => assert!(message.contains(want), "{want}: {message}"),
            other => panic!("{want}: {other:?}"),
        }
        assert_eq!(dec.deepest_level(), Some(20));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Random bytes as the five record streams of a valid mesh state: the
    /// record decoder returns errors, never panics, and whatever it accepts
    /// applies cleanly.
    #[test]
    fn random_record_streams_never_panic(
        seed in 0u64..50,
        streams in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..48), 5),
        major in 1u16..=4,
        edge_symbol in any::<bool>(),
    ) {
        use pqm_format::codec::{decode_record, Cursors, MeshState};
        use pqm_format::varint::Reader;
        let mut streams = streams;
        // Half the cases start with an edge-split symbol (spec §7.10), which
        // random bytes would rarely hit.
        if edge_symbol && !streams[0].is_empty() {
            streams[0][0] = 0x11;
        }
        let pm = testgen::generate(seed, 30);
        let (pos, quads) = pm.level_quads(pm.records.len());
        let q = expected_quantizer(&pm, 14, Grid::Cube);
        let mut st = MeshState::new(q.qmax(), pos.iter().map(|p| q.quantize(*p)).collect(), quads);
        let mut rd = [0, 1, 2, 3, 4].map(|k| Reader::new(&streams[k], "s"));
        let mut cur = Cursors::default();
        let (mv, mf) = (st.q.len() as u32 + 20, st.quads.len() as u32 + 20);
        for _ in 0..10 {
            match decode_record(&st, &mut rd, &mut cur, mv, mf, major) {
                Ok(r) => {
                    st.apply(&r);
                    prop_assert!(st.quads.iter().flatten().all(|&v| (v as usize) < st.q.len()));
                }
                Err(_) => break,
            }
        }
    }
}

/// A closed fan of 300 quads around vertex 0: more faces than a star may
/// have (255), so every form that walks or lists a star must refuse it.
fn fan_of_300() -> pqm_format::codec::MeshState {
    let n = 300u32;
    let mut q = vec![[0u32, 0, 0]];
    let mut quads = Vec::new();
    for i in 0..n {
        q.push([i, 1, 0]);
        q.push([i, 2, 0]);
    }
    for i in 0..n {
        let (a, b) = (1 + 2 * i, 1 + 2 * ((i + 1) % n));
        quads.push([0, a, a + 1, b]);
    }
    pqm_format::codec::MeshState::new((1 << 14) - 1, q, quads)
}

/// `chunk_growth`: each chunk holds at least its budget (`chunk_bytes`, or
/// the fraction of every earlier chunk's payload when that is more) and
/// closes soon after reaching it; the file has fewer chunks than with
/// fixed-size chunks, and every chunk-end level still equals the
/// coarsener's level.
#[test]
fn chunks_grow_with_the_file() {
    let mut pm = testgen::generate(41, 900);
    pqm_format::vectors::rotate_rewritten(&mut pm);
    let opts = |chunk_growth| EncodeOptions {
        chunk_bytes: 256,
        chunk_growth,
        ..EncodeOptions::default()
    };
    let flat = encode(&pm, &opts(0.0));
    let grown = encode(&pm, &opts(0.5));
    let q = expected_quantizer(&pm, 14, Grid::Cube);
    let table = |bytes: &[u8]| {
        decode_all(bytes, Limits::default())
            .unwrap()
            .chunks()
            .to_vec()
    };
    let (tf, tg) = (table(&flat), table(&grown));
    assert!(
        tg.len() * 2 < tf.len(),
        "{} chunks grown vs {} flat",
        tg.len(),
        tf.len()
    );
    // The table's payload lengths include each stream's length varint (at
    // most 3 bytes for these sizes) on top of the bytes the writer counts.
    let mut before = 0u64;
    for (i, c) in tg.iter().enumerate() {
        let budget = 256u64.max(before / 2);
        let len = c.uncompressed_len as u64;
        if i + 1 < tg.len() {
            assert!(
                len >= budget,
                "chunk {i}: {len} bytes under its budget {budget}"
            );
        }
        assert!(
            len <= 2 * budget + 512,
            "chunk {i}: {len} bytes, far over its budget {budget}"
        );
        before += len.saturating_sub(15);
    }
    let mut dec = decode_all(&grown, Limits::default()).unwrap();
    let mut k = 0;
    for c in &tg {
        k += c.record_count as usize;
        dec.set_level(Target::Level(k)).unwrap();
        assert_level(&dec, &pm, &q, k);
    }
    assert_eq!(k, pm.records.len());
    for bad in [-0.1, f64::NAN, 16.5] {
        assert!(matches!(
            write_to_vec(&pm, &opts(bad)),
            Err(EncodeError::InvalidOptions(_))
        ));
    }
}

/// `finest_diagonals` (header flag bit 3, a 4.1 file): only beside a corner
/// order that keeps the diagonals and major version 4; it changes the
/// header alone — the levels are those of the same file without it, and a
/// reader that ignores the flag (the bit cleared, the minor set back to 0)
/// decodes the same bytes to the same levels.
#[test]
fn finest_diagonals_flag_marks_the_header_and_nothing_else() {
    let mut pm = testgen::generate(43, 300);
    pqm_format::vectors::rotate_rewritten(&mut pm);
    let opts = |corner_order, finest_diagonals, version_major| EncodeOptions {
        chunk_bytes: 512,
        corner_order,
        finest_diagonals,
        version_major,
        ..EncodeOptions::default()
    };
    for order in [CornerOrder::Diagonal, CornerOrder::Input] {
        let plain = encode(&pm, &opts(order, false, 4));
        let marked = encode(&pm, &opts(order, true, 4));
        let (a, b) = (
            decode_all(&plain, Limits::default()).unwrap(),
            decode_all(&marked, Limits::default()).unwrap(),
        );
        let (ha, hb) = (a.header().unwrap(), b.header().unwrap());
        assert!(!ha.finest_diagonals() && hb.finest_diagonals(), "{order:?}");
        assert_eq!((ha.version_minor, hb.version_minor), (0, 1), "{order:?}");
        assert_eq!(hb.flags, ha.flags | 8);
        // Everything after the header is the same bytes.
        let hl = header_len(&plain);
        assert_eq!(hl, header_len(&marked));
        assert_eq!(plain[hl..], marked[hl..], "{order:?}");
        // Without the flag and the minor, the marked file is the plain one.
        let mut cleared = marked.clone();
        patch_header(&mut cleared, |h| {
            h[10] = 0;
            h[16] &= !8;
        });
        assert_eq!(cleared, plain, "{order:?}");
    }
    for bad in [
        opts(CornerOrder::Canonical, true, 4),
        opts(CornerOrder::Diagonal, true, 3),
    ] {
        assert!(matches!(
            write_to_vec(&pm, &bad),
            Err(EncodeError::InvalidOptions(_))
        ));
    }
}

/// `quad_triangles_shorter` splits every quad of every level along the
/// diagonal `pqm_core::io::quad_split_diagonal` picks on the decoded f64
/// positions (where the two code lengths differ; a tie keeps `v0–v2`), on
/// the cube grid and the box grid.
#[test]
fn quad_triangles_shorter_is_the_export_rule() {
    let mut pm = testgen::generate(47, 200);
    pqm_format::vectors::rotate_rewritten(&mut pm);
    for grid in [Grid::Cube, Grid::Box] {
        let bytes = encode(
            &pm,
            &EncodeOptions {
                grid,
                ..EncodeOptions::default()
            },
        );
        let mut dec = decode_all(&bytes, Limits::default()).unwrap();
        let step = dec.quantizer().unwrap().step();
        let n = pm.records.len();
        let (mut flipped, mut kept) = (0, 0);
        for k in [0, n / 2, n] {
            dec.set_level(Target::Level(k)).unwrap();
            let p = dec.positions_f64();
            let codes = dec.position_codes();
            for &q in dec.quads() {
                let t = quad_triangles_shorter(q, codes, step);
                let len = |u: u32, v: u32| {
                    (0..3)
                        .map(|a| {
                            let d = (codes[u as usize][a] as f64 - codes[v as usize][a] as f64)
                                * step[a];
                            d * d
                        })
                        .sum::<f64>()
                };
                if len(q[1], q[3]) == len(q[0], q[2]) {
                    assert_eq!(t, quad_triangles(q), "a tie keeps v0-v2");
                    continue;
                }
                let r = pqm_core::io::quad_split_diagonal(&p, q);
                let want = [0, 1, 2, 0, 2, 3].map(|i| q[(i + r) % 4]);
                assert_eq!(t, want, "{grid:?} level {k} quad {q:?}");
                if r == 1 {
                    flipped += 1;
                } else {
                    kept += 1;
                }
            }
        }
        assert!(
            flipped > 0 && kept > 0,
            "{grid:?}: {flipped} flipped, {kept} kept"
        );
    }
}
