//! Importance maps: curvature importance, remapping, sidecar and property
//! loaders.

mod attributes_shapes;
use attributes_shapes::*;

use glam::DVec3;
use pqm_core::attributes::{
    curvature_importance, importance_from_scalars, load_importance_sidecar,
    parse_importance_sidecar, remap_importance, AttributeError, Curvature,
};
use pqm_core::IndexedMesh;

/// A 20 × 20 grid with a smooth Gaussian bump in the middle.
fn bumpy_grid() -> IndexedMesh {
    let mut im = grid(20, 20);
    for p in im.positions.iter_mut() {
        let d2 = (p.x - 10.0).powi(2) + (p.y - 10.0).powi(2);
        p.z = 3.0 * (-d2 / 6.0).exp();
    }
    im
}

#[test]
fn curvature_importance_is_high_on_the_bump_and_one_on_the_flat() {
    let im = bumpy_grid();
    let m = mesh(&im);
    let imp = curvature_importance(&m, &Curvature::estimate(&m));
    assert_eq!(imp.len(), m.vertex_capacity());
    assert!(imp.iter().all(|&x| (1.0..=3.0).contains(&x)));
    let at = |i, j| imp[grid_id(20, i, j) as usize];
    // bump top vs. flat corner region
    assert!(at(10, 10) > 2.5, "top {}", at(10, 10));
    assert!(at(2, 2) < 1.01, "flat {}", at(2, 2));
    // the percentile clamp: at least 5% of vertices reach each end
    let n = imp.len() as f64;
    assert!(imp.iter().filter(|&&x| x >= 3.0 - 1e-12).count() as f64 >= 0.04 * n);
    assert!(imp.iter().filter(|&&x| x <= 1.0 + 1e-12).count() as f64 >= 0.04 * n);
}

#[test]
fn curvature_importance_is_unit_free() {
    let im = bumpy_grid();
    let mut big = im.clone();
    for p in big.positions.iter_mut() {
        *p = *p * 250.0 + DVec3::new(1e3, -2e3, 5.0);
    }
    let (a, b) = (mesh(&im), mesh(&big));
    let ia = curvature_importance(&a, &Curvature::estimate(&a));
    let ib = curvature_importance(&b, &Curvature::estimate(&b));
    for (x, y) in ia.iter().zip(&ib) {
        assert!((x - y).abs() < 1e-6, "{x} vs {y}");
    }
}

#[test]
fn uniform_curvature_gives_uniform_importance() {
    let m = mesh(&grid(6, 6));
    assert!(curvature_importance(&m, &Curvature::estimate(&m))
        .iter()
        .all(|&x| x == 1.0));
}

#[test]
fn remap_spans_one_to_three() {
    let r = remap_importance(&[5.0, -1.0, 2.0, 11.0]);
    assert_eq!(r, vec![2.0, 1.0, 1.5, 3.0]);
    assert_eq!(remap_importance(&[4.0, 4.0]), vec![1.0, 1.0]);
    assert!(remap_importance(&[]).is_empty());
    let r = remap_importance(&[0.0, f64::NAN, 2.0]);
    assert_eq!(r, vec![1.0, 1.0, 3.0]);
}

#[test]
fn sidecar_parses_values_and_comments() {
    let text = "# importance\n1.5\n\n  2 # trailing comment\n-3e-1\n";
    assert_eq!(
        parse_importance_sidecar(text, "imp.txt", 3).unwrap(),
        vec![1.5, 2.0, -0.3]
    );
}

fn err_text(r: Result<Vec<f64>, AttributeError>) -> String {
    r.expect_err("must fail").to_string()
}

#[test]
fn sidecar_errors_name_the_line() {
    let e = err_text(parse_importance_sidecar("1\n# x\nabc\n", "imp.txt", 3));
    assert!(
        e.contains("imp.txt line 3") && e.contains("'abc' is not a number"),
        "{e}"
    );
    let e = err_text(parse_importance_sidecar("1\n2 3\n", "imp.txt", 3));
    assert!(
        e.contains("line 2") && e.contains("one number per line"),
        "{e}"
    );
    let e = err_text(parse_importance_sidecar("1\nnan\n", "imp.txt", 2));
    assert!(
        e.contains("line 2") && e.contains("not a finite number"),
        "{e}"
    );
    let e = err_text(parse_importance_sidecar("1\n2\n", "imp.txt", 3));
    assert!(e.contains("imp.txt: 2 values for 3 vertices"), "{e}");
    let e = err_text(parse_importance_sidecar("1\n2\n3\n", "imp.txt", 2));
    assert!(e.contains("line 3") && e.contains("more values"), "{e}");
}

#[test]
fn sidecar_file_round_trip_and_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imp.txt");
    std::fs::write(&path, "0.5\n1\n").unwrap();
    assert_eq!(load_importance_sidecar(&path, 2).unwrap(), vec![0.5, 1.0]);
    let missing = dir.path().join("nope.txt");
    let e = err_text(load_importance_sidecar(&missing, 2));
    assert!(e.contains("cannot read") && e.contains("nope.txt"), "{e}");
}

#[test]
fn vertex_property_loader_checks_name_length_and_values() {
    let mut im = grid(1, 1);
    let e = err_text(importance_from_scalars(&im, "quality"));
    assert!(
        e.contains("'quality'") && e.contains("no per-vertex properties"),
        "{e}"
    );
    im.vertex_scalars
        .insert("quality".into(), vec![1.0, 2.0, 3.0, 4.0]);
    assert_eq!(
        importance_from_scalars(&im, "quality").unwrap(),
        vec![1.0, 2.0, 3.0, 4.0]
    );
    let e = err_text(importance_from_scalars(&im, "weight"));
    assert!(e.contains("available: quality"), "{e}");
    im.vertex_scalars.insert("short".into(), vec![1.0]);
    let e = err_text(importance_from_scalars(&im, "short"));
    assert!(e.contains("1 values for 4 vertices"), "{e}");
    im.vertex_scalars
        .insert("bad".into(), vec![1.0, f64::INFINITY, 0.0, 0.0]);
    let e = err_text(importance_from_scalars(&im, "bad"));
    assert!(e.contains("vertex 1"), "{e}");
}

#[test]
fn fandisk_creases_are_more_important_than_its_flat_parts() {
    let path = shared_mesh("quad/fandisk_quads.off");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let m = mesh(&read_off(&path));
    let c = Curvature::estimate(&m);
    let imp = curvature_importance(&m, &c);
    assert!(imp.iter().all(|x| (1.0..=3.0).contains(x)));
    let sharp = pqm_core::features::sharp_edges(&m, 60.0);
    let mut on = vec![false; m.vertex_capacity()];
    for &(a, b) in &sharp {
        on[a.idx()] = true;
        on[b.idx()] = true;
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let crease = median(
        m.vertices()
            .filter(|v| on[v.idx()])
            .map(|v| imp[v.idx()])
            .collect(),
    );
    let rest = median(
        m.vertices()
            .filter(|v| !on[v.idx()])
            .map(|v| imp[v.idx()])
            .collect(),
    );
    eprintln!("fandisk_quads median importance: creases {crease:.3}, elsewhere {rest:.3}");
    assert!(crease > rest + 0.5, "creases {crease} vs elsewhere {rest}");
}
