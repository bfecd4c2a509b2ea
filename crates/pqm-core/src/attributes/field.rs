//! The per-vertex direction field of qCoarsen and the paper's alignment
//! score (§4, "the alignment term A", Fig. 4).
//!
//! A [`Field`] holds one 3D vector per vertex id. Only its direction in the
//! tangent plane matters, **modulo 90°**: quads have two chord directions at
//! right angles, so the field is read as a cross field (4-RoSy), and `u`,
//! `−u` and `u` turned by 90° in the tangent plane all mean the same thing.
//! The length is a confidence: a zero vector (or shorter than
//! [`FIELD_MIN_LENGTH`]) means "no direction here" and the coarsener's
//! alignment term ignores it.
//!
//! The alignment of a direction `d` to the field `u` in the plane with
//! normal `n` is `|cos 2θ|`, where `θ` is the angle between the projections
//! of `d` and `u` onto the plane: 1 at 0° and 90°, 0 at 45° (the paper
//! scales the angle modulo 90° to `[0, 1]` with those three values).

use super::curvature::Curvature;
use super::{data_lines, mismatch, parse_err, parse_real, path_name, read_text, AttributeError};
use crate::mesh::{FaceId, Mesh, VertexId};
use glam::DVec3;
use std::path::Path;

/// Field vectors shorter than this (after projection to the tangent plane)
/// count as "no direction". Field vectors are meant to have length about 1
/// (unit directions or confidences in `[0, 1]`).
pub const FIELD_MIN_LENGTH: f64 = 1e-6;

/// A direction is treated as perpendicular to the plane — so without a
/// direction in it — when its projection keeps less than this fraction of
/// its length (1e-3, about 0.06° from the normal).
pub const MIN_PROJECTED_FRACTION: f64 = 1e-3;

/// A per-vertex direction field, indexed by vertex id (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Field {
    /// One vector per vertex id; zero means no direction.
    pub dirs: Vec<DVec3>,
}

impl Field {
    /// The empty field: no direction anywhere (`mesh.vertex_capacity()`
    /// zero vectors). The alignment term then drops out.
    pub fn none(mesh: &Mesh) -> Field {
        Field {
            dirs: vec![DVec3::ZERO; mesh.vertex_capacity()],
        }
    }

    /// The principal direction of maximal curvature magnitude at each vertex,
    /// scaled by its anisotropy (so umbilic and flat regions have no
    /// direction). See [`crate::attributes::curvature`].
    pub fn from_curvature(curvature: &Curvature) -> Field {
        Field {
            dirs: curvature
                .vertices
                .iter()
                .map(|c| c.dir_max * c.anisotropy)
                .collect(),
        }
    }

    /// The same vector `axis` at every live vertex (deleted vertices get
    /// zero); projected on the surface, as in the paper's Fig. 4 demo.
    pub fn constant(mesh: &Mesh, axis: DVec3) -> Field {
        let mut dirs = vec![DVec3::ZERO; mesh.vertex_capacity()];
        for v in mesh.vertices() {
            dirs[v.idx()] = axis;
        }
        Field { dirs }
    }

    /// [`Field::constant`] along a named coordinate axis: `x`, `y` or `z`
    /// (case-insensitive).
    pub fn from_axis_name(mesh: &Mesh, name: &str) -> Result<Field, AttributeError> {
        let axis = match name.trim().to_ascii_lowercase().as_str() {
            "x" => DVec3::X,
            "y" => DVec3::Y,
            "z" => DVec3::Z,
            _ => {
                return Err(mismatch(
                    "field axis",
                    format!("'{name}' is not an axis (expected x, y or z)"),
                ))
            }
        };
        Ok(Field::constant(mesh, axis))
    }

    /// True when no vertex has a direction (every vector shorter than
    /// [`FIELD_MIN_LENGTH`]).
    pub fn is_empty(&self) -> bool {
        !self
            .dirs
            .iter()
            .any(|d| d.length_squared() >= FIELD_MIN_LENGTH * FIELD_MIN_LENGTH)
    }

    /// The vector at `v` (zero for ids beyond the field).
    #[inline]
    pub fn at(&self, v: VertexId) -> DVec3 {
        self.dirs.get(v.idx()).copied().unwrap_or(DVec3::ZERO)
    }

