//! Helpers shared by the integration tests of this crate.
// Each test crate that includes this module uses only some of them.
#![allow(dead_code)]

use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm_core::{shapes, Mesh, ProgressiveMesh};
use pqm_format::{Decoder, Target};

/// A noisy bumpy torus (48 × 24 quads) coarsened as `pqm encode` does
/// (subset placement), in rounds of `rounds` when given: every operator,
/// a few hundred records.
pub fn coarsened_torus(rounds: Option<f64>) -> ProgressiveMesh {
    let src = shapes::noisy(&shapes::bumpy_torus(48, 24, 3.0, 1.0, 0.3, 5), 0.003, 4);
    let mesh = Mesh::from_indexed(&src).unwrap();
    let opts = CoarsenOptions {
        placement: Placement::Subset,
        round_fraction: rounds,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
    c.run(&mut |_| {});
    c.into_progressive()
}

/// Walks `dec` (a decoder of the whole file of `pm`) from the finest level
/// down to level 0 and back up, one level at a time, and asserts that each
/// level's quads and position codes are `pm.level_quads(k)`'s, quantized
/// on the file's grid.
pub fn assert_every_level_down_and_up(dec: &mut Decoder, pm: &ProgressiveMesh) {
    let q = dec.quantizer().expect("header read");
    let n = pm.records.len();
    for k in (0..=n).rev().chain(0..=n) {
        dec.set_level(Target::Level(k)).unwrap();
        let (pos, quads) = pm.level_quads(k);
        assert_eq!(dec.quads(), &quads[..], "level {k}");
        let want: Vec<[u32; 3]> = pos.iter().map(|p| q.quantize(*p)).collect();
        assert_eq!(dec.position_codes(), &want[..], "level {k}");
    }
}

/// `header_len` of a file's bytes (120, or 168 with the 3.2 bounds).
pub fn header_len(bytes: &[u8]) -> usize {
    u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize
}

/// Rewrites the header of `bytes` through `f`, fixing its CRC.
pub fn patch_header(bytes: &mut [u8], f: impl FnOnce(&mut [u8])) {
    let n = header_len(bytes);
    f(&mut bytes[..n]);
    let crc = crc32fast::hash(&bytes[..n - 4]);
    bytes[n - 4..n].copy_from_slice(&crc.to_le_bytes());
}
