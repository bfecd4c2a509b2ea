//! `pqm convert`: mesh format conversion, optional split and repair.

use crate::ctx::Ctx;
use crate::stats::mesh_stats;
use crate::util::{mesh_input_format, mesh_output_format};
use anyhow::{anyhow, bail};
use pqm_core::bridging::pair_and_bridge;
use pqm_core::io;
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use serde::Serialize;
use std::path::PathBuf;

/// How `--subdivide` splits.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubdivideArg {
    /// Each n-gon into n quads with midpoints and centroids: the surface does
    /// not change.
    Split,
    /// One Catmull-Clark step: the same quads, smoothed positions.
    CatmullClark,
    /// Adjacent triangles joined two by two, no new vertex (quads kept;
    /// polygons of five or more corners cut into triangles first); a
    /// triangle no pairing covers is joined to another, or to the
    /// boundary, by a strip of quads cut at edge midpoints (a few new
    /// vertices, after the input's). An error where even that fails.
    Pair,
}

/// Convert between OBJ, OFF, PLY, glTF and GLB; optionally repair or split into quads.
///
/// Formats are chosen by file extension.
///
/// Quads stay quads in every format (glTF/GLB use FB_ngon_encoding). The
/// input is checked (manifold, oriented, no degenerate or repeated-vertex
/// faces, no unused vertices); --repair fixes what it can and says what it
/// changed: welds exactly duplicated positions, drops unused vertices and
/// degenerate faces, splits non-manifold vertices, re-orients faces.
/// The output is written atomically (never half-written).
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm convert bunny.off bunny.glb
  pqm convert scan.ply scan_quads.obj --repair --subdivide split
  pqm convert cage.obj smooth.obj --subdivide catmull-clark --stats
  pqm convert bunny.off bunny_quads.obj --subdivide pair")]
pub struct Args {
    /// Input mesh (.obj, .off, .ply, .gltf, .glb).
    pub input: PathBuf,
    /// Output mesh (.obj, .off, .ply, .gltf, .glb).
    pub output: PathBuf,
    /// Make the mesh quad-only first: split every n-gon into n quads
    /// (`split`, `catmull-clark`) or join triangles in pairs (`pair`).
    #[arg(long, value_enum, value_name = "MODE")]
    pub subdivide: Option<SubdivideArg>,
    /// Repair the input and report what changed.
    #[arg(long)]
    pub repair: bool,
    /// Print the statistics of the output mesh.
    #[arg(long)]
    pub stats: bool,
}

#[derive(Serialize)]
struct Report {
    input: String,
    output: String,
    vertices: usize,
    faces: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    repair: Option<io::RepairReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stats: Option<crate::stats::MeshStats>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    mesh_input_format(&args.input)?;
    mesh_output_format(&args.output)?;
    let name = args.input.display();
    let mut mesh = io::read_mesh(&args.input).map_err(|e| anyhow!("{e}"))?;
    let mut repair = None;
    if args.repair {
        let r = io::repair(&mut mesh);
        if r.changed() {
            ctx.note(format!("{name}: repaired: {r}"));
        } else {
            ctx.note(format!("{name}: repair: nothing to change"));
        }
        repair = Some(r);
    }
    if let Err(e) = io::check(&mesh) {
        let hint = if args.repair {
            ""
        } else {
            " (--repair may fix it)"
        };
        bail!("{name}: {e}{hint}");
    }
    let before = mesh.face_count();
    match args.subdivide {
        None => {}
        Some(SubdivideArg::Pair) => {
            let (paired, r, b) = pair_and_bridge(&mesh)
                .map_err(|e| anyhow!("{name}: {e} (--subdivide split makes any mesh quad-only)"))?;
            mesh = paired;
            let strips = match b.lone {
                0 => String::new(),
                n => format!(
                    "; {n} triangles no pairing covers joined by {} strips with {} new vertices",
                    b.strips + b.boundary_strips,
                    b.new_vertices()
                ),
            };
            ctx.note(format!(
                "{name}: joined {} triangles in {} pairs ({} folded or not convex){strips}: \
                 {before} faces -> {} quads",
                r.triangles,
                r.pairs,
                r.folded,
                mesh.face_count()
            ));
        }
        Some(mode) => {
            let mode = if mode == SubdivideArg::Split {
                SplitMode::Linear
            } else {
                SplitMode::CatmullClark
            };
            mesh = catmull_clark_split(&mesh, mode).map_err(|e| anyhow!("{name}: {e}"))?;
            ctx.note(format!(
                "{name}: split {before} faces into {} quads",
                mesh.face_count()
            ));
        }
    }
    crate::util::write_mesh(&args.output, &mesh)?;
    let stats = args.stats.then(|| mesh_stats(&mesh, None));
    let report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        vertices: mesh.vertex_count(),
        faces: mesh.face_count(),
        repair,
        stats,
    };
    ctx.emit(&report, || {
        let mut s = format!(
            "wrote {} ({} vertices, {} faces)",
            report.output, report.vertices, report.faces
        );
        if let Some(st) = &report.stats {
            s.push_str(&format!("\n{st}"));
        }
        s
    })
}
