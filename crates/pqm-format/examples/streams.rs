//! Where the bits of a `.pqm` file go: decodes each given file, re-encodes
//! its records with this crate's encoder (same grid, default options) and
//! prints, per operator kind, how many records, which forms, the average
//! new / moved / rewritten / appended counts, and the compressed bits per
//! refined vertex each stream takes.
//!
//! `cargo run --release -p pqm-format --example streams -- [--v1|--v2|--v3] [--no-local] [--no-face-split] FILE.pqm...`
//! (write the files with `pqm encode`; re-encoding skips the coarsener;
//! by default as this crate's newest version (4.0); `--v3` as 3.x (the
//! delta base layout, version-2 prediction); `--v2` as version 2.0 — no
//! edge-split form; `--v1` as
//! version 1.1 — version-1 prediction, no face-split form; `--no-local` without the local form, as version 1.0 did;
//! `--no-face-split` without the face-split form; `--write` also saves the
//! re-encoded file beside the input as `NAME.reencoded.pqm`; `--input-corners`
//! re-encodes with the library's default corner order, `Input`, instead of
//! `pqm encode`'s `Canonical`, whose files this then describes as written).

use pqm_format::{decode_all, write_to_vec, EncodeOptions, Limits};

const OPS: [&str; 4] = ["qvMerge", "qeMerge", "doublet", "smooth"];

fn main() {
    let mut files: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| files.iter().any(|f| f == name);
    let local_form = !flag("--no-local");
    let face_split_form = !flag("--no-face-split");
    let version_major = if flag("--v1") {
        1
    } else if flag("--v2") {
        2
    } else if flag("--v3") {
        3
    } else {
        pqm_format::layout::VERSION_MAJOR
    };
    let write = flag("--write");
    // `pqm encode`'s corner order: its files' quads already start where
    // the decoder builds them, so the records come out as the file has
    // them (doublets as face splits where both forms fit).
    let corner_order = if flag("--input-corners") {
        pqm_format::CornerOrder::Input
    } else {
        pqm_format::CornerOrder::Canonical
    };
    files.retain(|f| !f.starts_with("--"));
    if files.is_empty() {
        eprintln!("usage: streams FILE.pqm...");
        std::process::exit(2);
    }
    for f in files {
        let bytes = match std::fs::read(&f) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{f}: {e}");
                continue;
            }
        };
        let dec = match decode_all(&bytes, Limits::none()) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{f}: {e}");
                continue;
            }
        };
        let Some(pm) = dec.to_progressive_mesh() else {
            eprintln!("{f}: nothing decoded");
            continue;
        };
        let bits = dec.header().map_or(14, |h| h.quant_bits);
        let opts = EncodeOptions {
            bits,
            local_form,
            face_split_form,
            version_major,
            corner_order,
            ..EncodeOptions::default()
        };
        let (out, r) = match write_to_vec(&pm, &opts) {
            Ok(x) => x,
            Err(e) => {
                eprintln!("{f}: re-encode: {e}");
                continue;
            }
        };
        if write {
            let to = std::path::Path::new(&f).with_extension("reencoded.pqm");
            if let Err(e) = std::fs::write(&to, &out) {
                eprintln!("{}: {e}", to.display());
            }
        }
        let n = r.refined_vertices.max(1) as f64;
        println!(
            "## {f}: {} → {} bytes; {} records, {} refined vertices; bits/refined vertex: conn {:.1} + pos {:.1} = {:.1} (file {:.1} bits/final vertex)",
            bytes.len(),
            out.len(),
            pm.records.len(),
            r.refined_vertices,
            r.bits_per_vertex.connectivity,
            r.bits_per_vertex.positions,
            r.bits_per_vertex.total,
            r.file_bits_per_vertex
        );
        println!("| op | records | forms g/s/l/f/e | avg new | avg moved | avg rewritten | avg appended | ops | conn | refs | slots | pos | total (bits/refined vertex) |");
        println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        let mut tot = [0f64; 5];
        for (o, s) in r.per_op.iter().enumerate() {
            if s.records == 0 {
                continue;
            }
            let k = s.records as f64;
            let b: Vec<f64> = s.bytes.iter().map(|x| 8.0 * x / n).collect();
            for t in 0..5 {
                tot[t] += b[t];
            }
            println!(
                "| {} | {} | {}/{}/{}/{}/{} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
                OPS[o],
                s.records,
                s.forms[0],
                s.forms[1],
                s.forms[2],
                s.forms[3],
                s.forms[4],
                s.new as f64 / k,
                s.moved as f64 / k,
                s.rewritten as f64 / k,
                s.appended as f64 / k,
                b[0],
                b[1],
                b[2],
                b[3],
                b[4],
                b.iter().sum::<f64>()
            );
        }
        println!(
            "| all | {} | | | | | | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            pm.records.len(),
            tot[0],
            tot[1],
            tot[2],
            tot[3],
            tot[4],
            tot.iter().sum::<f64>()
        );
        println!("raw stream bytes {:?}\n", r.stream_raw_bytes);
    }
}
