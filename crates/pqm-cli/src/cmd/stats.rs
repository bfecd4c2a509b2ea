//! `pqm stats`: the quality figures of a mesh (the qCoarsen paper's Table 1).

use crate::ctx::Ctx;
use crate::pipeline::load_mesh;
use crate::stats::mesh_stats;
use anyhow::anyhow;
use pqm_core::io;
use std::path::PathBuf;

/// Print quality figures of a mesh (counts, topology, Scaled Jacobian, valence).
///
/// With --reference, also the Hausdorff distance to another mesh.
///
/// The Scaled Jacobian of a quad is the minimum over its four corners (1 =
/// square corners, <= 0 = folded). A vertex is ideal when its valence is 4
/// inside, 3 on a smooth boundary, 2 at a boundary corner. Hausdorff figures
/// are symmetric and in units of the reference's bounding-box diagonal.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm stats spot.obj
  pqm stats spot_700.obj --reference spot.obj --json")]
pub struct Args {
    /// The mesh (.obj, .off, .ply, .gltf, .glb).
    pub mesh: PathBuf,
    /// Compare against this mesh: adds the Hausdorff distance.
    #[arg(long, value_name = "REF")]
    pub reference: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    // `stats` reports on any readable mesh, defects included (so a user can
    // see what is wrong); only unreadable files are errors.
    let mesh = io::read_mesh(&args.mesh).map_err(|e| anyhow!("{e}"))?;
    if let Err(e) = io::check(&mesh) {
        ctx.warn(format!("{}: {e}", args.mesh.display()));
    }
    let reference = match &args.reference {
        Some(r) => Some(load_mesh(r, false, ctx)?),
        None => None,
    };
    let s = mesh_stats(&mesh, reference.as_ref());
    ctx.emit_result(&s, || format!("{}\n{s}", args.mesh.display()))
}
