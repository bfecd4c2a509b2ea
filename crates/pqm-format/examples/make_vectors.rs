//! Writes the test vectors of `spec/vectors/` (spec §11).
//!
//! `cargo run -p pqm-format --example make_vectors`

use pqm_format::{decode_all, vectors, Limits, Target};
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../spec/vectors");
    std::fs::create_dir_all(&dir).expect("create spec/vectors");
    for v in vectors::all() {
        std::fs::write(dir.join(format!("{}.pqm", v.name)), &v.bytes).expect("write pqm");
        let mut dec = decode_all(&v.bytes, Limits::default()).expect("vector decodes");
        let json = vectors::digest_json(v.name, &mut dec, &v.levels, v.bytes.len());
        std::fs::write(dir.join(format!("{}.json", v.name)), json).expect("write json");
        for &k in &v.levels {
            dec.set_level(Target::Level(k)).expect("level");
            std::fs::write(
                dir.join(format!("{}.level{k}.obj", v.name)),
                vectors::obj(&dec),
            )
            .expect("write obj");
        }
        println!(
            "{}: {} bytes, levels {:?}, records per form (general, split, local, face split, edge split) {:?}",
            v.name,
            v.bytes.len(),
            v.levels,
            v.forms
        );
    }
}
