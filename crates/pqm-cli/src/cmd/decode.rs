//! `pqm decode`: write any level of a `.pqm` file as a mesh.

use crate::cmd::info::{level_error, level_rows, open};
use crate::cmd::levels::{write_mesh_with, GltfArgs};
use crate::ctx::Ctx;
use crate::stats::{mesh_stats, MeshStats};
use crate::util::{mesh_output_format, parse_nonneg};
use anyhow::{anyhow, bail};
use pqm_core::io::{self, MeshFormat};
use pqm_core::IndexedMesh;
use pqm_format::Target;
use serde::Serialize;
use std::path::PathBuf;

/// Decode any level of a .pqm file to .glb, .gltf, .obj, .ply or .off.
///
/// Quads stay quads (glTF: FB_ngon_encoding).
///
/// Pick the level with --level, --faces (the finest level with at most N
/// faces) or --error (the coarsest level whose geometric error is at most E,
/// a fraction of the bounding-box diagonal); without them, the full mesh.
/// --bytes B decodes only the first B bytes of the file, as a client that
/// has received that much would, and writes the deepest level they hold
/// (or the chosen level, if it is coarser). The full level is written with
/// the input's vertex order when the file stores it, so it equals the
/// encoder's input with positions snapped to the quantization grid; for a
/// triangle input, which `pqm encode` pairs into quads, --triangulate
/// writes its own triangles back.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm decode spot.pqm -o spot.glb
  pqm decode spot.pqm -o spot_base.obj --level 0
  pqm decode spot.pqm -o spot_1k.glb --faces 1000 --stats
  pqm decode spot.pqm -o first_20k.glb --bytes 20000
  pqm decode spot.pqm -o spot_q.glb --normals smooth --quantize
  pqm decode bunny.pqm -o bunny_tris.ply --triangulate")]
#[command(group(clap::ArgGroup::new("target").args(["level", "faces", "error"])))]
pub struct Args {
    /// The .pqm file.
    pub input: PathBuf,
    /// Output mesh (.glb, .gltf, .obj, .ply, .off).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Level K: records 0..K applied (0 = base mesh).
    #[arg(long, value_name = "K")]
    pub level: Option<usize>,
    /// The finest level with at most N faces.
    #[arg(long, value_name = "N")]
    pub faces: Option<usize>,
    /// The coarsest level whose geometric error (as `pqm info` lists it)
    /// is at most E (fraction of the bounding-box diagonal).
    #[arg(long, value_name = "E", value_parser = parse_nonneg)]
    pub error: Option<f64>,
    /// Use only the first B bytes of the file.
    #[arg(long, value_name = "B")]
    pub bytes: Option<u64>,
    /// Print the statistics of the output mesh.
    #[arg(long)]
    pub stats: bool,
    /// Write triangles, each quad split along the diagonal --quad-split
    /// picks: with `auto`, the full level of a triangle mesh `pqm encode`
    /// paired into quads gives back exactly the input's triangles (the file
    /// says its diagonals are meant, format 4.1), other levels and files
    /// split along the shorter diagonal.
    #[arg(long)]
    pub triangulate: bool,
    #[command(flatten)]
    pub gltf: GltfArgs,
}

