//! Round trips through every writer and reader, hand-written inputs for the
//! format variants, and the error messages.

mod io_util;

use glam::DVec3;
use io_util::{cube, faces, shared};
use pqm_core::io::{self, check, read_mesh, write_mesh, MeshIoError, MeshIoErrorKind};
use pqm_core::IndexedMesh;
use proptest::prelude::*;
use std::path::Path;

type Writer = fn(&mut Vec<u8>, &IndexedMesh) -> Result<(), MeshIoError>;
type Reader = fn(&[u8]) -> Result<IndexedMesh, MeshIoError>;

/// The exact (f64) formats: (name, writer, reader).
fn exact_formats() -> Vec<(&'static str, Writer, Reader)> {
    vec![
        ("obj", |w, m| io::write_obj(w, m), io::read_obj_bytes),
        ("off", |w, m| io::write_off(w, m), io::read_off_bytes),
        ("ply", |w, m| io::write_ply(w, m), io::read_ply_bytes),
        (
            "ply-ascii",
            |w, m| io::write_ply_ascii(w, m),
            io::read_ply_bytes,
        ),
    ]
}

fn gltf_formats() -> Vec<(&'static str, Writer)> {
    vec![
        ("gltf", |w, m| io::write_gltf(w, m)),
        ("glb", |w, m| io::write_glb(w, m)),
    ]
}

fn roundtrip_exact(m: &IndexedMesh, name: &str, w: Writer, r: Reader) -> IndexedMesh {
    let mut buf = Vec::new();
    w(&mut buf, m).unwrap_or_else(|e| panic!("{name}: write: {e}"));
    let back = r(&buf).unwrap_or_else(|e| panic!("{name}: read: {e}"));
    assert_eq!(back.positions.len(), m.positions.len(), "{name}");
    for (a, b) in back.positions.iter().zip(&m.positions) {
        assert_eq!(
            a.to_array().map(f64::to_bits),
            b.to_array().map(f64::to_bits),
            "{name}"
        );
    }
    assert_eq!(faces(&back), faces(m), "{name}");
    back
}

fn roundtrip_gltf(m: &IndexedMesh, name: &str, w: Writer) -> IndexedMesh {
    let mut buf = Vec::new();
    w(&mut buf, m).unwrap_or_else(|e| panic!("{name}: write: {e}"));
    let back = io::read_gltf_bytes(&buf, None).unwrap_or_else(|e| panic!("{name}: read: {e}"));
    assert_eq!(back.positions.len(), m.positions.len(), "{name}");
    for (a, b) in back.positions.iter().zip(&m.positions) {
        assert_eq!(*a, b.as_vec3().as_dvec3(), "{name}: positions within f32");
    }
    // Same polygons, each possibly rotated (the writer may change the anchor).
    assert_eq!(back.face_count(), m.face_count(), "{name}");
    for (f, (a, b)) in back.faces().zip(m.faces()).enumerate() {
        assert_eq!(a.len(), b.len(), "{name}: face {f} size");
        let r = a
            .iter()
            .position(|&v| v == b[0])
            .unwrap_or_else(|| panic!("{name}: face {f}"));
        let rotated: Vec<u32> = (0..a.len()).map(|k| a[(r + k) % a.len()]).collect();
        assert_eq!(rotated, b, "{name}: face {f}");
    }
    back
}

#[test]
fn shared_meshes_round_trip_through_every_format() {
    for file in [
        "quad/spot_control_mesh.obj",
        "quad/suzanne.obj",
        "quad/fandisk_quads.off",
        "quad/spot_quadrangulated.obj",
        "tri/fertility.off",
    ] {
        let m = read_mesh(&shared(file)).unwrap();
        for (name, w, r) in exact_formats() {
            let back = roundtrip_exact(&m, &format!("{file} {name}"), w, r);
            if name == "obj" {
                assert_eq!(back.texcoords, m.texcoords, "{file}");
                assert_eq!(back.corner_texcoords, m.corner_texcoords, "{file}");
                assert_eq!(back.normals, m.normals, "{file}");
                assert_eq!(back.corner_normals, m.corner_normals, "{file}");
                assert_eq!(back.groups, m.groups, "{file}");
            }
        }
        for (name, w) in gltf_formats() {
            let back = roundtrip_gltf(&m, &format!("{file} {name}"), w);
            assert_eq!(
                back.face_size_counts(),
                m.face_size_counts(),
                "{file}: quads stay quads"
            );
        }
    }
}

