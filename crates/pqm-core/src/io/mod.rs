//! Mesh input/output and input checking, all on [`IndexedMesh`].
//!
//! * [`read_mesh`] / [`write_mesh`] pick the format from the file extension
//!   (`obj`, `off`, `ply`, `gltf`, `glb`; case-insensitive). Writes are atomic:
//!   the data goes to a temporary file in the target's directory, which is
//!   fsynced and then renamed over the target, so a failed or interrupted write
//!   never leaves a half-written mesh behind.
//! * Per-format functions work on readers, writers and byte slices, so they are
//!   usable without files: [`read_obj`], [`read_off`], [`read_ply`], [`read_gltf`]
//!   (also reads GLB) and their `*_bytes` forms; [`write_obj`], [`write_off`],
//!   [`write_ply`] (binary little endian), [`write_ply_ascii`], [`write_gltf`]
//!   (embedded base64 buffer) and [`write_glb`].
//! * [`check`] names the first defect of a mesh; [`repair`] fixes what it can.
//!
//! Every reader treats its input as hostile: counts are checked against the
//! bytes that remain before anything is allocated, every index is checked
//! against the number of vertices, and no input makes a reader panic. A mesh
//! returned by a reader always has its vertex indices (and its texture
//! coordinate / normal indices) in range; everything else (face sizes,
//! manifoldness, ...) is the job of [`check`].

mod check;
mod gltf;
mod obj;
mod off;
mod ply;
mod repair;

pub use self::gltf::{
    lod_screen_coverage, quad_split_diagonal, read_gltf, read_gltf_bytes, triangulate, write_glb,
    write_glb_lod, write_glb_with, write_gltf, write_gltf_with, GltfWriteOptions, Normals,
    QuadSplit, FB_NGON_ENCODING, KHR_MESH_QUANTIZATION, MSFT_LOD,
};
pub use check::{check, Defect, Element, InvalidMesh};
pub use obj::{read_obj, read_obj_bytes, write_obj};
pub use off::{read_off, read_off_bytes, write_off};
pub use ply::{read_ply, read_ply_bytes, write_ply, write_ply_ascii};
pub use repair::{repair, RepairReport};

use crate::IndexedMesh;
use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// A mesh file format known to [`read_mesh`] and [`write_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// Wavefront OBJ (polygons, `vt`, `vn`, groups).
    Obj,
    /// Object File Format: ASCII, or pmp-library's `OFF BINARY` when reading.
    Off,
    /// Stanford PLY: ASCII or binary of either endianness when reading.
    Ply,
    /// glTF 2.0 JSON (`.gltf`).
    Gltf,
    /// Binary glTF 2.0 (`.glb`).
    Glb,
}

impl MeshFormat {
    /// The format named by the extension of `path` (case-insensitive), if any.
    pub fn from_path(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "obj" => MeshFormat::Obj,
            "off" => MeshFormat::Off,
            "ply" => MeshFormat::Ply,
            "gltf" => MeshFormat::Gltf,
            "glb" => MeshFormat::Glb,
            _ => return None,
        })
    }
}

/// Where in the input a parse error was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// 1-based line number of a text format.
    Line(u64),
    /// Byte offset into a binary format.
    Offset(u64),
    /// Position unknown (for example inside a JSON document).
    Unknown,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}: "),
            Location::Offset(o) => write!(f, "byte {o}: "),
            Location::Unknown => Ok(()),
        }
    }
}

/// What went wrong, split by whose fault it is.
#[derive(Debug, thiserror::Error)]
pub enum MeshIoErrorKind {
    /// The operating system failed (file missing, permission, disk full, ...).
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The input is not well-formed in its format.
    #[error("{location}{message}")]
    Parse {
        /// Where the problem is.
        location: Location,
        /// What the problem is.
        message: String,
    },
    /// The input is well-formed but describes an invalid mesh (from the
    /// readers' index checks or from [`check`]).
    #[error("{element} {message}")]
    Invalid {
        /// The offending element (`face 812`, `vertex 12`, ...).
        element: Element,
        /// The problem, phrased to follow the element (`repeats vertex 40`).
        message: String,
    },
    /// The input uses a feature this implementation does not handle, or the
    /// file extension names no known format.
    #[error("{0}")]
    Unsupported(String),
}

/// Error of a mesh reader or writer: the file (when known) and what went wrong.
///
/// Displays as `spot.obj: face 812 repeats vertex 40`, or without the
/// `path: ` prefix when the data did not come from a file.
#[derive(Debug, thiserror::Error)]
pub struct MeshIoError {
    /// The file being read or written, when known.
    pub path: Option<PathBuf>,
    /// What went wrong.
    #[source]
    pub kind: MeshIoErrorKind,
}

impl fmt::Display for MeshIoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = &self.path {
            write!(f, "{}: ", p.display())?;
        }
        write!(f, "{}", self.kind)
    }
}

impl MeshIoError {
    /// Attaches `path` (replacing any path already set).
    pub fn with_path(mut self, path: &Path) -> Self {
        self.path = Some(path.to_path_buf());
        self
    }

