//! Measured level errors (`pqm_format::level_error`): each chunk boundary's
//! sampled Hausdorff distance to the finest level, made non-increasing, is
//! tighter than the coarsener's bound; writing it changes no level and no
//! byte outside the error fields and their CRCs; a view then downloads
//! less; `set` refuses errors the spec forbids and damaged files, leaving
//! them as they were.

mod common;

use pqm_core::metrics::{hausdorff, HausdorffOptions};
use pqm_core::progressive::testgen::{self, GenOptions};
use pqm_core::ProgressiveMesh;
use pqm_format::level_error::{measure, set, MeasuredErrors};
use pqm_format::view::{file_diagonal, ViewLod};
use pqm_format::{
    write_to_vec, DecodeError, Decoder, EncodeOptions, FormatError, Limits, Section, Target,
};
use proptest::prelude::*;

fn encode(pm: &ProgressiveMesh, chunk_bytes: usize) -> Vec<u8> {
    let opts = EncodeOptions {
        chunk_bytes,
        chunk_growth: 0.0,
        ..EncodeOptions::default()
    };
    write_to_vec(pm, &opts).expect("encode").0
}

fn decoded(bytes: &[u8]) -> Decoder {
    let mut dec = Decoder::new(Limits::default());
    dec.keep_undo_logs().unwrap();
    dec.push(bytes).expect("decode");
    dec
}

/// `measure` with Metro's default sampling and no progress.
fn measure_metro(bytes: &[u8]) -> MeasuredErrors {
    measure(
        bytes,
        Limits::default(),
        &HausdorffOptions::default(),
        |_, _| {},
    )
    .unwrap()
}

/// The errors of level 0 and of every chunk boundary, as the file says.
fn errors(dec: &Decoder) -> Vec<f32> {
    std::iter::once(dec.header().unwrap().base_error)
        .chain(dec.chunks().iter().map(|c| c.error))
        .collect()
}

/// Byte ranges `set` may change: `base_error`, the header's CRC, each
/// chunk entry's error and the table's CRC.
fn error_fields(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let hl = common::header_len(bytes);
    let n = u32::from_le_bytes(bytes[44..48].try_into().unwrap()) as usize;
    let entry = u16::from_le_bytes(bytes[22..24].try_into().unwrap()) as usize;
    let mut out = vec![112..116, hl - 4..hl];
    out.extend((0..n).map(|i| hl + i * entry + 28..hl + i * entry + 32));
    out.push(hl + n * entry..hl + n * entry + 4);
    out
}

#[test]
fn measured_errors_are_monotone_tighter_than_the_bounds_and_change_no_level() {
    let pm = common::coarsened_torus(Some(0.05));
    let bytes = encode(&pm, 512);
    let bound = errors(&decoded(&bytes));
    assert!(bound.len() >= 6, "only {} chunks", bound.len() - 1);

    let mut calls = Vec::new();
    let m = measure(
        &bytes,
        Limits::default(),
        &HausdorffOptions::default(),
        |d, t| calls.push((d, t)),
    )
    .unwrap();
    let n = bound.len();
    assert_eq!(calls.last(), Some(&(n, n)));
    assert!(calls.windows(2).all(|w| w[0].0 < w[1].0));
    assert_eq!(m.levels.len(), n);
    assert_eq!((m.levels[0], m.levels[n - 1]), (0, pm.records.len()));
    assert_eq!(m.sampled[n - 1], 0.0);
    let measured: Vec<f32> = std::iter::once(m.base)
        .chain(m.chunks.iter().copied())
        .collect();
    for i in 0..n {
        // monotone, and no smaller than any finer level's sampled distance
        let finer = m.sampled[i..].iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(
            measured[i] as f64 >= finer,
            "level {}: {} < {finer}",
            m.levels[i],
            measured[i]
        );
        assert!((measured[i].next_down() as f64) < finer || finer == 0.0);
        // the sampled distance is the level's own, against the finest
        // level (both as the decoder gives them)
        if i + 1 < n && i % 3 == 0 {
            let mut dec = decoded(&bytes);
            dec.set_level(Target::Level(pm.records.len())).unwrap();
            let finest = dec.to_indexed_mesh();
            dec.set_level(Target::Level(m.levels[i])).unwrap();
            let h = hausdorff(
                &dec.to_indexed_mesh(),
                &finest,
                &HausdorffOptions::default(),
            );
            assert_eq!(h.symmetric.max, m.sampled[i]);
        }
        // tighter than the coarsener's drift bound
        assert!(
            measured[i] <= bound[i],
            "level {}: measured {} > bound {}",
            m.levels[i],
            measured[i],
            bound[i]
        );
    }
    assert!(
        measured[0] < bound[0] / 2.0,
        "level 0: measured {} against the bound {}",
        measured[0],
        bound[0]
    );

    let mut patched = bytes.clone();
    set(&mut patched, m.base, &m.chunks).unwrap();
    let fields = error_fields(&bytes);
    for (i, (a, b)) in bytes.iter().zip(&patched).enumerate() {
        if a != b {
            assert!(fields.iter().any(|r| r.contains(&i)), "byte {i} changed");
        }
    }
    let mut dec = decoded(&patched);
    assert_eq!(errors(&dec), measured);
    common::assert_every_level_down_and_up(&mut dec, &pm);
    // measuring the patched file gives the same errors
    let again = measure_metro(&patched);
    assert_eq!(again, m);
}

