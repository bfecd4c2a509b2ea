//! Every level of a real mesh, as a client decodes it, exported to GLB passes
//! the Khronos glTF-Validator with 0 errors, and our own glTF reader gets the
//! quads back as quads (FB_ngon_encoding).

use pqm::core::coarsen::{CoarsenOptions, Coarsener};
use pqm::core::io::{self, GltfWriteOptions, Normals};
use pqm::core::subdivide::{catmull_clark_split, SplitMode};
use pqm::core::Mesh;
use pqm::format::{write_to_vec, Decoder, EncodeOptions, Limits, Target};

#[test]
fn every_decoded_level_of_spot_control_is_valid_gltf() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = io::read_mesh(&root.join("../shared/meshes/quad/spot_control_mesh.obj")).unwrap();
    let quads = catmull_clark_split(&src, SplitMode::Linear).unwrap();
    let opts = CoarsenOptions::default();
    let mut c =
        Coarsener::with_defaults(Mesh::from_indexed(&quads).unwrap(), 60.0, &[], opts).unwrap();
    c.run(&mut |_| {});
    let pm = c.to_progressive();
    let (bytes, _) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
    let mut dec = Decoder::new(Limits::default());
    dec.push(&bytes).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    let n = pm.records.len();
    assert!(n > 50, "too few levels to be a meaningful test: {n}");
    for k in 0..=n {
        dec.set_level(Target::Level(k)).unwrap();
        let level = dec.to_indexed_mesh();
        // alternate the export options over the levels
        let gopts = GltfWriteOptions {
            normals: [Normals::None, Normals::Smooth, Normals::Flat][k % 3],
            quantize: k % 2 == 1,
            quad_split: [io::QuadSplit::Shorter, io::QuadSplit::First][k / 2 % 2],
        };
        let path = dir.path().join(format!("level_{k:04}.glb"));
        let mut buf = Vec::new();
        io::write_glb_with(&mut buf, &level, &gopts).unwrap();
        std::fs::write(&path, &buf).unwrap();
        // our reader gets the same quads back
        let back = io::read_gltf_bytes(&buf, None).unwrap();
        assert_eq!(back.face_count(), level.face_count(), "level {k}");
        assert!(back.is_quad_only(), "level {k}");
        files.push(path);
    }
    // the Khronos validator over all levels in one run (installed on demand)
    let tool = root.join("tools/gltf-validate");
    if !tool.join("node_modules/gltf-validator").is_dir() {
        let ok = std::process::Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund", "--prefix"])
            .arg(&tool)
            .status()
            .expect("npm is needed to install tools/gltf-validate");
        assert!(ok.success(), "npm ci --prefix tools/gltf-validate failed");
    }
    let out = std::process::Command::new("node")
        .arg(tool.join("validate.mjs"))
        .args(&files)
        .output()
        .expect("node is needed for the glTF validator");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for f in &files {
        let r = &report[f.to_str().unwrap()];
        assert_eq!(r["errors"], 0, "{}: {r:#}", f.display());
    }
    assert!(out.status.success());
}
