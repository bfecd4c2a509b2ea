//! `CornerOrder::Diagonal`: quads a record builds may start at their
//! opposite corner. The file decodes, at every level, to the progressive
//! mesh `write_stored` returns, id for id; that mesh differs from the
//! input only by rotations by 2 (every quad keeps its diagonal, so every
//! level splits into the same triangles); and the file is smaller on real
//! coarsener output.
//!
//! `CornerOrder::Canonical` (what `pqm encode` writes): quads a record
//! builds start where its form builds them. The same guarantees up to any
//! rotation (the same corners in the same cyclic order, not always the
//! same diagonal), and a file smaller still. Both code a doublet that fits
//! the face-split form in it, not in the split form `Input` tries first.

use pqm_core::progressive::testgen;
use pqm_core::ProgressiveMesh;
use pqm_format::*;
use proptest::prelude::*;

mod common;

/// `q` with its corners turned by `t` (`rotl` of the spec).
fn turned(q: [u32; 4], t: usize) -> [u32; 4] {
    [q[t % 4], q[(t + 1) % 4], q[(t + 2) % 4], q[(t + 3) % 4]]
}

/// Asserts that `stored` is `pm` up to quads started at their opposite
/// corner: the same base, vertices, moves and slots, and at every level
/// each quad equal to `pm`'s or to it turned by 2 (so `quad_triangles`
/// gives the same two triangles). Returns how many quads of the finest
/// level are turned.
fn assert_same_up_to_diagonal_turns(pm: &ProgressiveMesh, stored: &ProgressiveMesh) -> usize {
    assert_same_up_to_turns(pm, stored, true)
}

/// [`assert_same_up_to_diagonal_turns`], or with `diagonal` false, each
/// quad equal to `pm`'s turned by any of 0..=3.
fn assert_same_up_to_turns(
    pm: &ProgressiveMesh,
    stored: &ProgressiveMesh,
    diagonal: bool,
) -> usize {
    assert_eq!(stored.base, pm.base);
    assert_eq!(stored.vertex_order, pm.vertex_order);
    assert_eq!(stored.level_error, pm.level_error);
    assert_eq!(stored.records.len(), pm.records.len());
    for (a, b) in pm.records.iter().zip(&stored.records) {
        assert_eq!(a.op, b.op);
        assert_eq!(a.new_vertices, b.new_vertices);
        assert_eq!(a.moved, b.moved);
        let slots = |r: &pqm_core::SplitRecord| r.rewritten.iter().map(|w| w.0).collect::<Vec<_>>();
        assert_eq!(slots(a), slots(b));
        assert_eq!(a.appended_faces.len(), b.appended_faces.len());
    }
    let mut turned_last = 0;
    for k in 0..=pm.records.len() {
        let (pa, qa) = pm.level_quads(k);
        let (pb, qb) = stored.level_quads(k);
        assert_eq!(pa, pb, "level {k}");
        assert_eq!(qa.len(), qb.len(), "level {k}");
        turned_last = 0;
        for (s, (&x, &y)) in qa.iter().zip(&qb).enumerate() {
            if diagonal {
                assert!(
                    y == x || y == turned(x, 2),
                    "level {k}, slot {s}: {y:?} is not {x:?} nor its opposite-corner start"
                );
                assert_eq!(triangles(x), triangles(y), "level {k}, slot {s}");
            } else {
                assert!(
                    (0..4).any(|t| y == turned(x, t)),
                    "level {k}, slot {s}: {y:?} is not {x:?} turned"
                );
            }
            turned_last += (y != x) as usize;
        }
    }
    turned_last
}

/// The two triangles a renderer draws for `q`, each started at its
/// smallest id, sorted.
fn triangles(q: [u32; 4]) -> [[u32; 3]; 2] {
    let t = quad_triangles(q);
    let mut out = [canonical_triangle(&t[..3]), canonical_triangle(&t[3..])];
    out.sort();
    out
}

/// A triangle as its corners rotated to start at the smallest id (same
/// orientation).
fn canonical_triangle(t: &[u32]) -> [u32; 3] {
    let i = (0..3).min_by_key(|&i| t[i]).unwrap();
    [t[i], t[(i + 1) % 3], t[(i + 2) % 3]]
}

fn diagonal() -> EncodeOptions {
    EncodeOptions {
        corner_order: CornerOrder::Diagonal,
        ..EncodeOptions::default()
    }
}

fn canonical() -> EncodeOptions {
    EncodeOptions {
        corner_order: CornerOrder::Canonical,
        ..EncodeOptions::default()
    }
}

