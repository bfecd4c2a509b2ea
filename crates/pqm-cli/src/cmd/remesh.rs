//! `pqm remesh`: the qCoarsen paper's simplification-based quad remeshing
//! (section 5) on any polygon mesh — see `pqm_core::remesh`.

use crate::cmd::levels::{write_mesh_with, GltfArgs};
use crate::ctx::Ctx;
use crate::pipeline::{load_mesh, SmoothingArg};
use crate::stats::{mesh_stats, MeshStats};
use crate::util::{mesh_output_format, parse_ratio};
use anyhow::anyhow;
use pqm_core::coarsen::CoarsenReport;
use pqm_core::io::MeshFormat;
use pqm_core::remesh::{
    remesh_with_progress, RemeshOptions, RemeshPhase, RemeshTiming, StageStats, MAX_LEVELS,
};
use serde::Serialize;
use std::path::PathBuf;

/// Remesh any polygon mesh (triangles, quads, n-gons, any genus) into a
/// clean, curvature-adaptive quad mesh.
///
/// The pipeline of the qCoarsen paper (section 5): split every n-gon into n
/// quads (linear points, the surface does not move), coarsen with qCoarsen
/// to --ratio of the split's faces (curvature-based importance and field,
/// sharp edges kept), subdivide --levels times with Catmull-Clark, and move
/// every vertex onto the original surface (closest point, through a BVH).
/// The output has about ratio × 4^levels × (input corners) quads — with the
/// defaults, as many quads as the input has corners.
///
/// The report gives, for the split (before), the coarse mesh and the output
/// (after): faces, vertices, vertex structure (ideal %, extraordinary,
/// worst valence) and the symmetric Hausdorff distance to the input in
/// units of the input's bounding-box diagonal; plus the time of each phase.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm remesh fertility.off -o fertility_quads.obj
  pqm remesh bunny.off -o bunny.glb --ratio 0.1 --levels 2 --normals smooth
  pqm remesh part.obj -o part_quads.ply --sharp-angle 40 --json --stats")]
pub struct Args {
    /// Input mesh (.obj, .off, .ply, .gltf, .glb), any polygons.
    pub input: PathBuf,
    /// Output mesh (.obj, .off, .ply, .gltf, .glb).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Coarsen to this fraction of the split mesh's faces, in (0, 1].
    #[arg(long, value_name = "R", default_value_t = 0.25, value_parser = parse_ratio)]
    pub ratio: f64,
    /// Catmull-Clark subdivision steps after coarsening (0 to 6; each ×4 faces).
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(0..=MAX_LEVELS as i64))]
    pub levels: u32,
    /// Edges with a dihedral angle above DEG degrees are features the
    /// coarsener keeps; 180 turns automatic features off.
    #[arg(long, value_name = "DEG", default_value_t = 60.0)]
    pub sharp_angle: f64,
    /// Where the coarsener smooths vertices.
    #[arg(long, value_enum, default_value = "global")]
    pub smoothing: SmoothingArg,
    /// Skip the Hausdorff measurements (faster on big meshes).
    #[arg(long)]
    pub no_hausdorff: bool,
    /// Repair the input first (weld duplicates, drop unused vertices, split
    /// non-manifold vertices, re-orient) and report what changed.
    #[arg(long)]
    pub repair: bool,
    #[command(flatten)]
    pub gltf: GltfArgs,
    /// Print the statistics of the output mesh.
    #[arg(long)]
    pub stats: bool,
}

#[derive(Serialize)]
struct Stages<'a> {
    /// The split input (before).
    split: &'a StageStats,
    coarse: &'a StageStats,
    /// The remeshed output (after).
    output: &'a StageStats,
}

