//! End-to-end tests of the `pqm` binary: every command run as a user would,
//! on the bundled fixtures and on `../shared/meshes`.

use assert_cmd::Command;
use pqm_core::{io, IndexedMesh, Mesh};
use predicates::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel)
}

fn spot() -> PathBuf {
    fixtures().join("spot_quadrangulated.obj")
}

fn generated(name: &str) -> PathBuf {
    fixtures().join("generated").join(name)
}

fn pqm() -> Command {
    Command::cargo_bin("pqm").expect("pqm binary")
}

/// Runs `pqm --json ARGS`, expects success, parses stdout as one JSON value.
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

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `pqm --json encode` of the bundled cow into `out`, `flags` after the
/// output; its report.
fn encode_spot(out: &Path, flags: &[&str]) -> Value {
    let spot = spot();
    let mut args = vec!["encode", s(&spot), "-o", s(out)];
    args.extend_from_slice(flags);
    json_ok(&args)
}

/// `pqm encode` of the bundled cow into `out` with `flags` is a usage
/// error (exit code 2).
fn encode_spot_refused(out: &Path, flags: &[&str]) {
    let spot = spot();
    let mut args = vec!["encode", s(&spot), "-o", s(out)];
    args.extend_from_slice(flags);
    pqm().args(&args).assert().code(2);
}

/// Reads a mesh and checks every structural invariant of the half-edge mesh.
fn load_valid(path: &Path) -> (IndexedMesh, Mesh) {
    let im = io::read_mesh(path).unwrap_or_else(|e| panic!("{e}"));
    let m = Mesh::from_indexed(&im).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    m.validate_structure()
        .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    (im, m)
}

/// The faces of `m` as a sorted list, each rotated to start at its smallest
/// vertex (orientation kept).
fn face_set(m: &IndexedMesh) -> Vec<Vec<u32>> {
    let mut out: Vec<Vec<u32>> = m
        .faces()
        .map(|f| {
            let i = (0..f.len()).min_by_key(|&i| f[i]).unwrap();
            f[i..].iter().chain(&f[..i]).copied().collect()
        })
        .collect();
    out.sort();
    out
}

/// The faces of `m` named by their corners' positions (bit patterns), each
/// from its smallest corner, sorted: two meshes with the same faces under
/// different vertex numberings compare equal. (Positions may repeat, so
/// this compares lists, not an index map.)
fn faces_by_position(m: &IndexedMesh) -> Vec<Vec<[u64; 3]>> {
    let key = |v: u32| m.positions[v as usize].to_array().map(f64::to_bits);
    let mut out: Vec<Vec<[u64; 3]>> = m
        .faces()
        .map(|f| {
            let k: Vec<[u64; 3]> = f.iter().map(|&v| key(v)).collect();
            let i = (0..k.len()).min_by_key(|&i| k[i]).unwrap();
            k[i..].iter().chain(&k[..i]).copied().collect()
        })
        .collect();
    out.sort();
    out
}

/// Files in `dir` whose name ends in `.tmp` (left-over temporaries).
fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

// ---------------------------------------------------------------- usage

#[test]
fn no_arguments_prints_help_and_exits_2() {
    pqm()
        .assert()
        .code(2)
        .stderr(predicate::str::contains("Usage: pqm"))
        .stderr(predicate::str::contains("encode"));
}

#[test]
fn every_command_has_help_with_an_example() {
    for c in [
        "stats", "convert", "coarsen", "encode", "decode", "info", "demo",
    ] {
        pqm()
            .args([c, "--help"])
            .assert()
            .success()
            .stdout(predicate::str::contains("Example"))
            .stdout(predicate::str::contains(format!("pqm {c}")));
    }
    // a command's help opens with its own description (a doc comment
    // between it and its struct would hand that place to the flattened
    // coarsener options' doc)
    pqm()
        .args(["encode", "--help"])
        .assert()
        .success()
        .stdout(predicate::str::starts_with(
            "Encode meshes as progressive .pqm files",
        ));
}

#[test]
fn bad_usage_exits_2() {
    let d = TempDir::new().unwrap();
    let out = d.path().join("o.obj");
    let spot = spot();
    let spot = s(&spot);
    let cases: Vec<Vec<&str>> = vec![
        vec!["frobnicate"],
        vec!["stats"],
        vec!["coarsen", spot],
        vec!["coarsen", spot, "-o", s(&out), "--ratio", "1.5"],
        vec!["coarsen", spot, "-o", s(&out), "--smoothing", "sometimes"],
        vec!["encode", spot, "-o", "x.pqm", "--bits", "30"],
        vec!["encode", spot, spot, "-o", "x.pqm"],
        vec!["encode", spot],
        vec!["convert", spot, "out.xyz"],
        vec![
            "decode", "x.pqm", "-o", "y.glb", "--level", "1", "--faces", "3",
        ],
    ];
    for args in cases {
        pqm().args(&args).assert().code(2);
    }
    assert!(temp_files(d.path()).is_empty());
}

// ---------------------------------------------------------------- errors

