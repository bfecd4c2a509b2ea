//! Small helpers shared by the commands: atomic writes, output-format
//! checks, number formatting.

use crate::ctx::usage;
use anyhow::Context;
use pqm_core::io::{self, MeshFormat};
use pqm_core::IndexedMesh;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes a file atomically with [`pqm_core::io::write_atomic`] (temporary
/// file in the target's directory, fsync, rename; nothing half-written is
/// ever left), after checking that the directory exists so the error says
/// so. Errors name `path`.
pub fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        anyhow::bail!(
            "{}: cannot write: the directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    io::write_atomic::<anyhow::Error>(path, body).with_context(|| format!("{}", path.display()))
}

/// Writes `mesh` to `path` atomically in the format of its extension (see
/// [`write_atomic`]): OBJ, OFF (ASCII), PLY (binary little endian), glTF
/// (embedded buffer) or GLB. Errors name `path`.
pub fn write_mesh(path: &Path, mesh: &IndexedMesh) -> anyhow::Result<()> {
    crate::cmd::levels::write_mesh_with(path, mesh, &io::GltfWriteOptions::default())
}

/// Checks that `path` names a mesh format pqm writes (by extension); a
/// usage error (exit 2) otherwise.
pub fn mesh_output_format(path: &Path) -> anyhow::Result<MeshFormat> {
    MeshFormat::from_path(path).ok_or_else(|| {
        usage(format!(
            "{}: unknown output extension (expected .obj, .off, .ply, .gltf or .glb)",
            path.display()
        ))
    })
}

/// Checks that `path` names a mesh format pqm reads (by extension); a usage
/// error (exit 2) otherwise.
pub fn mesh_input_format(path: &Path) -> anyhow::Result<MeshFormat> {
    MeshFormat::from_path(path).ok_or_else(|| {
        usage(format!(
            "{}: unknown input extension (expected .obj, .off, .ply, .gltf or .glb)",
            path.display()
        ))
    })
}

/// `path` with its extension replaced, inside `dir`.
pub fn in_dir_with_ext(dir: &Path, path: &Path, ext: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    dir.join(format!("{stem}.{ext}"))
}

/// A byte count for people: `812 B`, `12.3 KiB`, `4.56 MiB`.
pub fn human_bytes(n: u64) -> String {
    const K: f64 = 1024.0;
    let x = n as f64;
    if x < K {
        format!("{n} B")
    } else if x < K * K {
        format!("{:.1} KiB", x / K)
    } else {
        format!("{:.2} MiB", x / (K * K))
    }
}

/// Clap value parser: a fraction in `(0, 1]`.
pub fn parse_ratio(s: &str) -> Result<f64, String> {
    let r: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if r > 0.0 && r <= 1.0 {
        Ok(r)
    } else {
        Err(format!("{s} is not in (0, 1]"))
    }
}

/// Clap value parser: a finite number `>= 0`.
pub fn parse_nonneg(s: &str) -> Result<f64, String> {
    let r: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if r.is_finite() && r >= 0.0 {
        Ok(r)
    } else {
        Err(format!("{s} is not a finite number >= 0"))
    }
}

/// Clap value parser: a chunk growth fraction in `0..=16`.
pub fn parse_growth(s: &str) -> Result<f64, String> {
    match parse_nonneg(s)? {
        r if r <= 16.0 => Ok(r),
        _ => Err(format!("{s} is not in 0..=16")),
    }
}
