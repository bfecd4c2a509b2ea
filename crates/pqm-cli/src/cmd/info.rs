//! `pqm info`: the header and chunk table of a `.pqm` file.

use crate::ctx::Ctx;
use anyhow::{anyhow, bail, Context};
use pqm_format::{Decoder, Limits};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Show the header and chunk table of a .pqm file.
///
/// Prints format version, counts, bounding box, quantization, and the chunk
/// table: one row per level a streaming client can stop at, with its faces,
/// vertices, geometric error and the bytes needed to reach it.
///
/// The error is the level's geometric error as a fraction of the
/// bounding-box diagonal: what the writer put in the file (`pqm encode`
/// measures it by default, `--level-error bound` writes the coarsener's
/// bound instead). "bytes" is cumulative: a client that has
/// received that many bytes can show that level (an HTTP range request up to
/// it suffices). A truncated file shows what it has so far.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm info spot.pqm
  pqm info spot.pqm --json | jq '.levels[] | select(.faces >= 1000) | .bytes' | head -1")]
pub struct Args {
    /// The .pqm file.
    pub input: PathBuf,
}

/// One level a client can stop at.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct LevelRow {
    /// Level (records applied): 0 for the base mesh, then the level after each chunk.
    pub level: usize,
    pub faces: u32,
    pub vertices: u32,
    /// Geometric error, fraction of the bounding-box diagonal.
    pub error: f64,
    /// File bytes needed to reach this level (cumulative).
    pub bytes: u64,
}

#[derive(Serialize)]
struct Report {
    file: String,
    file_bytes: u64,
    complete: bool,
    version: String,
    flags: u32,
    quant_bits: u8,
    quant_step: [f64; 3],
    /// The quantization grid (spec §5).
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    /// Every level's bounding box: the header's exact bounds (3.2) or else
    /// the grid.
    bounds_min: [f64; 3],
    bounds_max: [f64; 3],
    /// Whether the header holds the exact bounds (format 3.2).
    bounds_stored: bool,
    /// Whether the finest level's quads are meant to split along `v0–v2`
    /// (flag bit 3, format 4.1: a triangle mesh paired into quads).
    finest_diagonals: bool,
    base_vertices: u32,
    base_faces: u32,
    /// How the base section is coded: "traversal" (format 4.0's walk,
    /// spec §6.1) or "delta" (corner deltas); null before the base arrived.
    base_layout: Option<&'static str>,
    final_vertices: u32,
    final_faces: u32,
    records: u32,
    chunks: u32,
    has_vertex_order: bool,
    levels: Vec<LevelRow>,
}

