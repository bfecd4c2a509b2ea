//! `pqm coarsen`: qCoarsen a quad mesh down to a face count, ratio or error.

use crate::ctx::Ctx;
use crate::pipeline::{prepare, CoarsenerArgs};
use crate::stats::{mesh_stats, MeshStats};
use crate::util::{mesh_output_format, parse_nonneg, parse_ratio};
use pqm_core::coarsen::{CoarsenOptions, CoarsenReport, Coarsener, StopReason};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Coarsen a quad mesh with qCoarsen to a face count, ratio or error bound.
///
/// qvMerge, qeMerge and doublet removal run from one priority queue (the
/// qCoarsen paper's error), and the coarse quad mesh is written. On
/// block-structured CAD meshes (nearly all vertices of valence 4 and many
/// sharp edges, e.g. fandisk) whole quad strips are also collapsed at once
/// ("chord collapses"), which keeps the layout of the singular vertices,
/// and the last steps before a face target are chosen by playing a few
/// alternatives out to the target ("end phase"; slower, fewer irregular
/// vertices).
///
/// The result stays quad-only and valid, with the same topology (components,
/// boundary loops, genus) and every feature curve kept. A triangle mesh is
/// first made quad-only by joining its triangles in pairs (no new vertex;
/// --triangles), else — a triangle that cannot pair, an n-gon — split once
/// (each n-gon into n quads, linear points: the surface is unchanged);
/// the command says which on stderr; --no-subdivide refuses instead. Without a target it goes as far as the quality rules allow.
/// Prints the statistics of input and output, the time, and how many steps
/// of each kind were taken.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm coarsen spot.obj -o spot_700.obj --faces 700
  pqm coarsen fandisk.off -o fandisk_q.obj --ratio 0.1 --sharp-angle 45
  pqm coarsen body.obj -o body_lo.glb --max-error 0.005 --field y --json")]
pub struct Args {
    /// Input mesh (.obj, .off, .ply, .gltf, .glb).
    pub input: PathBuf,
    /// Output mesh (.obj, .off, .ply, .gltf, .glb).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Stop at this many faces (or fewer).
    #[arg(
        long,
        value_name = "N",
        help_heading = "Target (the first reached wins)"
    )]
    pub faces: Option<usize>,
    /// Stop at this fraction of the input's faces, in (0, 1].
    #[arg(long, value_name = "R", value_parser = parse_ratio, help_heading = "Target (the first reached wins)")]
    pub ratio: Option<f64>,
    /// Never exceed this error bound, as a fraction of the bounding-box
    /// diagonal (0.01 = 1 %).
    #[arg(long, value_name = "E", value_parser = parse_nonneg, help_heading = "Target (the first reached wins)")]
    pub max_error: Option<f64>,
    #[command(flatten)]
    pub coarsener: CoarsenerArgs,
    /// Print the statistics of the output mesh (input and output are always
    /// in the summary; this flag is accepted for consistency).
    #[arg(long)]
    pub stats: bool,
}

/// Counts of the coarsener's steps, for reports.
#[derive(Serialize, Clone, Debug)]
pub struct Operators {
    pub qv_merges: usize,
    pub qe_merges: usize,
    pub doublets: usize,
    /// Whole quad strips removed at once (CAD-like inputs only; each is
    /// one record, not counted in `qv_merges`).
    pub chord_collapses: usize,
    /// Steps chosen by the end phase (CAD-like inputs with a face target
    /// only; each is also counted as its own kind above).
    pub end_phase_steps: usize,
    pub rejected: usize,
}

impl Operators {
    /// The counts of a finished run: `r` is what `c.run` returned.
    pub fn of(r: &CoarsenReport, c: &Coarsener) -> Self {
        Operators {
            qv_merges: r.qv_merges,
            qe_merges: r.qe_merges,
            doublets: r.doublets,
            chord_collapses: c.chord_collapses(),
            end_phase_steps: c.end_phase_steps(),
            rejected: r.rejected,
        }
    }
}

#[derive(Serialize)]
struct Report {
    input: String,
    output: String,
    subdivided: bool,
    /// How the quad mesh came from a non-quad input: `none`, `paired` or `split`.
    conversion: crate::pipeline::QuadConversion,
    target_faces: Option<usize>,
    stop: &'static str,
    stop_reason: String,
    time_s: f64,
    error: f64,
    operators: Operators,
    /// What the input holds that the output does not (`texture
    /// coordinates`, `normals`, `face groups`).
    dropped: Vec<&'static str>,
    input_stats: MeshStats,
    output_stats: MeshStats,
}