    /// The field at face `f`: the 4-RoSy average ([`rosy4_average`]) of its
    /// vertices' vectors in the plane of the face normal. The result lies in
    /// that plane; its length is the average confidence, reduced where the
    /// vertices disagree. Allocation-free.
    pub fn at_face(&self, mesh: &Mesh, f: FaceId) -> DVec3 {
        let n = face_area_vector(mesh, f);
        rosy4_average(n, mesh.face_vertices(f).map(|v| self.at(v)))
    }
}

/// Twice the area vector of face `f` for a quad (`(p2 − p0) × (p3 − p1)`),
/// Newell's normal otherwise; not normalised.
#[inline]
fn face_area_vector(mesh: &Mesh, f: FaceId) -> DVec3 {
    if let Some(q) = mesh.quad_vertices(f) {
        let p = q.map(|v| mesh.position(v));
        return (p[2] - p[0]).cross(p[3] - p[1]);
    }
    mesh.face_normal(f)
}

/// Averages direction vectors as a cross field (4-RoSy) in the plane with
/// normal `normal` (any length): each vector is projected to the plane,
/// written as `m·e^{iφ}` in a tangent basis, and represented by `m·e^{4iφ}`,
/// so `u`, `−u` and `u` turned by 90° add up instead of cancelling. The
/// average of these (divided by the number of vectors, zero ones included)
/// is turned back into a vector at angle `arg / 4`: one of the four
/// equivalent representatives, with length = the averaged confidence.
/// Returns zero when `normal` is zero or nothing survives. Allocation-free.
pub fn rosy4_average(normal: DVec3, vectors: impl IntoIterator<Item = DVec3>) -> DVec3 {
    let Some(r) = Rosy4Sum::new(normal, vectors) else {
        return DVec3::ZERO;
    };
    let m = r.magnitude();
    if m.is_nan() || m <= 0.0 {
        return DVec3::ZERO;
    }
    let (s, c) = (0.25 * r.wy.atan2(r.wx)).sin_cos();
    (r.t1 * c + r.t2 * s) * m
}

/// The sum of `m·e^{4iφ}` over vectors projected into a tangent basis
/// `(t1, t2)` of a plane (see [`rosy4_average`]).
struct Rosy4Sum {
    t1: DVec3,
    t2: DVec3,
    wx: f64,
    wy: f64,
    count: usize,
}

impl Rosy4Sum {
    /// `None` when `normal` is zero or there are no vectors.
    #[inline]
    fn new(normal: DVec3, vectors: impl IntoIterator<Item = DVec3>) -> Option<Rosy4Sum> {
        let n = normal.normalize_or_zero();
        if n == DVec3::ZERO {
            return None;
        }
        let (t1, t2) = n.any_orthonormal_pair();
        let mut r = Rosy4Sum {
            t1,
            t2,
            wx: 0.0,
            wy: 0.0,
            count: 0,
        };
        for u in vectors {
            r.count += 1;
            let (a, b) = (u.dot(t1), u.dot(t2));
            let m2 = a * a + b * b;
            let usable = m2 > 0.0 && m2.is_finite();
            if !usable {
                continue;
            }
            // z⁴ / |z|³ has length |z| and angle 4φ
            let (x4, y4) = pow4(a, b);
            let s = 1.0 / (m2 * m2.sqrt());
            r.wx += x4 * s;
            r.wy += y4 * s;
        }
        (r.count > 0).then_some(r)
    }

    /// The averaged confidence `|Σ| / count`.
    #[inline]
    fn magnitude(&self) -> f64 {
        self.wx.hypot(self.wy) / self.count as f64
    }

    /// `e^{2iψ}` with `ψ` the averaged field's angle: the principal square
    /// root of the unit sum `Σ / |Σ|` (a stable complex square root, so
    /// that scores near 0 stay accurate). `None` when the sum is zero.
    #[inline]
    fn half_angle(&self) -> Option<(f64, f64)> {
        let w = self.wx.hypot(self.wy);
        let usable = w > 0.0 && w.is_finite();
        if !usable {
            return None;
        }
        let (x, y) = (self.wx / w, self.wy / w);
        Some(if x >= 0.0 {
            let re = (0.5 * (1.0 + x)).sqrt();
            (re, y / (2.0 * re))
        } else {
            let im = (0.5 * (1.0 - x)).sqrt().copysign(y);
            (y / (2.0 * im), im)
        })
    }
}

