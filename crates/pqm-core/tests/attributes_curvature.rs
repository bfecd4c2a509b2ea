//! Curvature estimation against analytic values on generated quad meshes,
//! and the 3×3 symmetric eigen solver.

mod attributes_shapes;
use attributes_shapes::*;

use glam::DVec3;
use pqm_core::attributes::{symmetric_eigen3, Curvature, CurvatureOptions};
use pqm_core::VertexId;
use proptest::prelude::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn sphere_is_umbilic_with_curvature_one_over_r() {
    let r = 2.0;
    let m = mesh(&quad_sphere(12, r));
    for rings in [1, 2] {
        let c = Curvature::compute(
            &m,
            &CurvatureOptions {
                rings,
                ..Default::default()
            },
        );
        let mut worst: f64 = 0.0;
        for v in m.vertices() {
            let pc = c.vertices[v.idx()];
            worst = worst
                .max(rel(pc.k_max, 1.0 / r))
                .max(rel(pc.k_min, 1.0 / r));
            // the normal points outward
            assert!(pc.normal.dot(m.position(v).normalize()) > 0.99);
            assert!(pc.anisotropy < 0.2, "anisotropy {} at {v:?}", pc.anisotropy);
        }
        // the cube-sphere lattice is irregular near the cube corners
        assert!(worst < 0.12, "rings {rings}: worst relative error {worst}");
    }
}

#[test]
fn cylinder_has_one_principal_curvature_across_the_axis() {
    let r = 1.5;
    let (nu, nv) = (48, 12);
    let m = mesh(&cylinder(nu, nv, r, 4.0));
    let c = Curvature::estimate(&m);
    let mut checked = 0;
    for v in m.vertices() {
        // interior rows only: boundary rings see half a neighbourhood
        let row = v.0 / nu;
        if row < 2 || row > nv - 2 {
            continue;
        }
        let pc = c.vertices[v.idx()];
        assert!(rel(pc.k_max, 1.0 / r) < 0.02, "k_max {} at {v:?}", pc.k_max);
        assert!(pc.k_min.abs() < 0.02 / r, "k_min {} at {v:?}", pc.k_min);
        assert!(
            pc.dir_max.dot(DVec3::Z).abs() < 1e-6,
            "dir_max {:?}",
            pc.dir_max
        );
        assert!(pc.dir_min.dot(DVec3::Z).abs() > 1.0 - 1e-6);
        assert!(pc.dir_max.dot(pc.normal).abs() < 1e-9);
        assert!(pc.anisotropy > 0.9);
        checked += 1;
    }
    assert!(checked > 100);
}

#[test]
fn plane_has_zero_curvature() {
    let m = mesh(&grid(8, 6));
    let c = Curvature::estimate(&m);
    for v in m.vertices() {
        let pc = c.vertices[v.idx()];
        assert!(pc.k_max.abs() < 1e-12 && pc.k_min.abs() < 1e-12);
        assert!(pc.anisotropy < 1e-6);
        assert!((pc.normal - DVec3::Z).length() < 1e-12);
    }
}

/// Worst relative errors `(outer k_max, outer k_min, inner k_max, inner
/// k_min)` over the equators of a torus (R = 3, r = 1); also checks the
/// direction of maximal curvature at the outer equator.
fn torus_equator_errors(nu: u32, nv: u32, rings: u32) -> [f64; 4] {
    let (big_r, r) = (3.0, 1.0);
    let m = mesh(&torus(nu, nv, big_r, r));
    let c = Curvature::compute(
        &m,
        &CurvatureOptions {
            rings,
            ..Default::default()
        },
    );
    let mut worst = [0.0f64; 4];
    for i in 0..nu {
        // outer equator: both convex, 1/r across the tube, 1/(R+r) around
        let o = c.vertices[VertexId(i).idx()];
        let p = m.position(VertexId(i));
        // max curvature runs around the tube: perpendicular to the major
        // circle's tangent (which is z × p)
        let tangent = DVec3::Z.cross(p).normalize();
        assert!(o.dir_max.dot(tangent).abs() < 1e-3, "{:?}", o.dir_max);
        assert!(o.dir_min.dot(tangent).abs() > 1.0 - 1e-3);
        // inner equator: a saddle, k_min = −1/(R − r)
        let s = c.vertices[VertexId((nv / 2) * nu + i).idx()];
        let e = [
            rel(o.k_max, 1.0 / r),
            rel(o.k_min, 1.0 / (big_r + r)),
            rel(s.k_max, 1.0 / r),
            rel(s.k_min, -1.0 / (big_r - r)),
        ];
        for k in 0..4 {
            worst[k] = worst[k].max(e[k]);
        }
    }
    worst
}

