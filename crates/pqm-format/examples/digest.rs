//! Writes `NAME.json` beside each `NAME.pqm` given: the spec §11 digest of
//! levels 0, n/3, 2n/3 and n by this crate's decoder
//! ([`pqm_format::vectors::digest_file`]). `scripts/test-all.sh` runs it on
//! the real-mesh files of `web/bench/data`, which the JavaScript decoder's
//! `bigfiles` test then decodes and compares level by level.
//!
//! `cargo run -p pqm-format --example digest -- FILE.pqm...`

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: digest FILE.pqm...");
        return ExitCode::from(2);
    }
    for path in &paths {
        let p = Path::new(path);
        let name = p.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
        let written = std::fs::read(p)
            .map_err(|e| e.to_string())
            .and_then(|bytes| {
                pqm_format::vectors::digest_file(name, &bytes).map_err(|e| e.to_string())
            })
            .and_then(|json| {
                std::fs::write(p.with_extension("json"), json).map_err(|e| e.to_string())
            });
        if let Err(e) = written {
            eprintln!("{path}: {e}");
            return ExitCode::FAILURE;
        }
        println!("{}", p.with_extension("json").display());
    }
    ExitCode::SUCCESS
}
