//! Catmull-Clark / linear split: counts, numbering, geometry of both modes,
//! boundary rules, attributes and error handling.

mod subdivide_util;

use glam::DVec3;
use pqm_core::shapes::{cube, grid, height_grid, quad_sphere, two_components};
use pqm_core::subdivide::{catmull_clark, catmull_clark_split, SplitMode, SubdivideError};
use pqm_core::IndexedMesh;
use std::collections::BTreeSet;
use subdivide_util::*;

const MODES: [SplitMode; 2] = [SplitMode::Linear, SplitMode::CatmullClark];

/// Undirected edges in order of first appearance (faces in order, edge i of a
/// face = face[i] → face[i+1]) — the documented numbering, recomputed naively.
fn edges_first_seen(m: &IndexedMesh) -> Vec<(u32, u32)> {
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for f in m.faces() {
        for i in 0..f.len() {
            let (a, b) = (f[i], f[(i + 1) % f.len()]);
            if seen.insert((a.min(b), a.max(b))) {
                out.push((a, b));
            }
        }
    }
    out
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-12
}

/// Regular n-gon of radius 1 in the z = 0 plane, counter-clockwise from +z.
fn ngon(n: u32) -> IndexedMesh {
    let pos = (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            DVec3::new(t.cos(), t.sin(), 0.0)
        })
        .collect();
    IndexedMesh::from_faces(pos, [(0..n).collect::<Vec<_>>()])
}

#[test]
fn cube_split_counts_and_topology() {
    let m = cube(2.0);
    for mode in MODES {
        let s = catmull_clark_split(&m, mode).unwrap();
        assert_eq!(s.face_count(), 24);
        assert_eq!(s.vertex_count(), 8 + 12 + 6);
        assert!(s.is_quad_only());
        assert_eq!(euler(&s), euler(&m));
        assert!(orientation_consistent(&s));
        assert!(is_closed(&s));
        // Orientation kept: child faces face the same way as their parent.
        for (c, q) in s.faces().enumerate() {
            let parent = m.face(c / 4);
            assert!(face_normal(&s, q).dot(face_normal(&m, parent)) > 0.0);
        }
    }
}

#[test]
fn numbering_follows_the_documented_order() {
    // Quads of two components, then a pentagon and a triangle sharing an edge.
    let mut m = two_components();
    let v0 = m.vertex_count() as u32;
    for i in 0..6 {
        m.positions
            .push(DVec3::new(5.0 + i as f64, (i * i) as f64 * 0.1, 0.0));
    }
    m.push_face(&[v0, v0 + 1, v0 + 2, v0 + 3, v0 + 4]);
    m.push_face(&[v0 + 5, v0 + 2, v0 + 1]);
    let s = catmull_clark_split(&m, SplitMode::Linear).unwrap();
    let edges = edges_first_seen(&m);
    let (v, e) = (m.vertex_count(), edges.len());
    assert_eq!(s.vertex_count(), v + e + m.face_count());
    assert_eq!(&s.positions[..v], &m.positions[..]);
    for (k, &(a, b)) in edges.iter().enumerate() {
        let mid = (m.positions[a as usize] + m.positions[b as usize]) * 0.5;
        assert!(close(s.positions[v + k], mid), "edge point {k}");
    }
    for (f, face) in m.faces().enumerate() {
        assert!(
            close(s.positions[v + e + f], centroid(&m, face)),
            "face point {f}"
        );
    }
    // Output face c is the quad of input corner c: (v_c, e_c, f, e_{c-1}).
    let mut c = 0;
    for (f, face) in m.faces().enumerate() {
        let n = face.len();
        for i in 0..n {
            let edge_id = |a: u32, b: u32| {
                edges
                    .iter()
                    .position(|&(x, y)| (x, y) == (a, b) || (x, y) == (b, a))
                    .unwrap()
            };
            let ei = edge_id(face[i], face[(i + 1) % n]);
            let ep = edge_id(face[(i + n - 1) % n], face[i]);
            let expect = [
                face[i],
                (v + ei) as u32,
                (v + e + f) as u32,
                (v + ep) as u32,
            ];
            assert_eq!(s.face(c), &expect[..], "output face {c}");
            c += 1;
        }
    }
}