#[test]
fn missing_file_gives_one_clear_line() {
    let out = pqm().args(["stats", "no/such/mesh.obj"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: no/such/mesh.obj: "), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn defective_mesh_names_file_face_and_vertex() {
    let d = TempDir::new().unwrap();
    let bad = d.path().join("bad.obj");
    std::fs::write(
        &bad,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 2 2 4\n",
    )
    .unwrap();
    // one line, nothing on stdout, no file: coarsen, and encode, which
    // takes batches but fails on one input as every other command does
    for (cmd, name) in [("coarsen", "out.obj"), ("encode", "out.pqm")] {
        let out_path = d.path().join(name);
        let out = pqm()
            .args([cmd, s(&bad), "-o", s(&out_path)])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{cmd}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{cmd}: {err}");
        assert!(
            err.contains("bad.obj: face 1 repeats vertex 1"),
            "{cmd}: {err}"
        );
        assert!(out.stdout.is_empty(), "{cmd}");
        assert!(!out_path.exists(), "{cmd}");
    }
    // a batch names each failure, then counts them
    let dir = d.path().join("batch");
    let out = pqm()
        .args(["encode", s(&bad), s(&spot()), "--out-dir", s(&dir)])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.obj: face 1 repeats vertex 1"), "{err}");
    assert!(err.contains("1 of 2 inputs failed"), "{err}");
    assert!(dir.join("spot_quadrangulated.pqm").exists());
    assert!(!dir.join("bad.pqm").exists());
}

#[test]
fn not_a_pqm_file_is_a_clear_error() {
    pqm()
        .args(["info", s(&spot())])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("spot_quadrangulated.obj"))
        .stderr(predicate::str::contains("not a .pqm file"));
}

#[test]
fn failed_writes_leave_no_file_behind() {
    let d = TempDir::new().unwrap();
    // a directory that does not exist
    let missing = d.path().join("nope").join("out.obj");
    pqm()
        .args(["convert", s(&generated("cube.obj")), s(&missing)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("does not exist"));
    assert!(!missing.exists());
    // the target is a directory: the temporary file is written, then the
    // rename fails and the temporary must be removed
    let blocker = d.path().join("out.obj");
    std::fs::create_dir(&blocker).unwrap();
    pqm()
        .args(["convert", s(&generated("cube.obj")), s(&blocker)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("out.obj"));
    assert!(blocker.is_dir());
    let pqm_out = d.path().join("x.pqm");
    std::fs::create_dir(&pqm_out).unwrap();
    pqm()
        .args(["encode", s(&generated("cube.obj")), "-o", s(&pqm_out)])
        .assert()
        .code(1);
    assert_eq!(temp_files(d.path()), Vec::<String>::new());
}

// ---------------------------------------------------------------- stats

#[test]
fn stats_json_has_the_documented_fields_and_topology() {
    for (file, genus, loops, comps) in [
        ("torus.obj", 1, 0, 1),
        ("grid.obj", 0, 1, 1),
        ("two_components.obj", 0, 0, 2),
        ("quad_sphere.obj", 0, 0, 1),
    ] {
        let v = json_ok(&["stats", s(&generated(file))]);
        for k in [
            "vertices",
            "faces",
            "quads",
            "triangles",
            "other_faces",
            "boundary_loops",
            "components",
            "genus",
        ] {
            assert!(v[k].is_number(), "{file}: {k} missing in {v}");
        }
        assert!(v["scaled_jacobian"]["median"].is_number());
        assert!(v["scaled_jacobian"]["worst"].is_number());
        assert!(v["valence"]["ideal_fraction"].is_number());
        assert!(v["valence"]["extraordinary"].is_number());
        assert!(v["valence"]["worst"].is_number());
        assert_eq!(v["genus"], genus, "{file}");
        assert_eq!(v["boundary_loops"], loops, "{file}");
        assert_eq!(v["components"], comps, "{file}");
        assert_eq!(v["quads"], v["faces"], "{file}");
    }
    // MANIFEST.md: spot_quadrangulated has V 2930, F 2928 (all quads), genus 0
    let v = json_ok(&["stats", s(&spot())]);
    assert_eq!(v["vertices"], 2930);
    assert_eq!(v["faces"], 2928);
    assert_eq!(v["quads"], 2928);
    assert_eq!(v["genus"], 0);
    // the text form is a table naming the figures
    pqm()
        .args(["stats", s(&spot())])
        .assert()
        .success()
        .stdout(predicate::str::contains("scaled jacobian"))
        .stdout(predicate::str::contains("valence"));
}

#[test]
fn stats_with_reference_reports_hausdorff() {
    let v = json_ok(&[
        "stats",
        s(&generated("quad_sphere.obj")),
        "--reference",
        s(&generated("quad_sphere.obj")),
    ]);
    // a mesh against itself is at distance 0
    let h = &v["hausdorff"];
    assert!(h["max"].as_f64().unwrap() < 1e-9, "{v}");
    assert!(h["mean"].as_f64().unwrap() < 1e-9, "{v}");
    // a coarsened sphere is not, but stays close (fractions of the diagonal)
    let d = TempDir::new().unwrap();
    let lo = d.path().join("lo.obj");
    json_ok(&[
        "coarsen",
        s(&generated("quad_sphere.obj")),
        "-o",
        s(&lo),
        "--ratio",
        "0.5",
    ]);
    let v = json_ok(&[
        "stats",
        s(&lo),
        "--reference",
        s(&generated("quad_sphere.obj")),
    ]);
    let (max, mean) = (
        v["hausdorff"]["max"].as_f64().unwrap(),
        v["hausdorff"]["mean"].as_f64().unwrap(),
    );
    assert!(max > 0.0 && max < 0.1 && mean <= max, "{v}");
}

// ---------------------------------------------------------------- convert

#[test]
fn convert_round_trips_through_every_format() {
    let d = TempDir::new().unwrap();
    let src = generated("two_components.obj");
    let orig = io::read_mesh(&src).unwrap();
    for ext in ["glb", "gltf", "ply", "off", "obj"] {
        let out = d.path().join(format!("m.{ext}"));
        let v = json_ok(&["convert", s(&src), s(&out)]);
        assert_eq!(v["faces"], orig.face_count());
        let (im, m) = load_valid(&out);
        assert_eq!(im.face_count(), orig.face_count(), "{ext}");
        assert_eq!(im.vertex_count(), orig.vertex_count(), "{ext}");
        assert!(im.is_quad_only(), "{ext}: quads must come back as quads");
        assert_eq!(m.components().1, 2);
    }
}

#[test]
fn convert_subdivide_and_repair_report_what_they_did() {
    let d = TempDir::new().unwrap();
    // spot's control cage: 160 quads, 4 triangles, 16 pentagons → one quad per corner
    let out = d.path().join("cage.obj");
    let v = json_ok(&[
        "convert",
        s(&fixtures().join("spot_control_mesh.obj")),
        s(&out),
        "--subdivide",
        "split",
        "--stats",
    ]);
    assert_eq!(v["faces"], 160 * 4 + 4 * 3 + 16 * 5);
    assert_eq!(v["stats"]["quads"], v["faces"]);
    assert_eq!(v["stats"]["genus"], 0);
    load_valid(&out);

    // a quad strip with a duplicated vertex (same position twice) and an unused one
    let dup = d.path().join("dup.obj");
    std::fs::write(
        &dup,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nv 1 0 0\nv 9 9 9\n\
         f 1 2 3 4\nf 7 5 6 3\n",
    )
    .unwrap();
    let fixed = d.path().join("fixed.obj");
    pqm()
        .args(["convert", s(&dup), s(&fixed)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("dup.obj"));
    pqm()
        .args(["convert", s(&dup), s(&fixed), "--repair"])
        .assert()
        .success()
        .stderr(predicate::str::contains("repaired"));
    let (im, _) = load_valid(&fixed);
    assert_eq!(im.vertex_count(), 6);
    let v = json_ok(&["convert", s(&dup), s(&fixed), "--repair"]);
    assert_eq!(v["repair"]["welded_vertices"], 1);
    // the welded copy and the unused vertex both become unreferenced
    assert_eq!(v["repair"]["dropped_unreferenced_vertices"], 2);
}

// ---------------------------------------------------------------- coarsen

#[test]
fn coarsen_reaches_the_target_and_keeps_a_valid_quad_mesh() {
    let d = TempDir::new().unwrap();
    let out = d.path().join("spot_lo.obj");
    let v = json_ok(&["coarsen", s(&spot()), "-o", s(&out), "--faces", "1500"]);
    let (im, m) = load_valid(&out);
    assert!(im.is_quad_only());
    assert_eq!(m.genus(), 0);
    assert_eq!(m.components().1, 1);
    assert_eq!(v["output_stats"]["faces"], im.face_count());
    assert_eq!(v["input_stats"]["faces"], 2928);
    assert_eq!(v["subdivided"], false);
    if v["stop"] == "target_reached" {
        assert!(im.face_count() <= 1500);
    } else {
        assert_eq!(v["stop"], "nothing_legal");
    }
    assert!(im.face_count() < 2928, "nothing was coarsened");
    let ops = &v["operators"];
    let steps = ops["qv_merges"].as_u64().unwrap() + ops["qe_merges"].as_u64().unwrap();
    assert!(steps > 0, "{v}");
    assert!(v["time_s"].as_f64().unwrap() >= 0.0);
}

/// Chord collapses and the end phase run on block-structured CAD input
/// (fandisk) and are reported, in JSON and in the text summary; an organic
/// mesh (spot) never gets them (the gate in `coarsen::chord`).
#[test]
fn coarsen_reports_chord_collapses_on_cad_input_only() {
    let d = TempDir::new().unwrap();
    let out = d.path().join("fandisk_250.obj");
    let fandisk = shared("quad/fandisk_quads.off");
    let v = json_ok(&["coarsen", s(&fandisk), "-o", s(&out), "--faces", "250"]);
    assert!(
        v["operators"]["chord_collapses"].as_u64().unwrap() > 0,
        "{v}"
    );
    assert!(
        v["operators"]["end_phase_steps"].as_u64().unwrap() > 0,
        "{v}"
    );
    let (im, _) = load_valid(&out);
    assert!(im.is_quad_only() && im.face_count() <= 250);
    let text = pqm()
        .args(["coarsen", s(&fandisk), "-o", s(&out), "--faces", "250"])
        .output()
        .unwrap();
    assert!(text.status.success());
    let summary =
        String::from_utf8_lossy(&text.stdout).into_owned() + &String::from_utf8_lossy(&text.stderr);
    assert!(summary.contains("chord collapses"), "{summary}");
    assert!(summary.contains("end phase"), "{summary}");
    let spot_out = d.path().join("spot_700.obj");
    let v = json_ok(&["coarsen", s(&spot()), "-o", s(&spot_out), "--faces", "700"]);
    assert_eq!(v["operators"]["chord_collapses"], 0, "{v}");
    assert_eq!(v["operators"]["end_phase_steps"], 0, "{v}");
}

#[test]
fn coarsen_makes_non_quad_input_quad_only_and_says_so() {
    let d = TempDir::new().unwrap();
    let cage = fixtures().join("spot_control_mesh.obj");
    let out = d.path().join("cage.obj");
    for (flags, says) in [
        (&[][..], "joined by 1 strip "),
        (
            &["--triangles", "split"][..],
            "split each n-gon into n quads",
        ),
    ] {
        pqm()
            .args(["coarsen", s(&cage), "-o", s(&out), "--ratio", "0.9"])
            .args(flags)
            .assert()
            .success()
            .stderr(predicate::str::contains(says));
        let (im, m) = load_valid(&out);
        assert!(im.is_quad_only());
        assert_eq!(m.genus(), 0);
    }
    // --no-subdivide refuses, naming the file and the face kinds
    let out2 = d.path().join("cage2.obj");
    pqm()
        .args(["coarsen", s(&cage), "-o", s(&out2), "--no-subdivide"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "spot_control_mesh.obj: not a quad mesh",
        ))
        .stderr(predicate::str::contains("4 triangles"));
    assert!(!out2.exists());
}

#[test]
fn coarsen_with_user_attributes_and_features() {
    let d = TempDir::new().unwrap();
    let sphere = generated("quad_sphere.obj");
    let im = io::read_mesh(&sphere).unwrap();
    // importance: high on one side
    let imp = d.path().join("imp.txt");
    let text: String = im
        .positions
        .iter()
        .map(|p| format!("{}\n", if p.x > 0.0 { 5.0 } else { 0.0 }))
        .collect();
    std::fs::write(&imp, format!("# importance\n{text}")).unwrap();
    // a feature polyline along the first face's edges
    let f0 = im.face(0);
    let feat = d.path().join("feat.txt");
    std::fs::write(&feat, format!("{} {} {}\n", f0[0], f0[1], f0[2])).unwrap();
    let out = d.path().join("s.obj");
    let v = json_ok(&[
        "coarsen",
        s(&sphere),
        "-o",
        s(&out),
        "--ratio",
        "0.5",
        "--importance",
        s(&imp),
        "--field",
        "z",
        "--features",
        s(&feat),
        "--sharp-angle",
        "180",
        "--smoothing",
        "local",
    ]);
    assert!(v["output_stats"]["faces"].as_u64().unwrap() < 384);
    load_valid(&out);
    // a sidecar with the wrong count names the file and both counts
    std::fs::write(&imp, "1\n2\n3\n").unwrap();
    pqm()
        .args([
            "coarsen",
            s(&sphere),
            "-o",
            s(&out),
            "--importance",
            s(&imp),
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("imp.txt"))
        .stderr(predicate::str::contains("3 values for 386 vertices"));
}

#[test]
fn user_attributes_follow_the_quad_split() {
    // The control cage has triangles and pentagons: attributes given per
    // input vertex must be carried onto the bridged or split mesh.
    let d = TempDir::new().unwrap();
    let cage = fixtures().join("spot_control_mesh.obj");
    let im = io::read_mesh(&cage).unwrap();
    let field = d.path().join("field.txt");
    let text: String = im
        .positions
        .iter()
        .map(|p| format!("{} {} 0\n", -p.y, p.x))
        .collect();
    std::fs::write(&field, text).unwrap();
    let imp = d.path().join("imp.txt");
    let text: String = (0..im.vertex_count())
        .map(|i| format!("{}\n", i % 7))
        .collect();
    std::fs::write(&imp, text).unwrap();
    let f0 = im.face(0);
    let feat = d.path().join("feat.txt");
    std::fs::write(&feat, format!("{} {}\n", f0[0], f0[1])).unwrap();
    let out = d.path().join("cage.obj");
    // Bridged (the default: new vertices at a few edge midpoints) or split.
    for (triangles, conversion) in [("pair", "bridged"), ("split", "split")] {
        let v = json_ok(&[
            "coarsen",
            s(&cage),
            "-o",
            s(&out),
            "--ratio",
            "0.8",
            "--field",
            s(&field),
            "--importance",
            s(&imp),
            "--features",
            s(&feat),
            "--triangles",
            triangles,
        ]);
        assert_eq!(v["conversion"], conversion);
        assert_eq!(v["subdivided"], triangles == "split");
        let (im_out, m) = load_valid(&out);
        assert!(im_out.is_quad_only());
        assert_eq!(m.genus(), 0);
    }
    // a polyline step that is not a mesh edge names the feature file
    let p0 = im.positions[f0[0] as usize];
    let far = (0..im.vertex_count())
        .max_by(|&a, &b| {
            let (da, db) = (im.positions[a].distance(p0), im.positions[b].distance(p0));
            da.total_cmp(&db)
        })
        .unwrap();
    std::fs::write(&feat, format!("{} {far}\n", f0[0])).unwrap();
    pqm()
        .args(["coarsen", s(&cage), "-o", s(&out), "--features", s(&feat)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("feat.txt"))
        .stderr(predicate::str::contains("not joined by a mesh edge"));
}

#[test]
fn quiet_prints_nothing_and_pipes_get_no_progress_bars() {
    let d = TempDir::new().unwrap();
    let out = d.path().join("t.obj");
    let o = pqm()
        .args(["-q", "coarsen", s(&generated("torus.obj")), "-o", s(&out)])
        .args(["--ratio", "0.5"])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(o.stdout.is_empty());
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = pqm()
        .args(["coarsen", s(&generated("torus.obj")), "-o", s(&out)])
        .args(["--ratio", "0.5"])
        .output()
        .unwrap();
    assert!(o.status.success());
    // no cursor movement or carriage returns from a bar on a pipe
    assert!(!o.stderr.contains(&b'\r') && !o.stderr.contains(&0x1b));
    assert!(!o.stdout.contains(&b'\r') && !o.stdout.contains(&0x1b));
}

// ---------------------------------------------------------------- encode / info / decode

#[test]
fn encode_info_decode_levels_prefixes_and_full_equality() {
    let d = TempDir::new().unwrap();
    let file = d.path().join("spot.pqm");
    let e = encode_spot(&file, &["--base-ratio", "0.4", "--chunk-bytes", "4096"]);
    let f = &e["files"][0];
    for k in [
        "input",
        "faces",
        "base_faces",
        "records",
        "bytes",
        "bits_per_vertex",
        "encode_time_s",
    ] {
        assert!(!f[k].is_null(), "{k} missing in {e}");
    }
    assert_eq!(f["faces"], 2928);
    assert_eq!(e["failed"].as_array().unwrap().len(), 0);
    let size = std::fs::metadata(&file).unwrap().len();
    assert_eq!(f["bytes"], size);

    let info = json_ok(&["info", s(&file)]);
    assert_eq!(info["final_faces"], 2928);
    assert_eq!(info["base_faces"], f["base_faces"]);
    assert_eq!(info["records"], f["records"]);
    assert_eq!(info["complete"], true);
    assert_eq!(info["quant_bits"], 14);
    let levels = info["levels"].as_array().unwrap();
    assert!(levels.len() >= 3, "want several chunks: {info}");
    let mut prev_bytes = 0;
    for row in levels {
        let b = row["bytes"].as_u64().unwrap();
        assert!(b > prev_bytes && b <= size);
        prev_bytes = b;
    }
    assert_eq!(levels.last().unwrap()["faces"], 2928);
    // positions + connectivity: the file up to the end of the records (the
    // finest level's bytes), without the vertex order that follows them
    let geometry = f["geometry_bits_per_vertex"].as_f64().unwrap();
    let records_end = levels.last().unwrap()["bytes"].as_u64().unwrap();
    let v = info["final_vertices"].as_u64().unwrap();
    assert!(
        (geometry - 8.0 * records_end as f64 / v as f64).abs() < 1e-9,
        "{geometry} {e}"
    );
    assert!(info["has_vertex_order"] == true && geometry < f["bits_per_vertex"].as_f64().unwrap());
    // the text form shows the table
    pqm()
        .args(["info", s(&file)])
        .assert()
        .success()
        .stdout(predicate::str::contains("level"))
        .stdout(predicate::str::contains("bytes"));
    // a truncated copy: percentages are of the whole file (never above
    // 100 %), and exactly the levels beyond the cut are marked
    let cut = levels[1]["bytes"].as_u64().unwrap() + 5;
    let part = d.path().join("part.pqm");
    std::fs::write(&part, &std::fs::read(&file).unwrap()[..cut as usize]).unwrap();
    let out = pqm().args(["info", s(&part)]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.contains('%') && !l.contains("file %"))
        .collect();
    assert_eq!(rows.len(), levels.len(), "{text}");
    for (row, level) in rows.iter().zip(levels) {
        let pct: f64 = row
            .split('%')
            .next()
            .unwrap()
            .split_whitespace()
            .last()
            .unwrap()
            .parse()
            .unwrap();
        assert!((0.0..=100.0).contains(&pct), "{row}");
        let beyond = level["bytes"].as_u64().unwrap() > cut;
        assert_eq!(row.contains("not received"), beyond, "{row}");
    }

    // decode at several levels: each is a valid genus-0 quad mesh with the
    // face count the chunk table announces
    let records = info["records"].as_u64().unwrap();
    for (i, k) in [0, records / 3, 2 * records / 3].iter().enumerate() {
        let out = d.path().join(format!("l{i}.glb"));
        let v = json_ok(&["decode", s(&file), "-o", s(&out), "--level", &k.to_string()]);
        assert_eq!(v["level"], *k);
        let (im, m) = load_valid(&out);
        assert_eq!(im.face_count() as u64, v["faces"].as_u64().unwrap());
        assert!(im.is_quad_only());
        assert_eq!(m.genus(), 0);
    }
    // glTF options: smooth normals and KHR_mesh_quantization; quads survive
    let out = d.path().join("q.glb");
    json_ok(&[
        "decode",
        s(&file),
        "-o",
        s(&out),
        "--level",
        "0",
        "--normals",
        "smooth",
        "--quantize",
    ]);
    let (im, _) = load_valid(&out);
    assert!(im.is_quad_only());
    assert_eq!(im.face_count() as u64, levels[0]["faces"].as_u64().unwrap());
    // --faces: the finest level with at most N faces
    let out = d.path().join("f.obj");
    let v = json_ok(&["decode", s(&file), "-o", s(&out), "--faces", "2000"]);
    assert!(v["faces"].as_u64().unwrap() <= 2000);
    load_valid(&out);
    // --error: the coarsest level within the bound
    let e_mid = levels[levels.len() / 2]["error"].as_f64().unwrap();
    let v = json_ok(&[
        "decode",
        s(&file),
        "-o",
        s(&out),
        "--error",
        &e_mid.to_string(),
    ]);
    assert!(v["error"].as_f64().unwrap() <= e_mid + 1e-12);
    load_valid(&out);

    // byte prefixes: at each chunk end the level after that chunk, in
    // between the deepest complete one
    for (i, row) in levels.iter().enumerate() {
        let b = row["bytes"].as_u64().unwrap();
        for prefix in [b, b + 17] {
            if prefix > size {
                continue;
            }
            let out = d.path().join(format!("p{i}_{prefix}.ply"));
            let v = json_ok(&[
                "decode",
                s(&file),
                "-o",
                s(&out),
                "--bytes",
                &prefix.to_string(),
            ]);
            assert_eq!(v["level"], row["level"], "prefix {prefix}");
            assert_eq!(v["faces"], row["faces"], "prefix {prefix}");
            let (im, _) = load_valid(&out);
            assert_eq!(im.face_count() as u64, row["faces"].as_u64().unwrap());
        }
    }
    // too few bytes for the base mesh: one clear line, nothing written
    let first = levels[0]["bytes"].as_u64().unwrap();
    let out = d.path().join("none.glb");
    pqm()
        .args([
            "decode",
            s(&file),
            "-o",
            s(&out),
            "--bytes",
            &(first - 1).to_string(),
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("do not hold the base mesh"));
    assert!(!out.exists());

    // the full level equals the quantized input: same faces (input vertex
    // order restored), positions within half a quantization step
    let out = d.path().join("full.obj");
    json_ok(&["decode", s(&file), "-o", s(&out), "--stats"]);
    let (full, _) = load_valid(&out);
    let input = io::read_mesh(&spot()).unwrap();
    assert_eq!(full.vertex_count(), input.vertex_count());
    // same faces (the slot order is the stream's, so compare as sets of
    // faces, each rotated to start at its smallest vertex)
    assert!(
        face_set(&full) == face_set(&input),
        "the full level's faces differ from the input's"
    );
    let step: Vec<f64> = info["quant_step"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (a, b) in full.positions.iter().zip(&input.positions) {
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 0.5 * step[k] * (1.0 + 1e-9) + 1e-12,
                "{a} vs {b}"
            );
        }
    }
    // a truncated file without --bytes is refused with a hint
    let cut = d.path().join("cut.pqm");
    let bytes = std::fs::read(&file).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    pqm()
        .args(["decode", s(&cut), "-o", s(&out)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("truncated"));
}

#[test]
fn batch_encode_reports_the_broken_input_and_finishes_the_others() {
    let d = TempDir::new().unwrap();
    let broken = d.path().join("broken.obj");
    std::fs::write(&broken, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let out_dir = d.path().join("out");
    let inputs = [
        generated("torus.obj"),
        broken.clone(),
        generated("grid.obj"),
        shared("quad/fandisk_quads.off"),
    ];
    let mut cmd = pqm();
    cmd.arg("--json").arg("encode");
    for i in &inputs {
        cmd.arg(i);
    }
    let o = cmd.arg("--out-dir").arg(&out_dir).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("broken.obj"), "{err}");
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["files"].as_array().unwrap().len(), 3);
    assert_eq!(v["failed"].as_array().unwrap().len(), 1);
    assert!(v["failed"][0]["input"]
        .as_str()
        .unwrap()
        .ends_with("broken.obj"));
    for name in ["torus.pqm", "grid.pqm", "fandisk_quads.pqm"] {
        let p = out_dir.join(name);
        assert!(p.is_file(), "{name} missing");
        let info = json_ok(&["info", s(&p)]);
        assert_eq!(info["complete"], true);
    }
    assert!(!out_dir.join("broken.pqm").exists());
    assert!(temp_files(&out_dir).is_empty());
    // the grid's full level keeps its boundary loop
    let g = d.path().join("grid.obj");
    json_ok(&["decode", s(&out_dir.join("grid.pqm")), "-o", s(&g)]);
    let (_, m) = load_valid(&g);
    assert_eq!(m.boundary_loops().len(), 1);
}

#[test]
fn encode_triangle_mesh_goes_through_the_split() {
    let d = TempDir::new().unwrap();
    // fertility: 12k triangles, genus 4 (MANIFEST.md)
    let file = d.path().join("fertility.pqm");
    let o = pqm()
        .args([
            "--json",
            "encode",
            s(&shared("tri/fertility.off")),
            "-o",
            s(&file),
        ])
        .args([
            "--base-ratio",
            "0.5",
            "--bits",
            "12",
            "--triangles",
            "split",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("split each n-gon"));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["files"][0]["subdivided"], true);
    let out = d.path().join("base.glb");
    json_ok(&["decode", s(&file), "-o", s(&out), "--level", "0"]);
    let (im, m) = load_valid(&out);
    assert!(im.is_quad_only());
    assert_eq!(m.genus(), 4);
}

// ---------------------------------------------------------------- demo, fixtures

#[test]
fn demo_writes_three_glb_levels() {
    let d = TempDir::new().unwrap();
    let dir = d.path().join("demo");
    let v = json_ok(&["demo", "--out-dir", s(&dir)]);
    assert!(dir.join("spot.pqm").is_file());
    let levels = v["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 3);
    let mut faces = Vec::new();
    for l in levels {
        let p = PathBuf::from(l["file"].as_str().unwrap());
        let (im, _) = load_valid(&p);
        assert!(im.is_quad_only());
        faces.push(im.face_count());
    }
    assert!(faces[0] < faces[1] && faces[1] < faces[2], "{faces:?}");
    assert_eq!(faces[2], 2928);
    // the demo's file is what `pqm encode` writes by default
    let plain = d.path().join("plain.pqm");
    encode_spot(&plain, &[]);
    assert!(std::fs::read(&plain).unwrap() == std::fs::read(dir.join("spot.pqm")).unwrap());
    // the text form says where the files are
    pqm()
        .args(["demo", "--out-dir", s(&dir)])
        .assert()
        .success()
        .stdout(predicate::str::contains("spot_base.glb"))
        .stdout(predicate::str::contains("Files are in"));
}

#[test]
fn checked_in_procedural_fixtures_are_what_the_command_generates() {
    let d = TempDir::new().unwrap();
    json_ok(&["fixtures", "--out-dir", s(d.path())]);
    for name in [
        "cube.obj",
        "quad_sphere.obj",
        "torus.obj",
        "grid.obj",
        "two_components.obj",
    ] {
        let fresh = std::fs::read(d.path().join(name)).unwrap();
        let checked_in = std::fs::read(generated(name)).unwrap();
        assert!(
            fresh == checked_in,
            "fixtures/generated/{name} is stale: run `cargo run -p pqm-cli -- fixtures`"
        );
        load_valid(&generated(name));
    }
}

/// `--vertex-order-deltas` writes the VORD section (3.0's) instead of
/// the VNBR section (3.1's), both in a 4.0 file; both decode to the same
/// full level, in the input's order, and VNBR is the smaller file.
#[test]
fn vertex_order_deltas_writes_vord_with_the_same_full_level() {
    let d = TempDir::new().unwrap();
    let (nbr, deltas) = (d.path().join("a.pqm"), d.path().join("b.pqm"));
    let a = encode_spot(&nbr, &["--grid", "box"]);
    let b = encode_spot(&deltas, &["--vertex-order-deltas", "--grid", "box"]);
    let (ba, bb) = (
        a["files"][0]["bytes"].as_u64().unwrap(),
        b["files"][0]["bytes"].as_u64().unwrap(),
    );
    assert!(ba < bb, "VNBR {ba} bytes, VORD {bb}");
    for file in [&nbr, &deltas] {
        let info = json_ok(&["info", s(file)]);
        assert_eq!(info["version"], "4.0");
        assert_eq!(info["has_vertex_order"], true);
    }
    let (oa, ob) = (d.path().join("a.obj"), d.path().join("b.obj"));
    json_ok(&["decode", s(&nbr), "-o", s(&oa)]);
    json_ok(&["decode", s(&deltas), "-o", s(&ob)]);
    assert_eq!(std::fs::read(&oa).unwrap(), std::fs::read(&ob).unwrap());
    // with --no-vertex-order the flag is a usage error (nothing to write)
    encode_spot_refused(&nbr, &["--no-vertex-order", "--vertex-order-deltas"]);
}

/// `--zstd-blocks`: `auto` (the default) is smaller than `single` on spot
/// and, counting each block past a section's first at
/// `BLOCK_PENALTY_BYTES` (what `auto` minimizes), no larger than
/// `per-part`; every mode decodes to the same full level, and a bad value
/// is a usage error.
#[test]
fn zstd_blocks_modes_decode_alike_and_auto_beats_one_block() {
    let d = TempDir::new().unwrap();
    let mut sizes = Vec::new();
    let mut objs = Vec::new();
    for mode in ["auto", "single", "per-part"] {
        let (pqm_file, obj) = (
            d.path().join(format!("{mode}.pqm")),
            d.path().join(format!("{mode}.obj")),
        );
        let r = encode_spot(&pqm_file, &["--zstd-blocks", mode]);
        sizes.push(r["files"][0]["bytes"].as_u64().unwrap());
        json_ok(&["decode", s(&pqm_file), "-o", s(&obj)]);
        objs.push(std::fs::read(&obj).unwrap());
    }
    assert!(
        sizes[0] < sizes[1],
        "auto {} bytes, single {}",
        sizes[0],
        sizes[1]
    );
    // per section auto picks the smallest bytes + penalty × extra blocks,
    // per-part's layout among the candidates (3 extra blocks in a chunk, 1
    // in the base): auto may be larger by at most per-part's penalties
    let chunks = json_ok(&["info", s(&d.path().join("per-part.pqm"))])["chunks"]
        .as_u64()
        .unwrap();
    let penalties = pqm_format::BLOCK_PENALTY_BYTES as u64 * (3 * chunks + 1);
    assert!(
        sizes[0] <= sizes[2] + penalties,
        "auto {} bytes, per-part {} (+ {penalties} of block penalties)",
        sizes[0],
        sizes[2]
    );
    assert!(objs[0] == objs[1] && objs[0] == objs[2]);
    encode_spot_refused(&d.path().join("x.pqm"), &["--zstd-blocks", "many"]);
}

#[test]
fn encode_without_vertex_order_is_smaller_and_the_same_mesh_up_to_renumbering() {
    let d = TempDir::new().unwrap();
    let (with, without) = (d.path().join("a.pqm"), d.path().join("b.pqm"));
    let a = encode_spot(&with, &[]);
    let b = encode_spot(&without, &["--no-vertex-order"]);
    let (ba, bb) = (
        a["files"][0]["bytes"].as_u64().unwrap(),
        b["files"][0]["bytes"].as_u64().unwrap(),
    );
    assert!(bb < ba, "no smaller without the order: {bb} vs {ba}");
    assert_eq!(json_ok(&["info", s(&with)])["has_vertex_order"], true);
    assert_eq!(json_ok(&["info", s(&without)])["has_vertex_order"], false);
    // the full levels are the same mesh: map each vertex to its position
    // and compare the faces as position tuples
    let full = |file: &Path, name: &str| {
        let out = d.path().join(name);
        json_ok(&["decode", s(file), "-o", s(&out)]);
        let im = io::read_mesh(&out).unwrap();
        (im.vertex_count(), faces_by_position(&im))
    };
    let (na, fa) = full(&with, "a.obj");
    let (nb, fb) = full(&without, "b.obj");
    assert_eq!(na, nb);
    assert!(
        fa == fb,
        "the two full levels differ beyond vertex numbering"
    );
}

#[test]
fn smoothing_with_subset_placement_is_a_usage_error() {
    let d = TempDir::new().unwrap();
    let out = d.path().join("x.pqm");
    let mesh_out = d.path().join("x.obj");
    for args in [
        vec!["encode", s(&spot()), "-o", s(&out), "--smoothing", "global"],
        vec![
            "coarsen",
            s(&spot()),
            "-o",
            s(&mesh_out),
            "--placement",
            "subset",
            "--smoothing",
            "local",
        ],
    ] {
        pqm()
            .args(&args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains("--placement subset never does"));
    }
    assert!(
        !out.exists() && !mesh_out.exists(),
        "nothing written on a usage error"
    );
    // the same smoothing with the paper's placement is fine
    pqm()
        .args([
            "-q",
            "encode",
            s(&spot()),
            "-o",
            s(&out),
            "--placement",
            "qem",
            "--smoothing",
            "global",
        ])
        .assert()
        .success();
    assert!(out.exists());
}

/// `--round-fraction` (rounds of independent steps) and `--reorder-window`
/// (records reordered in windows of steps) write files whose full level
/// is the input, like any; the default is `--round-fraction 0.005
/// --reorder-window 0.05` byte for byte (smaller than either off), and
/// `--no-rounds` / `--no-reorder-window` write other files.
#[test]
fn encode_in_rounds_and_windows_decodes_to_the_input_and_both_are_the_default() {
    let d = TempDir::new().unwrap();
    let p = |name: &str| d.path().join(name);
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    encode_spot(&p("plain.pqm"), &[]);
    encode_spot(&p("off.pqm"), &["--no-rounds"]);
    encode_spot(&p("no_window.pqm"), &["--no-reorder-window"]);
    encode_spot(
        &p("default.pqm"),
        &["--round-fraction", "0.005", "--reorder-window", "0.05"],
    );
    let e = encode_spot(&p("rounds.pqm"), &["--round-fraction", "0.05"]);
    assert_eq!(bytes(&p("plain.pqm")), bytes(&p("default.pqm")));
    for other in ["off.pqm", "no_window.pqm", "rounds.pqm"] {
        assert_ne!(bytes(&p("plain.pqm")), bytes(&p(other)), "{other}");
    }
    for other in ["off.pqm", "no_window.pqm"] {
        assert!(
            bytes(&p("plain.pqm")).len() < bytes(&p(other)).len(),
            "{other}"
        );
    }
    assert_eq!(e["files"][0]["faces"], 2928);
    let want = io::read_mesh(&spot()).unwrap();
    for file in ["rounds.pqm", "plain.pqm"] {
        let full = d.path().join("full.obj");
        json_ok(&["decode", s(&p(file)), "-o", s(&full)]);
        let (got, _) = load_valid(&full);
        assert_eq!(got.vertex_count(), want.vertex_count());
        // the same faces (each from its smallest vertex: the corner a face
        // starts at is not kept) over the input's vertex ids
        assert_eq!(face_set(&got), face_set(&want), "{file}");
    }
    encode_spot_refused(
        Path::new("x.pqm"),
        &["--round-fraction", "0.1", "--no-rounds"],
    );
    encode_spot_refused(
        Path::new("x.pqm"),
        &["--reorder-window", "0.1", "--no-reorder-window"],
    );
}

/// `--grid`: the default (`cube`) gives every axis one step and writes a
/// 3.2 file with the exact bounds in its header, smaller than `box` (the
/// pre-3.2 grid, one step per axis); both decode to the same quads (up to
/// where each starts), within half a cube step of each other, inside the
/// stored bounds.
#[test]
fn grid_cube_is_the_default_and_stores_the_bounds() {
    let d = TempDir::new().unwrap();
    let (default, cube, boxed) = (
        d.path().join("default.pqm"),
        d.path().join("cube.pqm"),
        d.path().join("box.pqm"),
    );
    encode_spot(&default, &[]);
    let c = encode_spot(&cube, &["--grid", "cube"]);
    let b = encode_spot(&boxed, &["--grid", "box"]);
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    assert_eq!(bytes(&default), bytes(&cube));
    let (bc, bb) = (
        c["files"][0]["bytes"].as_u64().unwrap(),
        b["files"][0]["bytes"].as_u64().unwrap(),
    );
    assert!(bc < bb, "cube {bc} bytes, box {bb}");
    let (ic, ib) = (json_ok(&["info", s(&cube)]), json_ok(&["info", s(&boxed)]));
    assert_eq!(ic["version"], "4.0");
    // the coarsener numbers its base in the walk's order: 4.0's traversal
    // layout (spec §6.1)
    assert_eq!(ic["base_layout"], "traversal");
    assert_eq!(ic["bounds_stored"], true);
    assert_eq!(ib["bounds_stored"], false);
    assert_eq!(ib["bounds_min"], ib["bbox_min"]);
    let v3 = |v: &Value| [0, 1, 2].map(|k| v[k].as_f64().unwrap());
    let step = v3(&ic["quant_step"]);
    assert!(
        step.iter().all(|&t| (t - step[0]).abs() <= 1e-12 * step[0]),
        "{step:?}"
    );
    // the box grid's bounds are the cube file's bounds, up to rounding
    let (lo, hi) = (v3(&ic["bounds_min"]), v3(&ic["bounds_max"]));
    for k in 0..3 {
        assert!(
            (lo[k] - v3(&ib["bounds_min"])[k]).abs() <= step[0],
            "axis {k}"
        );
        assert!(
            (hi[k] - v3(&ib["bounds_max"])[k]).abs() <= step[0],
            "axis {k}"
        );
        assert!(v3(&ic["bbox_min"])[k] <= lo[k] && hi[k] <= v3(&ic["bbox_max"])[k]);
    }
    let (oc, ob) = (d.path().join("c.obj"), d.path().join("b.obj"));
    json_ok(&["decode", s(&cube), "-o", s(&oc)]);
    json_ok(&["decode", s(&boxed), "-o", s(&ob)]);
    let ((mc, _), (mb, _)) = (load_valid(&oc), load_valid(&ob));
    // The same quads, each maybe starting at another corner: where a quad
    // a record builds starts (`--corner-order canonical`) follows the
    // record's encoding, which may pick another anchor where a chunk
    // starts elsewhere (chunks close by bytes, and the grids' residuals
    // differ).
    let from_smallest = |f: &[u32]| {
        let r = (0..f.len()).min_by_key(|&k| f[k]).unwrap();
        (0..f.len())
            .map(|k| f[(r + k) % f.len()])
            .collect::<Vec<u32>>()
    };
    assert_eq!(mc.face_count(), mb.face_count());
    for (f, (a, b)) in mc.faces().zip(mb.faces()).enumerate() {
        assert_eq!(from_smallest(a), from_smallest(b), "face {f}");
    }
    for (p, q) in mc.positions.iter().zip(&mb.positions) {
        assert!((*p - *q).abs().max_element() <= step[0], "{p} vs {q}");
        for k in 0..3 {
            // f32 OBJ output: a little slack on the bounds
            let slack = 1e-6 * (hi[k] - lo[k]).abs().max(1.0);
            assert!(
                lo[k] - slack <= p[k] && p[k] <= hi[k] + slack,
                "{p} outside the bounds"
            );
        }
    }
    encode_spot_refused(Path::new("x.pqm"), &["--grid", "sphere"]);
}

/// `--corner-order`: the default (`canonical`) starts every quad a record
/// builds where the decoder builds it and writes the smallest file;
/// `diagonal` lets quads start at their opposite corner, smaller than
/// `input`; all three decode to the input's quads (each face the same
/// corners in the same cyclic order), `diagonal` with the same diagonals
/// (the same triangles), and `input` keeps every quad's first corner.
#[test]
fn corner_order_canonical_is_the_default_and_keeps_the_quads() {
    let d = TempDir::new().unwrap();
    let (default, canonical, diagonal, input) = (
        d.path().join("default.pqm"),
        d.path().join("canonical.pqm"),
        d.path().join("diagonal.pqm"),
        d.path().join("input.pqm"),
    );
    let reports = [
        encode_spot(&default, &[]),
        encode_spot(&canonical, &["--corner-order", "canonical"]),
        encode_spot(&diagonal, &["--corner-order", "diagonal"]),
        encode_spot(&input, &["--corner-order", "input"]),
    ];
    let orders = reports
        .each_ref()
        .map(|r| r["files"][0]["corner_order"].as_str().unwrap());
    assert_eq!(orders, ["canonical", "canonical", "diagonal", "input"]);
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    assert_eq!(bytes(&default), bytes(&canonical));
    let sizes = [&canonical, &diagonal, &input].map(|p| bytes(p).len());
    assert!(
        sizes[0] < sizes[1] && sizes[1] < sizes[2],
        "canonical, diagonal, input: {sizes:?} bytes"
    );
    let want = io::read_mesh(&spot()).unwrap();
    // Each face from the smallest of the starts `turns` allows.
    let started = |m: &IndexedMesh, turns: &[usize]| {
        let mut out: Vec<Vec<u32>> = m
            .faces()
            .map(|f| {
                turns
                    .iter()
                    .map(|&t| f[t..].iter().chain(&f[..t]).copied().collect::<Vec<u32>>())
                    .min()
                    .unwrap()
            })
            .collect();
        out.sort();
        out
    };
    let (full_c, full_d, full_i) = (
        d.path().join("c.obj"),
        d.path().join("d.obj"),
        d.path().join("i.obj"),
    );
    json_ok(&["decode", s(&canonical), "-o", s(&full_c)]);
    json_ok(&["decode", s(&diagonal), "-o", s(&full_d)]);
    json_ok(&["decode", s(&input), "-o", s(&full_i)]);
    let (got_c, _) = load_valid(&full_c);
    let (got_d, _) = load_valid(&full_d);
    let (got_i, _) = load_valid(&full_i);
    assert_eq!(
        started(&got_c, &[0, 1, 2, 3]),
        started(&want, &[0, 1, 2, 3])
    );
    assert_ne!(
        started(&got_c, &[0, 2]),
        started(&want, &[0, 2]),
        "every quad keeps its diagonal"
    );
    assert_eq!(started(&got_d, &[0, 2]), started(&want, &[0, 2]));
    assert_ne!(
        started(&got_d, &[0]),
        started(&want, &[0]),
        "no quad starts elsewhere"
    );
    assert_eq!(started(&got_i, &[0]), started(&want, &[0]));
    encode_spot_refused(Path::new("x.pqm"), &["--corner-order", "first"]);
}

#[test]
fn chunk_growth_makes_fewer_chunks_with_the_same_final_mesh() {
    let d = TempDir::new().unwrap();
    let (flat, grown) = (d.path().join("flat.pqm"), d.path().join("grown.pqm"));
    let base = ["--chunk-bytes", "256", "--corner-order", "input"];
    let with = |g: &'static str| {
        let mut a = base.to_vec();
        a.extend(["--chunk-growth", g]);
        a
    };
    let f = &encode_spot(&flat, &with("0"))["files"][0];
    let g = &encode_spot(&grown, &with("0.5"))["files"][0];
    assert_eq!(
        (f["chunk_growth"].as_f64(), g["chunk_growth"].as_f64()),
        (Some(0.0), Some(0.5))
    );
    let (cf, cg) = (f["chunks"].as_u64().unwrap(), g["chunks"].as_u64().unwrap());
    assert!(cg * 2 < cf, "{cg} chunks grown vs {cf} flat");
    // The same records, so the same mesh at the finest level.
    let out = |p: &Path, o: &str| {
        let o = d.path().join(o);
        json_ok(&["decode", s(p), "-o", s(&o)]);
        std::fs::read_to_string(o).unwrap()
    };
    assert_eq!(out(&flat, "flat.obj"), out(&grown, "grown.obj"));
    for bad in ["-0.1", "17", "x"] {
        encode_spot_refused(&d.path().join("bad.pqm"), &["--chunk-growth", bad]);
    }
    assert!(!d.path().join("bad.pqm").exists());
}

#[test]
fn a_split_input_keeps_its_own_vertex_indices_and_gives_out_the_rest_anew() {
    // spot's control cage has triangles and pentagons: split into quads
    // first, its 194 vertices then the split's edge and face points.
    let d = TempDir::new().unwrap();
    let cage = fixtures().join("spot_control_mesh.obj");
    let n_in = io::read_mesh(&cage).unwrap().vertex_count();
    let (free, kept) = (d.path().join("free.pqm"), d.path().join("kept.pqm"));
    let enc = |out: &Path, flags: &[&str]| {
        let mut a = vec!["encode", s(&cage), "-o", s(out)];
        a.extend_from_slice(flags);
        let f = json_ok(&a)["files"][0].clone();
        (
            f["bytes"].as_u64().unwrap(),
            f["vertex_order_kept"].as_u64(),
        )
    };
    let ((bf, kf), (bk, kk)) = (enc(&free, &[]), enc(&kept, &["--keep-split-order"]));
    assert_eq!((kf, kk), (Some(n_in as u64), None));
    assert!(bf < bk, "free tail {bf} bytes, kept order {bk}");
    let full = |p: &Path, o: &str| {
        let o = d.path().join(o);
        json_ok(&["decode", s(p), "-o", s(&o)]);
        io::read_mesh(&o).unwrap()
    };
    let (a, b) = (full(&free, "free.obj"), full(&kept, "kept.obj"));
    assert_eq!(a.vertex_count(), b.vertex_count());
    assert!(a.vertex_count() > n_in);
    // The input's own vertices where the input has them.
    assert_eq!(a.positions[..n_in], b.positions[..n_in]);
    // The same mesh: the same faces, named by their corners' positions.
    assert_eq!(faces_by_position(&a), faces_by_position(&b));
    // A quad input is not split: the flag changes nothing.
    let (q1, q2) = (d.path().join("q1.pqm"), d.path().join("q2.pqm"));
    assert!(encode_spot(&q1, &[])["files"][0]["vertex_order_kept"].is_null());
    encode_spot(&q2, &["--keep-split-order"]);
    assert_eq!(std::fs::read(&q1).unwrap(), std::fs::read(&q2).unwrap());
}

/// A closed triangle mesh made in code: a bumpy torus's quads, each split
/// along one of its diagonals, so a perfect pairing exists but greedy
/// pairing by shape need not find it.
fn triangle_torus() -> IndexedMesh {
    use pqm_core::shapes;
    shapes::triangulated(&shapes::noisy(&shapes::torus(24, 12, 2.0, 0.7), 0.02, 7), 7)
}

/// The triangles of a mesh as sorted rotations of their vertex ids.
fn triangle_ids(tris: impl Iterator<Item = [u32; 3]>) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = tris
        .map(|t| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap();
            [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn paired_triangles_make_the_input_the_finest_level() {
    let d = TempDir::new().unwrap();
    let input = triangle_torus();
    let obj = d.path().join("torus_tris.obj");
    io::write_mesh(&obj, &input).unwrap();
    let (paired, split) = (d.path().join("paired.pqm"), d.path().join("split.pqm"));
    // Pairing is the default.
    let out = pqm()
        .args(["--json", "encode", s(&obj), "-o", s(&paired)])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("joined the triangles in"), "{stderr}");
    let p: Value = serde_json::from_slice(&out.stdout).unwrap();
    let p = &p["files"][0];
    let sp = json_ok(&["encode", s(&obj), "-o", s(&split), "--triangles", "split"]);
    let sp = &sp["files"][0];
    assert_eq!(p["conversion"], "paired");
    assert_eq!(sp["conversion"], "split");
    assert_eq!(p["subdivided"], false);
    // No new vertex; half as many faces as triangles.
    assert_eq!(p["vertices"].as_u64(), Some(input.vertex_count() as u64));
    assert_eq!(p["faces"].as_u64(), Some(input.face_count() as u64 / 2));
    // The split has about six times the vertices: the paired file is
    // several times smaller.
    let (bp, bs) = (p["bytes"].as_u64().unwrap(), sp["bytes"].as_u64().unwrap());
    assert!(3 * bp < bs, "paired {bp} bytes, split {bs}");
    // The finest level: the input's vertices at their indices (on the
    // grid), and each quad two input triangles across one diagonal.
    let fine = d.path().join("fine.obj");
    json_ok(&["decode", s(&paired), "-o", s(&fine)]);
    let fine = io::read_mesh(&fine).unwrap();
    assert_eq!(fine.vertex_count(), input.vertex_count());
    let step = input.bbox_diagonal() / (1 << 14) as f64;
    for (a, b) in fine.positions.iter().zip(&input.positions) {
        assert!((*a - *b).length() <= step, "{a} vs {b}");
    }
    let want = triangle_ids(input.faces().map(|f| [f[0], f[1], f[2]]));
    let mut got = Vec::new();
    for q in fine.faces() {
        assert_eq!(q.len(), 4);
        // `--corner-order auto` kept every quad's diagonal: split along
        // v0–v2 (what the decoders draw), each quad is its two triangles.
        let one = triangle_ids([[q[0], q[1], q[2]], [q[2], q[3], q[0]]].into_iter());
        assert!(
            one.iter().all(|x| want.binary_search(x).is_ok()),
            "quad {q:?} is not two input triangles across v0-v2"
        );
        got.extend(one);
    }
    got.sort_unstable();
    assert_eq!(got, want);
    assert_eq!(p["corner_order"], "diagonal");
    assert_eq!(p["finest_diagonals"], true);
    assert_eq!(p["dropped"], serde_json::json!([]));
    assert_eq!(sp["corner_order"], "canonical");
    assert_eq!(sp["finest_diagonals"], false);
    // The file says so (flag bit 3), and the finest level's glTF export
    // is exactly the input's triangles, as `--quad-split first` gives.
    let info = json_ok(&["info", s(&paired)]);
    assert_eq!(info["finest_diagonals"], true, "{info}");
    assert_eq!(json_ok(&["info", s(&split)])["finest_diagonals"], false);
    let glb = d.path().join("fine.glb");
    json_ok(&["decode", s(&paired), "-o", s(&glb)]);
    assert_eq!(
        triangle_ids(glb_triangles(&glb).remove(0).into_iter()),
        want
    );
    // `--triangulate` gives the input's triangles back: a triangle mesh's
    // round trip through pqm, positions on the grid.
    let tris = d.path().join("tris.obj");
    let r = json_ok(&[
        "decode",
        s(&paired),
        "-o",
        s(&tris),
        "--triangulate",
        "--stats",
    ]);
    assert_eq!(r["faces"].as_u64(), Some(input.face_count() as u64));
    let tris = io::read_mesh(&tris).unwrap();
    assert_eq!(tris.vertex_count(), input.vertex_count());
    assert_eq!(triangle_ids(tris.faces().map(|f| [f[0], f[1], f[2]])), want);
    // One GLB of two levels: the finest split along its meant diagonals,
    // the coarser along its shorter ones, as their own files are.
    let faces = p["faces"].as_u64().unwrap();
    let budgets = format!("{},{}", faces / 4, faces);
    let (lod, dir) = (d.path().join("lod.glb"), d.path().join("levels"));
    json_ok(&["levels", s(&paired), "--faces", &budgets, "--lod", s(&lod)]);
    json_ok(&["levels", s(&paired), "--faces", &budgets, "-o", s(&dir)]);
    let lod = glb_triangles(&lod);
    assert_eq!(lod.len(), 2);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    // finest first, as in the LOD file
    files.sort_by_key(|f| std::cmp::Reverse(std::fs::metadata(f).unwrap().len()));
    for (level, file) in lod.into_iter().zip(&files) {
        let own = glb_triangles(file).remove(0);
        assert_eq!(
            triangle_ids(level.into_iter()),
            triangle_ids(own.into_iter())
        );
    }
    // `--quad-split shorter` takes the shorter diagonal of every quad.
    let shorter = d.path().join("shorter.glb");
    json_ok(&[
        "decode",
        s(&paired),
        "-o",
        s(&shorter),
        "--quad-split",
        "shorter",
    ]);
    let by_length = fine.faces().flat_map(|q| {
        let q = [q[0], q[1], q[2], q[3]];
        let r = io::quad_split_diagonal(&fine.positions, q);
        let v = |k: usize| q[(r + k) % 4];
        [[v(0), v(1), v(2)], [v(0), v(2), v(3)]]
    });
    assert_eq!(
        triangle_ids(glb_triangles(&shorter).remove(0).into_iter()),
        triangle_ids(by_length)
    );
}

/// The triangles of each mesh of a GLB file, in mesh order.
fn glb_triangles(path: &Path) -> Vec<Vec<[u32; 3]>> {
    let bytes = std::fs::read(path).unwrap();
    let g = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = g.blob.as_deref().unwrap();
    g.meshes()
        .map(|m| {
            let mut tris = Vec::new();
            for p in m.primitives() {
                let ids: Vec<u32> = p
                    .reader(|_| Some(blob))
                    .read_indices()
                    .unwrap()
                    .into_u32()
                    .collect();
                tris.extend(ids.chunks(3).map(|c| [c[0], c[1], c[2]]));
            }
            tris
        })
        .collect()
}

#[test]
fn polygons_and_lone_triangles_are_bridged_not_split() {
    // spot's control cage: 160 quads, 4 triangles and 16 pentagons. Its
    // pentagons are cut into triangles and paired; the two triangles left
    // are joined by a strip of quads cut at edge midpoints.
    let d = TempDir::new().unwrap();
    let out_p = d.path().join("p.pqm");
    let cage = fixtures().join("spot_control_mesh.obj");
    let input = io::read_mesh(&cage).unwrap();
    let out = pqm()
        .args(["--json", "encode", s(&cage), "-o", s(&out_p)])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("polygons of five or more corners") && stderr.contains("joined by 1 strip"),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let p = &v["files"][0];
    assert_eq!(p["conversion"], "bridged");
    let out_s = d.path().join("s.pqm");
    let sp = json_ok(&["encode", s(&cage), "-o", s(&out_s), "--triangles", "split"]);
    let sp = &sp["files"][0];
    assert_eq!(sp["conversion"], "split");
    // A few new vertices where the split makes about four times the
    // input's; a file at most half the split's.
    let (nv, ns) = (
        p["vertices"].as_u64().unwrap(),
        sp["vertices"].as_u64().unwrap(),
    );
    let n = input.vertex_count() as u64;
    assert!(n < nv && nv < n + n / 10, "{n} input, {nv} bridged");
    assert!(ns > 3 * n);
    let (bp, bs) = (p["bytes"].as_u64().unwrap(), sp["bytes"].as_u64().unwrap());
    assert!(2 * bp < bs, "bridged {bp} bytes, split {bs}");
    // The finest level is the bridging: the input's vertices first, on
    // the grid, and what `check_bridging` accepts.
    let fine = d.path().join("fine.obj");
    json_ok(&["decode", s(&out_p), "-o", s(&fine)]);
    let (fine, _) = load_valid(&fine);
    let step = input.bbox_diagonal() / (1 << 14) as f64;
    for (a, b) in fine.positions.iter().zip(&input.positions) {
        assert!((*a - *b).length() <= step, "{a} vs {b}");
    }
    let (bridged, _, _) = pqm_core::bridging::pair_and_bridge(&input).unwrap();
    assert_eq!(fine.face_count(), bridged.face_count());
    pqm_core::bridging::check_bridging(&input, &bridged).unwrap();
    // A quad input says so.
    let q = d.path().join("q.pqm");
    assert_eq!(encode_spot(&q, &[])["files"][0]["conversion"], "none");
}

#[test]
fn triangles_alone_everywhere_are_split_not_bridged() {
    // Every triangle its own UV island: no pair is allowed, and strips
    // would add more vertices than the split.
    let d = TempDir::new().unwrap();
    let mut m = triangle_torus();
    m.texcoords = (0..m.indices.len())
        .map(|i| [i as f64 / 1e4, 0.0])
        .collect();
    m.corner_texcoords = (0..m.indices.len() as u32).collect();
    let obj = d.path().join("islands.obj");
    io::write_mesh(&obj, &m).unwrap();
    let out = d.path().join("islands.pqm");
    let o = pqm()
        .args(["--json", "encode", s(&obj), "-o", s(&out)])
        .output()
        .unwrap();
    assert!(o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("have no partner") && stderr.contains("split instead"),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["files"][0]["conversion"], "split");
    // The texture coordinates are not in the file, and both say so.
    assert!(
        stderr.contains("its texture coordinates are not kept"),
        "{stderr}"
    );
    assert_eq!(
        v["files"][0]["dropped"],
        serde_json::json!(["texture coordinates"])
    );
    let coarse = d.path().join("coarse.obj");
    let c = json_ok(&["coarsen", s(&obj), "-o", s(&coarse)]);
    assert_eq!(c["dropped"], serde_json::json!(["texture coordinates"]));
    assert!(io::read_mesh(&coarse).unwrap().corner_texcoords.is_empty());
}

#[test]
fn what_cannot_be_paired_or_bridged_is_split_with_a_note() {
    let d = TempDir::new().unwrap();
    let obj = d.path().join("tube.obj");
    io::write_mesh(&obj, &pqm_core::shapes::uncuttable_polygons()).unwrap();
    let (out_p, out_s) = (d.path().join("p.pqm"), d.path().join("s.pqm"));
    let out = pqm()
        .args(["--json", "encode", s(&obj), "-o", s(&out_p)])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("cannot pair the triangles")
            && stderr.contains("without repeating an edge")
            && stderr.contains("split instead"),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["files"][0]["conversion"], "split");
    // The same file as the split asked for.
    json_ok(&["encode", s(&obj), "-o", s(&out_s), "--triangles", "split"]);
    assert_eq!(
        std::fs::read(&out_p).unwrap(),
        std::fs::read(&out_s).unwrap()
    );
}

#[test]
fn convert_pairs_and_bridges_triangles_or_names_a_face_it_cannot() {
    let d = TempDir::new().unwrap();
    let input = triangle_torus();
    let obj = d.path().join("tris.obj");
    io::write_mesh(&obj, &input).unwrap();
    let quads = d.path().join("quads.obj");
    let v = json_ok(&["convert", s(&obj), s(&quads), "--subdivide", "pair"]);
    assert_eq!(v["vertices"].as_u64(), Some(input.vertex_count() as u64));
    let (out, _) = load_valid(&quads);
    pqm_core::pairing::check_pairing(&input, &out).unwrap();
    // spot's cage: its pentagons cut, its triangles paired or bridged.
    let cage = fixtures().join("spot_control_mesh.obj");
    let cage_q = d.path().join("cage.obj");
    let v = json_ok(&["convert", s(&cage), s(&cage_q), "--subdivide", "pair"]);
    let input = io::read_mesh(&cage).unwrap();
    assert!(v["vertices"].as_u64().unwrap() > input.vertex_count() as u64);
    let (out, _) = load_valid(&cage_q);
    pqm_core::bridging::check_bridging(&input, &out).unwrap();
    // Polygons no triangulation can cut: an error naming one, and no
    // output file.
    let tube = d.path().join("tube.obj");
    io::write_mesh(&tube, &pqm_core::shapes::uncuttable_polygons()).unwrap();
    let bad = d.path().join("bad.obj");
    pqm()
        .args(["convert", s(&tube), s(&bad)])
        .args(["--subdivide", "pair"])
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("face").and(predicate::str::contains("--subdivide split")),
        );
    assert!(!bad.exists());
}

/// A real triangle mesh through pqm and back: `pqm encode` pairs
/// fertility's triangles (the default), and `pqm decode --triangulate`
/// writes exactly its triangles again, on its vertices at their indices,
/// positions within half a grid step; the GLB export of the full level
/// holds the same triangles.
#[test]
fn a_real_triangle_mesh_comes_back_as_its_own_triangles() {
    let d = TempDir::new().unwrap();
    let input_path = shared("tri/fertility.off");
    let input = io::read_mesh(&input_path).unwrap();
    let file = d.path().join("fertility.pqm");
    let e = json_ok(&["encode", s(&input_path), "-o", s(&file)]);
    assert_eq!(e["files"][0]["conversion"], "paired");
    assert_eq!(e["files"][0]["finest_diagonals"], true);
    let want = triangle_ids(input.faces().map(|f| [f[0], f[1], f[2]]));
    let tris = d.path().join("tris.ply");
    json_ok(&["decode", s(&file), "-o", s(&tris), "--triangulate"]);
    let back = io::read_mesh(&tris).unwrap();
    assert_eq!(back.vertex_count(), input.vertex_count());
    assert_eq!(triangle_ids(back.faces().map(|f| [f[0], f[1], f[2]])), want);
    // the cube grid's step is the largest extent over 2^14 − 1 codes
    let (lo, hi) = input
        .positions
        .iter()
        .fold((input.positions[0], input.positions[0]), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    let step = (hi - lo).max_element() / ((1 << 14) - 1) as f64;
    for (a, b) in back.positions.iter().zip(&input.positions) {
        // half a step, and a little for the PLY's f32
        assert!(
            (*a - *b).abs().max_element() <= 0.5 * step + 1e-5 * step.max(1.0),
            "{a} vs {b}"
        );
    }
    let glb = d.path().join("fine.glb");
    json_ok(&["decode", s(&file), "-o", s(&glb)]);
    assert_eq!(
        triangle_ids(glb_triangles(&glb).remove(0).into_iter()),
        want
    );
}

/// `--level-error`: `measured` (the default) writes each level's sampled
/// Hausdorff distance to the full level, non-increasing and below the
/// coarsener's bound that `bound` writes; nothing else in the file
/// changes (same size, same levels), the JSON says which was written,
/// `decode --error` then stops at a coarser level, and a bad value is a
/// usage error.
#[test]
fn level_error_measured_is_tighter_than_the_bound_and_changes_nothing_else() {
    let d = TempDir::new().unwrap();
    let (m, b) = (d.path().join("m.pqm"), d.path().join("b.pqm"));
    let rm = encode_spot(&m, &["--chunk-bytes", "1024", "--chunk-growth", "0"]);
    let rb = encode_spot(
        &b,
        &[
            "--chunk-bytes",
            "1024",
            "--chunk-growth",
            "0",
            "--level-error",
            "bound",
        ],
    );
    let (fm, fb) = (&rm["files"][0], &rb["files"][0]);
    assert_eq!(fm["level_error"], "measured");
    assert_eq!(fb["level_error"], "bound");
    assert_eq!(fm["bytes"], fb["bytes"]);
    assert_eq!(fm["base_error_bound"], fb["base_error"]);
    let (em, eb) = (
        fm["base_error"].as_f64().unwrap(),
        fb["base_error"].as_f64().unwrap(),
    );
    assert!(
        em > 0.0 && em < eb / 2.0,
        "base error measured {em}, bound {eb}"
    );

    let levels = |p: &Path| -> Vec<(u64, f64)> {
        json_ok(&["info", s(p)])["levels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| (r["level"].as_u64().unwrap(), r["error"].as_f64().unwrap()))
            .collect()
    };
    let (lm, lb) = (levels(&m), levels(&b));
    assert!(lm.len() >= 10, "{} levels", lm.len());
    assert_eq!(lm.len(), lb.len());
    for (i, (a, z)) in lm.iter().zip(&lb).enumerate() {
        assert_eq!(a.0, z.0, "row {i}");
        assert!(
            a.1 <= z.1,
            "level {}: measured {} > bound {}",
            a.0,
            a.1,
            z.1
        );
        if i > 0 {
            assert!(a.1 <= lm[i - 1].1, "level {}: measured errors rise", a.0);
        }
    }
    assert_eq!(lm.last().unwrap().1, 0.0);
    // the same levels either way
    for level in ["0", &lm[lm.len() / 2].0.to_string()] {
        let (om, ob) = (d.path().join("m.obj"), d.path().join("b.obj"));
        json_ok(&["decode", s(&m), "-o", s(&om), "--level", level]);
        json_ok(&["decode", s(&b), "-o", s(&ob), "--level", level]);
        assert_eq!(
            std::fs::read(&om).unwrap(),
            std::fs::read(&ob).unwrap(),
            "level {level}"
        );
    }
    // a client asking for an error gets a coarser level from the measured file
    let e = (lb[lb.len() / 2].1).to_string();
    let dm = json_ok(&[
        "decode",
        s(&m),
        "-o",
        s(&d.path().join("e.obj")),
        "--error",
        &e,
    ]);
    let db = json_ok(&[
        "decode",
        s(&b),
        "-o",
        s(&d.path().join("f.obj")),
        "--error",
        &e,
    ]);
    assert!(
        dm["level"].as_u64() < db["level"].as_u64(),
        "--error {e}: measured level {}, bound level {}",
        dm["level"],
        db["level"]
    );
    encode_spot_refused(&m, &["--level-error", "exact"]);
}