fn decode_stored(
    pm: &ProgressiveMesh,
    opts: &EncodeOptions,
) -> (Vec<u8>, ProgressiveMesh, Decoder) {
    let mut bytes = Vec::new();
    let (_, stored) = write_stored(pm, opts, &mut bytes).unwrap();
    let dec = decode_all(&bytes, Limits::default()).unwrap();
    (bytes, stored, dec)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Generated meshes with every record form (splits with rewritten
    /// quads turned, face splits, edge splits), cut into small chunks, in
    /// every major version a writer can write (1.x and 2.0 lack the later
    /// forms: fewer quads are turned, the same guarantees).
    #[test]
    fn diagonal_files_decode_to_the_stored_mesh(
        seed in any::<u64>(),
        splits in 0usize..150,
        rotate in any::<bool>(),
        face_splits in 0usize..40,
        edge_splits in 0usize..12,
        chunk in 3usize..60,
        version_major in 1u16..=4,
    ) {
        let mut pm = testgen::generate(seed, splits);
        if rotate {
            pqm_format::vectors::rotate_rewritten(&mut pm);
        }
        pqm_format::vectors::add_face_splits(&mut pm, face_splits, seed);
        pqm_format::vectors::add_edge_splits(&mut pm, edge_splits, seed);
        let opts = EncodeOptions { chunk_records: Some(chunk), version_major, ..diagonal() };
        let (_, stored, mut dec) = decode_stored(&pm, &opts);
        assert_same_up_to_diagonal_turns(&pm, &stored);
        common::assert_every_level_down_and_up(&mut dec, &stored);
        let canon = EncodeOptions { chunk_records: Some(chunk), version_major, ..canonical() };
        let (_, stored, mut dec) = decode_stored(&pm, &canon);
        assert_same_up_to_turns(&pm, &stored, false);
        common::assert_every_level_down_and_up(&mut dec, &stored);
        // `Input` stores the mesh as it is.
        let (_, same, mut dec) = decode_stored(&pm, &EncodeOptions { chunk_records: Some(chunk), ..EncodeOptions::default() });
        prop_assert_eq!(&same, &pm);
        common::assert_every_level_down_and_up(&mut dec, &pm);
    }
}

#[test]
fn coarsener_output_is_smaller_and_draws_the_same_triangles() {
    // every operator, rounds as `pqm encode` runs them
    let pm = common::coarsened_torus(Some(0.005));
    assert!(pm.records.len() > 500, "{} records", pm.records.len());
    let (input, _, _) = decode_stored(&pm, &EncodeOptions::default());
    let (bytes, stored, mut dec) = decode_stored(&pm, &diagonal());
    let turned = assert_same_up_to_diagonal_turns(&pm, &stored);
    common::assert_every_level_down_and_up(&mut dec, &stored);
    // Some quads do start elsewhere, and that is what pays.
    let faces = pm.final_face_count();
    assert!(
        turned * 10 > faces,
        "{turned} of {faces} final quads turned"
    );
    assert!(
        bytes.len() * 200 < input.len() * 199,
        "diagonal {} bytes against input order {}",
        bytes.len(),
        input.len()
    );
}

#[test]
fn canonical_is_smaller_than_diagonal_and_keeps_face_splits() {
    let pm = common::coarsened_torus(Some(0.005));
    let mut diagonal_bytes = Vec::new();
    let diag = write(&pm, &diagonal(), &mut diagonal_bytes).unwrap();
    let (bytes, stored, mut dec) = decode_stored(&pm, &canonical());
    let canon = write(&pm, &canonical(), &mut Vec::new()).unwrap();
    let input = write(&pm, &EncodeOptions::default(), &mut Vec::new()).unwrap();
    let turned = assert_same_up_to_turns(&pm, &stored, false);
    common::assert_every_level_down_and_up(&mut dec, &stored);
    let faces = pm.final_face_count();
    assert!(
        turned * 10 > faces,
        "{turned} of {faces} final quads turned"
    );
    // Turning a face split's quads must not make it a (larger) split, and
    // a doublet that fits both forms is a face split: against the
    // unturned records (`Input`, the split form first), some splits become
    // face splits and nothing else moves, under both orders.
    let forms = |r: &EncodeReport| {
        (
            r.split_records,
            r.face_split_records,
            r.edge_split_records,
            r.local_records,
            r.general_records,
        )
    };
    let i = forms(&input);
    for (name, f) in [("canonical", forms(&canon)), ("diagonal", forms(&diag))] {
        assert!(f.1 >= i.1, "{name}: {f:?} against input's {i:?}");
        assert_eq!(
            (f.0 + f.1, f.2, f.3, f.4),
            (i.0 + i.1, i.2, i.3, i.4),
            "{name}: {f:?} against input's {i:?}"
        );
    }
    assert!(
        bytes.len() * 100 < diagonal_bytes.len() * 99,
        "canonical {} bytes against diagonal {}",
        bytes.len(),
        diagonal_bytes.len()
    );
}