#[derive(Serialize)]
struct Report {
    input: String,
    output: String,
    level: usize,
    final_level: usize,
    deepest_available: usize,
    faces: usize,
    vertices: usize,
    error: f64,
    bytes_read: u64,
    complete: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    stats: Option<MeshStats>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    mesh_output_format(&args.output)?;
    let name = args.input.display().to_string();
    let (mut dec, n) = open(&args.input, args.bytes)?;
    let status = dec.status();
    let Some(deepest) = dec.deepest_level() else {
        bail!(
            "{name}: the first {n} bytes do not hold the base mesh yet{}",
            level_rows(&dec)
                .first()
                .map_or(String::new(), |r| format!(" (it ends at byte {})", r.bytes))
        );
    };
    if !status.finished && args.bytes.is_none() {
        bail!(
            "{name}: the file is truncated or incomplete after {n} bytes (waiting for the {}); \
             pass --bytes {n} to decode what it holds",
            status
                .waiting_for
                .map_or("rest".to_string(), |s| s.to_string())
        );
    }
    let target = match (args.level, args.faces, args.error) {
        (Some(k), _, _) => Target::Level(k),
        (_, Some(f), _) => Target::Faces(f),
        (_, _, Some(e)) => Target::Error(e),
        _ => Target::Level(deepest),
    };
    if let Some(k) = args.level {
        if k > deepest {
            let total = dec.header().map_or(0, |h| h.record_count as usize);
            if k > total {
                bail!("{name}: level {k} does not exist (the file has levels 0..={total})");
            }
            ctx.note(format!(
                "{name}: level {k} is not in the bytes read; writing level {deepest}, the deepest available"
            ));
        }
    }
    dec.set_level(target).map_err(|e| anyhow!("{name}: {e}"))?;
    let level = dec.level();
    let final_level = dec.header().map_or(level, |h| h.record_count as usize);
    let mut mesh = dec.to_indexed_mesh();
    if level == final_level {
        // Decoded here, on first use; a bad section fails the export.
        if let Some(order) = dec.vertex_order().map_err(|e| anyhow!("{name}: {e}"))? {
            match to_input_order(&mesh, order) {
                Some(m) => mesh = m,
                None => ctx.warn(format!(
                    "{name}: the stored vertex order is not a permutation; kept the file's order"
                )),
            }
        }
    }
    let format = mesh_output_format(&args.output)?;
    let gltf = matches!(format, MeshFormat::Gltf | MeshFormat::Glb);
    if !gltf && (args.gltf.any_shading() || (args.gltf.any() && !args.triangulate)) {
        ctx.warn(format!(
            "{}: --normals/--quantize{} apply to .gltf/.glb output only",
            args.output.display(),
            if args.triangulate {
                ""
            } else {
                " and --quad-split (without --triangulate)"
            }
        ));
    }
    // The finest level of a paired triangle mesh splits into the input's
    // own triangles along each quad's v0–v2 (header flag bit 3).
    let meant = level == final_level && dec.header().is_some_and(|h| h.finest_diagonals());
    let options = args.gltf.options_for(meant);
    if args.triangulate {
        mesh = io::triangulate(&mesh, options.quad_split);
    }
    write_mesh_with(&args.output, &mesh, &options)?;
    let rows = level_rows(&dec);
    let report = Report {
        input: name,
        output: args.output.display().to_string(),
        level,
        final_level,
        deepest_available: deepest,
        faces: mesh.face_count(),
        vertices: mesh.vertex_count(),
        error: level_error(&rows, level),
        bytes_read: n,
        complete: status.finished,
        stats: args.stats.then(|| mesh_stats(&mesh, None)),
    };
    ctx.emit(&report, || {
        let mut s = format!(
            "wrote {}: level {} of {} ({} faces, {} vertices, error {:.3e}) from {} bytes",
            report.output,
            report.level,
            report.final_level,
            report.faces,
            report.vertices,
            report.error,
            report.bytes_read
        );
        if let Some(st) = &report.stats {
            s.push_str(&format!("\n{st}"));
        }
        s
    })
}

/// `mesh` renumbered so canonical vertex `c` becomes `order[c]`; `None`
/// when `order` is not a permutation of the vertices.
fn to_input_order(mesh: &IndexedMesh, order: &[u32]) -> Option<IndexedMesh> {
    let n = mesh.vertex_count();
    if order.len() != n {
        return None;
    }
    let mut seen = vec![false; n];
    let mut positions = vec![glam::DVec3::ZERO; n];
    for (c, &o) in order.iter().enumerate() {
        let o = o as usize;
        if o >= n || seen[o] {
            return None;
        }
        seen[o] = true;
        positions[o] = mesh.positions[c];
    }
    let faces: Vec<Vec<u32>> = mesh
        .faces()
        .map(|f| f.iter().map(|&v| order[v as usize]).collect())
        .collect();
    Some(IndexedMesh::from_faces(positions, faces))
}
