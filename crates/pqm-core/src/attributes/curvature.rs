//! Principal curvatures and directions per vertex from the normal-cycle
//! curvature tensor (Cohen-Steiner & Morvan 2003), as used by Alliez et al.
//! 2003, "Anisotropic polygonal remeshing".
//!
//! # Method
//! 1. Every face is virtually triangulated: a quad (or any polygon with more
//!    than three vertices) is split into a **centroid fan** — one triangle
//!    per edge, joining the edge to the face's vertex centroid — so a quad
//!    gives the four triangles the paper mentions, without favouring either
//!    diagonal. Triangles are kept as they are.
//! 2. Every edge `e` of that virtual triangulation with two triangles gets
//!    the tensor `β(e) · |e| · ê êᵀ`, where `β` is the signed dihedral angle
//!    between the triangles' normals (positive on convex edges, with normals
//!    pointing to the side the faces are counter-clockwise from) and `ê` the
//!    unit edge direction. Mesh boundary edges carry no bending.
//! 3. The neighbourhood `B` of vertex `v` is its `rings`-ring of faces
//!    (ring 1: the faces around `v`; ring k+1: every face sharing a vertex
//!    with ring k). An edge inside `B` counts fully, an edge on the border of
//!    `B` counts half (half of the edge's bending lies on each side). The
//!    tensor is `T(v) = Σ_e w(e) β(e) |e| ê êᵀ / area(B)`.
//! 4. `T` is diagonalised with [`symmetric_eigen3`]. The eigenvector most
//!    aligned with the vertex normal (area-weighted normal of the faces
//!    around `v`) is the normal direction; the two others are tangent. Their
//!    eigenvalues are the principal curvatures, with the directions
//!    **swapped**: an edge along `ê` bends the surface across `ê`, so the
//!    eigenvalue of eigenvector `e₁` is the curvature in the tangent
//!    direction perpendicular to `e₁`.
//!
//! # Units and conventions
//! Curvatures are in `1/u` (inverse model units), signed: positive where the
//! surface is convex towards its normal (a sphere with outward normals has
//! `+1/R`), negative on the inside of a saddle. "max"/"min" refer to the
//! **absolute value**: `|k_max| ≥ |k_min|`. Directions are unit vectors in
//! the vertex tangent plane (or zero when undefined). The direction field of
//! [`crate::attributes::Field::from_curvature`] uses `dir_max`; as a cross
//! field it is the same as `dir_min` (they are 90° apart), and the quad
//! edges of a good quad mesh follow both.
//!
//! Cost: O(F) for the per-face tensors plus, per vertex, the size of its
//! `rings`-ring (4 faces for `rings = 1`, 16 for `rings = 2` on a regular quad
//! mesh).

use crate::mesh::{Mesh, VertexId};
use glam::DVec3;
use rayon::prelude::*;

/// Options of [`Curvature::compute`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvatureOptions {
    /// Neighbourhood size in face rings (1 or more; 0 is treated as 1).
    /// 1 (the default) follows the surface closely and keeps creases
    /// localised (on the 766-vertex fandisk quad mesh, 2 rings spread the
    /// creases' curvature over most of the part); 2 averages out noise and
    /// the faceting of irregular meshes, at a bias that is second order in
    /// the ring size (measured: 8% on the small curvature of a 96 × 32
    /// torus, 2% at 192 × 64).
    pub rings: u32,
    /// Curvature below which a region counts as flat, in units of
    /// `1 / bounding-box diagonal` (default 0.05: a radius of 20 diagonals).
    /// It damps the anisotropy there (see [`PrincipalCurvature::anisotropy`]).
    pub flat_curvature: f64,
}

impl Default for CurvatureOptions {
    fn default() -> Self {
        CurvatureOptions {
            rings: 1,
            flat_curvature: 0.05,
        }
    }
}

