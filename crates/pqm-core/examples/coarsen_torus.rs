//! Coarsens a procedural bumpy torus and prints what happened — a quick way
//! to see the coarsener's speed and output quality without any input file.
//!
//! `cargo run --release -p pqm-core --example coarsen_torus -- [n_major n_minor target]`
use glam::DVec3;
use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::{IndexedMesh, Mesh};
use std::time::Instant;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (n, m, target) = (
        args.first().copied().unwrap_or(300),
        args.get(1).copied().unwrap_or(200),
        args.get(2).copied().unwrap_or(2000),
    );
    let mut p = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / m as f64 * std::f64::consts::TAU,
            );
            let r = 1.0 + 0.05 * (7.0 * u).sin() * (5.0 * v).cos();
            let big = 3.0 + r * v.cos();
            p.push(DVec3::new(big * u.cos(), big * u.sin(), r * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((j % m) * n + (i % n)) as u32;
    let faces = (0..m).flat_map(|j| {
        (0..n).map(move |i| [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
    });
    let src = IndexedMesh::from_faces(p, faces);
    let t = Instant::now();
    let mesh = Mesh::from_indexed(&src).expect("valid torus");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let report = c.run(&mut |_| {});
    let dt = t.elapsed();
    println!(
        "{} quads -> {} in {:.2?}: {report:?}",
        src.face_count(),
        c.mesh().face_count(),
        dt
    );
}