    pub(crate) fn parse(location: Location, message: impl Into<String>) -> Self {
        MeshIoErrorKind::Parse {
            location,
            message: message.into(),
        }
        .into()
    }

    pub(crate) fn line(line: u64, message: impl Into<String>) -> Self {
        Self::parse(Location::Line(line), message)
    }

    pub(crate) fn offset(offset: usize, message: impl Into<String>) -> Self {
        Self::parse(Location::Offset(offset as u64), message)
    }

    pub(crate) fn invalid(element: Element, message: impl Into<String>) -> Self {
        MeshIoErrorKind::Invalid {
            element,
            message: message.into(),
        }
        .into()
    }

    pub(crate) fn unsupported(message: impl Into<String>) -> Self {
        MeshIoErrorKind::Unsupported(message.into()).into()
    }
}

impl From<MeshIoErrorKind> for MeshIoError {
    fn from(kind: MeshIoErrorKind) -> Self {
        MeshIoError { path: None, kind }
    }
}

impl From<io::Error> for MeshIoError {
    fn from(e: io::Error) -> Self {
        MeshIoErrorKind::Io(e).into()
    }
}

impl From<InvalidMesh> for MeshIoError {
    fn from(e: InvalidMesh) -> Self {
        MeshIoError::invalid(e.element, e.message)
    }
}

/// Reads the mesh in `path`, choosing the format from the extension
/// (`obj`, `off`, `ply`, `gltf`, `glb`; case-insensitive). A `.gltf` file's
/// external buffers are looked up relative to the file's directory. Errors
/// carry `path`. The mesh is not [`check`]ed.
pub fn read_mesh(path: &Path) -> Result<IndexedMesh, MeshIoError> {
    let format = MeshFormat::from_path(path).ok_or_else(|| unknown_extension(path))?;
    let data = std::fs::read(path).map_err(|e| MeshIoError::from(e).with_path(path))?;
    let result = match format {
        MeshFormat::Obj => read_obj_bytes(&data),
        MeshFormat::Off => read_off_bytes(&data),
        MeshFormat::Ply => read_ply_bytes(&data),
        MeshFormat::Gltf | MeshFormat::Glb => read_gltf_bytes(&data, path.parent()),
    };
    result.map_err(|e| e.with_path(path))
}

/// Writes `mesh` to `path` atomically, choosing the format from the extension
/// (`obj`, `off` (ASCII), `ply` (binary little endian, double positions),
/// `gltf` (buffer embedded as a base64 data URI), `glb`).
///
/// The data is written to a temporary file in the same directory, flushed,
/// fsynced and renamed over `path`; on any error the temporary file is removed
/// and `path` is left as it was. Errors carry `path`.
pub fn write_mesh(path: &Path, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    let format = MeshFormat::from_path(path).ok_or_else(|| unknown_extension(path))?;
    write_atomic(path, |w| match format {
        MeshFormat::Obj => write_obj(w, mesh),
        MeshFormat::Off => write_off(w, mesh),
        MeshFormat::Ply => write_ply(w, mesh),
        MeshFormat::Gltf => write_gltf(w, mesh),
        MeshFormat::Glb => write_glb(w, mesh),
    })
    .map_err(|e| e.with_path(path))
}

/// [`write_mesh`] with glTF options (normals, quantization) for `.gltf` and
/// `.glb` targets; other formats ignore `gltf`.
pub fn write_mesh_with(
    path: &Path,
    mesh: &IndexedMesh,
    gltf: &GltfWriteOptions,
) -> Result<(), MeshIoError> {
    let format = MeshFormat::from_path(path).ok_or_else(|| unknown_extension(path))?;
    write_atomic(path, |w| match format {
        MeshFormat::Obj => write_obj(w, mesh),
        MeshFormat::Off => write_off(w, mesh),
        MeshFormat::Ply => write_ply(w, mesh),
        MeshFormat::Gltf => write_gltf_with(w, mesh, gltf),
        MeshFormat::Glb => write_glb_with(w, mesh, gltf),
    })
    .map_err(|e| e.with_path(path))
}

fn unknown_extension(path: &Path) -> MeshIoError {
    MeshIoError::unsupported(
        "unknown mesh file extension (expected .obj, .off, .ply, .gltf or .glb)",
    )
    .with_path(path)
}

/// Writes a file atomically: `body` writes into a temporary file in the
/// target's directory (`.NAME.XXXX.tmp`), which is flushed, fsynced, given
/// the usual permissions of a new file (0644 on Unix; temporary files start
/// private) and renamed over `path`. On any error the temporary file is
/// removed and `path` is untouched, so nothing half-written is ever left.
/// Generic over the caller's error type (the CLI passes `anyhow::Error`).
pub fn write_atomic<E: From<io::Error>>(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), E> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(dir)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = tmp
            .as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut w = io::BufWriter::with_capacity(1 << 20, tmp);
    body(&mut w)?;
    let tmp = w.into_inner().map_err(|e| E::from(e.into_error()))?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| E::from(e.error))?;
    // Make the rename itself durable; not all platforms can open directories.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// The text body OFF and ASCII PLY share: one row per vertex (`x y z`, then