/// [`alignment`] of `dir` against a field of angle `ψ` given as
/// `h = e^{2iψ}` in the basis `(t1, t2)`, without trigonometry or square
/// roots: `cos 2(δ − ψ) = Re(e^{2iδ} · conj(h))`.
#[inline]
fn alignment_half_angle(dir: DVec3, t1: DVec3, t2: DVec3, h: (f64, f64)) -> Option<f64> {
    let (a, b) = (dir.dot(t1), dir.dot(t2));
    let dd = a * a + b * b;
    let frac2 = MIN_PROJECTED_FRACTION * MIN_PROJECTED_FRACTION;
    let usable = dd > 0.0 && dd > frac2 * dir.length_squared();
    if !usable {
        return None;
    }
    let c2 = ((a * a - b * b) * h.0 + 2.0 * a * b * h.1) / dd;
    c2.is_finite().then(|| c2.abs().min(1.0))
}

/// `(a + ib)⁴` as `(re, im)`.
#[inline]
fn pow4(a: f64, b: f64) -> (f64, f64) {
    let (x2, y2) = (a * a - b * b, 2.0 * a * b);
    (x2 * x2 - y2 * y2, 2.0 * x2 * y2)
}

/// The paper's alignment score of direction `dir` against the field vector
/// `field` in the plane with normal `normal` (any non-zero length): both are
/// projected into the plane, and with `θ` the angle between the
/// projections, the score is `|cos 2θ|` — 1 when `dir` is parallel or
/// perpendicular to the field, 0 at 45°. Invariant under flipping either
/// vector and under turning the field by 90° in the plane.
///
/// `None` when there is nothing to compare: `normal` is zero, the projected
/// field is shorter than [`FIELD_MIN_LENGTH`], or either projection keeps
/// less than [`MIN_PROJECTED_FRACTION`] of its vector's length. No square
/// roots, trigonometry or allocation.
#[inline]
pub fn alignment(dir: DVec3, field: DVec3, normal: DVec3) -> Option<f64> {
    let nn = normal.length_squared();
    let usable = nn > 0.0 && nn.is_finite();
    if !usable {
        return None;
    }
    let d = dir - normal * (normal.dot(dir) / nn);
    let f = field - normal * (normal.dot(field) / nn);
    let (dd, ff) = (d.length_squared(), f.length_squared());
    let frac2 = MIN_PROJECTED_FRACTION * MIN_PROJECTED_FRACTION;
    let usable = ff >= FIELD_MIN_LENGTH * FIELD_MIN_LENGTH
        && ff > frac2 * field.length_squared()
        && dd > frac2 * dir.length_squared()
        && dd > 0.0;
    if !usable {
        return None;
    }
    let dot = d.dot(f);
    let dot2 = dot * dot;
    let prod = dd * ff;
    // cos 2θ = cos²θ − sin²θ = (2·dot² − |d|²|f|²) / (|d|²|f|²)
    let c2 = (2.0 * dot2 - prod) / prod;
    c2.is_finite().then(|| c2.abs().min(1.0))
}

/// The alignment of quad `f` to the field (paper §4, `A`): the mean of the
/// [`alignment`] of its two dual chords — midpoint of edge 0-1 → midpoint of
/// edge 2-3, and midpoint of 1-2 → midpoint of 3-0 — against
/// [`Field::at_face`], in the plane of the face normal. `None` when `f` is
/// not a quad or the field has no direction there. Allocation-free.
pub fn quad_alignment(mesh: &Mesh, f: FaceId, field: &Field) -> Option<f64> {
    let q = mesh.quad_vertices(f)?;
    let p = q.map(|v| mesh.position(v));
    let n = (p[2] - p[0]).cross(p[3] - p[1]);
    // Same result as `alignment(chord, field.at_face(mesh, f), n)`, but
    // scored directly against the 4-RoSy sum (no trigonometry).
    let r = Rosy4Sum::new(n, q.map(|v| field.at(v)))?;
    if r.magnitude().is_nan() || r.magnitude() < FIELD_MIN_LENGTH {
        return None;
    }
    // chord directions (factor ½ of the midpoints dropped: scale-invariant)
    let c1 = (p[2] + p[3]) - (p[0] + p[1]);
    let c2 = (p[3] + p[0]) - (p[1] + p[2]);
    let h = r.half_angle()?;
    match (
        alignment_half_angle(c1, r.t1, r.t2, h),
        alignment_half_angle(c2, r.t1, r.t2, h),
    ) {
        (Some(a), Some(b)) => Some(0.5 * (a + b)),
        (Some(a), None) | (None, Some(a)) => Some(a),
        (None, None) => None,
    }
}

