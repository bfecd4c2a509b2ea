//! Hausdorff distance between two mesh files (OBJ or OFF), as used by
//! `scripts/hausdorff_check.py`.
//!
//! ```text
//! cargo run --release -p pqm-core --example hausdorff -- MESH REFERENCE \
//!     [--samples N] [--no-vertices] [--no-edges] [--no-faces] [--json]
//! ```
//!
//! Prints the forward (MESH → REFERENCE), backward and symmetric `{max, mean}`
//! in units of REFERENCE's bounding-box diagonal, plus the absolute figures.
//! Files are read with `pqm_core::io::read_mesh` (any supported format).

use pqm_core::metrics::hausdorff::{hausdorff, HausdorffOptions};
use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let mut files = Vec::new();
    let mut json = false;
    let mut opts = HausdorffOptions::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--json" => json = true,
            "--no-vertices" => opts.sample_vertices = false,
            "--no-edges" => opts.sample_edges = false,
            "--no-faces" => opts.sample_faces = false,
            "--samples" => {
                let n = args.next().ok_or("--samples needs a number")?;
                opts.samples = Some(n.parse().map_err(|_| format!("bad sample count {n:?}"))?);
            }
            _ if a.starts_with("--") => return Err(format!("unknown option {a}")),
            _ => files.push(a),
        }
    }
    let [mesh, reference] = files.as_slice() else {
        return Err(
            "usage: hausdorff MESH REFERENCE [--samples N] [--no-vertices] \
                    [--no-edges] [--no-faces] [--json]"
                .into(),
        );
    };
    let mesh = load(Path::new(mesh))?;
    let reference = load(Path::new(reference))?;
    let start = std::time::Instant::now();
    let r = hausdorff(&mesh, &reference, &opts);
    let seconds = start.elapsed().as_secs_f64();
    if json {
        let value = serde_json::json!({
            "report": r,
            "absolute": {
                "forward": { "max": r.forward.max * r.unit, "mean": r.forward.mean * r.unit },
                "backward": { "max": r.backward.max * r.unit, "mean": r.backward.mean * r.unit },
            },
            "seconds": seconds,
        });
        println!("{value}");
    } else {
        println!("reference diagonal  {:.6}", r.unit);
        for (name, s, n) in [
            ("forward  (mesh -> ref)", r.forward, r.forward_samples),
            ("backward (ref -> mesh)", r.backward, r.backward_samples),
            (
                "symmetric",
                r.symmetric,
                r.forward_samples + r.backward_samples,
            ),
        ] {
            println!(
                "{name:<24} max {:.6e}  mean {:.6e}  ({n} samples)",
                s.max, s.mean
            );
        }
        println!("time {seconds:.3} s");
    }
    Ok(())
}

fn load(path: &Path) -> Result<pqm_core::IndexedMesh, String> {
    pqm_core::io::read_mesh(path).map_err(|e| e.to_string())
}
