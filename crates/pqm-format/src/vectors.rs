//! Test vectors of `spec/vectors/` (spec §11): how they are generated and
//! digested. Used by `examples/make_vectors.rs` (writes them) and by
//! `tests/vectors.rs` (regenerates them in memory and compares).

use crate::{write_to_vec, Decoder, EncodeOptions, Target};
use pqm_core::progressive::testgen::{generate_with, BaseShape, GenOptions};
use pqm_core::ProgressiveMesh;
use std::fmt::Write as _;

/// One test vector: a file and the levels whose digests are recorded.
pub struct Vector {
    /// File stem (`NAME.pqm`, `NAME.json`, `NAME.levelK.obj`).
    pub name: &'static str,
    /// The encoded file.
    pub bytes: Vec<u8>,
    /// Levels recorded in the JSON digest (and as OBJ files).
    pub levels: Vec<usize>,
    /// Records per form: general, split, local (spec §7.3).
    pub forms: [usize; 3],
}

/// Rotates the rewritten quads of every record by `(record + slot) mod 4`
/// corners (the same faces, another first corner), as the coarsener's
/// records do when it restores a face starting at another corner — what the
/// local form's rotation bits are for.
pub fn rotate_rewritten(pm: &mut ProgressiveMesh) {
    for (k, r) in pm.records.iter_mut().enumerate() {
        for (s, q) in r.rewritten.iter_mut() {
            let rot = (k + *s as usize) % 4;
            *q = [0, 1, 2, 3].map(|j| q[(j + rot) % 4]);
        }
    }
}

/// Every vector, generated deterministically.
pub fn all() -> Vec<Vector> {
    let make = |name, gen: GenOptions, opts: EncodeOptions| {
        let mut pm = generate_with(&gen);
        if name == "local_form" {
            rotate_rewritten(&mut pm);
        }
        let n = pm.records.len();
        let (bytes, r) = write_to_vec(&pm, &opts).expect("vector encodes");
        Vector {
            name,
            bytes,
            levels: vec![0, n / 3, 2 * n / 3, n],
            forms: [r.general_records, r.split_records, r.local_records],
        }
    };
    vec![
        make(
            "grid_small",
            GenOptions {
                base: BaseShape::Grid { nx: 3, ny: 3 },
                vertex_order: false,
                ..GenOptions::new(1, 12)
            },
            EncodeOptions {
                chunk_records: Some(4),
                ..EncodeOptions::default()
            },
        ),
        make(
            "box_vord",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                ..GenOptions::new(2, 40)
            },
            EncodeOptions {
                chunk_records: Some(10),
                ..EncodeOptions::default()
            },
        ),
        make(
            "general_bits8",
            GenOptions {
                base: BaseShape::Grid { nx: 4, ny: 2 },
                ..GenOptions::new(3, 20)
            },
            EncodeOptions {
                bits: 8,
                split_form: false,
                local_form: false,
                chunk_bytes: 64,
                ..EncodeOptions::default()
            },
        ),
        make(
            "local_form",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(5, 300)
            },
            EncodeOptions {
                split_form: false,
                chunk_records: Some(12),
                ..EncodeOptions::default()
            },
        ),
        make(
            "mixed_bits24",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                fuse_prob: 0.3,
                smooth_prob: 0.1,
                ..GenOptions::new(4, 60)
            },
            EncodeOptions {
                bits: 24,
                chunk_records: Some(16),
                zstd_level: 3,
                ..EncodeOptions::default()
            },
        ),
    ]
}

/// FNV-1a 64 of `bytes`.
pub fn fnv1a64(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// `(positions digest, quads digest)` of the decoder's current level.
pub fn level_digests(dec: &Decoder) -> (u64, u64) {
    let p = fnv1a64(
        dec.positions_f64()
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f64::to_le_bytes),
    );
    let q = fnv1a64(dec.quads().iter().flatten().flat_map(|v| v.to_le_bytes()));
    (p, q)
}

/// The JSON digest of `levels` (moves the decoder).
pub fn digest_json(name: &str, dec: &mut Decoder, levels: &[usize], file_len: usize) -> String {
    let final_level = dec.deepest_level().unwrap_or(0);
    let mut s = String::new();
    let _ = write!(
        s,
        "{{\n  \"file\": \"{name}.pqm\",\n  \"bytes\": {file_len},\n  \"final_level\": {final_level},\n  \"levels\": ["
    );
    for (i, &k) in levels.iter().enumerate() {
        let _ = dec.set_level(Target::Level(k));
        let (p, q) = level_digests(dec);
        let _ = write!(
            s,
            "{}\n    {{\"level\": {k}, \"vertex_count\": {}, \"face_count\": {}, \"positions_fnv1a64\": \"{p:016x}\", \"quads_fnv1a64\": \"{q:016x}\"}}",
            if i == 0 { "" } else { "," },
            dec.positions().len(),
            dec.quads().len()
        );
    }
    s.push_str("\n  ]\n}\n");
    s
}

/// The current level as OBJ text.
pub fn obj(dec: &Decoder) -> String {
    let mut s = String::new();
    for p in dec.positions_f64() {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for q in dec.quads() {
        let _ = writeln!(s, "f {} {} {} {}", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
    }
    s
}