#[test]
fn every_ngon_splits_into_n_quads() {
    for n in 3..=9 {
        let m = ngon(n);
        for mode in MODES {
            let s = catmull_clark_split(&m, mode).unwrap();
            assert_eq!(s.face_count(), n as usize);
            assert_eq!(s.vertex_count(), 2 * n as usize + 1);
            assert!(s.is_quad_only());
            assert!(orientation_consistent(&s));
            assert_eq!(euler(&s), 1);
            assert_eq!(boundary_loops(&s), 1);
            for q in s.faces() {
                assert!(face_normal(&s, q).z > 0.0, "n = {n}: quad flipped");
            }
        }
    }
}

#[test]
fn linear_split_keeps_planar_faces_unchanged() {
    // Box with planar faces of different sizes, plus a planar hexagon fan.
    let mut m = cube(1.0);
    for p in &mut m.positions {
        *p = DVec3::new(p.x * 3.0, p.y * 1.5, p.z) + DVec3::new(0.3, -0.2, 0.7);
    }
    let s = catmull_clark_split(&m, SplitMode::Linear).unwrap();
    let area = |mesh: &IndexedMesh| {
        mesh.faces()
            .map(|f| face_normal(mesh, f).length())
            .sum::<f64>()
    };
    assert!((area(&s) - area(&m)).abs() < 1e-9);
    for (c, q) in s.faces().enumerate() {
        let parent = m.face(c / 4);
        let n = face_normal(&m, parent).normalize();
        let p0 = m.positions[parent[0] as usize];
        for &v in q {
            let d = (s.positions[v as usize] - p0).dot(n);
            assert!(
                d.abs() < 1e-12,
                "vertex {v} leaves the plane of face {} by {d}",
                c / 4
            );
        }
        // And its normal matches the parent's.
        assert!(face_normal(&s, q).normalize().dot(n) > 1.0 - 1e-12);
    }
}

#[test]
fn catmull_clark_cube_rules_and_convergence() {
    // Cube with corners at ±1: the textbook first step puts corners at ±5/9
    // and edge points at (±3/4, ±3/4, 0) and permutations.
    let m = cube(2.0);
    let s = catmull_clark_split(&m, SplitMode::CatmullClark).unwrap();
    let lin = catmull_clark_split(&m, SplitMode::Linear).unwrap();
    for v in 0..8 {
        assert!(
            close(s.positions[v].abs(), DVec3::splat(5.0 / 9.0)),
            "corner {v}"
        );
    }
    for k in 8..20 {
        let mut c = s.positions[k].abs().to_array();
        c.sort_by(f64::total_cmp);
        assert!(
            close(DVec3::from(c), DVec3::new(0.0, 0.75, 0.75)),
            "edge point {k}"
        );
    }
    for k in 20..26 {
        assert!(
            close(s.positions[k], lin.positions[k]),
            "face points are centroids"
        );
    }
    // Every point moves inward (or stays, for face points) relative to the linear split.
    for (p, q) in s.positions.iter().zip(&lin.positions) {
        assert!(p.length() <= q.length() + 1e-12);
    }
    // Symmetry: the point set is invariant under the cube's symmetries.
    let key = |p: DVec3| (p * 1e9).round().to_array().map(|x| x as i64);
    let set: BTreeSet<[i64; 3]> = s.positions.iter().map(|&p| key(p)).collect();
    for &p in &s.positions {
        for q in [
            DVec3::new(-p.x, p.y, p.z),
            DVec3::new(p.y, p.z, p.x),
            DVec3::new(p.y, p.x, p.z),
        ] {
            assert!(set.contains(&key(q)), "{q} missing: not symmetric");
        }
    }
    // Converges toward a round limit surface: the max/min radius ratio stays
    // near 1 (the linear split keeps the cube's √3) and settles level by level.
    let spread = |mesh: &IndexedMesh| {
        let r: Vec<f64> = mesh.positions.iter().map(|p| p.length()).collect();
        r.iter().copied().fold(0.0, f64::max) / r.iter().copied().fold(f64::MAX, f64::min)
    };
    let mut spreads = Vec::new();
    for level in 1..=4 {
        let sub = catmull_clark(&m, level, SplitMode::CatmullClark).unwrap();
        let flat = catmull_clark(&m, level, SplitMode::Linear).unwrap();
        assert_eq!(sub.face_count(), 6 * 4usize.pow(level));
        assert!((spread(&flat) - 3f64.sqrt()).abs() < 1e-9);
        spreads.push(spread(&sub));
    }
    assert!(
        spreads[0] < 1.15 && spreads[1..].iter().all(|&s| s < 1.05),
        "{spreads:?}"
    );
    let steps: Vec<f64> = spreads.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    assert!(steps[2] < steps[0] / 4.0, "not converging: {spreads:?}");
}

