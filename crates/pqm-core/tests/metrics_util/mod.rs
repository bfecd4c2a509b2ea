//! Test helpers for the metrics tests: loading (through `pqm_core::io`), the
//! shared mesh directory, and procedural meshes.
#![allow(dead_code)]

use glam::DVec3;
use pqm_core::IndexedMesh;
use std::path::{Path, PathBuf};

/// `<repo>/../shared/meshes` (the crate is at `<repo>/crates/pqm-core`).
pub fn shared_meshes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes")
}

/// Loads a shared mesh by relative name, e.g. `quad/suzanne.obj`.
pub fn load_shared(name: &str) -> IndexedMesh {
    let path = shared_meshes().join(name);
    load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads a mesh file with the project's readers.
pub fn load(path: &Path) -> Result<IndexedMesh, String> {
    pqm_core::io::read_mesh(path).map_err(|e| e.to_string())
}

/// A `nx × ny` grid of unit quads in the z = 0 plane, corner at the origin,
/// lifted by `height(x, y)`.
pub fn grid(nx: usize, ny: usize, height: impl Fn(f64, f64) -> f64) -> IndexedMesh {
    let mut positions = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (i as f64, j as f64);
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut faces = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(positions, faces)
}

/// A torus of `n × m` quads (major radius 2, minor radius 1): closed, genus 1,
/// every vertex of valence 4.
pub fn torus(n: usize, m: usize) -> IndexedMesh {
    let mut positions = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let u = std::f64::consts::TAU * i as f64 / n as f64;
            let v = std::f64::consts::TAU * j as f64 / m as f64;
            let r = 2.0 + v.cos();
            positions.push(DVec3::new(r * u.cos(), r * u.sin(), v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % n) * m + (j % m)) as u32;
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..m {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(positions, faces)
}

/// The unit cube as 6 outward-facing quads.
pub fn cube() -> IndexedMesh {
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let positions = vec![
        p(0., 0., 0.),
        p(1., 0., 0.),
        p(1., 1., 0.),
        p(0., 1., 0.),
        p(0., 0., 1.),
        p(1., 0., 1.),
        p(1., 1., 1.),
        p(0., 1., 1.),
    ];
    let faces = [
        [0, 3, 2, 1], // bottom, normal −z
        [4, 5, 6, 7], // top, +z
        [0, 1, 5, 4], // front, −y
        [1, 2, 6, 5], // right, +x
        [2, 3, 7, 6], // back, +y
        [3, 0, 4, 7], // left, −x
    ];
    IndexedMesh::from_faces(positions, faces)
}
