//! Surface attributes that guide the qCoarsen coarsener (paper §4):
//!
//! * [`curvature`] — principal curvatures and directions per vertex
//!   (normal-cycle tensor, Cohen-Steiner & Morvan / Alliez et al. 2003), and
//!   a small robust 3×3 symmetric eigen solver;
//! * [`importance`] — the scalar importance map in `[1, 3]`, from curvature
//!   or from a user map (sidecar text file or a PLY vertex property);
//! * [`field`] — the per-vertex direction field and the paper's alignment
//!   score of quad dual chords against it.
//!
//! Every per-vertex vector here is indexed by vertex id
//! (`mesh.vertex_capacity()` entries); deleted vertices get neutral values.
//!
//! Sidecar text files share one syntax: `#` starts a comment that runs to
//! the end of the line, blank lines are ignored, numbers are separated by
//! white space. Errors name the file and the 1-based line.

pub mod curvature;
pub mod field;
pub mod importance;

pub use curvature::{symmetric_eigen3, Curvature, CurvatureOptions, PrincipalCurvature};
pub use field::{alignment, load_field_sidecar, parse_field_sidecar, quad_alignment, Field};
pub use importance::{
    curvature_importance, importance_from_scalars, load_importance_sidecar,
    parse_importance_sidecar, remap_importance,
};

use std::path::{Path, PathBuf};

/// An attribute (importance map, direction field or feature file) could not
/// be loaded or does not fit the mesh. Messages name the source and, for
/// text files, the 1-based line: `features.txt line 4: vertex 900 is out of
/// range (the mesh has 812 vertices)`.
#[derive(Debug, thiserror::Error)]
pub enum AttributeError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A line of a text sidecar is malformed.
    #[error("{source_name} line {line}: {message}")]
    Parse {
        /// The file (or other source) name.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The data does not fit the mesh (wrong count, missing property,
    /// an edge that is not in the mesh...).
    #[error("{source_name}: {message}")]
    Mismatch {
        /// The file (or other source) name.
        source_name: String,
        /// What is wrong.
        message: String,
    },
}

/// Reads a whole text file, mapping the error to [`AttributeError::Io`].
pub(crate) fn read_text(path: &Path) -> Result<String, AttributeError> {
    std::fs::read_to_string(path).map_err(|source| AttributeError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The data lines of a sidecar text: `(1-based line number, content without
/// comment)`, skipping blank and comment-only lines.
pub(crate) fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(i, l)| {
        let l = l.split('#').next().unwrap_or("").trim();
        (!l.is_empty()).then_some((i + 1, l))
    })
}

pub(crate) fn parse_err(source_name: &str, line: usize, message: String) -> AttributeError {
    AttributeError::Parse {
        source_name: source_name.to_string(),
        line,
        message,
    }
}

pub(crate) fn mismatch(source_name: &str, message: String) -> AttributeError {
    AttributeError::Mismatch {
        source_name: source_name.to_string(),
        message,
    }
}

/// Parses one finite real number of a sidecar line.
pub(crate) fn parse_real(source_name: &str, line: usize, tok: &str) -> Result<f64, AttributeError> {
    match tok.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(parse_err(
            source_name,
            line,
            format!("'{tok}' is not a finite number"),
        )),
        Err(_) => Err(parse_err(
            source_name,
            line,
            format!("'{tok}' is not a number"),
        )),
    }
}

/// A name for error messages: the path as given.
pub(crate) fn path_name(path: &Path) -> String {
    path.display().to_string()
}
