//! What each [`CornerOrder`] costs and what it draws (issue 4's size
//! target). Re-encodes each file's records (no vertex-order section, the
//! file's bits, grid and the other defaults) under `Input`, `Diagonal` and
//! `Canonical`, and prints per order the bytes, the bits per final vertex
//! of the records and base (`file_bits_per_vertex` without the section),
//! the record forms, and two figures of the finest level that the order
//! changes: the fraction of quads split along their shorter diagonal (the
//! `(v0, v2)` that [`pqm_format::quad_triangles`] draws) and the mean angle
//! between the normals of each quad's two triangles.
//!
//! `cargo run --release -p pqm-format --example corner_order_study -- FILE.pqm...`
//!
//! ## Figures (session 22; files of session 18's `pqm encode`, `diagonal`)
//!
//! A file written with `Diagonal` holds quads already turned by 2, so here
//! `input` draws the same triangles as `diagonal` (the input's); the two
//! differ in bytes because the turning orders write a doublet that fits
//! both forms as a face split (`Coding::face_split_first`).
//!
//! | file | input | diagonal | canonical | shorter diagonal: input / canonical | mean fold: input / canonical |
//! |---|---|---|---|---|---|
//! | spot | 16,107 B, 43.98 b/v | 15,975 B, 43.62 | 15,579 B, 42.54 | 0.493 / 0.504 | 3.86° / 3.81° |
//! | makehuman | 84,505 B, 35.29 | 83,031 B, 34.67 | 80,097 B, 33.45 | 0.519 / 0.523 | 7.06° / 7.04° |
//! | loki | 122,478 B, 35.61 | 120,016 B, 34.90 | 115,846 B, 33.68 | 0.506 / 0.500 | 3.99° / 3.94° |
//! | bunny (split) | 898,405 B, 34.39 | 878,307 B, 33.62 | 850,133 B, 32.54 | 0.391 / 0.573 | 0.86° / 0.96° |
//!
//! The input's diagonals are no better than the canonical ones: about half
//! of its quads are split along the shorter diagonal (fewer on the split
//! bunny), and the triangles fold alike.

use pqm_format::{write_stored, CornerOrder, EncodeOptions, EncodeReport};

#[path = "common/models.rs"]
mod models;

fn main() {
    models::study_files("corner_order_study", study);
}

/// Shorter-diagonal fraction and mean fold (degrees) of `pm`'s finest level.
fn diagonals(pm: &pqm_core::ProgressiveMesh) -> (f64, f64) {
    let (p, q) = pm.level_quads(pm.records.len());
    let (mut shorter, mut fold) = (0usize, 0.0f64);
    for f in &q {
        let [a, b, c, d] = f.map(|i| p[i as usize]);
        shorter += ((a - c).length() <= (b - d).length()) as usize;
        let n1 = (b - a).cross(c - a).normalize_or_zero();
        let n2 = (c - a).cross(d - a).normalize_or_zero();
        fold += n1.dot(n2).clamp(-1.0, 1.0).acos().to_degrees();
    }
    let n = q.len().max(1) as f64;
    (shorter as f64 / n, fold / n)
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened { dec, pm, .. } = models::open(f)?;
    let h = dec.header().ok_or("no header")?;
    println!("## {f}");
    println!("| order | bytes | bits/vertex | split / face split / edge split / local / general | shorter diagonal | mean fold |");
    println!("|---|---:|---:|---|---:|---:|");
    for (name, corner_order) in [
        ("input", CornerOrder::Input),
        ("diagonal", CornerOrder::Diagonal),
        ("canonical", CornerOrder::Canonical),
    ] {
        let opts = EncodeOptions {
            bits: h.quant_bits,
            vertex_order: false,
            corner_order,
            ..EncodeOptions::default()
        };
        let mut bytes = Vec::new();
        let (r, stored): (EncodeReport, _) =
            write_stored(&pm, &opts, &mut bytes).map_err(|e| e.to_string())?;
        let (shorter, fold) = diagonals(&stored);
        println!(
            "| {name} | {} | {:.2} | {} / {} / {} / {} / {} | {shorter:.3} | {fold:.2}° |",
            bytes.len(),
            r.file_bits_per_vertex,
            r.split_records,
            r.face_split_records,
            r.edge_split_records,
            r.local_records,
            r.general_records
        );
    }
    Ok(())
}