/// Reads `path` (all of it, or the first `limit` bytes) into a decoder.
/// Format errors name the file. Returns the decoder and the bytes read.
pub fn open(path: &Path, limit: Option<u64>) -> anyhow::Result<(Decoder, u64)> {
    use std::io::Read;
    let f = std::fs::File::open(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mut data = Vec::new();
    f.take(limit.unwrap_or(u64::MAX))
        .read_to_end(&mut data)
        .with_context(|| format!("{}: read failed", path.display()))?;
    let mut dec = Decoder::new(Limits::default());
    dec.push(&data)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    if dec.header().is_none() {
        bail!(
            "{}: {} bytes are not enough for the .pqm header and chunk table",
            path.display(),
            data.len()
        );
    }
    Ok((dec, data.len() as u64))
}

/// The stopping points of the file: the base mesh, then one row per chunk.
pub fn level_rows(dec: &Decoder) -> Vec<LevelRow> {
    pqm_format::view::boundaries(dec)
        .into_iter()
        .map(|b| LevelRow {
            level: b.level,
            faces: b.faces,
            vertices: b.vertices,
            error: b.error,
            bytes: b.bytes,
        })
        .collect()
}

/// Geometric error of level `k`: that of the last stopping point at or before it.
pub fn level_error(rows: &[LevelRow], k: usize) -> f64 {
    rows.iter()
        .take_while(|r| r.level <= k)
        .last()
        .map_or(0.0, |r| r.error)
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    let (dec, n) = open(&args.input, None)?;
    let (Some(h), Some(bounds)) = (dec.header(), dec.bounds()) else {
        bail!("{}: no header", args.input.display());
    };
    let status = dec.status();
    let step = dec.quantizer().map_or([0.0; 3], |q| q.step());
    let report = Report {
        file: args.input.display().to_string(),
        file_bytes: n,
        complete: status.finished,
        version: format!("{}.{}", h.version_major, h.version_minor),
        flags: h.flags,
        finest_diagonals: h.finest_diagonals(),
        quant_bits: h.quant_bits,
        quant_step: step,
        bbox_min: h.bbox_min,
        bbox_max: h.bbox_max,
        bounds_min: bounds[0],
        bounds_max: bounds[1],
        bounds_stored: h.bounds.is_some(),
        base_vertices: h.base_vertex_count,
        base_faces: h.base_face_count,
        base_layout: dec.base_layout().map(|l| match l {
            pqm_format::base::BaseLayout::Traversal => "traversal",
            pqm_format::base::BaseLayout::Delta => "delta",
        }),
        final_vertices: h.final_vertex_count,
        final_faces: h.final_face_count,
        records: h.record_count,
        chunks: h.chunk_count,
        has_vertex_order: h.flags
            & (pqm_format::layout::FLAG_VERTEX_ORDER | pqm_format::layout::FLAG_VERTEX_NEIGHBOURS)
            != 0,
        levels: level_rows(&dec),
    };
    if !status.finished {
        ctx.warn(format!(
            "{}: truncated or incomplete after {n} bytes (waiting for the {})",
            report.file,
            status
                .waiting_for
                .map_or("rest".to_string(), |s| s.to_string())
        ));
    }
    ctx.emit_result(&report, || {
        let mut s = String::new();
        let r = &report;
        s.push_str(&format!(
            "file          {} ({} bytes{})\n",
            r.file,
            r.file_bytes,
            if r.complete { "" } else { ", incomplete" }
        ));
        s.push_str(&format!("version       {}\n", r.version));
        if r.finest_diagonals {
            s.push_str("diagonals     the full mesh's quads split along v0-v2 into the input's triangles\n");
        }
        s.push_str(&format!(
            "base mesh     {} faces, {} vertices{}\nfull mesh     {} faces, {} vertices\n",
            r.base_faces,
            r.base_vertices,
            r.base_layout
                .map_or(String::new(), |l| format!(" ({l} layout)")),
            r.final_faces,
            r.final_vertices
        ));
        s.push_str(&format!(
            "records       {} in {} chunks\n",
            r.records, r.chunks
        ));
        let range = |lo: &[f64; 3], hi: &[f64; 3]| {
            format!(
                "[{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]",
                lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
            )
        };
        s.push_str(&format!(
            "bounds        {}{}\n",
            range(&r.bounds_min, &r.bounds_max),
            if r.bounds_stored { "" } else { " (the grid)" }
        ));
        s.push_str(&format!(
            "quantization  {} bits per axis, step [{:.3e}, {:.3e}, {:.3e}], grid {}\n",
            r.quant_bits,
            r.quant_step[0],
            r.quant_step[1],
            r.quant_step[2],
            range(&r.bbox_min, &r.bbox_max)
        ));
        s.push_str(&format!(
            "vertex order  {}\n\n",
            if r.has_vertex_order {
                "stored (full level in input order)"
            } else {
                "not stored"
            }
        ));
        s.push_str(&format!(
            "{:>8} {:>10} {:>10} {:>12} {:>12} {:>7}\n",
            "level", "faces", "vertices", "error", "bytes", "file %"
        ));
        // A truncated file: percentages of the whole file as far as the
        // chunk table tells it (up to its last chunk; optional sections
        // after it are not counted), and the levels not received marked.
        let whole = if r.complete {
            r.file_bytes
        } else {
            r.levels
                .iter()
                .map(|l| l.bytes)
                .max()
                .unwrap_or(0)
                .max(r.file_bytes)
        };
        for row in &r.levels {
            s.push_str(&format!(
                "{:>8} {:>10} {:>10} {:>12.3e} {:>12} {:>6.1}%{}\n",
                row.level,
                row.faces,
                row.vertices,
                row.error,
                row.bytes,
                100.0 * row.bytes as f64 / whole.max(1) as f64,
                if row.bytes > r.file_bytes {
                    "  not received"
                } else {
                    ""
                }
            ));
        }
        if !r.complete {
            s.push_str(&format!(
                "(file %: of the {whole} bytes up to the last chunk; the file has {})\n",
                r.file_bytes
            ));
        }
        s
    })
}
