//! Inner-loop costs of the attribute building blocks the coarsener calls
//! (quadric sums and solves, alignment scores, smoothing of one vertex) and
//! the one-off per-mesh passes (curvature, vertex quadrics).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::DVec3;
use pqm_core::attributes::{alignment, quad_alignment, Curvature, CurvatureOptions, Field};
use pqm_core::qem::{best_position, vertex_quadrics};
use pqm_core::smoothing::smoothed_position;
use pqm_core::{FaceId, IndexedMesh, Mesh, VertexId};
use std::f64::consts::TAU;

/// Torus with `nu × nv` quads (R = 3, r = 1).
fn torus(nu: u32, nv: u32) -> Mesh {
    let mut p = Vec::new();
    for j in 0..nv {
        let phi = TAU * j as f64 / nv as f64;
        for i in 0..nu {
            let theta = TAU * i as f64 / nu as f64;
            let rr = 3.0 + phi.cos();
            p.push(DVec3::new(rr * theta.cos(), rr * theta.sin(), phi.sin()));
        }
    }
    let id = |i: u32, j: u32| (j % nv) * nu + (i % nu);
    let mut faces = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::from_indexed(&IndexedMesh::from_faces(p, faces)).expect("torus")
}

fn bench(c: &mut Criterion) {
    let m = torus(200, 50); // 10k vertices, 10k quads
    let qs = vertex_quadrics(&m);
    let field = Field::constant(&m, DVec3::X);

    c.bench_function("quadric_add_best_position", |b| {
        let (a, v) = (VertexId(1234), VertexId(1235));
        let (pa, pv) = (m.position(a), m.position(v));
        b.iter(|| {
            let q = black_box(qs[a.idx()]) + black_box(qs[v.idx()]);
            best_position(&q, &[pa, pv, (pa + pv) * 0.5])
        })
    });
    c.bench_function("alignment", |b| {
        b.iter(|| {
            alignment(
                black_box(DVec3::new(1.0, 0.3, 0.1)),
                black_box(DVec3::X),
                black_box(DVec3::Z),
            )
        })
    });
    c.bench_function("quad_alignment", |b| {
        b.iter(|| quad_alignment(&m, black_box(FaceId(777)), &field))
    });
    c.bench_function("smoothed_position", |b| {
        b.iter(|| smoothed_position(&m, &[], black_box(VertexId(4321)), |u| m.position(u)))
    });
    let mut g = c.benchmark_group("per_mesh_10k");
    g.sample_size(10);
    g.bench_function("curvature_1ring", |b| b.iter(|| Curvature::estimate(&m)));
    let two = CurvatureOptions {
        rings: 2,
        ..Default::default()
    };
    g.bench_function("curvature_2ring", |b| {
        b.iter(|| Curvature::compute(&m, &two))
    });
    g.bench_function("vertex_quadrics", |b| b.iter(|| vertex_quadrics(&m)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