#[test]
fn grid_boundary_rules() {
    let m = grid(5, 3, 2.0, 1.0);
    for mode in MODES {
        let s = catmull_clark_split(&m, mode).unwrap();
        assert_eq!(euler(&s), 1);
        assert_eq!(boundary_loops(&s), 1);
        assert_eq!(boundary_edges(&s).len(), 2 * boundary_edges(&m).len());
        for p in &s.positions {
            assert!(p.z.abs() < 1e-15, "split of a flat grid must stay flat");
        }
        for (a, _) in boundary_edges(&s) {
            let p = s.positions[a as usize];
            let on_x = (p.x.abs() - 1.0).abs() < 1e-12;
            let on_y = (p.y.abs() - 0.5).abs() < 1e-12;
            assert!(on_x || on_y, "boundary vertex {a} at {p} left the boundary");
        }
        // Corners (one incident face) keep their position.
        for corner in [0usize, 5, 18, 23] {
            assert!(close(s.positions[corner], m.positions[corner]));
        }
    }
}

#[test]
fn catmull_clark_boundary_depends_only_on_boundary_vertices() {
    // Curved boundary: the output boundary must not feel interior changes.
    let a = height_grid(6, 5, |x, y| (2.0 * x).sin() + y * y);
    let mut b = a.clone();
    let bverts: BTreeSet<u32> = boundary_edges(&a).iter().map(|e| e.0).collect();
    for (v, p) in b.positions.iter_mut().enumerate() {
        if !bverts.contains(&(v as u32)) {
            p.z += 0.37 * (v as f64).sin();
        }
    }
    let sa = catmull_clark_split(&a, SplitMode::CatmullClark).unwrap();
    let sb = catmull_clark_split(&b, SplitMode::CatmullClark).unwrap();
    let mut checked = 0;
    for (v, _) in boundary_edges(&sa) {
        assert!(
            close(sa.positions[v as usize], sb.positions[v as usize]),
            "boundary vertex {v}"
        );
        checked += 1;
    }
    assert_eq!(checked, 2 * (6 + 5) * 2);
    // Non-corner boundary vertices follow the 1/8, 3/4, 1/8 curve rule.
    let next: std::collections::BTreeMap<u32, u32> = boundary_edges(&a).into_iter().collect();
    let prev: std::collections::BTreeMap<u32, u32> = boundary_edges(&a)
        .into_iter()
        .map(|(x, y)| (y, x))
        .collect();
    let faces_at = |v: u32| a.faces().filter(|f| f.contains(&v)).count();
    for (&v, &n) in &next {
        let p = a.positions[v as usize];
        let expect = if faces_at(v) == 1 {
            p
        } else {
            p * 0.75 + (a.positions[n as usize] + a.positions[prev[&v] as usize]) * 0.125
        };
        assert!(
            close(sa.positions[v as usize], expect),
            "boundary vertex {v}"
        );
    }
}

#[test]
fn catmull_clark_points_stay_in_the_convex_hull_box() {
    let m = quad_sphere(3, 1.0);
    let s = catmull_clark(&m, 2, SplitMode::CatmullClark).unwrap();
    let (lo, hi) = m.bounding_box().unwrap();
    for p in &s.positions {
        assert!(p.cmpge(lo - 1e-12).all() && p.cmple(hi + 1e-12).all());
    }
    assert_eq!(s.face_count(), m.face_count() * 16);
}

