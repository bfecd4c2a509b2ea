//! `pqm levels`: several levels of a `.pqm` file as glTF files, or all of
//! them in one GLB linked with `MSFT_lod`. Also home of [`GltfArgs`], the
//! `--normals` / `--quantize` flags any command writing glTF can flatten in,
//! and [`write_mesh_with`], the atomic mesh writer that honours them.

use crate::cmd::info::{level_error, level_rows};
use crate::ctx::{usage, Ctx};
use crate::stats::{mesh_stats, MeshStats};
use crate::util::{mesh_output_format, write_atomic};
use anyhow::{anyhow, Context};
use pqm_core::io::{self, GltfWriteOptions, MeshFormat, Normals, QuadSplit};
use pqm_core::IndexedMesh;
use pqm_format::{decode_all, Limits, Target};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Normals in glTF output (`--normals`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalsArg {
    /// No NORMAL attribute (viewers shade flat).
    #[default]
    None,
    /// One normal per vertex, area-weighted over its faces.
    Smooth,
    /// One normal per face (vertices duplicated per face).
    Flat,
}

impl From<NormalsArg> for Normals {
    fn from(n: NormalsArg) -> Normals {
        match n {
            NormalsArg::None => Normals::None,
            NormalsArg::Smooth => Normals::Smooth,
            NormalsArg::Flat => Normals::Flat,
        }
    }
}

/// glTF output options, shared by commands that write glTF/GLB.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct GltfArgs {
    /// Normals written to glTF/GLB output.
    #[arg(long, value_enum, default_value = "none", help_heading = "glTF output")]
    pub normals: NormalsArg,
    /// 16-bit positions and normals (KHR_mesh_quantization, a required
    /// extension): about half the vertex bytes, error below 1/65534 of the
    /// largest extent.
    #[arg(long, help_heading = "glTF output")]
    pub quantize: bool,
    /// The diagonal each quad is split along into glTF triangles (the
    /// quads themselves are kept through FB_ngon_encoding). `shorter`: the
    /// shorter one, as modelling tools split. `first`: the quad's v0–v2, as
    /// the file lists it. `auto` (the default): `first` for the finest
    /// level of a file that says its diagonals are meant (format 4.1: a
    /// triangle mesh `pqm encode` paired into quads, whose finest level
    /// then exports the input's own triangles), else `shorter`.
    #[arg(long, value_enum, default_value = "auto", help_heading = "glTF output")]
    pub quad_split: QuadSplitArg,
}

/// `--quad-split` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum QuadSplitArg {
    #[default]
    Auto,
    Shorter,
    First,
}

impl GltfArgs {
    /// The writer options these flags ask for, for a mesh of no `.pqm`
    /// file's finest level (`auto` splits along the shorter diagonal).
    pub fn options(&self) -> GltfWriteOptions {
        self.options_for(false)
    }

    /// The writer options for a mesh whose quads' `v0–v2` diagonals are
    /// meant when `diagonals_meant` (the finest level of a file with
    /// header flag bit 3): `auto` then splits along them.
    pub fn options_for(&self, diagonals_meant: bool) -> GltfWriteOptions {
        GltfWriteOptions {
            normals: self.normals.into(),
            quantize: self.quantize,
            quad_split: match self.quad_split {
                QuadSplitArg::First => QuadSplit::First,
                QuadSplitArg::Auto if diagonals_meant => QuadSplit::First,
                QuadSplitArg::Auto | QuadSplitArg::Shorter => QuadSplit::Shorter,
            },
        }
    }

    /// True when `--normals` or `--quantize` differs from the default.
    pub fn any_shading(&self) -> bool {
        self.options().normals != Normals::default() || self.quantize
    }

    /// True when any flag differs from the default.
    pub fn any(&self) -> bool {
        self.options() != GltfWriteOptions::default() || self.quad_split != QuadSplitArg::Auto
    }
}

/// Starts each quad of `mesh` at an end of its shorter diagonal, so that a
/// split along `v0–v2` ([`QuadSplit::First`]) is the split along the
/// shorter one: for the coarser levels of a `--lod` file whose finest
/// level is split along its meant diagonals (one split rule per file).
/// Only for meshes without corner attributes (decoded levels).
fn start_at_shorter_diagonal(mesh: &mut IndexedMesh) {
    for f in 0..mesh.face_count() {
        let (a, b) = (
            mesh.face_starts[f] as usize,
            mesh.face_starts[f + 1] as usize,
        );
        if b - a == 4 {
            let q = [0, 1, 2, 3].map(|k| mesh.indices[a + k]);
            if io::quad_split_diagonal(&mesh.positions, q) == 1 {
                mesh.indices[a..b].rotate_left(1);
            }
        }
    }
}