#[test]
fn a_view_downloads_less_with_measured_errors() {
    let pm = common::coarsened_torus(Some(0.05));
    let bytes = encode(&pm, 512);
    let m = measure_metro(&bytes);
    let mut patched = bytes.clone();
    set(&mut patched, m.base, &m.chunks).unwrap();
    let (bound, measured) = (decoded(&bytes), decoded(&patched));
    let diag = file_diagonal(&bound).expect("bounds");
    let lod = ViewLod::default();
    let mut fewer = 0;
    // from far (the whole object in a few pixels) to close (a pixel per
    // hundredth of a grid step)
    for s in 0..60 {
        let ppwu = 1e-2 * 1.25f64.powi(s);
        let b = lod.choose(&bound, ppwu, diag).unwrap();
        let t = lod.choose(&measured, ppwu, diag).unwrap();
        assert!(
            t.level <= b.level && t.bytes_for <= b.bytes_for,
            "{ppwu} px/unit: {t:?} against {b:?}"
        );
        assert!(t.screen_error <= lod.max_screen_error || t.level == pm.records.len());
        fewer += (t.bytes_for < b.bytes_for) as usize;
    }
    assert!(
        fewer >= 5,
        "the measured errors saved bytes at only {fewer} distances"
    );
}

#[test]
fn set_refuses_what_the_spec_forbids_and_leaves_the_file_alone() {
    let pm = testgen::generate_with(&GenOptions::new(7, 300));
    let bytes = encode(&pm, 256);
    let n = decoded(&bytes).chunks().len();
    assert!(n >= 3);
    let ok: Vec<f32> = (0..n).map(|i| (n - 1 - i) as f32 * 0.01).collect();
    let parameter = |base: f32, chunks: &[f32]| {
        let mut b = bytes.clone();
        let e = set(&mut b, base, chunks).unwrap_err();
        assert!(
            matches!(e, DecodeError::Parameter(_)),
            "{base} {chunks:?}: {e}"
        );
        assert_eq!(b, bytes, "a refused call changed the file");
    };
    parameter(1.0, &ok[1..]); // one error short
    parameter(f32::NAN, &ok);
    parameter(-0.5, &vec![-1.0; n]);
    parameter(0.005, &ok); // the base below chunk 0
    let mut rising = ok.clone();
    rising.swap(0, 1);
    parameter(1.0, &rising);
    let mut nan = ok.clone();
    nan[n - 1] = f32::NAN;
    parameter(1.0, &nan);
    // +∞ (unknown) is allowed, as in the header
    let mut b = bytes.clone();
    set(&mut b, f32::INFINITY, &ok).unwrap();
    assert_eq!(decoded(&b).header().unwrap().base_error, f32::INFINITY);

    // a damaged header or table keeps its bad CRC
    let hl = common::header_len(&bytes);
    for (at, section) in [(30, Section::Header), (hl + 5, Section::ChunkTable)] {
        let mut b = bytes.clone();
        b[at] ^= 0x40;
        let damaged = b.clone();
        match set(&mut b, 1.0, &ok) {
            Err(DecodeError::Format(FormatError::CrcMismatch { section: s, .. })) => {
                assert_eq!(s, section)
            }
            other => panic!("byte {at} damaged: {other:?}"),
        }
        assert_eq!(b, damaged);
    }
    let mut b = bytes.clone();
    b[0] = b'X';
    assert!(matches!(
        set(&mut b, 1.0, &ok),
        Err(DecodeError::Format(FormatError::BadMagic))
    ));
    // every prefix that ends before the table's CRC: an error, no panic
    let table_end = hl + n * 36 + 4;
    for len in 0..table_end {
        let mut b = bytes[..len].to_vec();
        assert!(set(&mut b, 1.0, &ok).is_err(), "prefix of {len} bytes");
        assert_eq!(b, bytes[..len]);
    }
    // measuring needs the whole file: a prefix is an error, never a panic
    for len in (0..bytes.len()).step_by(bytes.len() / 40 + 1) {
        assert!(
            measure(
                &bytes[..len],
                Limits::default(),
                &HausdorffOptions::default(),
                |_, _| {}
            )
            .is_err(),
            "prefix of {len} bytes measured"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// Any errors the spec allows are read back exactly, and the levels
    /// stay the same.
    #[test]
    fn set_errors_are_read_back_and_change_no_level(
        seed in 0u64..1000, splits in 40usize..200, chunk_bytes in 64usize..400,
        raw in proptest::collection::vec(0.0f32..2.0, 64),
    ) {
        let pm = testgen::generate_with(&GenOptions::new(seed, splits));
        let bytes = encode(&pm, chunk_bytes);
        let n = decoded(&bytes).chunks().len();
        let mut errs: Vec<f32> = raw.iter().cycle().take(n + 1).copied().collect();
        errs.sort_by(|a, b| b.total_cmp(a));
        let mut patched = bytes.clone();
        set(&mut patched, errs[0], &errs[1..]).unwrap();
        let mut a = decoded(&bytes);
        let mut b = decoded(&patched);
        prop_assert_eq!(errors(&b), errs);
        for k in [0, pm.records.len() / 2, pm.records.len()] {
            a.set_level(Target::Level(k)).unwrap();
            b.set_level(Target::Level(k)).unwrap();
            prop_assert_eq!(a.quads(), b.quads());
            prop_assert_eq!(a.position_codes(), b.position_codes());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Hostile bytes: `set` on a damaged, cut or lengthened file, or on
    /// noise behind the magic, returns an error or succeeds — never panics
    /// — and when it refuses, the bytes are as they were.
    #[test]
    fn set_never_panics_on_hostile_bytes(
        seed in 0u64..50,
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 0..4),
        cut in any::<prop::sample::Index>(),
        noise in proptest::collection::vec(any::<u8>(), 0..300),
        mode in 0u8..4,
        chunk_errors in proptest::collection::vec(0.0f32..1.0, 1..12),
    ) {
        let pm = testgen::generate_with(&GenOptions::new(seed, 60));
        let valid = encode(&pm, 128);
        let mut b = match mode {
            0 => valid.clone(),
            1 => valid[..cut.index(valid.len() + 1)].to_vec(),
            2 => [&valid[..], &noise[..]].concat(),
            _ => [&valid[..8], &noise[..]].concat(),
        };
        for (at, x) in &flips {
            if !b.is_empty() {
                let i = at.index(b.len());
                b[i] ^= x;
            }
        }
        // as many errors as the (maybe damaged) header claims chunks, so
        // that the table's checks are reached, within reason
        let claimed = (b.len() >= 48)
            .then(|| u32::from_le_bytes(b[44..48].try_into().unwrap()) as usize)
            .filter(|&n| n <= 10_000);
        let mut errs: Vec<f32> = match claimed {
            Some(n) => chunk_errors.iter().copied().cycle().take(n).collect(),
            None => chunk_errors.clone(),
        };
        errs.sort_by(|a, b| b.total_cmp(a));
        let before = b.clone();
        if set(&mut b, 1.0, &errs).is_err() {
            prop_assert_eq!(b, before);
        }
    }
}
