//! Runs the Khronos glTF-Validator (`tools/gltf-validate`, npm
//! `gltf-validator` pinned by its package-lock.json) on glTF and GLB files
//! written from real meshes, and requires zero errors. Warnings and infos are
//! printed. `npm ci` is run first when `node_modules` is missing, so a fresh
//! machine works (it needs `node` and `npm` and the npm registry).

mod io_util;

use io_util::{repo_root, shared};
use pqm_core::io::{read_mesh, write_mesh};
use std::process::Command;

#[test]
fn written_gltf_and_glb_pass_the_khronos_validator() {
    let tool = repo_root().join("tools/gltf-validate");
    if !tool.join("node_modules/gltf-validator").is_dir() {
        let status = Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund", "--prefix"])
            .arg(&tool)
            .status()
            .expect("running npm (needed to install tools/gltf-validate)");
        assert!(
            status.success(),
            "npm ci --prefix tools/gltf-validate failed"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    // Quads, quads + triangles + pentagons, triangles with u16 indices, and
    // triangles with more than 65534 vertices (u32 indices).
    for src in [
        "quad/fandisk_quads.off",
        "quad/spot_control_mesh.obj",
        "tri/fertility.off",
        "large/amo.off",
    ] {
        let m = read_mesh(&shared(src)).unwrap();
        let stem = src.rsplit('/').next().unwrap().split('.').next().unwrap();
        for ext in ["gltf", "glb"] {
            let out = dir.path().join(format!("{stem}.{ext}"));
            write_mesh(&out, &m).unwrap();
            files.push(out);
        }
    }
    let output = Command::new("node")
        .arg(tool.join("validate.mjs"))
        .args(&files)
        .output()
        .expect("running node (needed for the glTF validator)");
    let stdout = String::from_utf8_lossy(&output.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("validator JSON");
    for f in &files {
        let r = &report[f.to_str().unwrap()];
        assert_eq!(r["errors"], 0, "{}: {r}", f.display());
        for m in r["messages"].as_array().unwrap() {
            println!(
                "{}: {} {} {}",
                f.display(),
                m["severity"],
                m["code"],
                m["message"]
            );
        }
    }
    assert!(
        output.status.success(),
        "validator exit status {:?}",
        output.status
    );
}