#[test]
fn linear_attributes_are_interpolated_exactly() {
    // Texcoords and a scalar that are affine functions of position: linear
    // interpolation reproduces them exactly at every new point.
    let mut m = height_grid(4, 3, |x, y| 0.2 * x - y);
    let uv = |p: DVec3| [p.x + 0.5, 2.0 * p.y + 1.0];
    let g = |p: DVec3| 3.0 * p.x - p.y + 0.5 * p.z + 1.0;
    m.texcoords = m.positions.iter().map(|&p| uv(p)).collect();
    m.corner_texcoords = m.indices.clone();
    m.vertex_scalars
        .insert("g".into(), m.positions.iter().map(|&p| g(p)).collect());
    m.normals = vec![DVec3::Z];
    m.corner_normals = vec![0; m.indices.len()];
    for mode in MODES {
        let s = catmull_clark_split(&m, mode).unwrap();
        assert_eq!(s.corner_texcoords.len(), s.indices.len());
        assert!(
            s.normals.is_empty() && s.corner_normals.is_empty(),
            "normals are dropped"
        );
        let corners = m.indices.len();
        assert_eq!(
            s.texcoords.len(),
            m.texcoords.len() + corners + m.face_count()
        );
        // Texcoords interpolate the *linear* positions in both modes.
        let lin = catmull_clark_split(&m, SplitMode::Linear).unwrap();
        for (&v, &t) in s.indices.iter().zip(&s.corner_texcoords) {
            let want = uv(lin.positions[v as usize]);
            let got = s.texcoords[t as usize];
            assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
        }
        let sc = &s.vertex_scalars["g"];
        assert_eq!(sc.len(), s.vertex_count());
        for (v, &val) in sc.iter().enumerate() {
            assert!((val - g(lin.positions[v])).abs() < 1e-12, "scalar at {v}");
        }
    }
}

#[test]
fn texcoord_seams_stay_seams() {
    // Two quads sharing an edge but with different texcoords on each side.
    let pos = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(2.0, 1.0, 0.0),
    ];
    let mut m = IndexedMesh::from_faces(pos, [[0u32, 1, 2, 3], [1, 4, 5, 2]]);
    m.texcoords = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
        [5.0, 5.0],
        [6.0, 5.0],
        [6.0, 6.0],
        [5.0, 6.0],
    ];
    m.corner_texcoords = vec![0, 1, 2, 3, 4, 5, 6, 7];
    let s = catmull_clark_split(&m, SplitMode::CatmullClark).unwrap();
    // The shared edge point (edge 1-2) has one texcoord per side.
    let shared_edge_vertex = 6 + 1; // edges first seen: 0-1, 1-2, ...
    let uvs: BTreeSet<[i64; 2]> = s
        .indices
        .iter()
        .zip(&s.corner_texcoords)
        .filter(|(&v, _)| v == shared_edge_vertex)
        .map(|(_, &t)| s.texcoords[t as usize].map(|x| (x * 1e6) as i64))
        .collect();
    let want: BTreeSet<[i64; 2]> = [[1_000_000, 500_000], [5_000_000, 5_500_000]].into();
    assert_eq!(uvs, want);
}

#[test]
fn groups_map_to_the_first_child_quad() {
    let mut m = IndexedMesh::from_faces(
        (0..8)
            .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
            .collect(),
        [vec![0u32, 1, 2], vec![2, 1, 3, 4], vec![4, 3, 5, 6, 7]],
    );
    m.groups = vec![
        ("a".into(), 0),
        ("b".into(), 1),
        ("c".into(), 2),
        ("empty".into(), 3),
    ];
    let s = catmull_clark_split(&m, SplitMode::Linear).unwrap();
    let starts: Vec<u32> = s.groups.iter().map(|g| g.1).collect();
    assert_eq!(starts, vec![0, 3, 7, 12]);
    assert_eq!(s.face_count(), 12);
}