/// Writes `mesh` to `path` atomically in the format of its extension, with
/// `gltf` applied to .gltf/.glb output (other formats ignore it: warn the
/// user before calling when [`GltfArgs::any`]). Errors name `path`.
pub fn write_mesh_with(
    path: &Path,
    mesh: &IndexedMesh,
    gltf: &GltfWriteOptions,
) -> anyhow::Result<()> {
    let format = mesh_output_format(path)?;
    write_atomic(path, |w| {
        match format {
            MeshFormat::Obj => io::write_obj(w, mesh),
            MeshFormat::Off => io::write_off(w, mesh),
            MeshFormat::Ply => io::write_ply(w, mesh),
            MeshFormat::Gltf => io::write_gltf_with(w, mesh, gltf),
            MeshFormat::Glb => io::write_glb_with(w, mesh, gltf),
        }
        .map_err(|e| anyhow!("{e}"))
    })
}

/// Container for the per-level files of `-o DIR`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelFormat {
    /// Binary glTF.
    Glb,
    /// glTF JSON with the buffer embedded.
    Gltf,
}

/// Write several levels of a .pqm file as glTF: one file per level, and/or
/// one GLB with all of them linked by MSFT_lod.
///
/// Each N in --faces picks the finest level with at most N faces (the base
/// mesh if N is below it); levels picked twice are written once. With -o
/// DIR, level files are named after the input and the level's face count
/// (`spot_700.glb`); DIR is created if needed. With --lod OUT.glb, all
/// picked levels go into one GLB, finest first: the finest level's node
/// carries MSFT_lod and is the only node in the scene (viewers without the
/// extension show it alone), and extras.MSFT_screencoverage gives one hint
/// per level — the smallest fraction of the screen the object must cover
/// for that level to be shown: 0.5 for the finest, 0.5 × faces/finest faces
/// for the others (the faces per covered screen stay the same at every
/// switch), 0 for the coarsest, which is never culled.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm levels spot.pqm --faces 300,1000,3000 -o spot_levels
  pqm levels spot.pqm --faces 300,1000,3000 --lod spot_lod.glb --normals smooth
  pqm levels spot.pqm --faces 500,2000 -o out --format gltf --quantize --json")]
pub struct Args {
    /// The .pqm file.
    pub input: PathBuf,
    /// Face budgets, comma separated: each picks the finest level with at
    /// most that many faces.
    #[arg(long, value_name = "N1,N2,...", value_delimiter = ',', required = true, num_args = 1..)]
    pub faces: Vec<usize>,
    /// Directory for one file per level.
    #[arg(short, long, value_name = "DIR", required_unless_present = "lod")]
    pub output: Option<PathBuf>,
    /// One GLB with all the levels linked by MSFT_lod.
    #[arg(long, value_name = "OUT.glb")]
    pub lod: Option<PathBuf>,
    /// File type of the per-level files.
    #[arg(long, value_enum, default_value = "glb")]
    pub format: LevelFormat,
    #[command(flatten)]
    pub gltf: GltfArgs,
    /// Print the statistics of every level written.
    #[arg(long)]
    pub stats: bool,
}

#[derive(Serialize)]
struct LevelReport {
    /// The --faces values that picked this level.
    requested: Vec<usize>,
    level: usize,
    faces: usize,
    vertices: usize,
    error: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stats: Option<MeshStats>,
}

#[derive(Serialize)]
struct LodReport {
    file: String,
    coverage: Vec<f64>,
}

#[derive(Serialize)]
struct Report {
    input: String,
    final_level: usize,
    normals: String,
    quantize: bool,
    /// Finest first.
    levels: Vec<LevelReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lod: Option<LodReport>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    if let Some(lod) = &args.lod {
        if mesh_output_format(lod)? != MeshFormat::Glb {
            return Err(usage(format!(
                "{}: --lod writes one GLB; give it a .glb name",
                lod.display()
            )));
        }
    }
    let name = args.input.display().to_string();
    let bytes = std::fs::read(&args.input).with_context(|| format!("{name}: cannot read"))?;
    let mut dec = decode_all(&bytes, Limits::default()).map_err(|e| anyhow!("{name}: {e}"))?;
    let final_level = dec.header().map_or(0, |h| h.record_count as usize);
    let rows = level_rows(&dec);