/// The curvature estimate at one vertex (see the module docs for units and
/// sign conventions).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrincipalCurvature {
    /// The principal curvature of larger magnitude (signed, `1/u`).
    pub k_max: f64,
    /// The principal curvature of smaller magnitude (signed, `1/u`).
    pub k_min: f64,
    /// Unit tangent direction in which the normal curvature is `k_max`
    /// (zero when the vertex normal is undefined).
    pub dir_max: DVec3,
    /// Unit tangent direction of `k_min`: `normal × dir_max`.
    pub dir_min: DVec3,
    /// Unit vertex normal (area-weighted normal of the faces around it).
    pub normal: DVec3,
    /// How well defined the directions are, in `[0, 1]`:
    /// `(|k_max| − |k_min|) / (|k_max| + |k_min| + ε)`, with `ε` the
    /// `flat_curvature` option: 0 on umbilic (sphere-like) and flat regions,
    /// near 1 on cylinder-like regions.
    pub anisotropy: f64,
}

/// Per-vertex curvature of a mesh, indexed by vertex id
/// (`mesh.vertex_capacity()` entries; deleted vertices get
/// `PrincipalCurvature::default()`, all zero).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curvature {
    /// The estimate at each vertex id.
    pub vertices: Vec<PrincipalCurvature>,
}

/// Symmetric 3×3 tensor as `[xx, xy, xz, yy, yz, zz]`.
type Sym = [f64; 6];

#[inline]
fn sym_outer(e: DVec3, w: f64) -> Sym {
    [
        w * e.x * e.x,
        w * e.x * e.y,
        w * e.x * e.z,
        w * e.y * e.y,
        w * e.y * e.z,
        w * e.z * e.z,
    ]
}

#[inline]
fn sym_add(a: &mut Sym, b: &Sym, w: f64) {
    for (x, y) in a.iter_mut().zip(b.iter()) {
        *x += w * y;
    }
}

/// Signed dihedral angle across an edge: `n1` is the normal of the triangle
/// in which the edge runs along `e` counter-clockwise, `n2` the other one.
/// Positive when the surface is convex there.
#[inline]
fn signed_dihedral(n1: DVec3, n2: DVec3, e_unit: DVec3) -> f64 {
    n1.cross(n2).dot(e_unit).atan2(n1.dot(n2))
}

impl Curvature {
    /// Estimates curvature at every live vertex with the default options.
    pub fn estimate(mesh: &Mesh) -> Curvature {
        Curvature::compute(mesh, &CurvatureOptions::default())
    }

