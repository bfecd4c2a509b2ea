//! Measures the size of `.pqm` files written from generated progressive
//! meshes, split form vs local form vs general form, and prints bits per
//! vertex.
//!
//! `cargo run --release -p pqm-format --example measure [splits] [seed]`

use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_format::{write_to_vec, EncodeOptions};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let splits: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(50_000);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Box { n: 4 },
        smooth_prob: 0.0,
        fuse_prob: 0.0,
        ..GenOptions::new(seed, splits)
    });
    println!(
        "generated: base {} V / {} F, final {} V / {} F, {} records",
        pm.base.vertex_count(),
        pm.base.face_count(),
        pm.final_vertex_count(),
        pm.final_face_count(),
        pm.records.len()
    );
    for (name, split_form, local_form) in [
        ("split form", true, false),
        ("local form", false, true),
        ("general form", false, false),
    ] {
        for bits in [12u8, 14, 16] {
            let opts = EncodeOptions {
                bits,
                split_form,
                local_form,
                ..EncodeOptions::default()
            };
            let (bytes, r) = write_to_vec(&pm, &opts).expect("encode");
            let b = r.bits_per_vertex;
            println!(
                "{name:12} bits={bits}: {} bytes, {} chunks; per refined vertex: conn {:.2} + pos {:.2} = {:.2} bits; file {:.2} bits/final vertex; raw stream bytes {:?}",
                bytes.len(), r.chunk_count, b.connectivity, b.positions, b.total, r.file_bits_per_vertex, r.stream_raw_bytes
            );
        }
    }
}
