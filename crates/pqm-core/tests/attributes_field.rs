//! Direction fields: the alignment score, 4-RoSy averaging, quad alignment
//! and the sidecar loader.

mod attributes_shapes;
use attributes_shapes::*;

use glam::DVec3;
use pqm_core::attributes::field::rosy4_average;
use pqm_core::attributes::{
    alignment, load_field_sidecar, parse_field_sidecar, quad_alignment, Curvature, Field,
};
use pqm_core::{FaceId, IndexedMesh};
use proptest::prelude::*;

fn in_plane(deg: f64) -> DVec3 {
    let a = deg.to_radians();
    DVec3::new(a.cos(), a.sin(), 0.0)
}

#[test]
fn alignment_scores_angles_modulo_ninety_degrees() {
    let n = DVec3::Z;
    let f = DVec3::X;
    let score = |deg: f64| alignment(in_plane(deg), f, n).unwrap();
    assert!((score(0.0) - 1.0).abs() < 1e-12);
    assert!((score(90.0) - 1.0).abs() < 1e-12);
    assert!((score(180.0) - 1.0).abs() < 1e-12);
    assert!(score(45.0).abs() < 1e-12);
    assert!(score(135.0).abs() < 1e-12);
    assert!((score(30.0) - 0.5).abs() < 1e-12);
    assert!((score(60.0) - 0.5).abs() < 1e-12);
    // monotone from 0° to 45°
    let mut last = 2.0;
    for k in 0..=45 {
        let s = score(k as f64);
        assert!(s < last);
        last = s;
    }
}

#[test]
fn alignment_projects_into_the_plane() {
    let n = DVec3::new(0.0, 0.0, 2.0); // any length
                                       // normal components are ignored
    let a = alignment(DVec3::new(1.0, 1.0, 5.0), DVec3::new(1.0, 0.0, -3.0), n).unwrap();
    assert!(a.abs() < 1e-12);
    // a field along the normal has no direction in the plane
    assert_eq!(alignment(DVec3::X, DVec3::Z, n), None);
    assert_eq!(alignment(DVec3::X, DVec3::ZERO, n), None);
    assert_eq!(alignment(DVec3::X, DVec3::X * 1e-9, n), None);
    assert_eq!(alignment(DVec3::Z, DVec3::X, n), None);
    assert_eq!(alignment(DVec3::X, DVec3::Y, DVec3::ZERO), None);
}

proptest! {
    #[test]
    fn alignment_is_symmetric_and_cross_invariant(
        a in 0.0f64..360.0, b in 0.0f64..360.0, s in 0.1f64..10.0,
    ) {
        let n = DVec3::Z;
        let (d, f) = (in_plane(a) * s, in_plane(b));
        let x = alignment(d, f, n).unwrap();
        prop_assert!((0.0..=1.0).contains(&x));
        prop_assert!((x - alignment(-d, f, n).unwrap()).abs() < 1e-9);
        prop_assert!((x - alignment(d, in_plane(b + 90.0), n).unwrap()).abs() < 1e-9);
        prop_assert!((x - alignment(f, d, n).unwrap()).abs() < 1e-9);
        let theta = (a - b).to_radians();
        prop_assert!((x - (2.0 * theta).cos().abs()).abs() < 1e-9);
    }

    #[test]
    fn rosy4_average_ignores_sign_and_quarter_turns(a in 0.0f64..360.0, m in 0.1f64..3.0) {
        let u = in_plane(a) * m;
        let same = [u, -u, in_plane(a + 90.0) * m, in_plane(a - 90.0) * m];
        let avg = rosy4_average(DVec3::Z, same);
        prop_assert!((avg.length() - m).abs() < 1e-9);
        prop_assert!((alignment(avg, u, DVec3::Z).unwrap() - 1.0).abs() < 1e-9);
    }
}

