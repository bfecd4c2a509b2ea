//! `pqm encode`: coarsen to a base mesh and write a progressive `.pqm` file.

use crate::cmd::coarsen::{run_with_bar, stop_code, target_faces, Operators};
use crate::ctx::{usage, Ctx};
use crate::pipeline::{placement_and_smoothing, prepare, CoarsenerArgs};
use crate::util::{
    human_bytes, in_dir_with_ext, parse_growth, parse_nonneg, parse_ratio, write_atomic,
};
use anyhow::Context;
use pqm_core::coarsen::{CoarsenOptions, Placement};
use pqm_format::EncodeOptions;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `pqm encode`'s round fraction when neither `--round-fraction` nor
/// `--no-rounds` is given (see `CoarsenOptions::round_fraction`): files are
/// what `pqm encode` optimizes for, and 0.005 took 1.1–7.1 % off the bench
/// files' geometry for 0.3–1.4 points of ideal vertices at a quarter of the
/// faces (`docs/figures-history.md`, session 14).
pub const DEFAULT_ROUND_FRACTION: Option<f64> = Some(0.005);

/// `pqm encode`'s record window when neither `--reorder-window` nor
/// `--no-reorder-window` is given (see `CoarsenOptions::reorder_window`):
/// on top of the rounds, 0.05 took 0.6–1.3 bits per vertex off the bench
/// files' geometry, with the same Hausdorff distances and within about a
/// point of ideal vertices at 10–70 % of the faces
/// (`docs/s16-window-experiment.md`, session 16).
pub const DEFAULT_REORDER_WINDOW: Option<f64> = Some(0.05);

/// `pqm encode`'s corner order when `--corner-order` is not given:
/// `diagonal` took 2.2–2.5 % off the bench files and draws the input's
/// triangles (session 15); `canonical` draws the same quads in files
/// 2.2–3.1 % smaller than today's `diagonal` (session 22,
/// `docs/figures-history.md`); `auto` keeps `diagonal` where the input's
/// diagonals mean something, a paired triangle mesh's (session 26,
/// [`CornerArg::resolve`]).
pub const DEFAULT_CORNER_ORDER: CornerArg = CornerArg::Auto;