#[test]
fn quads_stay_quads_through_gltf_even_when_anchors_collide() {
    // Consecutive faces starting at the same vertex force the writer to rotate.
    let p = (0..9)
        .map(|i| DVec3::new((i % 3) as f64, (i / 3) as f64, 0.0))
        .collect();
    let m = IndexedMesh::from_faces(
        p,
        [[4u32, 5, 8, 7], [4, 7, 6, 3], [4, 3, 0, 1], [4, 1, 2, 5]],
    );
    check(&m).unwrap();
    for (name, w) in gltf_formats() {
        let back = roundtrip_gltf(&m, name, w);
        assert!(back.is_quad_only());
        let anchors: Vec<u32> = back.faces().map(|f| f[0]).collect();
        assert!(anchors.windows(2).all(|a| a[0] != a[1]), "{anchors:?}");
    }
}

#[test]
fn gltf_without_the_ngon_extension_reads_triangles() {
    let m = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    let mut buf = Vec::new();
    io::write_gltf(&mut buf, &m).unwrap();
    let mut doc: serde_json::Value = serde_json::from_slice(&buf).unwrap();
    assert_eq!(
        doc["extensionsUsed"],
        serde_json::json!([io::FB_NGON_ENCODING])
    );
    assert!(doc.get("extensionsRequired").is_none());
    doc.as_object_mut().unwrap().remove("extensionsUsed");
    let tri = io::read_gltf_bytes(&serde_json::to_vec(&doc).unwrap(), None).unwrap();
    let expected: usize = m.faces().map(|f| f.len() - 2).sum();
    assert_eq!(tri.face_count(), expected);
    assert_eq!(tri.face_size_counts(), (0, expected, 0));
}

#[test]
fn gltf_with_sibling_bin_file_reads_through_read_mesh() {
    let m = cube();
    let mut buf = Vec::new();
    io::write_gltf(&mut buf, &m).unwrap();
    let mut doc: serde_json::Value = serde_json::from_slice(&buf).unwrap();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
    let b64 = uri.split_once(";base64,").unwrap().1;
    use base64::Engine;
    let bin = base64::engine::general_purpose::STANDARD
        .decode(b64)
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube data.bin"), bin).unwrap();
    doc["buffers"][0]["uri"] = "cube%20data.bin".into();
    let path = dir.path().join("cube.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let back = read_mesh(&path).unwrap();
    assert_eq!(faces(&back), faces(&m));
    assert_eq!(back.positions, m.positions);
}

#[test]
fn ply_keeps_vertex_scalars() {
    let mut m = cube();
    m.vertex_scalars
        .insert("quality".into(), (0..8).map(|i| i as f64 * 0.1).collect());
    m.vertex_scalars
        .insert("importance".into(), (0..8).map(|i| -(i as f64)).collect());
    for (name, w, r) in exact_formats()
        .into_iter()
        .filter(|f| f.0.starts_with("ply"))
    {
        let back = roundtrip_exact(&m, name, w, r);
        assert_eq!(back.vertex_scalars, m.vertex_scalars, "{name}");
    }
}

#[test]
fn files_round_trip_through_read_mesh_and_write_mesh_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let m = read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
    for ext in ["obj", "OFF", "Ply", "gltf", "GLB"] {
        let path = dir.path().join(format!("spot.{ext}"));
        write_mesh(&path, &m).unwrap();
        let back = read_mesh(&path).unwrap();
        assert_eq!(back.face_count(), m.face_count(), "{ext}");
        assert_eq!(back.face_size_counts(), m.face_size_counts(), "{ext}");
    }
    // Only the five targets: no temporary files left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 5);

    // A failing write leaves the old file untouched and no temporary file.
    let target = dir.path().join("spot.obj");
    let before = std::fs::read(&target).unwrap();
    let mut broken = m.clone();
    broken.indices[3] = 10_000;
    let err = write_mesh(&target, &broken).unwrap_err();
    assert!(matches!(err.kind, MeshIoErrorKind::Invalid { .. }), "{err}");
    assert!(
        err.to_string().starts_with(&target.display().to_string()),
        "{err}"
    );
    assert_eq!(std::fs::read(&target).unwrap(), before);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 5);

    let err = write_mesh(&dir.path().join("x.stl"), &m).unwrap_err();
    assert!(matches!(err.kind, MeshIoErrorKind::Unsupported(_)), "{err}");
    let err = read_mesh(&dir.path().join("missing.obj")).unwrap_err();
    assert!(matches!(err.kind, MeshIoErrorKind::Io(_)), "{err}");
}