    /// Estimates curvature at every live vertex (see the module docs).
    pub fn compute(mesh: &Mesh, opts: &CurvatureOptions) -> Curvature {
        let (lo, hi) = mesh.bounding_box();
        let diag = if mesh.vertex_count() > 0 {
            (hi - lo).length()
        } else {
            0.0
        };
        let eps = if diag > 0.0 {
            opts.flat_curvature.max(0.0) / diag
        } else {
            0.0
        };
        let rings = opts.rings.max(1);

        // Per half-edge: unit normal of the virtual triangle that holds it.
        let mut he_normal = vec![DVec3::ZERO; mesh.halfedge_capacity()];
        // Per face: Σ (spoke tensors) + ½ Σ (own edge tensors); area; normal·area.
        let mut face_t = vec![[0.0; 6]; mesh.face_capacity()];
        let mut face_area = vec![0.0; mesh.face_capacity()];
        let mut face_n = vec![DVec3::ZERO; mesh.face_capacity()];
        let mut ring: Vec<(DVec3, crate::mesh::HalfedgeId)> = Vec::with_capacity(8);
        for f in mesh.faces() {
            ring.clear();
            ring.extend(
                mesh.face_halfedges(f)
                    .map(|h| (mesh.position(mesh.from_vertex(h)), h)),
            );
            let n = ring.len();
            if n == 3 {
                let c = (ring[1].0 - ring[0].0).cross(ring[2].0 - ring[0].0);
                let nn = c.normalize_or_zero();
                for &(_, h) in &ring {
                    he_normal[h.idx()] = nn;
                }
                face_area[f.idx()] = 0.5 * c.length();
                face_n[f.idx()] = 0.5 * c;
                continue;
            }
            let centroid = ring.iter().map(|r| r.0).sum::<DVec3>() / n as f64;
            let mut area = 0.0;
            let mut an = DVec3::ZERO;
            // triangle i = (centroid, p_i, p_{i+1}) holds half-edge i
            for i in 0..n {
                let (p, h) = ring[i];
                let q = ring[(i + 1) % n].0;
                let c = (p - centroid).cross(q - centroid);
                he_normal[h.idx()] = c.normalize_or_zero();
                area += 0.5 * c.length();
                an += 0.5 * c;
            }
            // spoke i (centroid → p_i) runs counter-clockwise in triangle i,
            // its other triangle is i − 1
            let mut t = [0.0; 6];
            for i in 0..n {
                let (p, h) = ring[i];
                let hp = ring[(i + n - 1) % n].1;
                let e = p - centroid;
                let len = e.length();
                if len <= 0.0 {
                    continue;
                }
                let eu = e / len;
                let beta = signed_dihedral(he_normal[h.idx()], he_normal[hp.idx()], eu);
                sym_add(&mut t, &sym_outer(eu, beta * len), 1.0);
            }
            face_t[f.idx()] = t;
            face_area[f.idx()] = area;
            face_n[f.idx()] = an;
        }
        // Mesh edges with two faces: half of the tensor to each face.
        for h in mesh.halfedges() {
            let t = mesh.twin(h);
            if h.0 > t.0 {
                continue;
            }
            let (Some(f1), Some(f2)) = (mesh.face(h), mesh.face(t)) else {
                continue;
            };
            let e = mesh.position(mesh.to_vertex(h)) - mesh.position(mesh.from_vertex(h));
            let len = e.length();
            if len <= 0.0 {
                continue;
            }
            let eu = e / len;
            let beta = signed_dihedral(he_normal[h.idx()], he_normal[t.idx()], eu);
            let et = sym_outer(eu, beta * len);
            sym_add(&mut face_t[f1.idx()], &et, 0.5);
            sym_add(&mut face_t[f2.idx()], &et, 0.5);
        }

        // Per vertex: gather the rings with stamp marks (no hashing). Each
        // vertex reads only the per-face sums above, so blocks of vertex ids
        // run in parallel (rayon), each with its own marks, and every
        // vertex gets the very value the sequential loop gave (on the
        // bunny this loop was most of the setup before coarsening).
        let mut out = vec![PrincipalCurvature::default(); mesh.vertex_capacity()];
        let block = out
            .len()
            .div_ceil(4 * rayon::current_num_threads())
            .max(4096);
        out.par_chunks_mut(block)
            .enumerate()
            .for_each(|(b, chunk)| {
                let mut face_mark = vec![u32::MAX; mesh.face_capacity()];
                let mut vert_mark = vec![u32::MAX; mesh.vertex_capacity()];
                let mut frontier: Vec<VertexId> = Vec::new();
                let mut next: Vec<VertexId> = Vec::new();
                for (k, slot) in chunk.iter_mut().enumerate() {
                    let v = VertexId((b * block + k) as u32);
                    if !mesh.is_vertex_alive(v) {
                        continue;
                    }
                    let stamp = v.0;
                    let mut normal = DVec3::ZERO;
                    for f in mesh.vertex_faces(v) {
                        normal += face_n[f.idx()];
                    }
                    let normal = normal.normalize_or_zero();
                    if normal == DVec3::ZERO {
                        continue;
                    }
                    let mut t = [0.0; 6];
                    let mut area = 0.0;
                    frontier.clear();
                    frontier.push(v);
                    vert_mark[v.idx()] = stamp;
                    for _ in 0..rings {
                        next.clear();
                        for &u in &frontier {
                            for f in mesh.vertex_faces(u) {
                                if face_mark[f.idx()] == stamp {
                                    continue;
                                }
                                face_mark[f.idx()] = stamp;
                                sym_add(&mut t, &face_t[f.idx()], 1.0);
                                area += face_area[f.idx()];
                                for w in mesh.face_vertices(f) {
                                    if vert_mark[w.idx()] != stamp {
                                        vert_mark[w.idx()] = stamp;
                                        next.push(w);
                                    }
                                }
                            }
                        }
                        std::mem::swap(&mut frontier, &mut next);
                    }
                    if area > 0.0 {
                        for x in t.iter_mut() {
                            *x /= area;
                        }
                    }
                    *slot = principal_from_tensor(&t, normal, eps);
                }
            });
        Curvature { vertices: out }
    }

