//! Helpers shared by the `gltf_export_*` tests: shared-mesh paths and a
//! runner for the Khronos glTF-Validator (`tools/gltf-validate`, npm
//! `gltf-validator` pinned by its package-lock.json; `npm ci` runs first when
//! its `node_modules` is missing, which needs `node`, `npm` and the registry).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// `<manifest>/../../../shared/meshes/<rel>`.
pub fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel)
}

/// The repository root (`<manifest>/../..`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs the validator on `files` and asserts zero errors in each; returns
/// the validator's JSON report (file name → counts and messages).
pub fn assert_valid_gltf(files: &[PathBuf]) -> serde_json::Value {
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
    let output = Command::new("node")
        .arg(tool.join("validate.mjs"))
        .args(files)
        .output()
        .expect("running node (needed for the glTF validator)");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "validator output is not JSON ({e}): {stdout}{}",
            String::from_utf8_lossy(&output.stderr)
        )
    });
    for f in files {
        let r = &report[f.to_str().unwrap()];
        assert_eq!(r["errors"], 0, "{}: {r:#}", f.display());
        for m in r["messages"].as_array().into_iter().flatten() {
            eprintln!(
                "{}: {} {} {}",
                name(f),
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
    report
}

fn name(p: &Path) -> String {
    p.file_name().unwrap().to_string_lossy().into_owned()
}

/// The JSON chunk of a GLB file.
pub fn glb_json(bytes: &[u8]) -> serde_json::Value {
    assert_eq!(&bytes[..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}
