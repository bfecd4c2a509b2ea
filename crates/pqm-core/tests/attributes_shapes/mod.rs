//! Small quad-mesh generators shared by the attribute, QEM, feature and
//! smoothing tests (`mod attributes_shapes;`).
#![allow(dead_code)]

use glam::DVec3;
use pqm_core::{IndexedMesh, Mesh};
use std::collections::HashMap;
use std::f64::consts::TAU;

pub fn mesh(im: &IndexedMesh) -> Mesh {
    Mesh::from_indexed(im).expect("generator builds a valid mesh")
}

/// `nx × ny` unit quads in the plane z = 0, counter-clockwise from +z.
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

/// Grid index of vertex (i, j) of [`grid`].
pub fn grid_id(nx: u32, i: u32, j: u32) -> u32 {
    j * (nx + 1) + i
}

/// The surface of the cube `[-1, 1]³` with `n × n` quads per side, outward
/// orientation; `warp` maps each lattice point (e.g. onto a sphere).
pub fn cube_lattice(n: u32, warp: impl Fn(DVec3) -> DVec3) -> IndexedMesh {
    let mut ids: HashMap<(i64, i64, i64), u32> = HashMap::new();
    let mut pos = Vec::new();
    let mut faces = Vec::new();
    let n = n as i64;
    let mut vid = |k: (i64, i64, i64), pos: &mut Vec<DVec3>| -> u32 {
        *ids.entry(k).or_insert_with(|| {
            let p = DVec3::new(k.0 as f64, k.1 as f64, k.2 as f64) * (2.0 / n as f64) - 1.0;
            pos.push(p);
            (pos.len() - 1) as u32
        })
    };
    for axis in 0..3 {
        for side in [0, n] {
            for a in 0..n {
                for b in 0..n {
                    let pt = |a: i64, b: i64| -> (i64, i64, i64) {
                        match axis {
                            0 => (side, a, b),
                            1 => (b, side, a),
                            _ => (a, b, side),
                        }
                    };
                    let mut q = [
                        vid(pt(a, b), &mut pos),
                        vid(pt(a + 1, b), &mut pos),
                        vid(pt(a + 1, b + 1), &mut pos),
                        vid(pt(a, b + 1), &mut pos),
                    ];
                    // orient outward
                    let p: Vec<DVec3> = q.iter().map(|&i| pos[i as usize]).collect();
                    let nrm = (p[2] - p[0]).cross(p[3] - p[1]);
                    let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
                    if nrm.dot(c) < 0.0 {
                        q.reverse();
                    }
                    faces.push(q);
                }
            }
        }
    }
    let pos = pos.into_iter().map(warp).collect();
    IndexedMesh::from_faces(pos, faces)
}

/// Quad sphere of radius `r`: the cube lattice projected onto the sphere.
pub fn quad_sphere(n: u32, r: f64) -> IndexedMesh {
    cube_lattice(n, |p| p.normalize() * r)
}

/// Open cylinder of radius `r` around the z axis, `nu` quads around and `nv`
/// along a height of `h` (centred at z = 0), outward normals.
pub fn cylinder(nu: u32, nv: u32, r: f64, h: f64) -> IndexedMesh {
    let mut p = Vec::new();
    for j in 0..=nv {
        for i in 0..nu {
            let t = TAU * i as f64 / nu as f64;
            p.push(DVec3::new(
                r * t.cos(),
                r * t.sin(),
                h * (j as f64 / nv as f64 - 0.5),
            ));
        }
    }
    let id = |i: u32, j: u32| j * nu + (i % nu);
    let mut faces = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(p, faces)
}

/// Torus around the z axis: major radius `big_r`, minor radius `r`, `nu`
/// quads around the axis, `nv` around the tube. Vertex `(i, j)` has id
/// `j * nu + i`; `j = 0` is the outer equator, `j = nv / 2` the inner one.
pub fn torus(nu: u32, nv: u32, big_r: f64, r: f64) -> IndexedMesh {
    let mut p = Vec::new();
    for j in 0..nv {
        let phi = TAU * j as f64 / nv as f64;
        for i in 0..nu {
            let theta = TAU * i as f64 / nu as f64;
            let rr = big_r + r * phi.cos();
            p.push(DVec3::new(
                rr * theta.cos(),
                rr * theta.sin(),
                r * phi.sin(),
            ));
        }
    }
    let id = |i: u32, j: u32| (j % nv) * nu + (i % nu);
    let mut faces = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::from_faces(p, faces)
}

/// A tiny deterministic PRNG (xorshift64*) for jitter.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[-1, 1)`.
    pub fn signed(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
}

/// Path of a shared real mesh.
pub fn shared_mesh(rel: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel)
}

/// Minimal OFF reader for the shared test meshes (no colours, no comments
/// inside the header beyond `#` lines).
pub fn read_off(path: &std::path::Path) -> IndexedMesh {
    let text = std::fs::read_to_string(path).expect("read OFF");
    let mut toks = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or(""))
        .flat_map(|l| l.split_whitespace());
    assert_eq!(toks.next(), Some("OFF"));
    let nv: usize = toks.next().unwrap().parse().unwrap();
    let nf: usize = toks.next().unwrap().parse().unwrap();
    let _ne = toks.next();
    let mut pos = Vec::with_capacity(nv);
    for _ in 0..nv {
        let mut c = [0.0; 3];
        for x in c.iter_mut() {
            *x = toks.next().unwrap().parse().unwrap();
        }
        pos.push(DVec3::from(c));
    }
    let mut faces: Vec<Vec<u32>> = Vec::with_capacity(nf);
    for _ in 0..nf {
        let k: usize = toks.next().unwrap().parse().unwrap();
        faces.push(
            (0..k)
                .map(|_| toks.next().unwrap().parse().unwrap())
                .collect(),
        );
    }
    IndexedMesh::from_faces(pos, faces)
}
