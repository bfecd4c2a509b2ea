//! `pqm demo`: the main job on the bundled fixture, start to finish.

use crate::cmd::coarsen::run_with_bar;
use crate::cmd::info::{level_error, level_rows, open};
use crate::ctx::Ctx;
use crate::pipeline::{prepare, CoarsenerArgs};
use crate::util::human_bytes;
use anyhow::{anyhow, bail, Context};
use pqm_core::coarsen::{CoarsenOptions, Placement};
use pqm_format::{EncodeOptions, Target};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Run encode -> info -> decode (3 levels) -> GLB on the bundled fixture.
///
/// The fixture is Keenan Crane's Spot (2,928 quads). It is encoded as a
/// progressive .pqm file, the file's chunk table is shown, and three levels
/// (base, middle, full) are decoded to GLB files you can open in any glTF
/// viewer. Prints where the files are.
///
/// The same steps by hand:
///   pqm encode fixtures/spot_quadrangulated.obj -o pqm-demo/spot.pqm
///   pqm info pqm-demo/spot.pqm
///   pqm decode pqm-demo/spot.pqm -o pqm-demo/spot_base.glb --level 0
#[derive(clap::Args, Debug)]
#[command(after_help = "Example:
  cargo run --release -p pqm-cli -- demo --out-dir /tmp/pqm-demo")]
pub struct Args {
    /// Where to write the files (created if missing).
    #[arg(long, value_name = "DIR", default_value = "pqm-demo")]
    pub out_dir: PathBuf,
}

#[derive(Serialize)]
struct LevelFile {
    name: &'static str,
    file: String,
    level: usize,
    faces: usize,
    vertices: usize,
    error: f64,
    bytes_needed: u64,
}

#[derive(Serialize)]
struct Report {
    fixture: String,
    pqm: String,
    input_faces: usize,
    base_faces: usize,
    records: usize,
    bytes: u64,
    bits_per_vertex: f64,
    encode_time_s: f64,
    levels: Vec<LevelFile>,
}

/// The bundled fixtures directory (next to the crate's sources).
pub fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    let fixture = fixtures_dir().join("spot_quadrangulated.obj");
    if !fixture.is_file() {
        bail!(
            "{}: the bundled fixture is missing (pqm demo runs from a checkout of the pqm \
             repository; restore fixtures/spot_quadrangulated.obj)",
            fixture.display()
        );
    }
    let fixture = fixture.canonicalize().unwrap_or(fixture);
    std::fs::create_dir_all(&args.out_dir)
        .with_context(|| format!("{}: cannot create the directory", args.out_dir.display()))?;

    // 1. encode
    let t0 = Instant::now();
    let cargs = CoarsenerArgs {
        importance: None,
        importance_property: None,
        field: None,
        features: None,
        sharp_angle: 60.0,
        placement: None,
        smoothing: None,
        no_subdivide: false,
        triangles: crate::pipeline::TrianglesArg::Pair,
        repair: false,
    };
    // as `pqm encode` does by default
    let opts = CoarsenOptions {
        placement: Placement::Subset,
        round_fraction: super::encode::DEFAULT_ROUND_FRACTION,
        reorder_window: super::encode::DEFAULT_REORDER_WINDOW,
        ..Default::default()
    };
    let mut p = prepare(&fixture, &cargs, opts, ctx)?;
    ctx.note(format!(
        "encoding {} ({} quads)",
        fixture.display(),
        p.quad_faces
    ));
    run_with_bar(&mut p.coarsener, None, "spot", ctx);
    let pm = p.coarsener.into_progressive();
    let pqm = args.out_dir.join("spot.pqm");
    let eopts = EncodeOptions {
        corner_order: super::encode::DEFAULT_CORNER_ORDER.into(),
        ..Default::default()
    };
    let enc = super::encode::write_pqm(
        &pqm,
        &pm,
        &eopts,
        super::encode::DEFAULT_LEVEL_ERROR,
        "spot",
        ctx,
    )
    .with_context(|| format!("{}", fixture.display()))?
    .report;
    let encode_time_s = t0.elapsed().as_secs_f64();

    // 2. info and 3. decode three levels
    let (mut dec, _) = open(&pqm, None)?;
    let rows = level_rows(&dec);
    let last = pm.records.len();
    let mut levels = Vec::new();
    for (name, k) in [("base", 0), ("middle", last / 2), ("full", last)] {
        dec.set_level(Target::Level(k))
            .map_err(|e| anyhow!("{}: {e}", pqm.display()))?;
        let mesh = dec.to_indexed_mesh();
        let file = args.out_dir.join(format!("spot_{name}.glb"));
        crate::util::write_mesh(&file, &mesh)?;
        let bytes_needed = rows
            .iter()
            .find(|r| r.level >= k)
            .map_or(enc.total_bytes, |r| r.bytes);
        levels.push(LevelFile {
            name,
            file: file.display().to_string(),
            level: k,
            faces: mesh.face_count(),
            vertices: mesh.vertex_count(),
            error: level_error(&rows, k),
            bytes_needed,
        });
    }
    let report = Report {
        fixture: fixture.display().to_string(),
        pqm: pqm.display().to_string(),
        input_faces: pm.final_face_count(),
        base_faces: pm.base.face_count(),
        records: pm.records.len(),
        bytes: enc.total_bytes,
        bits_per_vertex: enc.file_bits_per_vertex,
        encode_time_s,
        levels,
    };
    ctx.emit(&report, || {
        let r = &report;
        let mut s = format!(
            "1. encode  {} -> {}\n   {} quads coarsened to a base of {} quads; {} refinement records; \
             {} ({:.1} bits/vertex) in {:.2} s\n\n2. info    (pqm info {})\n",
            r.fixture,
            r.pqm,
            r.input_faces,
            r.base_faces,
            r.records,
            human_bytes(r.bytes),
            r.bits_per_vertex,
            r.encode_time_s,
            r.pqm
        );
        s.push_str(&format!(
            "   {:>7} {:>8} {:>9} {:>11} {:>9}\n",
            "level", "faces", "vertices", "error", "bytes"
        ));
        let step = (rows.len() / 8).max(1);
        for (i, row) in rows.iter().enumerate() {
            if i % step == 0 || i + 1 == rows.len() {
                s.push_str(&format!(
                    "   {:>7} {:>8} {:>9} {:>11.2e} {:>9}\n",
                    row.level, row.faces, row.vertices, row.error, row.bytes
                ));
            }
        }
        s.push_str("\n3. decode  three levels to GLB\n");
        for l in &r.levels {
            s.push_str(&format!(
                "   {:<7} level {:>5}: {:>5} quads, error {:.2e}, first {} of the file -> {}\n",
                l.name,
                l.level,
                l.faces,
                l.error,
                human_bytes(l.bytes_needed),
                l.file
            ));
        }
        s.push_str(&format!(
            "\nFiles are in {}. Open the .glb files in any glTF viewer; try\n  \
             pqm decode {} -o spot_1000.glb --faces 1000\n",
            args.out_dir.display(),
            r.pqm
        ));
        s
    })
}
