//! Hausdorff distance between two ~200k-quad meshes (target: ≤ 2 s on 2 cores).
//!
//! Mesh A is a 450 × 450 quad grid over [0, 1]² lifted by a bumpy height
//! field; mesh B samples the same height field on a 452 × 448 grid, so the two
//! surfaces differ by discretisation only. With the default options (Metro's
//! 10 samples per triangle) that is about 4 million samples per direction.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use pqm_core::bvh::Bvh;
use pqm_core::metrics::hausdorff::{hausdorff, triangulate, HausdorffOptions};
use pqm_core::IndexedMesh;
use std::hint::black_box;
use std::time::Duration;

fn height(x: f64, y: f64) -> f64 {
    0.05 * (x * 23.0).sin() * (y * 17.0).cos() + 0.02 * ((x + y) * 61.0).sin()
}

fn bumpy_grid(nx: usize, ny: usize) -> IndexedMesh {
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (i as f64 / nx as f64, j as f64 / ny as f64);
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut faces = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(positions, faces)
}

fn bench(c: &mut Criterion) {
    let a = bumpy_grid(450, 450);
    let b = bumpy_grid(452, 448);
    let mut group = c.benchmark_group("hausdorff");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(30));
    group.bench_function("grid450_vs_grid452x448_default", |bench| {
        bench.iter(|| black_box(hausdorff(&a, &b, &HausdorffOptions::default())))
    });
    let tris = triangulate(&a);
    group.bench_function("bvh_build_405k_triangles", |bench| {
        bench.iter(|| black_box(Bvh::build(&a.positions, &tris).map(|b| b.triangle_count())))
    });
    group.finish();
    let r = hausdorff(&a, &b, &HausdorffOptions::default());
    eprintln!(
        "faces {} / {}; samples {} + {}; symmetric max {:.3e} mean {:.3e} (x diag)",
        a.face_count(),
        b.face_count(),
        r.forward_samples,
        r.backward_samples,
        r.symmetric.max,
        r.symmetric.mean
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
