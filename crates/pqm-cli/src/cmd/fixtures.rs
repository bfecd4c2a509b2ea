//! `pqm fixtures` (hidden): regenerates the procedural test meshes in
//! `fixtures/generated/` from `pqm_core::shapes`.

use crate::ctx::Ctx;
use anyhow::Context;
use pqm_core::{shapes, IndexedMesh};
use serde::Serialize;
use std::path::PathBuf;

/// Regenerate the procedural fixtures as OBJ files.
///
/// Writes a cube, a quad sphere, a torus, a grid and a two-component mesh.
#[derive(clap::Args, Debug)]
#[command(after_help = "Example:
  cargo run -p pqm-cli -- fixtures --out-dir fixtures/generated")]
pub struct Args {
    /// Directory to write into (created if missing).
    #[arg(long, value_name = "DIR", default_value = "fixtures/generated")]
    pub out_dir: PathBuf,
}

#[derive(Serialize)]
struct Written {
    file: String,
    vertices: usize,
    faces: usize,
}

/// The procedural fixtures: `(file name, mesh)`.
pub fn fixtures() -> Vec<(&'static str, IndexedMesh)> {
    vec![
        ("cube.obj", shapes::cube(1.0)),
        ("quad_sphere.obj", shapes::quad_sphere(8, 1.0)),
        ("torus.obj", shapes::torus(24, 12, 2.0, 0.6)),
        ("grid.obj", shapes::grid(12, 8, 1.5, 1.0)),
        ("two_components.obj", shapes::two_components()),
    ]
}

/// Runs the command.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    std::fs::create_dir_all(&args.out_dir)
        .with_context(|| format!("{}: cannot create the directory", args.out_dir.display()))?;
    let mut written = Vec::new();
    for (name, mesh) in fixtures() {
        let path = args.out_dir.join(name);
        crate::util::write_mesh(&path, &mesh)?;
        written.push(Written {
            file: path.display().to_string(),
            vertices: mesh.vertex_count(),
            faces: mesh.face_count(),
        });
    }
    ctx.emit(&written, || {
        written
            .iter()
            .map(|w| {
                format!(
                    "wrote {} ({} vertices, {} faces)",
                    w.file, w.vertices, w.faces
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    })
}
