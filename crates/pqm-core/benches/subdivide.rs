//! Catmull-Clark split throughput: a ~200k-quad sphere (both modes) and a
//! 135k-quad bumpy torus (540k quads out).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pqm_core::shapes::{bumpy_torus, quad_sphere};
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use std::hint::black_box;

fn bench_split(c: &mut Criterion) {
    // 6 · 183² = 200,934 quads in, 803,736 quads out.
    let sphere = quad_sphere(183, 1.0);
    let mut g = c.benchmark_group("catmull_clark_split");
    g.sample_size(20);
    g.throughput(Throughput::Elements(sphere.face_count() as u64));
    for (name, mode) in [
        ("linear", SplitMode::Linear),
        ("catmull_clark", SplitMode::CatmullClark),
    ] {
        g.bench_function(format!("quad_sphere_183/{name}"), |b| {
            b.iter(|| catmull_clark_split(black_box(&sphere), mode).expect("valid mesh"))
        });
    }
    // The brief's reference size: 135k quads in, 540k quads out.
    let torus = bumpy_torus(450, 300, 3.0, 1.0, 0.3, 7);
    g.throughput(Throughput::Elements(torus.face_count() as u64));
    g.bench_function("bumpy_torus_135k/catmull_clark", |b| {
        b.iter(|| catmull_clark_split(black_box(&torus), SplitMode::CatmullClark).expect("valid"))
    });
    g.finish();
}

criterion_group!(benches, bench_split);
criterion_main!(benches);
