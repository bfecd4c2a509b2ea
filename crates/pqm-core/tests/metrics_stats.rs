//! MeshStats: consistency with the individual metrics, serialisation, display.

mod metrics_util;
use metrics_util as common;

use pqm_core::metrics::{mesh_stats, scaled_jacobian, topology, valence};

#[test]
fn stats_agree_with_the_metrics_and_the_manifest() {
    let m = common::load_shared("quad/suzanne.obj");
    let s = mesh_stats(&m, None);
    assert_eq!(
        (s.vertices, s.faces, s.quads, s.triangles, s.other_faces),
        (507, 500, 468, 32, 0)
    );
    assert_eq!(
        (s.components, s.boundary_loops, s.genus, s.euler),
        (3, 4, 0, 2)
    );
    assert_eq!(s.scaled_jacobian, scaled_jacobian(&m).stats);
    assert_eq!(s.valence, valence(&m).stats);
    assert_eq!(topology(&m).genus, s.genus);
    assert!(s.hausdorff.is_none());

    let with_ref = mesh_stats(&m, Some(&m));
    let h = with_ref.hausdorff.expect("reference given");
    assert!(h.max < 1e-12 && h.mean < 1e-12);
}

#[test]
fn json_has_exactly_the_documented_fields() {
    let m = common::cube();
    let json = serde_json::to_value(mesh_stats(&m, None)).unwrap();
    let obj = json.as_object().unwrap();
    let mut keys: Vec<&str> = obj.keys().map(|k| k.as_str()).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "boundary_loops",
            "components",
            "euler",
            "faces",
            "forced_irregular",
            "genus",
            "other_faces",
            "quads",
            "scaled_jacobian",
            "triangles",
            "valence",
            "vertices"
        ]
    );
    assert_eq!(json["scaled_jacobian"]["worst"], 1.0);
    assert_eq!(json["valence"]["worst"], 3);
    assert_eq!(json["valence"]["extraordinary"], 8);
    assert!(json["valence"]["ideal_fraction"].is_number());

    let json = serde_json::to_value(mesh_stats(&m, Some(&m))).unwrap();
    assert!(json["hausdorff"]["max"].is_number() && json["hausdorff"]["mean"].is_number());
}

#[test]
fn display_is_a_readable_table() {
    let m = common::torus(8, 6);
    let text = mesh_stats(&m, Some(&m)).to_string();
    let row = |name: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("{name}"));
        line[name.len()..].trim().to_string()
    };
    assert_eq!(row("vertices"), "48");
    assert_eq!(row("genus"), "1");
    assert_eq!(row("boundary loops"), "0");
    assert_eq!(row("faces"), "48 (48 quads, 0 triangles, 0 other)");
    assert!(row("valence").starts_with("100.0% ideal, 0 extraordinary, worst 4"));
    assert!(row("scaled jacobian").starts_with("median "));
    // "max 7.7e-17, mean ..." — rounding-level for a mesh against itself.
    let h = row("hausdorff");
    let max: f64 = h
        .split(['(', ')', ',', ' '])
        .skip_while(|t| *t != "max")
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!(max < 1e-12, "{text}");
    assert_eq!(text.lines().count(), 9);
}