/// Encode meshes as progressive .pqm files (coarse base + refinement records).
///
/// Each input is coarsened to a base mesh (by default as far as the quality
/// rules allow); the file stores the base plus every refinement step, so a
/// client shows the base from the first bytes and refines while the rest
/// arrives.
///
/// Several inputs run in parallel, one progress bar each plus a total; a
/// failing input is reported and the others still finish (exit code 1 if
/// any failed). Positions are quantized to --bits per axis over the bounding
/// cube (see --grid); decoding the full level gives exactly the quantized input. A
/// triangle mesh's triangles are joined in pairs first, no new vertex, so
/// the full level is the input (`--triangles`); what cannot pair, and
/// other polygons, is split into quads (see `pqm coarsen --help`).
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm encode spot.obj -o spot.pqm
  pqm encode assets/*.obj --out-dir pqm/ --bits 16 --json
  pqm encode bunny.off -o bunny.pqm --base-faces 500 --chunk-bytes 8192")]
#[command(group(clap::ArgGroup::new("out").required(true).args(["output", "out_dir"])))]
pub struct Args {
    /// Input meshes (.obj, .off, .ply, .gltf, .glb).
    #[arg(required = true, value_name = "IN")]
    pub inputs: Vec<PathBuf>,
    /// Output file (one input only).
    #[arg(short, long, value_name = "OUT.pqm")]
    pub output: Option<PathBuf>,
    /// Output directory: IN's name with the .pqm extension (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// Coarsen the base mesh down to this many faces (or fewer).
    #[arg(long, value_name = "N", help_heading = "Base mesh")]
    pub base_faces: Option<usize>,
    /// Coarsen the base mesh down to this fraction of the input's faces, in (0, 1].
    #[arg(long, value_name = "R", value_parser = parse_ratio, conflicts_with = "base_faces", help_heading = "Base mesh")]
    pub base_ratio: Option<f64>,
    /// Never exceed this error bound (fraction of the bbox diagonal).
    #[arg(long, value_name = "E", value_parser = parse_nonneg, help_heading = "Base mesh")]
    pub max_error: Option<f64>,
    #[command(flatten)]
    pub coarsener: CoarsenerArgs,
    /// Coarsen in rounds of independent steps, each round committing up to
    /// R × its starting face count steps, so that the records of a round are
    /// stored in ascending order of their anchor vertices (smaller vertex
    /// references, same file format). With R = 0.005: 1.1–7.1 % smaller
    /// geometry, encoding up to 40 % slower, intermediate levels with
    /// up to 1.4 points fewer ideal vertices, decoding up to ≈ 3 % slower
    /// (the same work, less local); larger R: smaller files, worse levels.
    /// Only with `--placement subset`. Default: 0.005.
    #[arg(long, value_name = "R", value_parser = parse_ratio, conflicts_with = "no_rounds", help_heading = "Coarsener")]
    pub round_fraction: Option<f64>,
    /// One step at a time in the priority queue's order (no rounds; see
    /// --round-fraction).
    #[arg(long, help_heading = "Coarsener")]
    pub no_rounds: bool,
    /// Reorder the records in windows of F × the face count (cut from the
    /// coarse end): within a window, records that commute are put in
    /// ascending sweeps of their anchor vertices (smaller vertex
    /// references, same file format). The coarsening is unchanged, so the
    /// levels at window ends are exactly the coarsener's; inside a window a
    /// level has part of the window's steps. With F = 0.05: 0.6–1.3 bits
    /// per vertex less geometry on top of rounds, or 0.1–4.2 without them;
    /// below ≈ 0.02 files grow. A level inside a window gets the error
    /// bound of its fine end raised by those of the steps it has
    /// collapsed. Only with `--placement subset`. Default: 0.05.
    #[arg(long, value_name = "F", value_parser = parse_ratio, conflicts_with = "no_reorder_window", help_heading = "Coarsener")]
    pub reorder_window: Option<f64>,
    /// Keep the records in the order of the steps (or of the rounds; see
    /// --reorder-window).
    #[arg(long, help_heading = "Coarsener")]
    pub no_reorder_window: bool,
    /// Quantization bits per axis, 8..=24 (with the default `--grid cube`,
    /// over the largest extent, as Draco's and gltfpack's bits).
    #[arg(long, value_name = "N", default_value_t = 14, value_parser = clap::value_parser!(u8).range(8..=24), help_heading = "File")]
    pub bits: u8,
    /// Close a record chunk once its uncompressed size reaches this many
    /// bytes (smaller chunks: finer streaming steps, a little more overhead).
    #[arg(long, value_name = "N", default_value_t = 16384, value_parser = clap::value_parser!(u64).range(64..=(1 << 30)), help_heading = "File")]
    pub chunk_bytes: u64,
    /// Let chunks grow with the file: a chunk also holds at least this
    /// fraction of everything before it (0: every chunk --chunk-bytes).
    /// Early chunks stay small, so the base and the first levels still
    /// arrive in small steps; the fine end, where each record changes
    /// little, goes in fewer, larger chunks that compress better (on
    /// meshes over 100k faces, 2–3 % less for positions and connectivity)
    /// under a shorter chunk table.
    #[arg(long, value_name = "F", default_value_t = 0.1, value_parser = parse_growth, help_heading = "File")]
    pub chunk_growth: f64,
    /// Leave out the vertex-order section: the full level then has the
    /// decoder's vertex order instead of the input's (as Draco and gltfpack
    /// also reorder). Saves 2–15 bits per vertex (format 3.1's `VNBR`
    /// section, which codes the input order against the mesh, or 3.0's
    /// `VORD` deltas where those come out smaller); keep the
    /// default when something else refers to the input's vertex indices.
    #[arg(long, help_heading = "File")]
    pub no_vertex_order: bool,
    /// Always write the vertex order as format 3.0's `VORD` section (deltas,
    /// 4.7–22 bits per vertex), for readers that predate 3.1 (they skip
    /// `VNBR` and keep the decoder's order). By default `pqm` writes
    /// whichever of `VNBR` and `VORD` is smaller (`VNBR` on nearly every
    /// mesh).
    #[arg(long, help_heading = "File", conflicts_with = "no_vertex_order")]
    pub vertex_order_deltas: bool,
    /// Keep the order of the vertices the quad split makes too. An input
    /// that is split into quads (`--triangles split`, or one that cannot
    /// pair) gets edge and face points after its own vertices; by default
    /// only the input's own vertices keep their indices at the full level,
    /// and the split's points are numbered after them in the order that
    /// codes smallest (the split bunny's vertex order: 10 bits per vertex →
    /// about 2); so are the edge and face points a bridged input gains.
    /// Quad and paired inputs make no new vertex and keep their whole
    /// order either way.
    #[arg(long, help_heading = "File", conflicts_with = "no_vertex_order")]
    pub keep_split_order: bool,
    /// How each section's zstd frame is cut into blocks: `auto` gives a
    /// chunk's streams (operation symbols, connectivity, vertex references,
    /// positions) blocks of their own where that saves more than a block
    /// costs a JavaScript decoder (1–3 % smaller files); `single` is one
    /// block per frame (the least decoding work); `per-part` always splits.
    #[arg(long, value_enum, default_value_t = BlocksArg::Auto, value_name = "MODE", help_heading = "File")]
    pub zstd_blocks: BlocksArg,
    /// zstd's minimum match length: `auto` tries the level's own (3), 5 and
    /// 6 on each section and keeps the smallest frame (the longer on a tie:
    /// fewer sequences to decode); on large meshes 5 or 6 are 1–4 % smaller
    /// and decode faster, small ones keep 3. `level` is the level's own
    /// (files as before this option); 3..=7 fixes it (6 is level 19's cap).
    #[arg(long, default_value = "auto", value_name = "auto|level|N", value_parser = parse_min_match, help_heading = "File")]
    pub zstd_min_match: pqm_format::ZstdMinMatch,
    /// Where each stored quad's corner list starts. `canonical` starts each
    /// quad a record builds where the decoder builds it (no rotation to
    /// code): the smallest files, every quad with its corners in the
    /// input's cyclic order, but a renderer may split some quads into
    /// triangles along the other diagonal. `diagonal` lets a quad start
    /// only at its opposite corner, so every level splits into exactly the
    /// input's triangles (`canonical`'s files are 2.2–3.4 % smaller). `input`
    /// keeps each input quad's first corner at the full level, for tools
    /// that refer to a face's corners by position (another 2–2.5 %). `auto`
    /// (the default): `diagonal` for a triangle mesh paired into quads
    /// (`--triangles pair`: the full level then draws the input's own
    /// triangles), `canonical` for anything else.
    #[arg(long, value_enum, default_value_t = DEFAULT_CORNER_ORDER, value_name = "ORDER", help_heading = "File")]
    pub corner_order: CornerArg,
    /// The quantization grid. `cube` gives every axis the step of the
    /// largest extent (as Draco and gltfpack quantize: --bits bounds the
    /// error by half that step everywhere) and stores the exact bounds in
    /// the header (format 3.2); `box` gives each axis its own extent (the
    /// grid before 3.2): finer steps on the shorter axes, 0.6–3.1 bits per
    /// vertex more on the bench meshes.
    #[arg(long, value_enum, default_value_t = GridArg::Cube, value_name = "GRID", help_heading = "File")]
    pub grid: GridArg,
    /// The geometric error written for each level (the header's and the
    /// chunk table's; spec §3). `measured` (the default): each chunk
    /// boundary's sampled symmetric Hausdorff distance to the full level
    /// (Metro's sampling, as `pqm stats --reference`), made
    /// non-increasing, as 3D Tiles' geometric errors and meshoptimizer's
    /// simplification errors are estimates. `bound`: the coarsener's
    /// bound, the largest drift of a vertex from the input vertices it
    /// stands for, several times larger. A client that picks its level by
    /// screen-space error (`pqm view` with `?view`, pqm-three's
    /// `updateForView`) stops downloading sooner with `measured` (on the
    /// bench meshes its errors are 2–23 % of the bounds). The rest of the
    /// file is the same byte for byte; measuring adds a third to two
    /// thirds to the encoding time.
    #[arg(long, value_enum, default_value_t = DEFAULT_LEVEL_ERROR, value_name = "KIND", help_heading = "File")]
    pub level_error: LevelErrorArg,
}

/// `--level-error`'s default (also `pqm demo`'s).
pub const DEFAULT_LEVEL_ERROR: LevelErrorArg = LevelErrorArg::Measured;

/// `--level-error` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LevelErrorArg {
    Measured,
    Bound,
}

/// `--grid` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridArg {
    Cube,
    Box,
}

impl From<GridArg> for pqm_format::Grid {
    fn from(g: GridArg) -> Self {
        match g {
            GridArg::Cube => pqm_format::Grid::Cube,
            GridArg::Box => pqm_format::Grid::Box,
        }
    }
}

/// `--corner-order` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CornerArg {
    /// `diagonal` for a triangle mesh whose triangles were paired into
    /// quads (`--triangles pair`), else `canonical`.
    Auto,
    /// Each quad keeps its diagonal: every level splits into the input's
    /// triangles.
    Diagonal,
    /// Each input quad keeps its first corner at the full level.
    Input,
    /// Each quad starts where the decoder builds it: the smallest files.
    Canonical,
}

impl CornerArg {
    /// The order `auto` stands for, given how the quad mesh was made and
    /// whether most of the input's faces were triangles (or polygons). The
    /// quads of paired triangles then keep the input's own triangles at the
    /// full level: a renderer splitting each quad along its `q0–q2`
    /// diagonal draws exactly them, where under `canonical` it draws about
    /// half the quads along their other diagonal, folding some (the paired
    /// bunny: 180 quads whose two triangles face apart, against 8 of the
    /// input's own pairs). The rotation fields this keeps cost 2–3.4 % of
    /// the file (bunny 201,858 → 208,691 B, fertility 32,142 → 32,909,
    /// decimated makehuman 54,809 → 55,942, session 26). An input's own
    /// quads carry no diagonal anyone chose (a quad-dominant input pays
    /// the same for its few triangles: the sword +3.9 %), and a split's
    /// quads lie flat in their triangle.
    pub fn resolve(
        self,
        conversion: crate::pipeline::QuadConversion,
        mostly_triangles: bool,
    ) -> CornerArg {
        match self {
            CornerArg::Auto if paired_triangles(conversion, mostly_triangles) => {
                CornerArg::Diagonal
            }
            CornerArg::Auto => CornerArg::Canonical,
            c => c,
        }
    }

    /// Whether a file in this (resolved) order keeps the full level's
    /// diagonals, so that its header may say they are meant (flag bit 3)
    /// where they are a paired triangle mesh's.
    fn keeps_finest_diagonals(self) -> bool {
        matches!(self, CornerArg::Diagonal | CornerArg::Input)
    }
}

/// Whether the quad mesh is a triangle mesh's triangles joined in pairs
/// (or bridged), so its quads' diagonals are the input's edges: most of
/// the input's faces were not quads, and pairing made the quads.
fn paired_triangles(conversion: crate::pipeline::QuadConversion, mostly_triangles: bool) -> bool {
    use crate::pipeline::QuadConversion;
    mostly_triangles && matches!(conversion, QuadConversion::Paired | QuadConversion::Bridged)
}

impl From<CornerArg> for pqm_format::CornerOrder {
    fn from(c: CornerArg) -> Self {
        match c {
            CornerArg::Diagonal => pqm_format::CornerOrder::Diagonal,
            CornerArg::Input => pqm_format::CornerOrder::Input,
            // `resolve` first; a mesh of unknown making gets the quads'
            // cyclic order only
            CornerArg::Canonical | CornerArg::Auto => pqm_format::CornerOrder::Canonical,
        }
    }
}

/// `--zstd-min-match`: `auto`, `level` or a length 3..=7.
fn parse_min_match(s: &str) -> Result<pqm_format::ZstdMinMatch, String> {
    match s {
        "auto" => Ok(pqm_format::ZstdMinMatch::Auto),
        "level" => Ok(pqm_format::ZstdMinMatch::Level),
        _ => match s.parse::<u32>() {
            Ok(n @ 3..=7) => Ok(pqm_format::ZstdMinMatch::Fixed(n)),
            _ => Err(format!("'{s}' is not auto, level or a length from 3 to 7")),
        },
    }
}

/// `--zstd-blocks` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlocksArg {
    Auto,
    Single,
    PerPart,
}

impl From<BlocksArg> for pqm_format::ZstdBlocks {
    fn from(b: BlocksArg) -> Self {
        match b {
            BlocksArg::Auto => pqm_format::ZstdBlocks::Auto,
            BlocksArg::Single => pqm_format::ZstdBlocks::Single,
            BlocksArg::PerPart => pqm_format::ZstdBlocks::PerPart,
        }
    }
}

/// What one encoded file reports.
#[derive(Serialize, Clone, Debug)]
pub struct FileReport {
    pub input: String,
    pub output: String,
    /// Faces of the full level (the coarsener's input).
    pub faces: usize,
    pub vertices: usize,
    pub base_faces: usize,
    pub base_vertices: usize,
    pub records: usize,
    pub chunks: usize,
    pub bytes: u64,
    /// Whole-file bits per final vertex.
    pub bits_per_vertex: f64,
    /// Bits per final vertex of positions and connectivity only: the file
    /// without its optional sections (the vertex order). The figure to set
    /// beside Draco's, whose edgebreaker does not keep the input order.
    pub geometry_bits_per_vertex: f64,
    /// Record bits per refined vertex.
    pub record_bits_per_vertex: f64,
    pub bits: u8,
    pub subdivided: bool,
    /// How the quad mesh came from a non-quad input: `none`, `paired` or `split`.
    pub conversion: crate::pipeline::QuadConversion,
    /// Where merged vertices went (`subset`: every level at input positions).
    pub placement: Placement,
    /// Where each stored quad's corner list starts (`--corner-order`, `auto`
    /// resolved): `canonical`, `diagonal` or `input`.
    pub corner_order: CornerArg,
    /// The file says its finest level's quad diagonals are the input's
    /// triangles' (header flag bit 3, format 4.1): a triangle mesh paired
    /// into quads, with a corner order that keeps the diagonals.
    pub finest_diagonals: bool,
    /// What the input holds that the file does not (`texture coordinates`,
    /// `normals`, `face groups`): `.pqm` files hold positions and quads.
    pub dropped: Vec<&'static str>,
    /// `--chunk-growth`: each chunk holds at least this fraction of the
    /// record payload before it.
    pub chunk_growth: f64,
    /// The full level keeps the input's vertex indices below this (a split
    /// input: its own vertices; the split's points are numbered as they
    /// code smallest); `null` when it keeps every index, or has no vertex
    /// order (`--no-vertex-order`).
    pub vertex_order_kept: Option<usize>,
    /// `--level-error`: `measured` or `bound`.
    pub level_error: LevelErrorArg,
    /// Level 0's geometric error as written (the header's `base_error`),
    /// in units of the bounding-box diagonal.
    pub base_error: f64,
    /// The coarsener's bound for level 0, whichever was written.
    pub base_error_bound: f64,
    pub stop: &'static str,
    pub error: f64,
    pub operators: Operators,
    /// Seconds for reading, coarsening and writing.
    pub encode_time_s: f64,
}

#[derive(Serialize)]
struct Failure {
    input: String,
    error: String,
}

#[derive(Serialize)]
struct Report {
    files: Vec<FileReport>,
    failed: Vec<Failure>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    // a usage conflict is reported once, before any input is read
    placement_and_smoothing(&args.coarsener, Placement::Subset)?;
    let outputs = output_paths(args)?;
    if let Some(dir) = &args.out_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the output directory", dir.display()))?;
    }
    // One input in text mode fails as any other command does: its error is
    // the command's one line (a batch names each failure as it happens, then
    // counts them).
    let single_text = args.inputs.len() == 1 && !ctx.json;
    let total = ctx.bar(args.inputs.len() as u64, "total");
    total.set_message("files");
    let mut results: Vec<anyhow::Result<FileReport>> = args
        .inputs
        .par_iter()
        .zip(outputs.par_iter())
        .map(|(input, output)| {
            let r = encode_one(input, output, args, ctx);
            if let (Err(e), false) = (&r, single_text) {
                ctx.error_line(format!("{e:#}").replace('\n', " "));
            }
            total.inc(1);
            r
        })
        .collect();
    total.finish_and_clear();
    if single_text && results.iter().any(|r| r.is_err()) {
        return results.swap_remove(0).map(|_| ());
    }
    let mut report = Report {
        files: Vec::new(),
        failed: Vec::new(),
    };
    for (input, r) in args.inputs.iter().zip(results) {
        match r {
            Ok(f) => report.files.push(f),
            Err(e) => report.failed.push(Failure {
                input: input.display().to_string(),
                error: format!("{e:#}").replace('\n', " "),
            }),
        }
    }
    ctx.emit(&report, || {
        let mut s = String::new();
        for f in &report.files {
            s.push_str(&format!(
                "{} -> {}: {} faces, base {} faces, {} records in {} chunks, {} ({:.1} bits/vertex, {:.1} without the vertex order), {:.2} s\n",
                f.input,
                f.output,
                f.faces,
                f.base_faces,
                f.records,
                f.chunks,
                human_bytes(f.bytes),
                f.bits_per_vertex,
                f.geometry_bits_per_vertex,
                f.encode_time_s
            ));
        }
        if !report.failed.is_empty() {
            s.push_str(&format!(
                "{} of {} inputs failed (see the errors above)\n",
                report.failed.len(),
                args.inputs.len()
            ));
        }
        s
    })?;
    if report.failed.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "{} of {} inputs failed",
            report.failed.len(),
            args.inputs.len()
        )
    }
}

/// The output path of each input; usage errors for `-o` with several
/// inputs and for two inputs that would write the same file.
fn output_paths(args: &Args) -> anyhow::Result<Vec<PathBuf>> {
    if let Some(o) = &args.output {
        if args.inputs.len() > 1 {
            return Err(usage(format!(
                "-o names one output file but {} inputs were given; use --out-dir DIR",
                args.inputs.len()
            )));
        }
        return Ok(vec![o.clone()]);
    }
    let dir = args.out_dir.as_deref().unwrap_or(Path::new("."));
    let outs: Vec<PathBuf> = args
        .inputs
        .iter()
        .map(|i| in_dir_with_ext(dir, i, "pqm"))
        .collect();
    let mut seen = BTreeSet::new();
    for (i, o) in args.inputs.iter().zip(&outs) {
        if !seen.insert(o.clone()) {
            return Err(usage(format!(
                "{}: would overwrite {} written for another input with the same name",
                i.display(),
                o.display()
            )));
        }
    }
    Ok(outs)
}

fn encode_one(input: &Path, output: &Path, args: &Args, ctx: &Ctx) -> anyhow::Result<FileReport> {
    let t0 = Instant::now();
    let opts = CoarsenOptions {
        target_faces: args.base_faces,
        target_ratio: args.base_ratio,
        max_error: args.max_error,
        placement: Placement::Subset,
        round_fraction: if args.no_rounds {
            None
        } else {
            args.round_fraction.or(DEFAULT_ROUND_FRACTION)
        },
        reorder_window: if args.no_reorder_window {
            None
        } else {
            args.reorder_window.or(DEFAULT_REORDER_WINDOW)
        },
        ..Default::default()
    };
    let mut p = prepare(input, &args.coarsener, opts, ctx)?;
    let placement = p.coarsener.options().placement;
    let target = target_faces(args.base_faces, args.base_ratio, p.quad_faces);
    let label = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let r = run_with_bar(&mut p.coarsener, target, &label, ctx);
    let operators = Operators::of(&r, &p.coarsener);
    if let Some((rounds, steps, deferrals)) = p.coarsener.round_stats() {
        ctx.verbose(format!(
            "{label}: {steps} steps in {rounds} rounds ({:.1} per round), {deferrals} candidates set aside",
            steps as f64 / rounds.max(1) as f64
        ));
    }
    let pm = p.coarsener.into_progressive();
    let non_quads = p.input.faces().filter(|f| f.len() != 4).count();
    let mostly_triangles = 2 * non_quads >= p.input.face_count();
    let corner_order = args.corner_order.resolve(p.conversion, mostly_triangles);
    // The file says its finest diagonals are meant (header flag bit 3, a
    // 4.1 file) where they are a paired triangle mesh's and kept: exports
    // of the finest level then give the input's own triangles.
    let finest_diagonals =
        paired_triangles(p.conversion, mostly_triangles) && corner_order.keeps_finest_diagonals();
    let eopts = EncodeOptions {
        bits: args.bits,
        chunk_bytes: args.chunk_bytes as usize,
        chunk_growth: args.chunk_growth,
        vertex_order: !args.no_vertex_order,
        // The split's or the bridging's edge and face points are pqm's
        // own: their indices mean nothing to the user (pipeline: the
        // input's vertices first).
        vertex_order_keep: (p.conversion.adds_vertices() && !args.keep_split_order)
            .then(|| p.input.vertex_count()),
        vertex_order_code: if args.vertex_order_deltas {
            pqm_format::VertexOrderCode::Deltas
        } else {
            pqm_format::VertexOrderCode::Smaller
        },
        zstd_blocks: args.zstd_blocks.into(),
        zstd_min_match: args.zstd_min_match,
        corner_order: corner_order.into(),
        finest_diagonals,
        grid: args.grid.into(),
        ..Default::default()
    };
    let Written {
        report: enc,
        base_error,
        base_error_bound: bound_base_error,
    } = write_pqm(output, &pm, &eopts, args.level_error, &label, ctx)
        .with_context(|| format!("{}", input.display()))?;
    Ok(FileReport {
        input: input.display().to_string(),
        output: output.display().to_string(),
        faces: pm.final_face_count(),
        vertices: pm.final_vertex_count(),
        base_faces: pm.base.face_count(),
        base_vertices: pm.base.vertex_count(),
        records: pm.records.len(),
        chunks: enc.chunk_count,
        bytes: enc.total_bytes,
        bits_per_vertex: enc.file_bits_per_vertex,
        geometry_bits_per_vertex: 8.0 * (enc.total_bytes - enc.section_bytes) as f64
            / pm.final_vertex_count().max(1) as f64,
        record_bits_per_vertex: enc.bits_per_vertex.total,
        bits: args.bits,
        subdivided: p.conversion == crate::pipeline::QuadConversion::Split,
        conversion: p.conversion,
        placement,
        corner_order,
        finest_diagonals,
        dropped: p.dropped.clone(),
        chunk_growth: args.chunk_growth,
        vertex_order_kept: eopts.vertex_order_keep.filter(|_| eopts.vertex_order),
        level_error: args.level_error,
        base_error,
        base_error_bound: bound_base_error,
        stop: stop_code(&r),
        error: r.error,
        operators,
        encode_time_s: t0.elapsed().as_secs_f64(),
    })
}

/// What [`write_pqm`] wrote.
pub struct Written {
    /// The encoder's report.
    pub report: pqm_format::EncodeReport,
    /// Level 0's geometric error as written.
    pub base_error: f64,
    /// The coarsener's bound for level 0.
    pub base_error_bound: f64,
}

/// Encodes `pm` with `eopts`, writes the `level_error` kind of errors
/// (measured: `pqm_format::level_error`, a progress bar labelled `label`)
/// and only then writes `output` whole (a temporary file renamed): what
/// `pqm encode` and `pqm demo` write.
pub fn write_pqm(
    output: &Path,
    pm: &pqm_core::ProgressiveMesh,
    eopts: &EncodeOptions,
    level_error: LevelErrorArg,
    label: &str,
    ctx: &Ctx,
) -> anyhow::Result<Written> {
    let mut bytes = Vec::new();
    let report = pqm_format::write(pm, eopts, &mut bytes).context("cannot encode")?;
    // the encoder wrote a whole header: its fields are there to read
    let base_error_bound = pqm_format::Header::parse(&bytes).base_error as f64;
    let base_error = match level_error {
        LevelErrorArg::Bound => base_error_bound,
        LevelErrorArg::Measured => {
            let t = Instant::now();
            let pb = ctx.bar(report.chunk_count as u64 + 1, format!("{label} errors"));
            pb.set_message("levels measured");
            let m = pqm_format::level_error::measure(
                &bytes,
                pqm_format::Limits::none(),
                &pqm_format::level_error::sampling(pm.final_face_count()),
                |done, _| pb.set_position(done as u64),
            )
            .context("measuring the levels' errors")?;
            pb.finish_and_clear();
            pqm_format::level_error::set(&mut bytes, m.base, &m.chunks)
                .context("writing the levels' errors")?;
            ctx.verbose(format!(
                "{label}: level errors measured in {:.2} s (level 0: {:.5}, the coarsener's bound {:.5})",
                t.elapsed().as_secs_f64(),
                m.base,
                base_error_bound
            ));
            m.base as f64
        }
    };
    write_atomic(output, |w| {
        w.write_all(&bytes)?;
        Ok(())
    })?;
    Ok(Written {
        report,
        base_error,
        base_error_bound,
    })
}