    /// `sqrt(k_max² + k_min²)` at vertex `v` (`1/u`; 0 for unknown ids).
    pub fn magnitude(&self, v: VertexId) -> f64 {
        self.vertices
            .get(v.idx())
            .map_or(0.0, |c| c.k_max.hypot(c.k_min))
    }
}

/// Principal curvatures from the averaged tensor `t` at a vertex with unit
/// normal `normal`; `eps` damps the anisotropy of flat regions.
fn principal_from_tensor(t: &Sym, normal: DVec3, eps: f64) -> PrincipalCurvature {
    let m = [[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]];
    let (vals, vecs) = symmetric_eigen3(m);
    // the eigenvector closest to the normal is the normal direction
    let mut ni = 0;
    for i in 1..3 {
        if vecs[i].dot(normal).abs() > vecs[ni].dot(normal).abs() {
            ni = i;
        }
    }
    let (a, b) = ((ni + 1) % 3, (ni + 2) % 3);
    // eigenvalue of e_a is the curvature across e_a, i.e. along e_b
    let (mut k_max, mut k_min, mut across_max) = (vals[a], vals[b], vecs[a]);
    if k_min.abs() > k_max.abs() {
        std::mem::swap(&mut k_max, &mut k_min);
        across_max = vecs[b];
    }
    // direction of k_max is perpendicular to `across_max` in the tangent plane
    let dir_max = normal.cross(across_max).normalize_or_zero();
    let dir_max = (dir_max - normal * normal.dot(dir_max)).normalize_or_zero();
    let dir_min = normal.cross(dir_max);
    let denom = k_max.abs() + k_min.abs() + eps;
    let anisotropy = if denom > 0.0 {
        ((k_max.abs() - k_min.abs()) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    PrincipalCurvature {
        k_max,
        k_min,
        dir_max,
        dir_min,
        normal,
        anisotropy,
    }
}

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations
/// (robust for repeated and zero eigenvalues; at most 32 sweeps, usually 4
/// or 5). Only the upper triangle of `m` is read.
///
/// Returns the eigenvalues in ascending order and the matching unit
/// eigenvectors (`m · vecs[i] ≈ vals[i] · vecs[i]`; the vectors form a
/// right-handed orthonormal basis). A non-finite input gives non-finite
/// output.
pub fn symmetric_eigen3(m: [[f64; 3]; 3]) -> ([f64; 3], [DVec3; 3]) {
    let mut a = [
        [m[0][0], m[0][1], m[0][2]],
        [m[0][1], m[1][1], m[1][2]],
        [m[0][2], m[1][2], m[2][2]],
    ];
    // v's columns are the eigenvectors
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let norm2: f64 = a.iter().flatten().map(|x| x * x).sum();
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        // off-diagonal mass negligible at double precision (or all zero)
        if off <= 1e-32 * norm2 || !(off.is_finite()) {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq == 0.0 {
                continue;
            }
            // rotation angle zeroing a[p][q] (Numerical Recipes, §11.1)
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            let t = if theta.abs() > 1e150 {
                0.5 / theta
            } else {
                theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
            };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with J the rotation in the (p, q) plane
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for (k, (&apk, &aqk)) in rp.iter().zip(rq.iter()).enumerate() {
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            for row in v.iter_mut() {
                let (vkp, vkq) = (row[p], row[q]);
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let vals = idx.map(|i| a[i][i]);
    let mut vecs = idx.map(|i| DVec3::new(v[0][i], v[1][i], v[2][i]));
    // right-handed basis (the sign of an eigenvector is arbitrary)
    if vecs[0].cross(vecs[1]).dot(vecs[2]) < 0.0 {
        vecs[2] = -vecs[2];
    }
    (vals, vecs)
}
