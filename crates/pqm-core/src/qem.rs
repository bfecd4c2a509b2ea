//! Quadric error metrics (Garland & Heckbert 1997) extended to quads as in
//! QMS (Daniels et al. 2008), for placing merged vertices.
//!
//! A [`Quadric`] is the symmetric 4×4 matrix `A` of `E(p) = [p 1] A [p 1]ᵀ`,
//! a weighted sum of squared distances to planes. Units: with positions in
//! model units `u`, plane quadrics give `u²` per unit weight; the quadrics of
//! [`Quadric::from_triangle`] and [`vertex_quadrics`] are area-weighted, so
//! their errors are in `u⁴` (area × squared distance).
//!
//! Every operation on [`Quadric`] is `Copy`, allocation-free and a few dozen
//! flops: the coarsener calls them in its inner loop.

use crate::mesh::{FaceId, Mesh};
use glam::DVec3;
use std::ops::{Add, AddAssign, Mul};

/// The conditioning test of [`Quadric::optimal_point`]: the 3×3 block `M` of
/// the quadric is accepted when `det(M) ≥ OPTIMAL_POINT_MIN_CONDITION ·
/// (tr(M)/3)³`.
///
/// `det / (tr/3)³` is the cube of the ratio of the geometric to the
/// arithmetic mean of `M`'s eigenvalues (`M` is positive semi-definite): it
/// is 1 for an isotropic quadric (a corner of three orthogonal planes) and 0
/// when the planes do not pin the point down in some direction (a flat
/// region, or a crease made of two planes). Passing the test guarantees
/// `λ_min / λ_max ≥ OPTIMAL_POINT_MIN_CONDITION / 27`, so the solve can
/// amplify the input's rounding errors by at most ~3·10⁵ — beyond that the
/// "optimal" point moves along an almost free direction and is meaningless.
pub const OPTIMAL_POINT_MIN_CONDITION: f64 = 1e-4;

/// A symmetric 4×4 quadric stored as its upper triangle, row by row:
/// `[a00 a01 a02 a03 a11 a12 a13 a22 a23 a33]`.
///
/// With `M` the upper-left 3×3 block, `b = (a03, a13, a23)` and `c = a33`,
/// `E(p) = pᵀ M p + 2 b·p + c`. `Default` is the zero quadric.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadric {
    /// Upper triangle of the matrix, row by row (see the type docs).
    pub a: [f64; 10],
}

impl Quadric {
    /// The zero quadric (no error anywhere).
    pub const ZERO: Quadric = Quadric { a: [0.0; 10] };

    /// The quadric of the plane `n·p + d = 0`: `E(p) = (n·p + d)²`, the
    /// squared distance when `n` is unit length (a longer `n` scales the
    /// error by `|n|²`).
    #[inline]
    pub fn from_plane(n: DVec3, d: f64) -> Quadric {
        Quadric {
            a: [
                n.x * n.x,
                n.x * n.y,
                n.x * n.z,
                n.x * d,
                n.y * n.y,
                n.y * n.z,
                n.y * d,
                n.z * n.z,
                n.z * d,
                d * d,
            ],
        }
    }

    /// The plane quadric of triangle `p0 p1 p2`, weighted by its area:
    /// `E(p) = area · dist(p, plane)²`. A degenerate triangle (zero area)
    /// gives the zero quadric.
    #[inline]
    pub fn from_triangle(p0: DVec3, p1: DVec3, p2: DVec3) -> Quadric {
        let c = (p1 - p0).cross(p2 - p0);
        let len = c.length();
        if len <= 0.0 || !len.is_finite() {
            return Quadric::ZERO;
        }
        let n = c / len;
        // area = len / 2; scaling the unit plane by sqrt(area) would cost a
        // sqrt, so scale the product instead.
        Quadric::from_plane(n, -n.dot(p0)) * (0.5 * len)
    }

    /// The error `E(p) = [p 1] A [p 1]ᵀ`, clamped at 0 (rounding can make
    /// the exact value of a semi-definite form slightly negative).
    #[inline]
    pub fn evaluate(&self, p: DVec3) -> f64 {
        let a = &self.a;
        let (x, y, z) = (p.x, p.y, p.z);
        let e = x * (a[0] * x + 2.0 * (a[1] * y + a[2] * z + a[3]))
            + y * (a[4] * y + 2.0 * (a[5] * z + a[6]))
            + z * (a[7] * z + 2.0 * a[8])
            + a[9];
        e.max(0.0)
    }