/// The face count the options aim at (`None` when only an error bound or
/// nothing is given).
pub fn target_faces(faces: Option<usize>, ratio: Option<f64>, input_faces: usize) -> Option<usize> {
    let by_ratio = ratio.map(|r| (r * input_faces as f64).ceil() as usize);
    match (faces, by_ratio) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

/// Runs `c` with a progress bar labelled `label`; returns the report.
pub fn run_with_bar(
    c: &mut Coarsener,
    target: Option<usize>,
    label: &str,
    ctx: &Ctx,
) -> CoarsenReport {
    let start = c.mesh().face_count() as u64;
    let goal = target.unwrap_or(0) as u64;
    let pb = ctx.bar(start.saturating_sub(goal), label.to_string());
    pb.set_message("faces removed");
    let report = c.run(&mut |faces| pb.set_position(start.saturating_sub(faces as u64)));
    pb.finish_and_clear();
    report
}

/// One sentence on why coarsening stopped.
pub fn stop_sentence(r: &CoarsenReport, faces: usize, target: Option<usize>) -> String {
    match (r.stop, target) {
        (Some(StopReason::TargetReached), Some(t)) => format!("reached the target ({t} faces)"),
        (Some(StopReason::TargetReached), None) => "reached the target".to_string(),
        (Some(StopReason::NothingLegal), Some(t)) if faces > t => format!(
            "stopped at {faces} faces, before the target of {t}: no legal step was left \
             (every remaining step would break a quality rule or the error bound)"
        ),
        (Some(StopReason::NothingLegal), _) => {
            "no legal step was left (as far as the quality rules and error bound allow)".to_string()
        }
        (None, _) => "stopped".to_string(),
    }
}

/// Name of the stop reason for JSON.
pub fn stop_code(r: &CoarsenReport) -> &'static str {
    match r.stop {
        Some(StopReason::TargetReached) => "target_reached",
        Some(StopReason::NothingLegal) => "nothing_legal",
        None => "unknown",
    }
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    mesh_output_format(&args.output)?;
    let t0 = Instant::now();
    let opts = CoarsenOptions {
        target_faces: args.faces,
        target_ratio: args.ratio,
        max_error: args.max_error,
        ..Default::default()
    };
    let mut p = prepare(&args.input, &args.coarsener, opts, ctx)?;
    let target = target_faces(args.faces, args.ratio, p.quad_faces);
    let label = args
        .input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let r = run_with_bar(&mut p.coarsener, target, &label, ctx);
    let out = p.coarsener.mesh().to_indexed().0;
    crate::util::write_mesh(&args.output, &out)?;
    let time_s = t0.elapsed().as_secs_f64();
    let report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        subdivided: p.split(),
        conversion: p.conversion,
        target_faces: target,
        stop: stop_code(&r),
        stop_reason: stop_sentence(&r, out.face_count(), target),
        time_s,
        error: r.error,
        operators: Operators::of(&r, &p.coarsener),
        dropped: p.dropped.clone(),
        input_stats: mesh_stats(&p.input, None),
        output_stats: mesh_stats(&out, None),
    };
    if r.stop == Some(StopReason::NothingLegal) && target.is_some_and(|t| out.face_count() > t) {
        ctx.warn(format!("{}: {}", report.input, report.stop_reason));
    }
    ctx.emit(&report, || {
        format!(
            "{} -> {}: {} -> {} faces in {:.2} s; {}\n\
             steps: {} qvMerge, {} qeMerge, {} doublet removals{} ({} candidates rejected); \
             error bound {:.3e} of the bbox diagonal\n\n\
             input ({}{})\n{}\noutput\n{}",
            report.input,
            report.output,
            report.input_stats.faces,
            report.output_stats.faces,
            time_s,
            report.stop_reason,
            r.qv_merges,
            r.qe_merges,
            r.doublets,
            match (p.coarsener.chord_collapses(), p.coarsener.end_phase_steps()) {
                (0, 0) => String::new(),
                (n, 0) => format!(", {n} chord collapses"),
                (n, e) => format!(", {n} chord collapses, {e} steps chosen by the end phase"),
            },
            r.rejected,
            r.error,
            report.input,
            if p.split() {
                ", before the quad split"
            } else {
                ""
            },
            report.input_stats,
            report.output_stats
        )
    })
}