#[test]
fn error_display_names_file_element_and_problem() {
    let m = IndexedMesh::from_faces(
        (0..4)
            .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
            .collect(),
        [[0u32, 1, 2], [1, 3, 3]],
    );
    let e = MeshIoError::from(check(&m).unwrap_err()).with_path(Path::new("spot.obj"));
    assert_eq!(e.to_string(), "spot.obj: face 1 repeats vertex 3");

    let e = io::read_obj_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2 x\n").unwrap_err();
    assert_eq!(e.to_string(), "line 3: bad vertex index 'x'");
    let e = io::read_obj_bytes(b"v 0 0 0\nf 1 2 3\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "face 0 references vertex 2 but the file has 1"
    );
}

#[test]
fn obj_negative_indices_groups_and_noise() {
    let text = "# comment\r\nmtllib x.mtl\r\no first\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0 1.0\r\n\
                vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nusemtl m\r\ns 1\r\nf -3/-3 -2/-2 -1/-1\r\n\
                g second\r\nv 0 1 0 0.5 0.5 0.5\r\nvt 0 1\r\nf 1/1 3/3 -1/-1 # trailing\r\n\
                l 1 2\r\n";
    let m = io::read_obj_bytes(text.as_bytes()).unwrap();
    assert_eq!(faces(&m), vec![vec![0, 1, 2], vec![0, 2, 3]]);
    assert_eq!(m.corner_texcoords, vec![0, 1, 2, 0, 2, 3]);
    assert_eq!(m.positions[3], DVec3::new(0.0, 1.0, 0.0));
    assert_eq!(m.groups, vec![("first".into(), 0), ("second".into(), 1)]);
    // A negative index reaching before the first vertex is an error with a line.
    let e = io::read_obj_bytes(b"v 0 0 0\nf -1 -2 -1\n").unwrap_err();
    assert!(matches!(e.kind, MeshIoErrorKind::Parse { .. }), "{e}");
    assert!(e.to_string().starts_with("line 2:"), "{e}");
}

#[test]
fn ply_big_endian_and_other_list_types() {
    // Big endian, float positions, an extra `quality`, ushort count and uint
    // indices under the name `vertex_index`, an extra face property, and an
    // unused element after the faces.
    let mut d = b"ply\nformat binary_big_endian 1.0\ncomment by hand\nelement vertex 4\n\
property float x\nproperty float y\nproperty float z\nproperty double quality\n\
element face 2\nproperty uchar flags\nproperty list ushort uint vertex_index\n\
element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
        .to_vec();
    let pts = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.5, 2.0, 0.25],
    ];
    for (k, p) in pts.iter().enumerate() {
        for c in p {
            d.extend_from_slice(&c.to_be_bytes());
        }
        d.extend_from_slice(&(k as f64 * 1.5).to_be_bytes());
    }
    for f in [&[0u32, 1, 2, 3][..], &[0, 2, 3]] {
        d.push(7);
        d.extend_from_slice(&(f.len() as u16).to_be_bytes());
        for i in f {
            d.extend_from_slice(&i.to_be_bytes());
        }
    }
    d.extend_from_slice(&0i32.to_be_bytes());
    d.extend_from_slice(&1i32.to_be_bytes());
    let m = io::read_ply_bytes(&d).unwrap();
    assert_eq!(faces(&m), vec![vec![0, 1, 2, 3], vec![0, 2, 3]]);
    assert_eq!(m.positions[3], DVec3::new(0.5, 2.0, 0.25));
    assert_eq!(m.vertex_scalars["quality"], vec![0.0, 1.5, 3.0, 4.5]);
    assert_eq!(m.vertex_scalars.len(), 1);
    // Truncating the big-endian body is an error.
    assert!(io::read_ply_bytes(&d[..d.len() - 9]).is_err());

    // ASCII with char (int8) indices and an int count.
    let a = b"ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\nproperty double y\r\n\
property double z\r\nelement face 1\r\nproperty list int char vertex_indices\r\nend_header\r\n\
0 0 0\r\n1 0 0\r\n0 1 0\r\n3 2 1 0\r\n";
    let m = io::read_ply_bytes(a).unwrap();
    assert_eq!(faces(&m), vec![vec![2, 1, 0]]);
    // Negative indices are an error naming the face.
    let bad = String::from_utf8_lossy(a).replace("3 2 1 0", "3 2 -1 0");
    let e = io::read_ply_bytes(bad.as_bytes()).unwrap_err();
    assert_eq!(e.to_string(), "face 0 has vertex index -1");
}