#[test]
fn rosy4_average_of_diagonal_disagreement_vanishes() {
    let avg = rosy4_average(DVec3::Z, [in_plane(0.0), in_plane(45.0)]);
    assert!(avg.length() < 1e-12);
    // mixing in zero vectors lowers the confidence
    let avg = rosy4_average(DVec3::Z, [DVec3::X, DVec3::ZERO]);
    assert!((avg.length() - 0.5).abs() < 1e-12);
}

/// The grid rotated by `deg` about z.
fn rotated_grid(deg: f64) -> IndexedMesh {
    let mut im = grid(4, 4);
    let (s, c) = deg.to_radians().sin_cos();
    for p in im.positions.iter_mut() {
        *p = DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
    }
    im
}

#[test]
fn quad_alignment_of_a_grid_to_a_constant_field() {
    for (deg, want) in [
        (0.0, 1.0),
        (90.0, 1.0),
        (45.0, 0.0),
        (15.0, 30f64.to_radians().cos()),
    ] {
        let m = mesh(&rotated_grid(deg));
        let field = Field::from_axis_name(&m, "x").unwrap();
        for f in m.faces() {
            let a = quad_alignment(&m, f, &field).unwrap();
            assert!((a - want).abs() < 1e-12, "{deg}°: {a} vs {want}");
        }
        // the field along the normal: nothing to align to
        let z = Field::from_axis_name(&m, "Z").unwrap();
        assert_eq!(quad_alignment(&m, FaceId(0), &z), None);
        assert_eq!(quad_alignment(&m, FaceId(0), &Field::none(&m)), None);
    }
}

#[test]
fn axis_names_are_checked() {
    let m = mesh(&grid(1, 1));
    let e = Field::from_axis_name(&m, "w").unwrap_err().to_string();
    assert!(e.contains("'w' is not an axis"), "{e}");
    assert!(Field::none(&m).is_empty());
    assert!(!Field::constant(&m, DVec3::Y).is_empty());
}

#[test]
fn cylinder_quads_align_with_their_curvature_field() {
    let (nu, nv) = (32, 8);
    let m = mesh(&cylinder(nu, nv, 1.0, 2.0));
    let field = Field::from_curvature(&Curvature::estimate(&m));
    for f in m.faces() {
        let a = quad_alignment(&m, f, &field).expect("cylinder is anisotropic");
        assert!(a > 0.999, "face {f:?}: {a}");
    }
    // the same cylinder twisted by half a quad per row is misaligned
    let mut twisted = cylinder(nu, nv, 1.0, 2.0);
    for (k, p) in twisted.positions.iter_mut().enumerate() {
        let row = (k as u32 / nu) as f64;
        let t = row * std::f64::consts::PI / nu as f64;
        let (s, c) = t.sin_cos();
        *p = DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
    }
    let tm = mesh(&twisted);
    let tf = Field::from_curvature(&Curvature::estimate(&tm));
    let mean: f64 = tm
        .faces()
        .filter_map(|f| quad_alignment(&tm, f, &tf))
        .sum::<f64>()
        / tm.face_count() as f64;
    assert!(mean < 0.95, "twisted mean alignment {mean}");
}

#[test]
fn torus_alignment_to_the_x_axis_varies_like_fig_4() {
    let m = mesh(&torus(32, 16, 3.0, 1.0));
    let field = Field::from_axis_name(&m, "x").unwrap();
    let scores: Vec<f64> = m
        .faces()
        .filter_map(|f| quad_alignment(&m, f, &field))
        .collect();
    // quads near the x-z and y-z planes are aligned, quads at 45° around
    // the axis are not
    let hi = scores.iter().filter(|&&s| s > 0.9).count();
    let lo = scores.iter().filter(|&&s| s < 0.1).count();
    assert!(hi > 0 && lo > 0, "hi {hi} lo {lo}");
}

