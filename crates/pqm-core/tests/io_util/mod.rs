//! Helpers shared by the `io_*` integration tests.
#![allow(dead_code)]

use pqm_core::IndexedMesh;
use std::path::PathBuf;

/// `/work/shared/meshes` seen from this crate (`<manifest>/../../../shared/meshes`).
pub fn shared_meshes() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes")
}

pub fn shared(rel: &str) -> PathBuf {
    shared_meshes().join(rel)
}

/// The repository root (`<manifest>/../..`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn faces(m: &IndexedMesh) -> Vec<Vec<u32>> {
    m.faces().map(|f| f.to_vec()).collect()
}

/// A unit cube made of six quads, counter-clockwise seen from outside.
pub fn cube() -> IndexedMesh {
    use glam::DVec3;
    let p = (0..8)
        .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
        .collect();
    IndexedMesh::from_faces(
        p,
        [
            [0u32, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ],
    )
}