/// that vertex's value of each of `scalars`), one row per face (`n i j k …`),
/// written through `buf` in 64 KiB pieces, then flushed.
pub(crate) fn write_ascii_rows(
    mut w: impl Write,
    mut buf: Vec<u8>,
    mesh: &IndexedMesh,
    scalars: &[&Vec<f64>],
) -> Result<(), MeshIoError> {
    for (v, p) in mesh.positions.iter().enumerate() {
        let vals = p.to_array().into_iter().chain(scalars.iter().map(|s| s[v]));
        for (k, x) in vals.enumerate() {
            if k > 0 {
                buf.push(b' ');
            }
            fmt_f64(&mut buf, x);
        }
        buf.push(b'\n');
        if buf.len() >= 1 << 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    for f in mesh.faces() {
        write!(buf, "{}", f.len())?;
        for &i in f {
            write!(buf, " {i}")?;
        }
        buf.push(b'\n');
        if buf.len() >= 1 << 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)?;
    w.flush()?;
    Ok(())
}

/// Formats `x` like C's `%g` but with the shortest digits that read back to
/// exactly `x` (so f64 positions round-trip): `1`, `0.5`, `-2.25e-7`, `1e300`.
pub(crate) fn fmt_f64(out: &mut Vec<u8>, x: f64) {
    // Rust's `Debug` for f64 is shortest-round-trip and switches to exponent
    // notation outside [1e-5, 1e16); only the "1.0" style suffix needs trimming.
    let start = out.len();
    let _ = write!(out, "{x:?}");
    if out.ends_with(b".0") {
        out.truncate(out.len() - 2);
    } else if let Some(p) = out[start..].windows(3).position(|w| w == b".0e") {
        // "1.0e300" -> "1e300"
        out.drain(start + p..start + p + 2);
    }
}

/// Checks what writers index blindly: consistent `face_starts`, vertex
/// indices in range, per-corner arrays empty or aligned and in range, vertex
/// scalar arrays of vertex length. Writers call it first so that a malformed
/// mesh gives an error instead of a panic or an unreadable file.
pub(crate) fn check_writable(m: &IndexedMesh) -> Result<(), MeshIoError> {
    let fs = &m.face_starts;
    let ok_starts = (fs.is_empty() && m.indices.is_empty())
        || (fs.first() == Some(&0)
            && fs.last().map(|&l| l as usize) == Some(m.indices.len())
            && fs.windows(2).all(|w| w[0] <= w[1]));
    if !ok_starts {
        return Err(MeshIoError::invalid(
            Element::Mesh,
            "has inconsistent face_starts (must start at 0, never decrease and end at indices.len())",
        ));
    }
    let nv = m.positions.len();
    if let Some(c) = m.indices.iter().position(|&i| i as usize >= nv) {
        let f = check::face_of_corner(m, c as u32);
        return Err(MeshIoError::invalid(
            Element::Face(f),
            format!(
                "references vertex {} but the mesh has {nv} vertices",
                m.indices[c]
            ),
        ));
    }
    for (what, idx, n) in [
        ("texture coordinate", &m.corner_texcoords, m.texcoords.len()),
        ("normal", &m.corner_normals, m.normals.len()),
    ] {
        if !idx.is_empty() && idx.len() != m.indices.len() {
            return Err(MeshIoError::invalid(
                Element::Mesh,
                format!(
                    "has {} corner {what} indices for {} corners",
                    idx.len(),
                    m.indices.len()
                ),
            ));
        }
        if let Some(c) = idx.iter().position(|&i| i as usize >= n) {
            let f = check::face_of_corner(m, c as u32);
            return Err(MeshIoError::invalid(
                Element::Face(f),
                format!("references {what} {} but the mesh has {n}", idx[c]),
            ));
        }
    }
    if let Some((name, v)) = m.vertex_scalars.iter().find(|(_, v)| v.len() != nv) {
        return Err(MeshIoError::invalid(
            Element::Mesh,
            format!(
                "has {} values of vertex property '{name}' for {nv} vertices",
                v.len()
            ),
        ));
    }
    Ok(())
}

/// Reads everything from `reader` into memory (the parsers work on slices).
pub(crate) fn read_all(mut reader: impl io::Read) -> Result<Vec<u8>, MeshIoError> {
    let mut data = Vec::new();
    reader.read_to_end(&mut data)?;
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_float_formatting_round_trips() {
        for x in [
            0.0,
            -0.0,
            1.0,
            0.1,
            -2.5e-7,
            1e300,
            123456.789,
            f64::MIN_POSITIVE,
            3e16,
        ] {
            let mut s = Vec::new();
            fmt_f64(&mut s, x);
            let s = String::from_utf8(s).unwrap();
            assert!(!s.ends_with(".0"), "{s}");
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
    }
}