/// Reads a direction-field sidecar for `mesh` (see [`parse_field_sidecar`]).
pub fn load_field_sidecar(path: &Path, mesh: &Mesh) -> Result<Field, AttributeError> {
    let text = read_text(path)?;
    parse_field_sidecar(&text, &path_name(path), mesh)
}

/// Parses a direction-field sidecar: one 3D vector (`x y z`) per line, either
/// one per vertex id or one per face id of `mesh` as loaded (ids
/// `0..vertex_capacity()` / `0..face_capacity()`). `#` comments and blank
/// lines are allowed; a zero vector means no direction.
///
/// The number of vectors decides: as many as vertices → per vertex; as many
/// as faces → per face, and each vertex gets the [`rosy4_average`] of its
/// faces' vectors in its tangent plane (normal = sum of the face normals).
/// When the mesh has as many vertices as faces (every closed genus-1 quad
/// mesh), the first data line must say which: `per_vertex` or `per_face`
/// (the directive is accepted in any file). Errors name the source and line.
pub fn parse_field_sidecar(
    text: &str,
    source_name: &str,
    mesh: &Mesh,
) -> Result<Field, AttributeError> {
    let (nv, nf) = (mesh.vertex_capacity(), mesh.face_capacity());
    let max = nv.max(nf);
    let mut directive: Option<bool> = None; // Some(true) = per face
    let mut vecs: Vec<DVec3> = Vec::new();
    for (line, content) in data_lines(text) {
        match content {
            "per_vertex" | "per_face" => {
                if directive.is_some() || !vecs.is_empty() {
                    return Err(parse_err(
                        source_name,
                        line,
                        format!("'{content}' must be the first data line, given once"),
                    ));
                }
                directive = Some(content == "per_face");
                continue;
            }
            _ => {}
        }
        let toks: Vec<&str> = content.split_whitespace().collect();
        if toks.len() != 3 {
            return Err(parse_err(
                source_name,
                line,
                format!("expected three numbers 'x y z', found '{content}'"),
            ));
        }
        if vecs.len() == max {
            return Err(parse_err(
                source_name,
                line,
                format!("more vectors than the mesh's {nv} vertices and {nf} faces"),
            ));
        }
        let x = parse_real(source_name, line, toks[0])?;
        let y = parse_real(source_name, line, toks[1])?;
        let z = parse_real(source_name, line, toks[2])?;
        vecs.push(DVec3::new(x, y, z));
    }
    let n = vecs.len();
    let per_face = match directive {
        Some(pf) => {
            let want = if pf { nf } else { nv };
            if n != want {
                return Err(mismatch(
                    source_name,
                    format!(
                        "{n} vectors, but the mesh has {want} {}",
                        if pf { "faces" } else { "vertices" }
                    ),
                ));
            }
            pf
        }
        None if n == nv && n == nf => {
            return Err(mismatch(
                source_name,
                format!(
                    "{n} vectors match both the vertex and the face count; \
                     start the file with a line 'per_vertex' or 'per_face'"
                ),
            ))
        }
        None if n == nv => false,
        None if n == nf => true,
        None => {
            return Err(mismatch(
                source_name,
                format!("{n} vectors, but the mesh has {nv} vertices and {nf} faces"),
            ))
        }
    };
    if !per_face {
        return Ok(Field { dirs: vecs });
    }
    let mut dirs = vec![DVec3::ZERO; nv];
    for v in mesh.vertices() {
        let normal: DVec3 = mesh.vertex_faces(v).map(|f| mesh.face_normal(f)).sum();
        dirs[v.idx()] = rosy4_average(normal, mesh.vertex_faces(v).map(|f| vecs[f.idx()]));
    }
    Ok(Field { dirs })
}