    // Resolve the budgets to levels, finest first, each level once.
    let mut picked: Vec<(usize, Vec<usize>)> = Vec::new();
    for &n in &args.faces {
        let k = dec
            .resolve(Target::Faces(n))
            .map_err(|e| anyhow!("{name}: {e}"))?;
        match picked.iter_mut().find(|(l, _)| *l == k) {
            Some((_, req)) => req.push(n),
            None => picked.push((k, vec![n])),
        }
    }
    picked.sort_by_key(|p| std::cmp::Reverse(p.0));

    // The finest level of a file whose diagonals are meant is split along
    // them (`--quad-split auto`).
    let meant = dec.header().is_some_and(|h| h.finest_diagonals());
    let opts_at = |k: usize| args.gltf.options_for(meant && k == final_level);
    let stem = args
        .input
        .file_stem()
        .map_or_else(|| "level".to_string(), |s| s.to_string_lossy().into_owned());
    if let Some(dir) = &args.output {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the directory", dir.display()))?;
    }
    let bar = ctx.bar(picked.len() as u64, stem.clone());
    let mut meshes = Vec::with_capacity(picked.len());
    let mut levels = Vec::with_capacity(picked.len());
    for (k, requested) in &picked {
        dec.set_level(Target::Level(*k))
            .map_err(|e| anyhow!("{name}: level {k}: {e}"))?;
        let mesh = dec.to_indexed_mesh();
        let faces = mesh.face_count();
        if requested.iter().all(|&n| n < faces) {
            ctx.note(format!(
                "{name}: no level has at most {} faces; using the base mesh ({faces} faces)",
                requested.iter().max().copied().unwrap_or(0)
            ));
        }
        let file = match &args.output {
            Some(dir) => {
                let ext = match args.format {
                    LevelFormat::Glb => "glb",
                    LevelFormat::Gltf => "gltf",
                };
                let path = dir.join(format!("{stem}_{faces}.{ext}"));
                write_mesh_with(&path, &mesh, &opts_at(*k))?;
                ctx.verbose(format!("wrote {} (level {k})", path.display()));
                Some(path.display().to_string())
            }
            None => None,
        };
        levels.push(LevelReport {
            requested: requested.clone(),
            level: *k,
            faces,
            vertices: mesh.vertex_count(),
            error: level_error(&rows, *k),
            file,
            stats: args.stats.then(|| mesh_stats(&mesh, None)),
        });
        meshes.push(mesh);
        bar.inc(1);
    }
    bar.finish_and_clear();

    let lod = match &args.lod {
        Some(path) => {
            let counts: Vec<usize> = meshes.iter().map(IndexedMesh::face_count).collect();
            let coverage = io::lod_screen_coverage(&counts);
            // One split rule per file: where the finest level splits along
            // its meant diagonals and the others along the shorter ones,
            // the others start at their shorter diagonal first.
            let (finest, coarser) = (opts_at(picked[0].0), args.gltf.options());
            if finest.quad_split != coarser.quad_split {
                for m in &mut meshes[1..] {
                    start_at_shorter_diagonal(m);
                }
            }
            let opts = finest;
            write_atomic(path, |w| {
                io::write_glb_lod(w, &meshes, &coverage, &opts).map_err(|e| anyhow!("{e}"))
            })?;
            Some(LodReport {
                file: path.display().to_string(),
                coverage,
            })
        }
        None => None,
    };

    let report = Report {
        input: name,
        final_level,
        normals: format!("{:?}", args.gltf.normals).to_lowercase(),
        quantize: args.gltf.quantize,
        levels,
        lod,
    };
    ctx.emit(&report, || text(&report))
}

fn text(r: &Report) -> String {
    let mut s = format!(
        "{}: {} level(s), final level {} (normals {}, {})\n",
        r.input,
        r.levels.len(),
        r.final_level,
        r.normals,
        if r.quantize {
            "quantized"
        } else {
            "float positions"
        }
    );
    s.push_str(&format!(
        "{:>7} {:>9} {:>9} {:>11}  {}\n",
        "level", "faces", "vertices", "error", "file"
    ));
    for (i, l) in r.levels.iter().enumerate() {
        let cov = r.lod.as_ref().map_or(String::new(), |d| {
            format!("  coverage >= {:.4}", d.coverage[i])
        });
        s.push_str(&format!(
            "{:>7} {:>9} {:>9} {:>11.3e}  {}{cov}\n",
            l.level,
            l.faces,
            l.vertices,
            l.error,
            l.file.as_deref().unwrap_or("-")
        ));
        if let Some(st) = &l.stats {
            s.push_str(&format!("{st}\n"));
        }
    }
    if let Some(d) = &r.lod {
        s.push_str(&format!(
            "wrote {} ({} levels, MSFT_lod)\n",
            d.file,
            r.levels.len()
        ));
    }
    s
}
