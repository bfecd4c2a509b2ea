//! The checked-in vectors of `spec/vectors/` are what the generator writes
//! today, byte for byte, and decode to their recorded digests and OBJs.

use pqm_format::{base, decode_all, vectors, Limits, Target};
use std::path::PathBuf;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../spec/vectors")
}

#[test]
fn checked_in_vectors_match_the_generator_and_their_digests() {
    let all = vectors::all();
    assert!(all.len() >= 4);
    // Together the vectors exercise every record form.
    for form in 0..5 {
        assert!(
            all.iter().any(|v| v.forms[form] > 0),
            "no vector uses form {form}"
        );
    }
    for v in all {
        let path = dir().join(format!("{}.pqm", v.name));
        let on_disk = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            on_disk == v.bytes,
            "{} differs from the generator (rerun `cargo run -p pqm-format --example make_vectors` if the format changed on purpose)",
            v.name
        );
        // Decode the checked-in bytes and compare with the checked-in digest.
        let mut dec = decode_all(&on_disk, Limits::default()).unwrap();
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir().join(format!("{}.json", v.name))).unwrap(),
        )
        .unwrap();
        assert_eq!(json["bytes"].as_u64(), Some(on_disk.len() as u64));
        // The vertex order (VORD or VNBR section) has its own digest.
        assert_eq!(
            json["vertex_order_fnv1a64"].as_str().map(str::to_string),
            dec.vertex_order()
                .unwrap()
                .map(|o| format!("{:016x}", vectors::vertex_order_digest(o))),
            "{} vertex order",
            v.name
        );
        // The 3.2 header bounds (`cube_grid` and the 4.0 vectors have them) are listed
        // exactly, and are the box of every position the levels show.
        let listed = |key: &str| {
            json[key]
                .as_array()
                .map(|a| [0, 1, 2].map(|k| a[k].as_f64().unwrap()))
        };
        let bounds = dec.header().unwrap().bounds;
        assert_eq!(
            bounds,
            listed("bounds_min")
                .zip(listed("bounds_max"))
                .map(|(lo, hi)| [lo, hi]),
            "{} bounds",
            v.name
        );
        assert_eq!(
            bounds.is_some(),
            v.name == "cube_grid" || v.name.starts_with("v4_"),
            "{}",
            v.name
        );
        // Flag bit 3 (4.1): listed where set, and only in a 4.1 file.
        let h = dec.header().unwrap();
        assert_eq!(
            h.finest_diagonals(),
            json["finest_diagonals"].as_bool().unwrap_or(false),
            "{} finest diagonals",
            v.name
        );
        assert_eq!(
            h.finest_diagonals(),
            (h.version_major, h.version_minor) == (4, 1),
            "{}",
            v.name
        );
        let levels = json["levels"].as_array().unwrap();
        assert_eq!(levels.len(), v.levels.len());
        for l in levels {
            let k = l["level"].as_u64().unwrap() as usize;
            dec.set_level(Target::Level(k)).unwrap();
            let (p, q) = vectors::level_digests(&dec);
            assert_eq!(
                l["vertex_count"].as_u64(),
                Some(dec.positions().len() as u64)
            );
            assert_eq!(l["face_count"].as_u64(), Some(dec.quads().len() as u64));
            assert_eq!(
                l["positions_fnv1a64"].as_str().unwrap(),
                format!("{p:016x}"),
                "{} level {k}",
                v.name
            );
            assert_eq!(
                l["quads_fnv1a64"].as_str().unwrap(),
                format!("{q:016x}"),
                "{} level {k}",
                v.name
            );
            let obj =
                std::fs::read_to_string(dir().join(format!("{}.level{k}.obj", v.name))).unwrap();
            assert!(obj == vectors::obj(&dec), "{} level {k} OBJ", v.name);
        }
    }
}

/// `box_vord` keeps the 3.0 `VORD` section, `box_vnbr` is the 3.1 file
/// with a `VNBR` section whose order is coherent but not trivial.
#[test]
fn both_vertex_order_sections_have_a_vector() {
    let all = vectors::all();
    let tag = |name: &str| {
        let v = all.iter().find(|v| v.name == name).unwrap();
        let dec = decode_all(&v.bytes, Limits::default()).unwrap();
        let c = dec.chunks().last().unwrap();
        let at = (c.offset + c.compressed_len as u64) as usize;
        assert!(dec.vertex_order().unwrap().is_some());
        (v.bytes[at..at + 4].to_vec(), v.bytes[8..12].to_vec())
    };
    assert_eq!(tag("box_vord"), (b"VORD".to_vec(), vec![2, 0, 0, 0]));
    assert_eq!(tag("box_vnbr"), (b"VNBR".to_vec(), vec![3, 0, 1, 0]));
}

/// The 4.0 vectors cover both base layouts (spec §6): the traversal
/// layout, and the delta layout behind its layout byte.
#[test]
fn the_4_0_vectors_hold_both_base_layouts() {
    let all = vectors::all();
    let layout = |name: &str| {
        let v = all.iter().find(|v| v.name == name).unwrap();
        assert_eq!(&v.bytes[8..12], &[4, 0, 0, 0], "{name}");
        let dec = decode_all(&v.bytes, Limits::default()).unwrap();
        let h = dec.header().unwrap();
        let at = h.header_len as usize + h.chunk_count as usize * h.chunk_entry_len as usize + 4;
        let byte =
            zstd::stream::decode_all(&v.bytes[at..at + h.base_compressed_len as usize]).unwrap()[0];
        (byte, dec.base_layout())
    };
    assert_eq!(
        layout("v4_traversal"),
        (base::LAYOUT_TRAVERSAL, Some(base::BaseLayout::Traversal))
    );
    assert_eq!(
        layout("v4_delta_base"),
        (base::LAYOUT_DELTA, Some(base::BaseLayout::Delta))
    );
}

#[test]
fn fnv1a64_matches_the_published_check_value() {
    // FNV-1a 64 of "a" is 0xaf63dc4c8601ec8c (reference value of the algorithm).
    assert_eq!(vectors::fnv1a64(*b"a"), 0xaf63_dc4c_8601_ec8c);
    assert_eq!(vectors::fnv1a64([]), 0xcbf2_9ce4_8422_2325);
}
