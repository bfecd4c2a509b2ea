//! glTF export options (`GltfWriteOptions`): every combination of normals
//! (none, smooth, flat) and quantization, as `.gltf` and `.glb`, on meshes
//! with triangles + quads + pentagons, pure quads, and enough corners for
//! 32-bit indices. Each file must pass the Khronos validator with zero
//! errors, read back through our reader with the same polygons (quads stay
//! quads via FB_ngon_encoding) and positions within the quantization step,
//! declare its extensions as their specs require, and carry normals that
//! point the way the faces do.

mod gltf_export_util;

use glam::DVec3;
use gltf_export_util::{assert_valid_gltf, glb_json, shared};
use pqm_core::io::{
    read_gltf_bytes, read_mesh, write_glb, write_glb_with, write_gltf, write_gltf_with,
    GltfWriteOptions, Normals, QuadSplit, FB_NGON_ENCODING, KHR_MESH_QUANTIZATION,
};
use pqm_core::subdivide::{catmull_clark, SplitMode};
use pqm_core::IndexedMesh;

const ALL_NORMALS: [Normals; 3] = [Normals::None, Normals::Smooth, Normals::Flat];

fn all_options() -> Vec<GltfWriteOptions> {
    let mut v = Vec::new();
    for normals in ALL_NORMALS {
        for quantize in [false, true] {
            for quad_split in [QuadSplit::Shorter, QuadSplit::First] {
                v.push(GltfWriteOptions {
                    normals,
                    quantize,
                    quad_split,
                });
            }
        }
    }
    v
}

fn face_sizes(m: &IndexedMesh) -> Vec<usize> {
    m.faces().map(|f| f.len()).collect()
}

fn newell(m: &IndexedMesh, face: &[u32]) -> DVec3 {
    let p = |k: usize| m.positions[face[k % face.len()] as usize];
    (0..face.len()).map(|k| p(k).cross(p(k + 1))).sum()
}

/// Decodes the NORMAL accessor of the first primitive of a GLB (float32 or
/// normalized SHORT with any stride).
fn glb_normals(bytes: &[u8]) -> Option<Vec<DVec3>> {
    let doc = glb_json(bytes);
    let acc_i = doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].as_u64()? as usize;
    let acc = &doc["accessors"][acc_i];
    let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let bin = &bytes[20 + json_len + 8..];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
    let float = acc["componentType"] == 5126;
    if !float {
        assert_eq!(acc["componentType"], 5122, "normals are float or SHORT");
        assert_eq!(acc["normalized"], true);
    }
    let size = if float { 4 } else { 2 };
    let stride = view["byteStride"].as_u64().map_or(3 * size, |s| s as usize);
    let count = acc["count"].as_u64().unwrap() as usize;
    Some(
        (0..count)
            .map(|k| {
                let c = |i: usize| {
                    let o = start + k * stride + i * size;
                    if float {
                        f64::from(f32::from_le_bytes(bin[o..o + 4].try_into().unwrap()))
                    } else {
                        f64::from(i16::from_le_bytes(bin[o..o + 2].try_into().unwrap())) / 32767.0
                    }
                };
                DVec3::new(c(0), c(1), c(2))
            })
            .collect(),
    )
}

