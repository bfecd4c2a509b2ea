//! The scalar importance map of qCoarsen (paper §4): one value per vertex in
//! `[1, 3]` ("in practice the best results are observed when the scalar
//! importance values are transformed into the range [1.0, 3.0]"). Larger
//! values keep elements smaller there.
//!
//! Sources:
//! * [`curvature_importance`] — from the estimated curvature, the default;
//! * [`load_importance_sidecar`] / [`parse_importance_sidecar`] — a text file
//!   with one value per vertex;
//! * [`importance_from_scalars`] — a per-vertex property of the input file
//!   (for example a PLY `quality` property).
//!
//! The loaders return the user's raw values; pass them through
//! [`remap_importance`] to get the `[1, 3]` range.

use super::curvature::Curvature;
use super::{data_lines, mismatch, parse_err, parse_real, path_name, read_text, AttributeError};
use crate::indexed::IndexedMesh;
use crate::mesh::Mesh;
use std::path::Path;

/// The importance range of the paper.
pub const IMPORTANCE_MIN: f64 = 1.0;
/// The importance range of the paper.
pub const IMPORTANCE_MAX: f64 = 3.0;

/// Percentiles of the unit-free curvature that map to [`IMPORTANCE_MIN`]
/// and [`IMPORTANCE_MAX`] in [`curvature_importance`].
pub const CURVATURE_PERCENTILES: (f64, f64) = (0.05, 0.95);

/// Importance from curvature, indexed by vertex id (`mesh.vertex_capacity()`
/// entries; deleted vertices get 1).
///
/// 1. The magnitude `sqrt(k_max² + k_min²)` is multiplied by the bounding-box
///    diagonal, so the value is unit-free (scaling the model changes
///    nothing): a sphere whose diameter is the diagonal gets `2√2`.
/// 2. The 5th and 95th percentiles over the live vertices
///    ([`CURVATURE_PERCENTILES`]) bound the range, so a few spikes (noise,
///    sharp corners) do not flatten everything else; values are clamped to
///    it and mapped linearly to `[1, 3]`.
/// 3. When the two percentiles coincide (uniform curvature, e.g. a sphere or
///    a plane) every vertex gets 1: no region is more important than another.
pub fn curvature_importance(mesh: &Mesh, curvature: &Curvature) -> Vec<f64> {
    let (lo, hi) = mesh.bounding_box();
    let diag = if mesh.vertex_count() > 0 {
        (hi - lo).length()
    } else {
        0.0
    };
    let mut out = vec![IMPORTANCE_MIN; mesh.vertex_capacity()];
    let mut live: Vec<f64> = mesh
        .vertices()
        .map(|v| curvature.magnitude(v) * diag)
        .filter(|x| x.is_finite())
        .collect();
    if live.is_empty() {
        return out;
    }
    live.sort_unstable_by(f64::total_cmp);
    let at = |q: f64| live[((live.len() - 1) as f64 * q).round() as usize];
    let (p_lo, p_hi) = (at(CURVATURE_PERCENTILES.0), at(CURVATURE_PERCENTILES.1));
    // Relative tolerance: percentiles equal up to rounding mean "uniform".
    let spread = p_hi - p_lo > 1e-9 * p_hi.abs().max(1e-12);
    if !spread {
        return out;
    }
    for v in mesh.vertices() {
        let x = curvature.magnitude(v) * diag;
        let t = if x.is_finite() {
            ((x - p_lo) / (p_hi - p_lo)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        out[v.idx()] = IMPORTANCE_MIN + t * (IMPORTANCE_MAX - IMPORTANCE_MIN);
    }
    out
}

/// Maps user importance values linearly so that their minimum becomes 1 and
/// their maximum 3. A constant map (or an empty one) becomes all 1.
/// Non-finite entries are ignored for the range and become 1.
pub fn remap_importance(values: &[f64]) -> Vec<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &x in values.iter().filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    let range = hi - lo;
    values
        .iter()
        .map(|&x| {
            if x.is_finite() && range > 0.0 && range.is_finite() {
                IMPORTANCE_MIN + (x - lo) / range * (IMPORTANCE_MAX - IMPORTANCE_MIN)
            } else {
                IMPORTANCE_MIN
            }
        })
        .collect()
}

/// Reads an importance sidecar: a text file with exactly one finite number
/// per vertex, in vertex order (`#` comments and blank lines allowed; see
/// [`crate::attributes`]). Returns the raw values (see [`remap_importance`]).
/// Errors name the file and line: `imp.txt line 7: 'abc' is not a number`,
/// `imp.txt: 1200 values for 1202 vertices`.
pub fn load_importance_sidecar(
    path: &Path,
    vertex_count: usize,
) -> Result<Vec<f64>, AttributeError> {
    let text = read_text(path)?;
    parse_importance_sidecar(&text, &path_name(path), vertex_count)
}

/// [`load_importance_sidecar`] on text already in memory; `source_name`
/// names it in errors.
pub fn parse_importance_sidecar(
    text: &str,
    source_name: &str,
    vertex_count: usize,
) -> Result<Vec<f64>, AttributeError> {
    let mut out = Vec::with_capacity(vertex_count.min(1 << 24));
    for (line, content) in data_lines(text) {
        let mut toks = content.split_whitespace();
        let (Some(tok), None) = (toks.next(), toks.next()) else {
            return Err(parse_err(
                source_name,
                line,
                format!("expected one number per line, found '{content}'"),
            ));
        };
        if out.len() == vertex_count {
            return Err(parse_err(
                source_name,
                line,
                format!("more values than the mesh's {vertex_count} vertices"),
            ));
        }
        out.push(parse_real(source_name, line, tok)?);
    }
    if out.len() != vertex_count {
        return Err(mismatch(
            source_name,
            format!("{} values for {vertex_count} vertices", out.len()),
        ));
    }
    Ok(out)
}

/// The per-vertex property `name` of `mesh` (for example a PLY `quality`
/// property read into [`IndexedMesh::vertex_scalars`]), checked: it must
/// exist, have one value per vertex and be finite. Returns the raw values
/// (see [`remap_importance`]).
pub fn importance_from_scalars(mesh: &IndexedMesh, name: &str) -> Result<Vec<f64>, AttributeError> {
    let source = format!("vertex property '{name}'");
    let Some(values) = mesh.vertex_scalars.get(name) else {
        let known: Vec<&str> = mesh.vertex_scalars.keys().map(|k| k.as_str()).collect();
        let known = if known.is_empty() {
            "the mesh has no per-vertex properties".to_string()
        } else {
            format!("available: {}", known.join(", "))
        };
        return Err(mismatch(&source, format!("not found ({known})")));
    };
    if values.len() != mesh.vertex_count() {
        return Err(mismatch(
            &source,
            format!(
                "{} values for {} vertices",
                values.len(),
                mesh.vertex_count()
            ),
        ));
    }
    if let Some(i) = values.iter().position(|x| !x.is_finite()) {
        return Err(mismatch(
            &source,
            format!("vertex {i} has the non-finite value {}", values[i]),
        ));
    }
    Ok(values.clone())
}