#[test]
fn off_ascii_variants_and_binary() {
    let text = "OFF 4 2 0 # counts on the header line\n# comment\n\n0 0 0\n1 0 0\n1 1 0\n\
                0 1 0\n4 0 1 2 3 255 0 0\n3 0 2 3\n";
    let m = io::read_off_bytes(text.as_bytes()).unwrap();
    assert_eq!(faces(&m), vec![vec![0, 1, 2, 3], vec![0, 2, 3]]);
    let coff = "COFF\r\n3 1 3\r\n0 0 0 255 0 0 255\r\n1 0 0 0 255 0 255\r\n0 1 0 0 0 255 255\r\n3 0 1 2\r\n";
    let m = io::read_off_bytes(coff.as_bytes()).unwrap();
    assert_eq!(m.positions[1], DVec3::X);
    // pmp binary layout, built by hand.
    let mut b = b"OFF BINARY\n".to_vec();
    for n in [3i32, 1, 0] {
        b.extend_from_slice(&n.to_le_bytes());
    }
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5] {
        b.extend_from_slice(&c.to_le_bytes());
    }
    for i in [3i32, 0, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let m = io::read_off_bytes(&b).unwrap();
    assert_eq!(faces(&m), vec![vec![0, 1, 2]]);
    assert_eq!(m.positions[2], DVec3::new(0.0, 1.0, 0.5));
    // Counts that cannot fit are rejected before allocating.
    let mut huge = b"OFF BINARY\n".to_vec();
    for n in [i32::MAX, i32::MAX, 0] {
        huge.extend_from_slice(&n.to_le_bytes());
    }
    assert!(io::read_off_bytes(&huge)
        .unwrap_err()
        .to_string()
        .contains("do not fit"));
    let e = io::read_off_bytes(b"OFF\n4000000000 1 0\n0 0 0\n").unwrap_err();
    assert!(e.to_string().contains("remaining bytes"), "{e}");
    let e = io::read_off_bytes(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "face 0 references vertex 7 but the file has 3 vertices"
    );
}

fn arb_mesh() -> impl Strategy<Value = IndexedMesh> {
    let coord = prop_oneof![
        any::<f64>().prop_filter("finite", |x| x.is_finite()),
        -1e3..1e3f64,
        Just(0.1),
        Just(-0.0),
    ];
    (3usize..40).prop_flat_map(move |nv| {
        let positions = prop::collection::vec([coord.clone(), coord.clone(), coord.clone()], nv);
        let face = prop::collection::vec(0..nv as u32, 3..7);
        (positions, prop::collection::vec(face, 1..30)).prop_map(|(p, f)| {
            IndexedMesh::from_faces(p.into_iter().map(DVec3::from_array).collect(), f)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_meshes_round_trip_exactly(m in arb_mesh()) {
        for (name, w, r) in exact_formats() {
            roundtrip_exact(&m, name, w, r);
        }
    }
}
