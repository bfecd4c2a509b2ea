//! What the vertex order costs: re-encodes each given `.pqm` file's records
//! with its vertex order as a `VORD` section (3.0, deltas) and as a `VNBR`
//! section (3.1, coded against the mesh, spec §8.2), checks that both decode
//! to the same permutation, and prints section and whole-file bits per
//! final vertex plus the order's FNV-1a 64 digest (spec §11; the JS decoder
//! must give the same).
//!
//! `cargo run --release -p pqm-format --example vertex_order -- FILE.pqm...`

use pqm_format::{
    decode_all, vectors, vorder, write_to_vec, EncodeOptions, Limits, VertexOrderCode,
};

fn main() {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        eprintln!("usage: vertex_order FILE.pqm...");
        std::process::exit(2);
    }
    println!("| file | final vertices | VORD bits/vertex | VNBR bits/vertex | file bits/vertex VORD → VNBR | VNBR escapes | VNBR encode / decode (ms) | order digest |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    for f in files {
        let run = || -> Result<String, String> {
            let bytes = std::fs::read(&f).map_err(|e| e.to_string())?;
            let dec = decode_all(&bytes, Limits::none()).map_err(|e| e.to_string())?;
            let pm = dec.to_progressive_mesh().ok_or("nothing decoded")?;
            if pm.vertex_order.is_empty() {
                return Err("the file has no vertex order".into());
            }
            let bits = dec.header().map_or(14, |h| h.quant_bits);
            let n = pm.vertex_order.len() as f64;
            let mut cells = Vec::new();
            let mut orders = Vec::new();
            for deltas in [true, false] {
                let opts = EncodeOptions {
                    bits,
                    vertex_order_code: if deltas {
                        VertexOrderCode::Deltas
                    } else {
                        VertexOrderCode::Neighbours
                    },
                    ..EncodeOptions::default()
                };
                let (out, r) = write_to_vec(&pm, &opts).map_err(|e| e.to_string())?;
                let back = decode_all(&out, Limits::none()).map_err(|e| e.to_string())?;
                orders.push(
                    back.vertex_order()
                        .map_err(|e| e.to_string())?
                        .map(<[u32]>::to_vec),
                );
                // The section header (16 bytes) is counted with its section.
                cells.push((8.0 * r.section_bytes as f64 / n, r.file_bits_per_vertex));
            }
            if orders[0] != orders[1] || orders[0].as_deref() != Some(&pm.vertex_order[..]) {
                return Err("VORD and VNBR decode to different orders".into());
            }
            // The VNBR coding alone, timed (best of 3).
            let (_, quads) = pm.level_quads(pm.records.len());
            let base = pm.base.vertex_count();
            let best = |f: &dyn Fn()| {
                (0..3)
                    .map(|_| {
                        let t = std::time::Instant::now();
                        f();
                        t.elapsed().as_secs_f64() * 1e3
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            let payload = vorder::encode(&pm.vertex_order, &quads, base)?;
            let enc_ms = best(&|| {
                vorder::encode(&pm.vertex_order, &quads, base).unwrap();
            });
            let dec_ms = best(&|| {
                vorder::decode(&payload, pm.vertex_order.len(), &quads, base).unwrap();
            });
            let escapes = payload[..pm.vertex_order.len()]
                .iter()
                .filter(|&&s| s == vorder::SYM_ESCAPE)
                .count();
            Ok(format!(
                "{} | {:.1} | {:.1} | {:.1} → {:.1} | {:.0} % | {enc_ms:.1} / {dec_ms:.1} | {:016x}",
                n,
                cells[0].0,
                cells[1].0,
                cells[0].1,
                cells[1].1,
                100.0 * escapes as f64 / n,
                vectors::vertex_order_digest(&pm.vertex_order)
            ))
        };
        match run() {
            Ok(row) => println!("| {f} | {row} |"),
            Err(e) => eprintln!("{f}: {e}"),
        }
    }
}