#[derive(Serialize)]
struct Report<'a> {
    input: String,
    output: String,
    input_faces: usize,
    ratio: f64,
    levels: u32,
    sharp_angle: f64,
    stages: Stages<'a>,
    coarsen: &'a CoarsenReport,
    timing: RemeshTiming,
    #[serde(skip_serializing_if = "Option::is_none")]
    stats: Option<MeshStats>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    let format = mesh_output_format(&args.output)?;
    if args.gltf.any() && !matches!(format, MeshFormat::Gltf | MeshFormat::Glb) {
        ctx.warn(format!(
            "{}: --normals/--quantize/--quad-split apply to .gltf/.glb output only; ignored",
            args.output.display()
        ));
    }
    if !(0.0..=180.0).contains(&args.sharp_angle) {
        return Err(crate::ctx::usage(format!(
            "--sharp-angle {} is not in [0, 180] degrees",
            args.sharp_angle
        )));
    }
    let name = args.input.display().to_string();
    let input = load_mesh(&args.input, args.repair, ctx)?;
    let opts = RemeshOptions {
        ratio: args.ratio,
        levels: args.levels,
        sharp_angle: args.sharp_angle,
        smoothing: args.smoothing.into(),
        measure: !args.no_hausdorff,
    };
    let spinner = ctx.spinner(
        args.input
            .file_name()
            .map_or_else(|| name.clone(), |s| s.to_string_lossy().into_owned()),
    );
    let mut on_phase = |p: RemeshPhase| match p {
        RemeshPhase::Split => spinner.set_message("splitting into quads"),
        RemeshPhase::Coarsen(f) => spinner.set_message(format!("coarsening: {f} faces")),
        RemeshPhase::Subdivide => spinner.set_message("subdividing"),
        RemeshPhase::Project => spinner.set_message("projecting onto the input"),
        RemeshPhase::Measure => spinner.set_message("measuring"),
    };
    let result = remesh_with_progress(&input, &opts, &mut on_phase);
    spinner.finish_and_clear();
    let r = result.map_err(|e| anyhow!("{name}: {e}"))?;
    write_mesh_with(&args.output, &r.mesh, &args.gltf.options())?;

    let report = Report {
        input: name,
        output: args.output.display().to_string(),
        input_faces: input.face_count(),
        ratio: args.ratio,
        levels: args.levels,
        sharp_angle: args.sharp_angle,
        stages: Stages {
            split: &r.split,
            coarse: &r.coarse,
            output: &r.output,
        },
        coarsen: &r.coarsen,
        timing: r.timing,
        stats: args.stats.then(|| mesh_stats(&r.mesh, Some(&input))),
    };
    ctx.emit(&report, || text(&report))
}

fn text(r: &Report<'_>) -> String {
    let mut s = format!(
        "remeshed {} ({} faces) -> {}: ratio {}, {} subdivision level(s)\n",
        r.input, r.input_faces, r.output, r.ratio, r.levels
    );
    s.push_str(&format!(
        "{:<8} {:>9} {:>9} {:>8} {:>8} {:>6} {:>12} {:>12}\n",
        "stage", "faces", "vertices", "ideal", "extraord", "worst", "hausdorff", "mean"
    ));
    for (label, st) in [
        ("split", r.stages.split),
        ("coarse", r.stages.coarse),
        ("output", r.stages.output),
    ] {
        let (hmax, hmean) = st
            .hausdorff
            .map_or(("-".to_string(), "-".to_string()), |h| {
                (format!("{:.3e}", h.max), format!("{:.3e}", h.mean))
            });
        s.push_str(&format!(
            "{:<8} {:>9} {:>9} {:>7.1}% {:>8} {:>6} {:>12} {:>12}\n",
            label,
            st.faces,
            st.vertices,
            100.0 * st.valence.ideal_fraction,
            st.valence.extraordinary,
            st.valence.worst,
            hmax,
            hmean
        ));
    }
    s.push_str("(hausdorff: symmetric, in units of the input's bounding-box diagonal)\n");
    let c = r.coarsen;
    s.push_str(&format!(
        "coarsener: {} qvMerge, {} qeMerge, {} doublets; {}\n",
        c.qv_merges,
        c.qe_merges,
        c.doublets,
        match c.stop {
            Some(pqm_core::coarsen::StopReason::NothingLegal) =>
                "stopped early: no legal step left",
            _ => "target reached",
        }
    ));
    let t = &r.timing;
    s.push_str(&format!(
        "time: split {:.2} s, coarsen {:.2} s, subdivide {:.2} s, project {:.2} s, measure {:.2} s, total {:.2} s",
        t.split, t.coarsen, t.subdivide, t.project, t.measure, t.total
    ));
    if let Some(st) = &r.stats {
        s.push_str(&format!("\n{st}"));
    }
    s
}
