//! End-to-end tests of `pqm remesh` and `pqm levels` (the built binary):
//! reports, outputs that are valid quad meshes with the input's topology
//! (fertility keeps genus 4), glTF files (per level and MSFT_lod) that pass
//! the Khronos validator for every --normals/--quantize combination and
//! read back as quads, and clear errors with the documented exit codes.

use assert_cmd::Command;
use pqm_core::{io, IndexedMesh, Mesh};
use predicates::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command as Std;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixture(name: &str) -> PathBuf {
    repo().join("fixtures").join(name)
}

fn shared(rel: &str) -> PathBuf {
    repo().join("../shared/meshes").join(rel)
}

fn pqm() -> Command {
    Command::cargo_bin("pqm").expect("pqm binary")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn json_ok(args: &[&str]) -> Value {
    let out = pqm().arg("--json").args(args).output().unwrap();
    assert!(
        out.status.success(),
        "pqm {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout of pqm {args:?} is not one JSON value ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// Reads a mesh and checks every structural invariant of the half-edge mesh.
fn load_valid(path: &Path) -> IndexedMesh {
    let im = io::read_mesh(path).unwrap_or_else(|e| panic!("{e}"));
    Mesh::from_indexed(&im)
        .and_then(|m| m.validate_structure())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    im
}

/// Runs the Khronos validator (tools/gltf-validate) and requires 0 errors.
fn assert_valid_gltf(files: &[PathBuf]) {
    let tool = repo().join("tools/gltf-validate");
    if !tool.join("node_modules/gltf-validator").is_dir() {
        let ok = Std::new("npm")
            .args(["ci", "--no-audit", "--no-fund", "--prefix"])
            .arg(&tool)
            .status()
            .expect("running npm (needed to install tools/gltf-validate)")
            .success();
        assert!(ok, "npm ci --prefix tools/gltf-validate failed");
    }
    let out = Std::new("node")
        .arg(tool.join("validate.mjs"))
        .args(files)
        .output()
        .expect("running node (needed for the glTF validator)");
    let report: Value = serde_json::from_slice(&out.stdout).expect("validator JSON");
    for f in files {
        let r = &report[s(f)];
        assert_eq!(r["errors"], 0, "{}: {r:#}", f.display());
    }
    assert!(out.status.success(), "validator failed: {report:#}");
}

fn encode_spot(dir: &Path) -> PathBuf {
    let pqm_file = dir.join("spot.pqm");
    pqm()
        .args([
            "-q",
            "encode",
            s(&fixture("spot_quadrangulated.obj")),
            "-o",
            s(&pqm_file),
        ])
        .assert()
        .success();
    pqm_file
}

#[test]
fn remesh_reports_stages_and_writes_a_valid_quad_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("spot_remesh.glb");
    let input = fixture("spot_control_mesh.obj");
    let r = json_ok(&[
        "remesh",
        s(&input),
        "-o",
        s(&out),
        "--normals",
        "smooth",
        "--stats",
    ]);
    let m = load_valid(&out);
    assert!(m.is_quad_only());
    for stage in ["split", "coarse", "output"] {
        let st = &r["stages"][stage];
        assert!(st["faces"].as_u64().unwrap() > 0, "{stage}: {r:#}");
        let ideal = st["valence"]["ideal_fraction"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&ideal), "{stage}");
        let h = st["hausdorff"]["max"].as_f64().unwrap();
        assert!((0.0..0.05).contains(&h), "{stage}: hausdorff {h}");
    }
    // 180 faces (160 quads, 4 triangles, 16 pentagons) = 732 corners.
    assert_eq!(r["stages"]["split"]["faces"], 732);
    assert_eq!(
        r["stages"]["output"]["faces"].as_u64().unwrap(),
        m.face_count() as u64
    );
    assert_eq!(
        m.face_count() as u64,
        4 * r["stages"]["coarse"]["faces"].as_u64().unwrap(),
        "one subdivision level"
    );
    assert_eq!(r["stats"]["genus"], 0);
    assert_eq!(r["stats"]["quads"].as_u64().unwrap(), m.face_count() as u64);
    assert!(r["timing"]["total"].as_f64().unwrap() > 0.0);
    assert_valid_gltf(&[out]);

    // The table names the stages and the unit of the Hausdorff column.
    let out2 = dir.path().join("spot_remesh.obj");
    pqm()
        .args(["remesh", s(&input), "-o", s(&out2), "--levels", "0"])
        .assert()
        .success()
        .stdout(
            predicate::str::contains("split")
                .and(predicate::str::contains("output"))
                .and(predicate::str::contains("bounding-box diagonal")),
        );
    assert!(load_valid(&out2).is_quad_only());
}

#[test]
fn remesh_of_fertility_keeps_genus_four() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fertility_quads.obj");
    let r = json_ok(&[
        "remesh",
        s(&shared("tri/fertility.off")),
        "-o",
        s(&out),
        "--stats",
    ]);
    let m = load_valid(&out);
    assert!(m.is_quad_only());
    assert_eq!(r["stats"]["genus"], 4, "{r:#}");
    assert_eq!(r["stats"]["components"], 1);
    let before = &r["stages"]["split"];
    let after = &r["stages"]["output"];
    assert!(after["hausdorff"]["max"].as_f64().unwrap() < 0.01, "{r:#}");
    assert!(
        after["valence"]["ideal_fraction"].as_f64().unwrap()
            > before["valence"]["ideal_fraction"].as_f64().unwrap()
    );
}