#[test]
fn isolated_vertices_and_levels_zero() {
    let mut m = cube(1.0);
    m.positions.push(DVec3::new(9.0, 9.0, 9.0));
    let s = catmull_clark_split(&m, SplitMode::CatmullClark).unwrap();
    assert_eq!(s.positions[8], DVec3::new(9.0, 9.0, 9.0));
    assert_eq!(s.vertex_count(), 9 + 12 + 6);
    assert_eq!(catmull_clark(&m, 0, SplitMode::CatmullClark).unwrap(), m);
    assert!(catmull_clark_split(&IndexedMesh::new(), SplitMode::Linear)
        .unwrap()
        .positions
        .is_empty());
}

#[test]
fn bad_input_gives_named_errors() {
    let p = |n: usize| {
        (0..n)
            .map(|i| DVec3::new(i as f64, 0.0, (i % 2) as f64))
            .collect::<Vec<_>>()
    };
    // Three faces on edge 0-1.
    let nm = IndexedMesh::from_faces(p(5), [[0u32, 1, 2], [1, 0, 3], [0, 1, 4]]);
    let err = catmull_clark_split(&nm, SplitMode::CatmullClark).unwrap_err();
    assert_eq!(
        err,
        SubdivideError::NonManifoldEdge {
            a: 0,
            b: 1,
            count: 3
        }
    );
    assert!(err.to_string().contains("edge 0-1"), "{err}");

    let oob = IndexedMesh::from_faces(p(3), [[0u32, 1, 7]]);
    let err = catmull_clark_split(&oob, SplitMode::Linear).unwrap_err();
    assert!(
        matches!(
            err,
            SubdivideError::VertexOutOfRange {
                face: 0,
                vertex: 7,
                ..
            }
        ),
        "{err}"
    );

    let rep = IndexedMesh::from_faces(p(4), [vec![0u32, 1, 2], vec![0, 2, 3, 2]]);
    let err = catmull_clark_split(&rep, SplitMode::Linear).unwrap_err();
    assert_eq!(err.to_string(), "face 1 repeats vertex 2");

    let small = IndexedMesh::from_faces(p(3), [vec![0u32, 1]]);
    let err = catmull_clark_split(&small, SplitMode::Linear).unwrap_err();
    assert_eq!(err, SubdivideError::DegenerateFace { face: 0, len: 2 });

    let mut bad_table = IndexedMesh::from_faces(p(4), [[0u32, 1, 2, 3]]);
    bad_table.face_starts = vec![0, 5];
    assert!(matches!(
        catmull_clark_split(&bad_table, SplitMode::Linear),
        Err(SubdivideError::MalformedFaces(_))
    ));
    bad_table.face_starts = vec![0, 5, 4];
    assert!(matches!(
        catmull_clark_split(&bad_table, SplitMode::Linear),
        Err(SubdivideError::MalformedFaces(_))
    ));
    bad_table.face_starts = vec![0, 3, 2, 4];
    assert!(matches!(
        catmull_clark_split(&bad_table, SplitMode::Linear),
        Err(SubdivideError::MalformedFaces(_))
    ));

    let mut tex = IndexedMesh::from_faces(p(4), [[0u32, 1, 2, 3]]);
    tex.texcoords = vec![[0.0, 0.0]];
    tex.corner_texcoords = vec![0, 0, 0];
    assert!(matches!(
        catmull_clark_split(&tex, SplitMode::Linear),
        Err(SubdivideError::BadTexcoords(_))
    ));
    tex.corner_texcoords = vec![0, 0, 0, 1];
    let err = catmull_clark_split(&tex, SplitMode::Linear).unwrap_err();
    assert!(err.to_string().contains("corner 3"), "{err}");

    let mut sc = IndexedMesh::from_faces(p(4), [[0u32, 1, 2, 3]]);
    sc.vertex_scalars.insert("q".into(), vec![1.0; 3]);
    let err = catmull_clark_split(&sc, SplitMode::Linear).unwrap_err();
    assert_eq!(
        err.to_string(),
        "vertex scalar 'q' has 3 values for 4 vertices"
    );
}
