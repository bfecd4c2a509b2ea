//! Hostile input: random bytes, truncations and byte flips of valid files fed
//! to every reader must give `Ok` or `Err`, never a panic (proptest), and
//! truncated files must give errors.

mod io_util;

use io_util::shared;
use pqm_core::io;
use pqm_core::IndexedMesh;
use proptest::prelude::*;
use std::sync::OnceLock;

type Writer = fn(&mut Vec<u8>, &IndexedMesh) -> Result<(), io::MeshIoError>;

/// Valid small files of every format: (name, bytes).
fn samples() -> &'static Vec<(&'static str, Vec<u8>)> {
    static S: OnceLock<Vec<(&'static str, Vec<u8>)>> = OnceLock::new();
    S.get_or_init(|| {
        let m = io::read_mesh(&shared("quad/spot_control_mesh.obj")).unwrap();
        let mut out = vec![(
            "obj",
            std::fs::read(shared("quad/spot_control_mesh.obj")).unwrap(),
        )];
        let mut tiny = m.clone();
        tiny.vertex_scalars
            .insert("quality".into(), vec![0.5; tiny.vertex_count()]);
        let writers: [(&str, Writer); 5] = [
            ("off", |w, m| io::write_off(w, m)),
            ("ply", |w, m| io::write_ply(w, m)),
            ("ply", |w, m| io::write_ply_ascii(w, m)),
            ("gltf", |w, m| io::write_gltf(w, m)),
            ("glb", |w, m| io::write_glb(w, m)),
        ];
        for (name, w) in writers {
            let mut buf = Vec::new();
            w(&mut buf, &tiny).unwrap();
            out.push((name, buf));
        }
        // pmp binary OFF: first kilobytes of amo.off are a valid prefix only,
        // so build a small one from the mesh instead.
        let mut b = b"OFF BINARY\n".to_vec();
        for n in [m.vertex_count() as i32, m.face_count() as i32, 0] {
            b.extend_from_slice(&n.to_le_bytes());
        }
        for p in &m.positions {
            for c in p.to_array() {
                b.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        for f in m.faces() {
            b.extend_from_slice(&(f.len() as i32).to_le_bytes());
            for &i in f {
                b.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
        out.push(("off", b));
        out
    })
}

fn read(name: &str, data: &[u8]) -> Result<IndexedMesh, io::MeshIoError> {
    match name {
        "obj" => io::read_obj_bytes(data),
        "off" => io::read_off_bytes(data),
        "ply" => io::read_ply_bytes(data),
        _ => io::read_gltf_bytes(data, None),
    }
}

/// Every reader on the same bytes; a successful read must be index-safe.
fn read_all_formats(data: &[u8]) {
    for name in ["obj", "off", "ply", "gltf"] {
        if let Ok(m) = read(name, data) {
            assert_eq!(m.face_starts.last().copied(), Some(m.indices.len() as u32));
            assert!(
                m.indices.iter().all(|&i| (i as usize) < m.positions.len()),
                "{name}"
            );
        }
    }
}

#[test]
fn samples_are_valid() {
    for (name, data) in samples() {
        let m = read(name, data).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.face_count(), 180, "{name}");
    }
}

#[test]
fn truncated_binary_files_are_errors() {
    for (name, data) in samples() {
        let binary = !data.is_ascii() || *name == "gltf";
        if !binary {
            continue; // a truncated text file may still be a valid shorter mesh
        }
        for cut in [0, 1, 10, data.len() / 3, data.len() / 2, data.len() - 1] {
            assert!(
                read(name, &data[..cut]).is_err(),
                "{name} cut at {cut} of {}",
                data.len()
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_bytes_never_panic(
        prefix in prop::sample::select(vec![
            &b""[..], b"ply\n", b"ply\nformat ascii 1.0\nelement vertex ",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n",
            b"OFF\n", b"OFF BINARY\n", b"glTF\x02\x00\x00\x00", b"{\"asset\":{\"version\":\"2.0\"},",
            b"v 0 0 0\nf ", b"COFF ",
        ]),
        body in prop::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut data = prefix.to_vec();
        data.extend_from_slice(&body);
        read_all_formats(&data);
    }

    #[test]
    fn truncations_never_panic(k in 0usize..7, frac in 0.0f64..1.0) {
        let (name, data) = &samples()[k];
        let cut = (data.len() as f64 * frac) as usize;
        let _ = read(name, &data[..cut]);
    }

    #[test]
    fn corruptions_never_panic(
        k in 0usize..7,
        edits in prop::collection::vec((0.0f64..1.0, any::<u8>()), 1..8),
    ) {
        let (name, data) = &samples()[k];
        let mut d = data.clone();
        for (at, byte) in edits {
            let i = ((d.len() as f64 * at) as usize).min(d.len() - 1);
            d[i] = byte;
        }
        let _ = read(name, &d);
        read_all_formats(&d);
    }

    #[test]
    fn header_numbers_never_panic(n in "[0-9]{1,30}", which in 0usize..4) {
        let texts = [
            format!("ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n"),
            format!("ply\nformat binary_little_endian {n}.0\nelement vertex 1\nend_header\n"),
            format!("OFF\n{n} {n} 0\n0 0 0\n3 0 0 0\n"),
            format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -{n}\nf {n} 1 2\n"),
        ];
        read_all_formats(texts[which].as_bytes());
    }
}

/// gltf-json indexes `accessors` with a primitive's POSITION unchecked while
/// validating: the reader must refuse such a file before that, naming it.
#[test]
fn gltf_primitive_naming_a_missing_accessor_is_an_error() {
    let json =
        br#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":5}}]}]}"#;
    let err = io::read_gltf_bytes(json, None).expect_err("accessor 5 does not exist");
    let msg = err.to_string();
    assert!(msg.contains("accessor 5"), "{msg}");
}