#[test]
fn torus_equators_match_analytic_curvatures() {
    // 1-ring: close to the analytic values already on a coarse torus
    for e in torus_equator_errors(96, 32, 1) {
        assert!(e < 0.025, "1-ring errors {e}");
    }
    // 2-ring: averaging over ±22° of the tube biases the small curvature
    // (it varies as cos φ / (R + r cos φ)); the bias is second order in the
    // neighbourhood size, so doubling the resolution cuts it about 4×.
    let coarse = torus_equator_errors(96, 32, 2);
    let fine = torus_equator_errors(192, 64, 2);
    for k in 0..4 {
        assert!(coarse[k] < 0.1, "2-ring coarse errors {coarse:?}");
        assert!(fine[k] < 0.03, "2-ring fine errors {fine:?}");
        assert!(
            fine[k] < coarse[k] / 3.0,
            "no convergence: {coarse:?} → {fine:?}"
        );
    }
}

#[test]
fn curvature_scales_inversely_with_the_model() {
    let im = torus(24, 12, 3.0, 1.0);
    let mut big = im.clone();
    for p in big.positions.iter_mut() {
        *p *= 10.0;
    }
    let (a, b) = (
        Curvature::estimate(&mesh(&im)),
        Curvature::estimate(&mesh(&big)),
    );
    for (x, y) in a.vertices.iter().zip(&b.vertices) {
        assert!((x.k_max - 10.0 * y.k_max).abs() < 1e-9);
        assert!((x.k_min - 10.0 * y.k_min).abs() < 1e-9);
        assert!((x.anisotropy - y.anisotropy).abs() < 1e-9);
    }
}

fn check_eigen(m: [[f64; 3]; 3]) {
    let (vals, vecs) = symmetric_eigen3(m);
    let scale = m
        .iter()
        .flatten()
        .fold(0.0f64, |s, x| s.max(x.abs()))
        .max(1e-300);
    assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
    for i in 0..3 {
        assert!((vecs[i].length() - 1.0).abs() < 1e-12);
        for j in 0..i {
            assert!(vecs[i].dot(vecs[j]).abs() < 1e-12);
        }
        let mv = DVec3::new(
            m[0][0] * vecs[i].x + m[0][1] * vecs[i].y + m[0][2] * vecs[i].z,
            m[0][1] * vecs[i].x + m[1][1] * vecs[i].y + m[1][2] * vecs[i].z,
            m[0][2] * vecs[i].x + m[1][2] * vecs[i].y + m[2][2] * vecs[i].z,
        );
        assert!(
            (mv - vecs[i] * vals[i]).length() < 1e-11 * scale,
            "residual {:?} for λ={}",
            mv - vecs[i] * vals[i],
            vals[i]
        );
    }
    assert!(vecs[0].cross(vecs[1]).dot(vecs[2]) > 0.0);
    let tr = m[0][0] + m[1][1] + m[2][2];
    assert!((vals.iter().sum::<f64>() - tr).abs() < 1e-11 * scale);
}

#[test]
fn eigen_handles_degenerate_matrices() {
    check_eigen([[0.0; 3]; 3]);
    check_eigen([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]);
    check_eigen([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]);
    check_eigen([[1e-20, 1e-30, 0.0], [1e-30, 1e-20, 0.0], [0.0, 0.0, 1e20]]);
    let (vals, _) = symmetric_eigen3([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
    assert!((vals[0] - 1.0).abs() < 1e-14 && (vals[1] - 3.0).abs() < 1e-14);
    assert!((vals[2] - 5.0).abs() < 1e-14);
}

proptest! {
    #[test]
    fn eigen_decomposes_random_symmetric_matrices(
        d in prop::array::uniform6(-100.0f64..100.0),
        repeat in 0usize..3,
    ) {
        let mut m = [[d[0], d[1], d[2]], [d[1], d[3], d[4]], [d[2], d[4], d[5]]];
        // repeated eigenvalues: a rank-one update of a multiple of identity
        if repeat > 0 {
            let u = DVec3::new(d[0], d[1], d[2]).normalize_or(DVec3::X);
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] = if i == j { d[3] } else { 0.0 } + d[4] * u[i] * u[j];
                }
            }
        }
        check_eigen(m);
    }
}