#[test]
fn remesh_errors_are_one_line_with_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("spot_control_mesh.obj");
    let out = dir.path().join("x.obj");
    // Bad usage: exit 2.
    for bad in [
        vec!["remesh", s(&input), "-o", s(&out), "--ratio", "0"],
        vec!["remesh", s(&input), "-o", s(&out), "--levels", "9"],
        vec!["remesh", s(&input), "-o", "x.xyz"],
        vec!["remesh", s(&input), "-o", s(&out), "--sharp-angle", "200"],
    ] {
        pqm().args(&bad).assert().code(2);
    }
    // A missing input and a non-manifold input: exit 1, naming the file.
    let missing = dir.path().join("missing.obj");
    pqm()
        .args(["remesh", s(&missing), "-o", s(&out)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("missing.obj"));
    let fin = dir.path().join("fin.obj");
    std::fs::write(
        &fin,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
    )
    .unwrap();
    pqm()
        .args(["remesh", s(&fin), "-o", s(&out)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("fin.obj"));
    assert!(!out.exists(), "nothing written on failure");
}

#[test]
fn levels_writes_files_named_by_face_count_and_a_valid_lod() {
    let dir = tempfile::tempdir().unwrap();
    let pqm_file = encode_spot(dir.path());
    let mut files = Vec::new();
    for normals in ["none", "smooth", "flat"] {
        for quantize in [false, true] {
            let tag = format!("{normals}{}", if quantize { "_q" } else { "" });
            let out_dir = dir.path().join(&tag);
            let lod = dir.path().join(format!("{tag}_lod.glb"));
            let mut args = vec![
                "levels",
                s(&pqm_file),
                "--faces",
                "600,1500,100000",
                "-o",
                s(&out_dir),
                "--lod",
                s(&lod),
                "--normals",
                normals,
            ];
            if quantize {
                args.push("--quantize");
            }
            let r = json_ok(&args);
            let levels = r["levels"].as_array().unwrap();
            assert_eq!(levels.len(), 3, "{r:#}");
            let faces: Vec<usize> = levels
                .iter()
                .map(|l| l["faces"].as_u64().unwrap() as usize)
                .collect();
            assert!(
                faces.windows(2).all(|w| w[0] > w[1]),
                "finest first: {faces:?}"
            );
            assert_eq!(faces[0], 2928, "100000 picks the full mesh");
            assert!(faces[1] <= 1500, "{faces:?}");
            // 600 picks a level within budget, or the base mesh if none is.
            assert!(faces[2] <= 600 || levels[2]["level"] == 0, "{r:#}");
            for l in levels {
                let f = l["faces"].as_u64().unwrap();
                let path = PathBuf::from(l["file"].as_str().unwrap());
                assert_eq!(path.file_name().unwrap(), format!("spot_{f}.glb").as_str());
                let m = io::read_mesh(&path).unwrap();
                assert!(
                    m.is_quad_only(),
                    "{}: quads come back as quads",
                    path.display()
                );
                assert_eq!(m.face_count() as u64, f);
                files.push(path);
            }
            // Coverage: the documented rule over the levels' face counts.
            let cov: Vec<f64> = r["lod"]["coverage"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_f64().unwrap())
                .collect();
            assert_eq!(cov, io::lod_screen_coverage(&faces));
            let back = io::read_mesh(&lod).unwrap();
            assert_eq!(back.face_count(), faces.iter().sum::<usize>());
            assert!(back.is_quad_only());
            files.push(lod);
        }
    }
    assert_valid_gltf(&files);
}

#[test]
fn levels_gltf_format_lod_only_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let pqm_file = encode_spot(dir.path());
    // .gltf files per level.
    let out_dir = dir.path().join("gltf");
    let r = json_ok(&[
        "levels",
        s(&pqm_file),
        "--faces",
        "800",
        "-o",
        s(&out_dir),
        "--format",
        "gltf",
        "--stats",
    ]);
    let file = PathBuf::from(r["levels"][0]["file"].as_str().unwrap());
    assert_eq!(file.extension().unwrap(), "gltf");
    assert!(r["levels"][0]["stats"]["quads"].as_u64().unwrap() > 0);
    assert_valid_gltf(&[file]);
    // --lod alone writes no directory.
    let lod = dir.path().join("only.glb");
    let r = json_ok(&[
        "levels",
        s(&pqm_file),
        "--faces",
        "700,2000",
        "--lod",
        s(&lod),
    ]);
    assert!(r["levels"][0]["file"].is_null());
    assert!(lod.is_file());

    // Usage errors: exit 2.
    pqm()
        .args(["levels", s(&pqm_file), "--faces", "700"])
        .assert()
        .code(2);
    pqm()
        .args(["levels", s(&pqm_file), "-o", s(dir.path())])
        .assert()
        .code(2);
    pqm()
        .args(["levels", s(&pqm_file), "--faces", "700", "--lod", "x.gltf"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(".glb"));
    // A truncated file: exit 1 naming it, nothing written.
    let bytes = std::fs::read(&pqm_file).unwrap();
    let cut = dir.path().join("cut.pqm");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let lod2 = dir.path().join("cut_lod.glb");
    pqm()
        .args(["levels", s(&cut), "--faces", "700", "--lod", s(&lod2)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("cut.pqm"));
    assert!(!lod2.exists());
}