#[test]
fn sidecar_per_vertex_and_per_face() {
    let m = mesh(&grid(2, 1)); // 6 vertices, 2 faces
    let text = "# field\n1 0 0\n0 1 0\n1 0 0\n0 0 0\n1 0 0\n0 1 0\n";
    let f = parse_field_sidecar(text, "f.txt", &m).unwrap();
    assert_eq!(f.dirs[1], DVec3::Y);
    assert_eq!(f.dirs[3], DVec3::ZERO);
    // per face: face 0 along x, face 1 along y (same cross field); a vertex
    // shared by both keeps the direction at full confidence
    let f = parse_field_sidecar("1 0 0\n0 -1 0 # flipped\n", "f.txt", &m).unwrap();
    assert_eq!(f.dirs.len(), 6);
    for d in &f.dirs {
        assert!((d.length() - 1.0).abs() < 1e-12);
        assert!((alignment(*d, DVec3::X, DVec3::Z).unwrap() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn sidecar_errors_and_the_ambiguous_count() {
    let m = mesh(&grid(2, 1));
    let e = parse_field_sidecar("1 0\n", "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("f.txt line 1") && e.contains("three numbers"),
        "{e}"
    );
    let e = parse_field_sidecar("1 0 0\n1 x 0\n", "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("'x'"), "{e}");
    let e = parse_field_sidecar("1 0 0\n1 0 0\n1 0 0\n", "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("3 vectors") && e.contains("6 vertices and 2 faces"),
        "{e}"
    );
    let many = "1 0 0\n".repeat(7);
    let e = parse_field_sidecar(&many, "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 7"), "{e}");
    let e = parse_field_sidecar("1 0 0\nper_face\n", "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("first data line"), "{e}");
    let e = parse_field_sidecar("per_vertex\n1 0 0\n1 0 0\n", "f.txt", &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 vectors, but the mesh has 6 vertices"), "{e}");

    // a closed torus has as many vertices as faces: the file must say which
    let t = mesh(&torus(4, 4, 3.0, 1.0));
    let body = "1 0 0\n".repeat(16);
    let e = parse_field_sidecar(&body, "t.txt", &t)
        .unwrap_err()
        .to_string();
    assert!(e.contains("per_vertex") && e.contains("per_face"), "{e}");
    let pv = parse_field_sidecar(&format!("per_vertex\n{body}"), "t.txt", &t).unwrap();
    assert_eq!(pv.dirs, vec![DVec3::X; 16]);
    let pf = parse_field_sidecar(&format!("# x\nper_face\n{body}"), "t.txt", &t).unwrap();
    assert_eq!(pf.dirs.len(), 16);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.txt");
    std::fs::write(&path, "0 0 1\n0 0 1\n").unwrap();
    assert_eq!(load_field_sidecar(&path, &m).unwrap().dirs.len(), 6);
    let e = load_field_sidecar(&dir.path().join("none.txt"), &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("none.txt"), "{e}");
}

#[test]
fn quad_alignment_equals_chord_alignment_to_the_face_field() {
    let m = mesh(&torus(16, 8, 3.0, 1.0));
    let mut rng = Rng(11);
    let field = Field {
        dirs: (0..m.vertex_capacity())
            .map(|_| DVec3::new(rng.signed(), rng.signed(), rng.signed()))
            .collect(),
    };
    let mut checked = 0;
    for f in m.faces() {
        let q = m.quad_vertices(f).unwrap().map(|v| m.position(v));
        let n = (q[2] - q[0]).cross(q[3] - q[1]);
        let u = field.at_face(&m, f);
        let c1 = (q[2] + q[3]) - (q[0] + q[1]);
        let c2 = (q[3] + q[0]) - (q[1] + q[2]);
        let want = match (alignment(c1, u, n), alignment(c2, u, n)) {
            (Some(a), Some(b)) => Some(0.5 * (a + b)),
            _ => None,
        };
        let got = quad_alignment(&m, f, &field);
        match (got, want) {
            (Some(g), Some(w)) => {
                assert!((g - w).abs() < 1e-9, "{f:?}: {g} vs {w}");
                checked += 1;
            }
            (g, w) => assert_eq!(g.is_some(), w.is_some()),
        }
    }
    assert!(checked > 100);
}