    /// The point minimising [`Quadric::evaluate`], or `None` when the 3×3
    /// system is ill-conditioned (see [`OPTIMAL_POINT_MIN_CONDITION`]) or
    /// the quadric is zero.
    #[inline]
    pub fn optimal_point(&self) -> Option<DVec3> {
        let a = &self.a;
        let (m00, m01, m02, m11, m12, m22) = (a[0], a[1], a[2], a[4], a[5], a[7]);
        // cofactors of the symmetric block
        let c00 = m11 * m22 - m12 * m12;
        let c01 = m02 * m12 - m01 * m22;
        let c02 = m01 * m12 - m02 * m11;
        let det = m00 * c00 + m01 * c01 + m02 * c02;
        let tr3 = (m00 + m11 + m22) / 3.0;
        let conditioned = tr3 > 0.0 && det >= OPTIMAL_POINT_MIN_CONDITION * tr3 * tr3 * tr3;
        if !conditioned {
            return None;
        }
        let c11 = m00 * m22 - m02 * m02;
        let c12 = m01 * m02 - m00 * m12;
        let c22 = m00 * m11 - m01 * m01;
        let b = DVec3::new(a[3], a[6], a[8]);
        // p = -M⁻¹ b, M⁻¹ = adj(M) / det (adj symmetric)
        let inv = 1.0 / det;
        let p = -DVec3::new(
            c00 * b.x + c01 * b.y + c02 * b.z,
            c01 * b.x + c11 * b.y + c12 * b.z,
            c02 * b.x + c12 * b.y + c22 * b.z,
        ) * inv;
        p.is_finite().then_some(p)
    }
}

impl Add for Quadric {
    type Output = Quadric;
    #[inline]
    fn add(mut self, o: Quadric) -> Quadric {
        self += o;
        self
    }
}

impl AddAssign for Quadric {
    #[inline]
    fn add_assign(&mut self, o: Quadric) {
        for (x, y) in self.a.iter_mut().zip(o.a.iter()) {
            *x += *y;
        }
    }
}

impl Mul<f64> for Quadric {
    type Output = Quadric;
    /// Scales the quadric (a weight on every plane it holds).
    #[inline]
    fn mul(mut self, w: f64) -> Quadric {
        for x in self.a.iter_mut() {
            *x *= w;
        }
        self
    }
}

/// The quadric of face `f`, the sum of the area-weighted plane quadrics of
/// its virtual triangles:
/// * a quad `v0 v1 v2 v3` contributes the four triangles of both diagonal
///   splits (`v0v1v2`, `v0v2v3`, `v1v2v3`, `v1v3v0`) at half weight each,
///   as in QMS: both splits together cover the quad twice, so the total
///   weight is the quad's area and a non-planar quad is not biased towards
///   one diagonal;
/// * a triangle contributes itself;
/// * a larger polygon is fan-triangulated from its first vertex.
pub fn face_quadric(mesh: &Mesh, f: FaceId) -> Quadric {
    if let Some([a, b, c, d]) = mesh.quad_vertices(f) {
        let [p0, p1, p2, p3] = [a, b, c, d].map(|v| mesh.position(v));
        return (Quadric::from_triangle(p0, p1, p2)
            + Quadric::from_triangle(p0, p2, p3)
            + Quadric::from_triangle(p1, p2, p3)
            + Quadric::from_triangle(p1, p3, p0))
            * 0.5;
    }
    let mut it = mesh.face_vertices(f).map(|v| mesh.position(v));
    let mut q = Quadric::ZERO;
    let (Some(p0), Some(mut prev)) = (it.next(), it.next()) else {
        return q;
    };
    for p in it {
        q += Quadric::from_triangle(p0, prev, p);
        prev = p;
    }
    q
}

/// Per-vertex quadrics, indexed by vertex id (`mesh.vertex_capacity()`
/// entries; deleted vertices get the zero quadric): each vertex sums the
/// [`face_quadric`] of every face around it. Errors are in `u⁴` (area ×
/// squared distance). O(faces).
pub fn vertex_quadrics(mesh: &Mesh) -> Vec<Quadric> {
    let mut out = vec![Quadric::ZERO; mesh.vertex_capacity()];
    for f in mesh.faces() {
        let q = face_quadric(mesh, f);
        for v in mesh.face_vertices(f) {
            out[v.idx()] += q;
        }
    }
    out
}

/// Where to put a merged vertex with quadric `q`: the optimal point when
/// the quadric is well conditioned and the point lies within a trust region
/// around the candidates, otherwise the candidate of least error (the first
/// one on ties). Typical candidates are the merging endpoints and their
/// midpoint.
///
/// The trust region is a ball around the candidates' mean of radius
/// `4 × max(spread, 1e-9 · scale)`, where `spread` is the largest distance
/// of a candidate from that mean and `scale` the largest coordinate
/// magnitude: a well-conditioned quadric can still put its optimum far
/// away on nearly flat geometry, which would fold the mesh. Returns the
/// quadric's optimal point (or the origin) when `candidates` is empty.
pub fn best_position(q: &Quadric, candidates: &[DVec3]) -> DVec3 {
    let opt = q.optimal_point();
    if candidates.is_empty() {
        return opt.unwrap_or(DVec3::ZERO);
    }
    if let Some(p) = opt {
        let mean = candidates.iter().copied().sum::<DVec3>() / candidates.len() as f64;
        let mut spread2: f64 = 0.0;
        let mut scale: f64 = 0.0;
        for c in candidates {
            spread2 = spread2.max(c.distance_squared(mean));
            scale = scale.max(c.abs().max_element());
        }
        let r = 4.0 * spread2.sqrt().max(1e-9 * scale);
        if p.distance_squared(mean) <= r * r {
            return p;
        }
    }
    let mut best = candidates[0];
    let mut best_e = q.evaluate(best);
    for &c in &candidates[1..] {
        let e = q.evaluate(c);
        if e < best_e {
            best = c;
            best_e = e;
        }
    }
    best
}
