//! Writes a `.pqm` file with the reference encoder, for the web decoder's
//! benchmark and large-file tests.
//!
//! * `make-pqm synth SPLITS OUT [SEED]` — random quad vertex splits of a
//!   subdivided box (the generator behind `spec/vectors/`), default encoder
//!   options (14 bits, split form, 16 KiB chunks, zstd 19).
//! * `make-pqm mesh IN TARGET_FACES OUT` — coarsens a real mesh file (quad
//!   split first if it is not quad-only) to `TARGET_FACES` with the default
//!   coarsener options and writes its progressive mesh.
//!
//! * `make-pqm digest FILE...` — writes `NAME.json` beside each `NAME.pqm`:
//!   the spec §11 digest of levels 0, n/3, 2n/3 and n by the reference decoder.
//! * `make-pqm check FILE...` — decodes each file with the reference decoder
//!   and prints one line per file: `ok LEVELS DIGEST_POSITIONS DIGEST_QUADS`
//!   of the finest level, or `err MESSAGE` (for differential tests against
//!   the JavaScript decoder).
//!
//! * `make-pqm recode IN OUT` — decodes `IN` and writes its records again
//!   with the default encoder options of the crate it is built against, on
//!   the same quantization grid (e.g. a format 1.1 file as 2.0: the same
//!   levels, to compare decoders on both versions without re-coarsening).
//!
//! `synth`, `mesh` and `recode` print the counts as one JSON line and, when the
//! environment variable `DIGEST` names a file, write the spec §11 JSON digest
//! of levels 0, n/3, 2n/3 and n there (the same as `spec/vectors/*.json`).
use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_core::{io, subdivide, Mesh, ProgressiveMesh};
use pqm_format::{decode_all, vectors, write_to_vec, EncodeOptions, Limits, Target};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: make-pqm synth SPLITS OUT [SEED] | make-pqm mesh IN TARGET_FACES OUT | make-pqm recode IN OUT | make-pqm digest FILE... | make-pqm check FILE...";
    let pm: ProgressiveMesh;
    let out: &str;
    let mut bits = EncodeOptions::default().bits;
    match args.first().map(String::as_str) {
        Some("synth") if args.len() >= 3 => {
            let splits: usize = args[1].parse().expect("SPLITS");
            let seed: u64 = args.get(3).map_or(1, |s| s.parse().expect("SEED"));
            pm = testgen::generate_with(&GenOptions {
                base: BaseShape::Box { n: 4 },
                smooth_prob: 0.0,
                fuse_prob: 0.0,
                ..GenOptions::new(seed, splits)
            });
            out = &args[2];
        }
        Some("mesh") if args.len() >= 4 => {
            let mut im = io::read_mesh(std::path::Path::new(&args[1])).expect("read mesh");
            if !im.is_quad_only() {
                im = subdivide::catmull_clark_split(&im, subdivide::SplitMode::Linear)
                    .expect("quad split");
            }
            let target: usize = args[2].parse().expect("TARGET_FACES");
            let mesh = Mesh::from_indexed(&im).expect("valid mesh");
            let opts = CoarsenOptions {
                target_faces: Some(target),
                ..Default::default()
            };
            let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("coarsener");
            c.run(&mut |_| {});
            pm = c.to_progressive();
            out = &args[3];
        }
        Some("recode") if args.len() >= 3 => {
            let bytes = std::fs::read(&args[1]).expect("read");
            let dec = decode_all(&bytes, Limits::default()).expect("decodes");
            pm = dec.to_progressive_mesh().expect("a decoded base mesh");
            bits = dec.header().map_or(bits, |h| h.quant_bits);
            out = &args[2];
        }
        Some("digest") => {
            // NAME.json next to each NAME.pqm (levels 0, n/3, 2n/3, n)
            for path in &args[1..] {
                let bytes = std::fs::read(path).expect("read");
                let p = std::path::Path::new(path);
                let name = p.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
                let json = vectors::digest_file(name, &bytes).expect("decodes");
                std::fs::write(p.with_extension("json"), json).expect("write digest");
            }
            return;
        }
        Some("check") => {
            for path in &args[1..] {
                let bytes = std::fs::read(path).expect("read");
                match decode_all(&bytes, Limits::default()) {
                    Ok(mut dec) => {
                        let n = dec.deepest_level().unwrap_or(0);
                        let _ = dec.set_level(Target::Level(n));
                        let (p, q) = vectors::level_digests(&dec);
                        let diagonals = dec.header().is_some_and(|h| h.finest_diagonals());
                        println!("{path} ok {n} {p:016x} {q:016x} diagonals {diagonals}");
                    }
                    Err(e) => {
                        // what a streaming decoder keeps after the error
                        let mut dec = pqm_format::Decoder::new(Limits::default());
                        let _ = dec.push(&bytes);
                        println!("{path} err {e} (deepest level {:?})", dec.deepest_level());
                    }
                }
            }
            return;
        }
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    }
    let opts = EncodeOptions {
        bits,
        ..EncodeOptions::default()
    };
    let (bytes, report) = write_to_vec(&pm, &opts).expect("encode");
    std::fs::write(out, &bytes).expect("write");
    if let Ok(digest) = std::env::var("DIGEST") {
        let name = std::path::Path::new(out)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("out");
        let json = vectors::digest_file(name, &bytes).expect("decodes");
        std::fs::write(digest, json).expect("write digest");
    }
    println!(
        "{{\"file\": \"{out}\", \"bytes\": {}, \"records\": {}, \"chunks\": {}, \"base_vertices\": {}, \"base_faces\": {}, \"final_vertices\": {}, \"final_faces\": {}}}",
        bytes.len(),
        pm.records.len(),
        report.chunk_count,
        pm.base.vertex_count(),
        pm.base.face_count(),
        pm.final_vertex_count(),
        pm.final_face_count()
    );
}
