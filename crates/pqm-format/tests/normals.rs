//! `pqm_format::normals::SmoothNormals`: whatever path reaches a level —
//! streamed in pieces, stepped, jumped, coarsened and refined again, with
//! records that move vertices or not — the kept normals are exactly those
//! computed at that level, and the ranges `apply` returns name every vertex
//! whose normal changed.

use pqm_core::progressive::testgen::{self, GenOptions};
use pqm_format::normals::SmoothNormals;
use pqm_format::{write_to_vec, Change, Decoder, EncodeOptions, Limits, Target};
use proptest::prelude::*;

/// Applies `c` and checks the result against the level's own normals and
/// the reported ranges against what changed since `before`.
fn apply_and_check(
    n: &mut SmoothNormals,
    dec: &Decoder,
    c: &Change,
    before: &[[f32; 3]],
) -> Result<(), TestCaseError> {
    let ranges = n.apply(dec, c);
    let want = SmoothNormals::compute(dec);
    prop_assert_eq!(n.normals(), want.as_slice(), "level {}", dec.level());
    let nv = want.len() as u32;
    prop_assert!(
        ranges.windows(2).all(|w| w[0].end < w[1].start),
        "sorted, disjoint, not adjacent"
    );
    prop_assert!(ranges.iter().all(|r| r.start < r.end && r.end <= nv));
    let inside = |v: u32| ranges.iter().any(|r| r.contains(&v));
    for v in 0..nv {
        let old = before.get(v as usize);
        let appended = c.vertices_appended.contains(&v);
        if old != Some(&want[v as usize]) && !(appended && old.is_none()) {
            prop_assert!(inside(v), "vertex {v} changed but no range names it");
        }
        if appended {
            prop_assert!(
                inside(v) || want[v as usize] == [0.0; 3],
                "new vertex {v} has no range"
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn every_path_to_a_level_gives_its_own_normals(
        seed in any::<u64>(), splits in 20usize..300, smooth_prob in 0.0f64..1.0,
        chunk_bytes in 64usize..2048, pieces in prop::collection::vec(1usize..700, 1..10),
        walk in prop::collection::vec((0.0f64..1.0, any::<bool>()), 1..25),
    ) {
        let pm = testgen::generate_with(&GenOptions { smooth_prob, ..GenOptions::new(seed, splits) });
        let opts = EncodeOptions { chunk_bytes, ..EncodeOptions::default() };
        let bytes = write_to_vec(&pm, &opts).expect("encode").0;
        let mut dec = Decoder::new(Limits::default());
        let mut n = SmoothNormals::default();
        let mut started = false;
        // streamed: refined to the deepest level after every piece
        let mut at = 0;
        let mut i = 0;
        while at < bytes.len() {
            let end = (at + pieces[i % pieces.len()]).min(bytes.len());
            dec.push(&bytes[at..end]).unwrap();
            at = end;
            i += 1;
            if dec.deepest_level().is_some() {
                let before = n.normals().to_vec();
                let c = if started { dec.refine_to(Target::Level(usize::MAX)).unwrap() } else { dec.full_upload() };
                started = true;
                apply_and_check(&mut n, &dec, &c, &before)?;
            }
        }
        let last = dec.deepest_level().unwrap();
        // walked: jumps, and single steps
        for (x, step) in walk {
            let k = if step {
                // one level down or up
                if x < 0.5 && dec.level() > 0 { dec.level() - 1 } else { (dec.level() + 1).min(last) }
            } else {
                (x * last as f64) as usize
            };
            let before = n.normals().to_vec();
            let c = dec.set_level(Target::Level(k)).unwrap();
            apply_and_check(&mut n, &dec, &c, &before)?;
        }
        // starting over from a full upload gives the same
        let mut fresh = SmoothNormals::default();
        fresh.apply(&dec, &dec.full_upload());
        prop_assert_eq!(fresh.normals(), n.normals());
    }
}

/// Every spec vector, stepped one level at a time down to the base and
/// back up: the vectors' records move vertices (version-1 smoothing).
#[test]
fn spec_vectors_step_by_step() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../spec/vectors");
    let mut files = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        if path.extension().and_then(|x| x.to_str()) != Some("pqm") {
            continue;
        }
        files += 1;
        let bytes = std::fs::read(&path).unwrap();
        let mut dec = Decoder::new(Limits::default());
        dec.push(&bytes).unwrap();
        let mut n = SmoothNormals::default();
        n.apply(&dec, &dec.full_upload());
        let last = dec.deepest_level().unwrap();
        let mut moved = 0;
        for k in (0..last).rev().chain(1..=last) {
            let c = dec.set_level(Target::Level(k)).unwrap();
            moved += usize::from(!c.vertices_moved.is_empty());
            n.apply(&dec, &c);
            assert_eq!(
                n.normals(),
                SmoothNormals::compute(&dec).as_slice(),
                "{}: level {k}",
                path.display()
            );
        }
        assert!(moved > 0, "{}: no step moved a vertex", path.display());
    }
    assert!(files >= 10, "{files} vectors");
}