/// What a reader must get back from `m` written with `opts`.
fn check_read_back(m: &IndexedMesh, back: &IndexedMesh, opts: &GltfWriteOptions, what: &str) {
    assert_eq!(face_sizes(back), face_sizes(m), "{what}: polygons differ");
    let tol = if opts.quantize {
        // Half a grid step (largest half extent / 32767) plus f32 rounding.
        let (lo, hi) = m.bounding_box().unwrap();
        (hi - lo).max_element() / 32767.0 + 1e-6 * m.bbox_diagonal()
    } else {
        1e-6 * m.bbox_diagonal()
    };
    let expect: Vec<DVec3> = match opts.normals {
        Normals::Flat => {
            // Vertex k is corner k; a quad may start at another corner
            // (its fan starts at an end of its shorter diagonal).
            assert_eq!(back.face_count(), m.face_count(), "{what}");
            let mut k = 0u32;
            for (f, (a, b)) in back.faces().zip(m.faces()).enumerate() {
                let n = b.len();
                let corners: Vec<u32> = (k..k + n as u32).collect();
                let same = (0..n).any(|r| (0..n).all(|i| a[i] == corners[(i + r) % n]));
                assert!(
                    same,
                    "{what}: flat face {f} read back as {a:?}, corners {corners:?}"
                );
                k += n as u32;
            }
            m.indices.iter().map(|&i| m.positions[i as usize]).collect()
        }
        _ => {
            // The writer may rotate a polygon by one corner so that its
            // anchor differs from the previous polygon's.
            for (f, (a, b)) in back.faces().zip(m.faces()).enumerate() {
                let same = (0..b.len()).any(|r| (0..b.len()).all(|k| a[k] == b[(k + r) % b.len()]));
                assert!(same, "{what}: face {f} read back as {a:?}, written {b:?}");
            }
            m.positions.clone()
        }
    };
    assert_eq!(back.positions.len(), expect.len(), "{what}");
    for (k, (a, b)) in back.positions.iter().zip(&expect).enumerate() {
        assert!(
            (*a - *b).abs().max_element() <= tol,
            "{what}: vertex {k} read back at {a}, written {b} (tolerance {tol})"
        );
    }
}

fn check_json(doc: &serde_json::Value, opts: &GltfWriteOptions, m: &IndexedMesh, what: &str) {
    let list = |k: &str| -> Vec<String> {
        doc[k]
            .as_array()
            .map(|a| a.iter().map(|s| s.as_str().unwrap().to_owned()).collect())
            .unwrap_or_default()
    };
    let used = list("extensionsUsed");
    let required = list("extensionsRequired");
    assert!(used.contains(&FB_NGON_ENCODING.to_owned()), "{what}");
    assert!(!required.contains(&FB_NGON_ENCODING.to_owned()), "{what}");
    let q = KHR_MESH_QUANTIZATION.to_owned();
    assert_eq!(used.contains(&q), opts.quantize, "{what}: extensionsUsed");
    assert_eq!(
        required.contains(&q),
        opts.quantize,
        "{what}: extensionsRequired"
    );
    let attrs = &doc["meshes"][0]["primitives"][0]["attributes"];
    assert_eq!(
        attrs["NORMAL"].is_number(),
        opts.normals != Normals::None,
        "{what}"
    );
    let pos = &doc["accessors"][attrs["POSITION"].as_u64().unwrap() as usize];
    let verts = match opts.normals {
        Normals::Flat => m.indices.len(),
        _ => m.positions.len(),
    };
    assert_eq!(pos["count"], verts, "{what}: vertex count");
    assert_eq!(
        pos["componentType"],
        if opts.quantize { 5122 } else { 5126 },
        "{what}"
    );
    let node = &doc["nodes"][0];
    assert_eq!(
        node["scale"].is_array(),
        opts.quantize,
        "{what}: dequantization scale"
    );
}

/// Normals must agree with the polygons' orientation: a flat normal with
/// its face's Newell normal, a smooth normal with the sum of its faces'.
fn check_normals(m: &IndexedMesh, normals: &[DVec3], kind: Normals, what: &str) {
    match kind {
        Normals::None => {}
        Normals::Flat => {
            let mut c = 0;
            for face in m.faces() {
                let n = newell(m, face).normalize();
                for _ in face {
                    assert!(
                        normals[c].dot(n) > 0.999,
                        "{what}: corner {c} normal off its face"
                    );
                    c += 1;
                }
            }
        }
        Normals::Smooth => {
            let mut acc = vec![DVec3::ZERO; m.positions.len()];
            for face in m.faces() {
                let n = newell(m, face);
                for &v in face {
                    acc[v as usize] += n;
                }
            }
            for (v, (n, a)) in normals.iter().zip(&acc).enumerate() {
                assert!(n.dot(a.normalize()) > 0.999, "{what}: vertex {v} normal");
            }
        }
    }
}

#[test]
fn plain_writers_equal_default_options() {
    let m = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    let opts = GltfWriteOptions::default();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_gltf(&mut a, &m).unwrap();
    write_gltf_with(&mut b, &m, &opts).unwrap();
    assert_eq!(a, b);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_glb(&mut a, &m).unwrap();
    write_glb_with(&mut b, &m, &opts).unwrap();
    assert_eq!(a, b);
}

