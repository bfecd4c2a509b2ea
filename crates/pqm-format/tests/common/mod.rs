//! Helpers shared by the integration tests of this crate.

use pqm_core::ProgressiveMesh;
use pqm_format::{Decoder, Target};

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
