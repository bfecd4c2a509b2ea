//! Procedural quad meshes for tests and benchmarks, generated in code.
//!
//! Every shape is quad-only, consistently oriented (faces counter-clockwise
//! seen from outside, i.e. normals point away from the enclosed volume; for
//! the open grids "outside" is `+z`), carries positions and faces only (no
//! texcoords, normals, groups or scalars), and is fully deterministic.
//! Lengths are in arbitrary model units and angles in radians.
//!
//! Resolution parameters below their minimum are raised to it (documented per
//! shape) rather than failing, so every call returns a valid mesh.
//!
//! | shape | V | F | χ | boundary |
//! |---|---|---|---|---|
//! | [`cube`] | 8 | 6 | 2 | closed |
//! | [`box_grid`]`(n, _)` | 6n² + 2 | 6n² | 2 | closed |
//! | [`quad_sphere`]`(n, _)` | 6n² + 2 | 6n² | 2 | closed |
//! | [`torus`]`(a, b, _, _)` | ab | ab | 0 | closed |
//! | [`grid`]`(nx, ny, _, _)` | (nx+1)(ny+1) | nx·ny | 1 | one loop |
//! | [`two_components`] | 8 + 98 | 6 + 96 | 4 | closed |

use crate::indexed::IndexedMesh;
use glam::DVec3;
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_4, TAU};