#[test]
fn every_option_combination_validates_and_reads_back() {
    let spot = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    assert_eq!(spot.face_size_counts(), (160, 4, 16));
    let fandisk = read_mesh(&shared("quad/fandisk_quads.off")).unwrap();
    // 46,848 quads: 187k corners, so flat normals need 32-bit indices.
    let big = catmull_clark(&spot, 4, SplitMode::CatmullClark).unwrap();
    let meshes = [
        ("spot", &spot, true),
        ("fandisk", &fandisk, true),
        ("big", &big, false),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (name, m, with_gltf) in meshes {
        for opts in all_options() {
            let tag = format!("{name}-{:?}-q{}", opts.normals, u8::from(opts.quantize));
            let mut glb = Vec::new();
            write_glb_with(&mut glb, m, &opts).unwrap();
            let doc = glb_json(&glb);
            check_json(&doc, &opts, m, &tag);
            let back = read_gltf_bytes(&glb, None).unwrap_or_else(|e| panic!("{tag}: {e}"));
            check_read_back(m, &back, &opts, &tag);
            if let Some(n) = glb_normals(&glb) {
                check_normals(m, &n, opts.normals, &tag);
            }
            let path = dir.path().join(format!("{tag}.glb"));
            std::fs::write(&path, &glb).unwrap();
            files.push(path);
            if with_gltf {
                let mut text = Vec::new();
                write_gltf_with(&mut text, m, &opts).unwrap();
                let doc: serde_json::Value = serde_json::from_slice(&text).unwrap();
                check_json(&doc, &opts, m, &tag);
                let back = read_gltf_bytes(&text, None).unwrap();
                check_read_back(m, &back, &opts, &format!("{tag}.gltf"));
                let path = dir.path().join(format!("{tag}.gltf"));
                std::fs::write(&path, &text).unwrap();
                files.push(path);
            }
        }
    }
    assert_valid_gltf(&files);
}

#[test]
fn flat_normals_keep_consecutive_polygons_apart() {
    // Two quads sharing an edge, written so that with shared vertices the
    // second would start at the first's anchor: per-face copies must still
    // give each polygon its own anchor and two consecutive fan triangles.
    let p = (0..6)
        .map(|i| DVec3::new((i % 3) as f64, (i / 3) as f64, 0.0))
        .collect();
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 4, 3], [1, 2, 5, 4]]);
    for quantize in [false, true] {
        let opts = GltfWriteOptions {
            normals: Normals::Flat,
            quantize,
            ..GltfWriteOptions::default()
        };
        let mut glb = Vec::new();
        write_glb_with(&mut glb, &m, &opts).unwrap();
        let back = read_gltf_bytes(&glb, None).unwrap();
        assert_eq!(back.face_size_counts(), (2, 0, 0));
        check_read_back(&m, &back, &opts, "two quads");
    }
}

#[test]
fn degenerate_faces_get_a_unit_normal_not_nan() {
    // A zero-area triangle next to a proper one: the validator rejects
    // non-unit normals, so the degenerate face still needs a unit vector.
    let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(2.0, 0.0, 0.0)];
    let m = IndexedMesh::from_faces(p, [[0u32, 1, 2], [0, 1, 3]]);
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for opts in all_options() {
        let mut glb = Vec::new();
        write_glb_with(&mut glb, &m, &opts).unwrap();
        if let Some(n) = glb_normals(&glb) {
            assert!(
                n.iter().all(|n| (n.length() - 1.0).abs() < 1e-4),
                "{opts:?}: {n:?}"
            );
        }
        let path = dir.path().join(format!(
            "degenerate-{:?}-{}.glb",
            opts.normals, opts.quantize
        ));
        std::fs::write(&path, &glb).unwrap();
        files.push(path);
    }
    assert_valid_gltf(&files);
}

#[test]
fn bad_meshes_are_errors_with_options_too() {
    let m = IndexedMesh::from_faces(vec![DVec3::ZERO, DVec3::X], [[0u32, 1]]);
    for opts in all_options() {
        let err = write_glb_with(Vec::new(), &m, &opts)
            .unwrap_err()
            .to_string();
        assert!(err.contains("face 0"), "{opts:?}: {err}");
    }
    let empty = IndexedMesh::new();
    assert!(write_gltf_with(Vec::new(), &empty, &GltfWriteOptions::default()).is_err());
}
