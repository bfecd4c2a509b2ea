//! Tiny procedural meshes shared by the integration tests.
#![allow(dead_code)]

use glam::DVec3;
use pqm_core::IndexedMesh;

pub fn cube() -> IndexedMesh {
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

/// nx × ny quads in the plane, counter-clockwise seen from +z.
pub fn grid(nx: u32, ny: u32) -> IndexedMesh {
    let mut p = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            p.push(DVec3::new(i as f64, j as f64, 0.0));
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let mut faces = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(p, faces)
}

/// A torus of n × m quads (genus 1, every vertex valence 4).
pub fn torus(n: u32, m: u32) -> IndexedMesh {
    let mut p = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / m as f64 * std::f64::consts::TAU,
            );
            let r = 3.0 + v.cos();
            p.push(DVec3::new(r * u.cos(), r * u.sin(), v.sin()));
        }
    }
    let id = |i: u32, j: u32| (j % m) * n + (i % n);
    let mut faces = Vec::new();
    for j in 0..m {
        for i in 0..n {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(p, faces)
}

/// A cube whose faces are n × n grids, projected onto the unit sphere
/// (closed, genus 0, 6n² quads, eight valence-3 vertices).
pub fn quad_sphere(n: u32) -> IndexedMesh {
    let mut p: Vec<DVec3> = Vec::new();
    let mut faces = Vec::new();
    let key = |q: DVec3| {
        let s = (q * n as f64).round();
        (s.x as i64, s.y as i64, s.z as i64)
    };
    let mut index = std::collections::BTreeMap::new();
    let axes = [
        (DVec3::X, DVec3::Y, DVec3::Z),
        (-DVec3::X, DVec3::Z, DVec3::Y),
        (DVec3::Y, DVec3::Z, DVec3::X),
        (-DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::Z, DVec3::X, DVec3::Y),
        (-DVec3::Z, DVec3::Y, DVec3::X),
    ];
    for (nrm, u, v) in axes {
        let mut id = |i: u32, j: u32| {
            let q =
                nrm + u * (2.0 * i as f64 / n as f64 - 1.0) + v * (2.0 * j as f64 / n as f64 - 1.0);
            *index.entry(key(q)).or_insert_with(|| {
                p.push(q.normalize());
                (p.len() - 1) as u32
            })
        };
        for j in 0..n {
            for i in 0..n {
                let f = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
                faces.push(f);
            }
        }
    }
    // orient outward
    for f in faces.iter_mut() {
        let c: DVec3 = f.iter().map(|&i| p[i as usize]).sum::<DVec3>() / 4.0;
        let n = (p[f[1] as usize] - p[f[0] as usize]).cross(p[f[2] as usize] - p[f[0] as usize]);
        if n.dot(c) < 0.0 {
            f.reverse();
        }
    }
    IndexedMesh::from_faces(p, faces)
}

/// A soup of `faces` over `nv` points (out-of-range and repeated indices,
/// faces of any size allowed), the first point's x NaN when `nan`, and with
/// `texcoords` (if any) cycled over the corners as indices into a table of
/// three: what a hostile file that got past a reader could hand a
/// conversion.
pub fn face_soup(nv: usize, faces: &[Vec<u32>], nan: bool, texcoords: &[u32]) -> IndexedMesh {
    let mut positions: Vec<DVec3> = (0..nv)
        .map(|i| DVec3::new((i % 3) as f64, (i / 3) as f64, ((i * 7) % 5) as f64 * 0.1))
        .collect();
    if nan && nv > 0 {
        positions[0].x = f64::NAN;
    }
    let mut m = IndexedMesh::from_faces(positions, faces.iter().map(|f| f.as_slice()));
    if !texcoords.is_empty() {
        m.texcoords = vec![[0.0, 0.0]; 3];
        m.corner_texcoords = texcoords
            .iter()
            .cycle()
            .take(m.indices.len())
            .copied()
            .collect();
    }
    m
}