/// The surface of the lattice cube `[0, n]³` split into `n × n` quads per
/// side, with shared lattice points welded. Returns lattice coordinates and
/// outward-oriented quads. Vertices are numbered in order of first use
/// (sides in the order +x, +y, +z, −x, −y, −z; rows then columns).
fn cube_lattice(n: u32) -> (Vec<[u32; 3]>, Vec<[u32; 4]>) {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut lattice = Vec::with_capacity(6 * (n as usize).pow(2) + 2);
    let mut quads = Vec::with_capacity(6 * (n as usize).pow(2));
    for (axis, positive) in [
        (0, true),
        (1, true),
        (2, true),
        (0, false),
        (1, false),
        (2, false),
    ] {
        // Tangent axes with e_u × e_v = outward normal, so (u, v)-CCW quads
        // are CCW seen from outside.
        let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
        if !positive {
            std::mem::swap(&mut u, &mut v);
        }
        let mut id = |i: u32, j: u32| {
            let mut l = [0u32; 3];
            l[axis] = if positive { n } else { 0 };
            l[u] = i;
            l[v] = j;
            *ids.entry(l).or_insert_with(|| {
                lattice.push(l);
                (lattice.len() - 1) as u32
            })
        };
        for j in 0..n {
            for i in 0..n {
                quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    (lattice, quads)
}

/// A regular polygon of `n` corners on the unit circle in the `z = 0`
/// plane, counter-clockwise from `(1, 0, 0)`, as one face (a mesh with
/// boundary; `n ≥ 3`).
pub fn regular_polygon(n: u32) -> IndexedMesh {
    let p: Vec<DVec3> = (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / n as f64;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    IndexedMesh::from_faces(p, [(0..n).collect::<Vec<u32>>()])
}

/// [`torus`]`(3, 3, 2.0, 0.7)` with two of its faces joined into an
/// octagon (face 4) and the others into a hexagon (face 5), both wrapped
/// around the tube, which is three edges around: no triangulation can cut
/// them without a diagonal that is already an edge. A valid mesh that
/// pairing and bridging must refuse by name.
pub fn uncuttable_polygons() -> IndexedMesh {
    let t = torus(3, 3, 2.0, 0.7);
    IndexedMesh::from_faces(
        t.positions,
        [
            vec![1u32, 4, 5, 2],
            vec![3, 6, 7, 4],
            vec![4, 7, 8, 5],
            vec![5, 8, 6, 3],
            vec![6, 0, 2, 5, 3, 4, 1, 7],
            vec![7, 1, 2, 0, 6, 8],
        ],
    )
}

/// Axis-aligned cube centred at the origin with edge length `size`:
/// 8 vertices, 6 quads, closed, genus 0.
pub fn cube(size: f64) -> IndexedMesh {
    let (lattice, quads) = cube_lattice(1);
    let h = size * 0.5;
    let positions = lattice
        .iter()
        .map(|l| DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64) * size - DVec3::splat(h))
        .collect();
    IndexedMesh::from_faces(positions, quads)
}

/// Axis-aligned box centred at the origin with edge lengths `size`, each
/// side an `n × n` grid of quads (`n ≥ 1`, raised to 1 if smaller), with
/// welded vertices: 6n² quads, 6n² + 2 vertices, closed, genus 0, eight
/// valence-3 corners and all others valence 4, its twelve edges sharp
/// (90°) — the block layout of a CAD part.
pub fn box_grid(n: u32, size: DVec3) -> IndexedMesh {
    let n = n.max(1);
    let (lattice, quads) = cube_lattice(n);
    let positions = lattice
        .iter()
        .map(|l| {
            let unit = DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64) / n as f64;
            (unit - DVec3::splat(0.5)) * size
        })
        .collect();
    IndexedMesh::from_faces(positions, quads)
}

/// Sphere of radius `radius` centred at the origin, made from a cube whose
/// sides are `n × n` grids (`n ≥ 1`, raised to 1 if smaller), with welded
/// vertices: 6n² quads, 6n² + 2 vertices, closed, genus 0, eight valence-3
/// vertices (the cube corners), all others valence 4.
///
/// Cube points are warped with `tan(πx/4)` per coordinate before being
/// projected to the sphere, which makes the quads much more uniform in size
/// than a plain central projection.
pub fn quad_sphere(n: u32, radius: f64) -> IndexedMesh {
    let n = n.max(1);
    let (lattice, quads) = cube_lattice(n);
    let positions = lattice
        .iter()
        .map(|l| {
            let warp = |x: u32| (FRAC_PI_4 * (2.0 * x as f64 / n as f64 - 1.0)).tan();
            DVec3::new(warp(l[0]), warp(l[1]), warp(l[2])).normalize() * radius
        })
        .collect();
    IndexedMesh::from_faces(positions, quads)
}

/// Torus around the z axis: `n_major` quads around the z axis (≥ 3), `n_minor`
/// around the tube (≥ 3), centre-line radius `major_radius`, tube radius
/// `minor_radius` (use `minor_radius < major_radius` for an embedded torus).
/// `n_major · n_minor` vertices and quads, genus 1, every vertex valence 4.
/// Vertex `(i, j)` (angle `2πi/n_major` around z, `2πj/n_minor` around the
/// tube, starting on the outer equator) has index `i · n_minor + j`.
pub fn torus(n_major: u32, n_minor: u32, major_radius: f64, minor_radius: f64) -> IndexedMesh {
    torus_with(n_major, n_minor, major_radius, |_, _| minor_radius)
}

/// Shared torus builder; `tube(θ, φ)` gives the tube radius at each vertex.
fn torus_with(
    n_major: u32,
    n_minor: u32,
    major_radius: f64,
    tube: impl Fn(f64, f64) -> f64,
) -> IndexedMesh {
    let (na, nb) = (n_major.max(3), n_minor.max(3));
    let mut positions = Vec::with_capacity((na * nb) as usize);
    for i in 0..na {
        let theta = TAU * i as f64 / na as f64;
        for j in 0..nb {
            let phi = TAU * j as f64 / nb as f64;
            let r = tube(theta, phi);
            let ring = major_radius + r * phi.cos();
            positions.push(DVec3::new(
                ring * theta.cos(),
                ring * theta.sin(),
                r * phi.sin(),
            ));
        }
    }
    // ∂p/∂θ × ∂p/∂φ points away from the tube's centre line, so (θ, φ)-CCW
    // quads are CCW seen from outside.
    let id = |i: u32, j: u32| (i % na) * nb + (j % nb);
    let quads = (0..na)
        .flat_map(|i| {
            (0..nb).map(move |j| [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
        })
        .collect::<Vec<_>>();
    IndexedMesh::from_faces(positions, quads)
}

/// Flat rectangular grid in the `z = 0` plane, centred at the origin, spanning
/// `[-size_x/2, size_x/2] × [-size_y/2, size_y/2]`, with `nx × ny` quads
/// (`nx, ny ≥ 1`) facing `+z`. Vertex `(i, j)` (column `i` along x, row `j`
/// along y) has index `j · (nx + 1) + i`. Open, one boundary loop, χ = 1.
pub fn grid(nx: u32, ny: u32, size_x: f64, size_y: f64) -> IndexedMesh {
    let (nx, ny) = (nx.max(1), ny.max(1));
    let mut positions = Vec::with_capacity(((nx + 1) * (ny + 1)) as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push(DVec3::new(
                size_x * (i as f64 / nx as f64 - 0.5),
                size_y * (j as f64 / ny as f64 - 0.5),
                0.0,
            ));
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let quads = (0..ny)
        .flat_map(|j| {
            (0..nx).map(move |i| [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
        })
        .collect::<Vec<_>>();
    IndexedMesh::from_faces(positions, quads)
}

/// Height field over the unit square: [`grid`]`(nx, ny, 1.0, 1.0)` (so
/// `x, y ∈ [-0.5, 0.5]`) with each vertex lifted to `z = f(x, y)`.
/// Same topology and numbering as [`grid`].
pub fn height_grid(nx: u32, ny: u32, f: impl Fn(f64, f64) -> f64) -> IndexedMesh {
    let mut m = grid(nx, ny, 1.0, 1.0);
    for p in &mut m.positions {
        p.z = f(p.x, p.y);
    }
    m
}

/// Concatenates meshes into one (positions and faces only; vertex indices of
/// later parts are offset). Attributes other than positions are dropped.
pub fn concat(parts: &[IndexedMesh]) -> IndexedMesh {
    let mut out = IndexedMesh::new();
    for part in parts {
        let offset = out.positions.len() as u32;
        out.positions.extend_from_slice(&part.positions);
        for f in part.faces() {
            let shifted: Vec<u32> = f.iter().map(|&v| v + offset).collect();
            out.push_face(&shifted);
        }
    }
    out
}

/// Two disjoint closed components in one mesh: [`cube`]`(1.0)` centred at the
/// origin, then [`quad_sphere`]`(4, 0.5)` centred at `(2, 0, 0)`. The cube's
/// vertices and faces come first. 106 vertices, 102 quads, χ = 4.
pub fn two_components() -> IndexedMesh {
    let mut sphere = quad_sphere(4, 0.5);
    for p in &mut sphere.positions {
        p.x += 2.0;
    }
    concat(&[cube(1.0), sphere])
}

/// SplitMix64: a tiny, well-mixed deterministic generator (no dependency).
fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Uniform value in `[-1, 1)` from `(seed, stream)`.
fn unit_noise(seed: u64, stream: u64) -> f64 {
    let bits = splitmix64(seed ^ splitmix64(stream)) >> 11; // 53 random bits
    bits as f64 / (1u64 << 52) as f64 - 1.0
}

/// Copy of `mesh` with every vertex moved by an independent uniform offset in
/// `[-amplitude, amplitude]³` (same unit as the positions). Deterministic:
/// the same `seed` gives the same mesh. Topology is unchanged.
pub fn noisy(mesh: &IndexedMesh, amplitude: f64, seed: u64) -> IndexedMesh {
    let mut m = mesh.clone();
    for (v, p) in m.positions.iter_mut().enumerate() {
        let s = 3 * v as u64;
        *p += DVec3::new(
            unit_noise(seed, s),
            unit_noise(seed, s + 1),
            unit_noise(seed, s + 2),
        ) * amplitude;
    }
    m
}

/// A triangle mesh from a quad mesh: each quad `[a, b, c, d]` split into
/// two triangles along the diagonal `a–c` or `b–d`, chosen per face by a
/// hash of `(seed, face)`. Same vertices; the faces of quad `f` are
/// triangles `2f` and `2f + 1`. (A perfect pairing of the triangles always
/// exists: the quads. `crate::pairing` tests recover one.)
pub fn triangulated(quads: &IndexedMesh, seed: u64) -> IndexedMesh {
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(2 * quads.face_count());
    for (f, q) in quads.faces().enumerate() {
        if splitmix64(seed ^ splitmix64(f as u64)) & 1 == 0 {
            tris.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
        } else {
            tris.extend([[q[1], q[2], q[3]], [q[1], q[3], q[0]]]);
        }
    }
    IndexedMesh::from_faces(quads.positions.clone(), tris)
}

/// A [`torus`] whose tube radius varies smoothly:
/// `minor_radius · (1 + amplitude · b(θ, φ))` with `b ∈ [-1, 1]` a sum of
/// three periodic sinusoids whose integer frequencies (1..=6) and phases come
/// from `seed`. `amplitude` is a fraction of `minor_radius`; keep it below 1
/// so the tube never collapses. Same topology and numbering as [`torus`].
pub fn bumpy_torus(
    n_major: u32,
    n_minor: u32,
    major_radius: f64,
    minor_radius: f64,
    amplitude: f64,
    seed: u64,
) -> IndexedMesh {
    let waves: Vec<(f64, f64, f64)> = (0..3u64)
        .map(|k| {
            let r = |s: u64| unit_noise(seed, 1000 + 3 * k + s);
            let freq = |x: f64| (((x + 1.0) * 3.0).floor() + 1.0).min(6.0);
            (freq(r(0)), freq(r(1)), r(2) * std::f64::consts::PI)
        })
        .collect();
    torus_with(n_major, n_minor, major_radius, |theta, phi| {
        let b: f64 = waves
            .iter()
            .map(|&(a, c, ph)| (a * theta + c * phi + ph).sin())
            .sum();
        minor_radius * (1.0 + amplitude * b / 3.0)
    })
}
