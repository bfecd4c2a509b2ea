//! `write_glb_lod`: several levels of detail in one GLB linked with
//! `MSFT_lod`. The file must pass the Khronos validator for every option
//! combination, name the coarser nodes from the finest node's extension,
//! carry the coverage hints, show only the finest node in the scene, share
//! one quantization transform across levels, and read back (all levels, in
//! order) with every polygon intact. `lod_screen_coverage` is checked
//! against the rule its documentation states.

mod gltf_export_util;

use gltf_export_util::{assert_valid_gltf, glb_json, shared};
use pqm_core::io::{
    lod_screen_coverage, read_gltf_bytes, read_mesh, write_glb_lod, GltfWriteOptions, Normals,
    KHR_MESH_QUANTIZATION, MSFT_LOD,
};
use pqm_core::subdivide::{catmull_clark, SplitMode};
use pqm_core::IndexedMesh;

/// Finest first: the control mesh of Spot (quads, triangles, pentagons)
/// subdivided twice, once, and not at all.
fn levels() -> Vec<IndexedMesh> {
    let spot = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    vec![
        catmull_clark(&spot, 2, SplitMode::CatmullClark).unwrap(),
        catmull_clark(&spot, 1, SplitMode::CatmullClark).unwrap(),
        spot,
    ]
}

fn face_counts(levels: &[IndexedMesh]) -> Vec<usize> {
    levels.iter().map(IndexedMesh::face_count).collect()
}

#[test]
fn lod_glb_validates_links_levels_and_reads_back() {
    let levels = levels();
    let coverage = lod_screen_coverage(&face_counts(&levels));
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for normals in [Normals::None, Normals::Smooth, Normals::Flat] {
        for quantize in [false, true] {
            let opts = GltfWriteOptions {
                normals,
                quantize,
                ..GltfWriteOptions::default()
            };
            let mut glb = Vec::new();
            write_glb_lod(&mut glb, &levels, &coverage, &opts).unwrap();
            let doc = glb_json(&glb);
            let tag = format!("{normals:?}-q{}", u8::from(quantize));

            let used: Vec<&str> = doc["extensionsUsed"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_str().unwrap())
                .collect();
            assert!(used.contains(&MSFT_LOD), "{tag}");
            let required = doc["extensionsRequired"]
                .as_array()
                .cloned()
                .unwrap_or_default();
            assert!(
                !required.iter().any(|v| v == MSFT_LOD),
                "{tag}: MSFT_lod is optional"
            );
            assert_eq!(
                required.iter().any(|v| v == KHR_MESH_QUANTIZATION),
                quantize,
                "{tag}"
            );
            let nodes = doc["nodes"].as_array().unwrap();
            assert_eq!(nodes.len(), levels.len(), "{tag}: one node per level");
            assert_eq!(
                doc["scenes"][doc["scene"].as_u64().unwrap() as usize]["nodes"],
                serde_json::json!([0])
            );
            assert_eq!(
                nodes[0]["extensions"][MSFT_LOD]["ids"],
                serde_json::json!([1, 2]),
                "{tag}"
            );
            assert_eq!(
                nodes[0]["extras"]["MSFT_screencoverage"],
                serde_json::json!(coverage),
                "{tag}"
            );
            for (k, node) in nodes.iter().enumerate() {
                let mesh = &doc["meshes"][node["mesh"].as_u64().unwrap() as usize];
                let idx = mesh["primitives"][0]["indices"].as_u64().unwrap() as usize;
                let tris = doc["accessors"][idx]["count"].as_u64().unwrap() as usize / 3;
                let expect: usize = levels[k].faces().map(|f| f.len() - 2).sum();
                assert_eq!(tris, expect, "{tag}: node {k} is level {k}");
                // One shared transform, so any node's transform fits any mesh.
                assert_eq!(node["scale"], nodes[0]["scale"], "{tag}");
                assert_eq!(node["translation"], nodes[0]["translation"], "{tag}");
            }

            // Our reader reads every mesh in order: all levels' polygons.
            let back = read_gltf_bytes(&glb, None).unwrap();
            let sizes: Vec<usize> = back.faces().map(|f| f.len()).collect();
            let expect: Vec<usize> = levels
                .iter()
                .flat_map(|m| m.faces().map(|f| f.len()))
                .collect();
            assert_eq!(sizes, expect, "{tag}: polygons of the levels");
            let (lo, hi) = levels
                .iter()
                .map(|m| m.bounding_box().unwrap())
                .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
                .unwrap();
            let (blo, bhi) = back.bounding_box().unwrap();
            let tol = 1e-4 * (hi - lo).length();
            assert!((blo - lo).abs().max_element() < tol, "{tag}: {blo} vs {lo}");
            assert!((bhi - hi).abs().max_element() < tol, "{tag}: {bhi} vs {hi}");

            let path = dir.path().join(format!("lod-{tag}.glb"));
            std::fs::write(&path, &glb).unwrap();
            files.push(path);
        }
    }
    assert_valid_gltf(&files);
}

#[test]
fn screen_coverage_follows_the_documented_rule() {
    let counts = [40_000, 10_000, 2_500, 600];
    let c = lod_screen_coverage(&counts);
    assert_eq!(c.len(), counts.len());
    assert_eq!(c[0], 0.5, "the finest level from half the screen up");
    assert_eq!(
        *c.last().unwrap(),
        0.0,
        "the coarsest level is never culled"
    );
    assert!(c.windows(2).all(|w| w[1] <= w[0]), "{c:?}");
    // Same face density at every switch but the last.
    for k in 0..counts.len() - 1 {
        let density = counts[k] as f64 / c[k];
        assert!(
            (density - 2.0 * counts[0] as f64).abs() < 1e-6,
            "level {k}: {density}"
        );
    }
    assert_eq!(lod_screen_coverage(&[100]), vec![0.0]);
    assert!(lod_screen_coverage(&[]).is_empty());
}

#[test]
fn a_single_level_is_a_plain_glb() {
    let spot = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    let opts = GltfWriteOptions::default();
    let mut lod = Vec::new();
    write_glb_lod(&mut lod, std::slice::from_ref(&spot), &[0.0], &opts).unwrap();
    let mut plain = Vec::new();
    pqm_core::io::write_glb_with(&mut plain, &spot, &opts).unwrap();
    assert_eq!(lod, plain);
}

#[test]
fn bad_lod_arguments_are_errors() {
    let levels = levels();
    let opts = GltfWriteOptions::default();
    let err = |levels: &[IndexedMesh], cov: &[f64]| {
        write_glb_lod(Vec::new(), levels, cov, &opts)
            .unwrap_err()
            .to_string()
    };
    assert!(err(&[], &[]).contains("no levels"));
    assert!(err(&levels, &[0.5, 0.1]).contains("3 levels"));
    assert!(err(&levels, &[0.5, 0.6, 0.0]).contains("increases"));
    assert!(err(&levels, &[0.5, f64::NAN, 0.0]).contains("level 1"));
    let reversed: Vec<IndexedMesh> = levels.iter().rev().cloned().collect();
    assert!(err(&reversed, &[0.5, 0.2, 0.0]).contains("finest first"));
    let mut broken = levels.clone();
    broken[1] = IndexedMesh::new();
    broken[2] = IndexedMesh::new();
    let e = err(&broken, &[0.5, 0.2, 0.0]);
    assert!(e.contains("LOD level 1"), "{e}");
}
