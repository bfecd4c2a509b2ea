//! Test helpers for the metrics tests: a tiny OBJ/OFF loader (stopgap until
//! the `io` module lands; it reads only positions and faces), the shared mesh
//! directory, and procedural meshes.
//!
//! The `examples/hausdorff.rs` example includes this file with `#[path]`, so
//! it must not depend on anything test-only.
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

/// Loads an OBJ or OFF (ASCII, or pmp-library `OFF BINARY`) file.
pub fn load(path: &Path) -> Result<IndexedMesh, String> {
    let data = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let result = match ext.as_str() {
        "obj" => parse_obj(&data),
        "off" => parse_off(&data),
        _ => Err("unknown extension (expected .obj or .off)".to_string()),
    };
    result.map_err(|e| format!("{}: {e}", path.display()))
}

fn check_indices(mesh: &IndexedMesh) -> Result<(), String> {
    let n = mesh.positions.len();
    for (f, face) in mesh.faces().enumerate() {
        if let Some(&v) = face.iter().find(|&&v| v as usize >= n) {
            return Err(format!(
                "face {f} references vertex {v} but there are {n} vertices"
            ));
        }
    }
    Ok(())
}

fn parse_obj(data: &[u8]) -> Result<IndexedMesh, String> {
    let text = String::from_utf8_lossy(data);
    let mut mesh = IndexedMesh::new();
    let mut face = Vec::new();
    for (line_no, line) in text.lines().enumerate() {
        let mut tok = line.split_whitespace();
        match tok.next() {
            Some("v") => {
                let mut c = [0.0; 3];
                for x in &mut c {
                    *x = tok
                        .next()
                        .and_then(|t| t.parse().ok())
                        .ok_or(format!("line {}: bad vertex", line_no + 1))?;
                }
                mesh.positions.push(DVec3::from_array(c));
            }
            Some("f") => {
                face.clear();
                for t in tok {
                    let i: i64 = t
                        .split('/')
                        .next()
                        .and_then(|s| s.parse().ok())
                        .ok_or(format!("line {}: bad face index {t:?}", line_no + 1))?;
                    let n = mesh.positions.len() as i64;
                    let v = if i > 0 { i - 1 } else { n + i };
                    if v < 0 || v >= n {
                        return Err(format!("line {}: index {i} out of range", line_no + 1));
                    }
                    face.push(v as u32);
                }
                mesh.push_face(&face);
            }
            _ => {}
        }
    }
    check_indices(&mesh)?;
    Ok(mesh)
}

fn parse_off(data: &[u8]) -> Result<IndexedMesh, String> {
    if data.starts_with(b"OFF BINARY") {
        return parse_off_binary(data);
    }
    // Line based, so that per-vertex normals/colours (NOFF, COFF) and per-face
    // colours after the indices are ignored.
    let text = String::from_utf8_lossy(data);
    let mut lines = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty());
    let header = lines.next().ok_or("empty file")?;
    let mut head = header.split_whitespace();
    if !head.next().is_some_and(|h| h.ends_with("OFF")) {
        return Err("not an OFF file".into());
    }
    let counts: Vec<&str> = match head.next() {
        Some(first) => std::iter::once(first).chain(head).collect(),
        None => lines
            .next()
            .ok_or("missing counts")?
            .split_whitespace()
            .collect(),
    };
    let count = |i: usize| -> Result<usize, String> {
        counts
            .get(i)
            .and_then(|t| t.parse().ok())
            .ok_or(format!("bad count {i}"))
    };
    let (nv, nf) = (count(0)?, count(1)?);
    if nv > data.len() || nf > data.len() {
        return Err("counts exceed file size".into());
    }
    let mut mesh = IndexedMesh::new();
    for i in 0..nv {
        let line = lines.next().ok_or(format!("missing vertex {i}"))?;
        let c: Vec<f64> = line
            .split_whitespace()
            .take(3)
            .filter_map(|t| t.parse().ok())
            .collect();
        if c.len() != 3 {
            return Err(format!("vertex {i}: expected 3 coordinates"));
        }
        mesh.positions.push(DVec3::new(c[0], c[1], c[2]));
    }
    for f in 0..nf {
        let line = lines.next().ok_or(format!("missing face {f}"))?;
        let t: Vec<&str> = line.split_whitespace().collect();
        let k: usize = t
            .first()
            .and_then(|s| s.parse().ok())
            .ok_or(format!("face {f}: bad size"))?;
        let idx: Result<Vec<u32>, _> = t.iter().skip(1).take(k).map(|s| s.parse::<u32>()).collect();
        let idx = idx.map_err(|_| format!("face {f}: bad index"))?;
        if idx.len() != k {
            return Err(format!("face {f}: short"));
        }
        mesh.push_face(&idx);
    }
    check_indices(&mesh)?;
    Ok(mesh)
}

fn parse_off_binary(data: &[u8]) -> Result<IndexedMesh, String> {
    let mut pos = data
        .iter()
        .position(|&b| b == b'\n')
        .ok_or("no header line")?
        + 1;
    let int = |pos: &mut usize| -> Result<i32, String> {
        let b = data.get(*pos..*pos + 4).ok_or("truncated")?;
        *pos += 4;
        Ok(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let nv = int(&mut pos)?;
    let nf = int(&mut pos)?;
    let _ne = int(&mut pos)?;
    if nv < 0 || nf < 0 || nv as usize * 12 > data.len() || nf as usize * 4 > data.len() {
        return Err("bad counts".into());
    }
    let mut mesh = IndexedMesh::new();
    for _ in 0..nv {
        let mut c = [0.0; 3];
        for x in &mut c {
            let b = data.get(pos..pos + 4).ok_or("truncated")?;
            *x = f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64;
            pos += 4;
        }
        mesh.positions.push(DVec3::from_array(c));
    }
    let mut face = Vec::new();
    for _ in 0..nf {
        let k = int(&mut pos)?;
        if !(0..=1024).contains(&k) {
            return Err("bad face size".into());
        }
        face.clear();
        for _ in 0..k {
            face.push(u32::try_from(int(&mut pos)?).map_err(|_| "negative index")?);
        }
        mesh.push_face(&face);
    }
    check_indices(&mesh)?;
    Ok(mesh)
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
