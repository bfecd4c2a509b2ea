//! The mesh readers `pqm encode` and `pqm convert` put user files through
//! (OBJ, OFF, PLY, glTF/GLB) on hostile bytes: an error or a mesh, never a
//! panic; a mesh read goes through the validity check and, when refused,
//! the repair, without a crash either; then through triangle pairing (what
//! `pqm encode` does to a triangle mesh since session 24), whose result,
//! when there is one, must pass `check_pairing`, and through pairing with
//! bridging (the default since session 25), whose result must pass
//! `check_bridging` when the mesh is valid. The first byte picks the
//! reader.
//!
//! `cargo fuzz run read_mesh -s none` (stable Rust: no sanitizer).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pqm_core::io::{
    check, read_gltf_bytes, read_obj_bytes, read_off_bytes, read_ply_bytes, repair,
};
use pqm_core::bridging::{check_bridging, pair_and_bridge};
use pqm_core::pairing::{check_pairing, pair_triangles};

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let mesh = match which % 4 {
        0 => read_obj_bytes(rest),
        1 => read_off_bytes(rest),
        2 => read_ply_bytes(rest),
        _ => read_gltf_bytes(rest, None),
    };
    if let Ok(mut m) = mesh {
        // What `pqm convert --repair` and `pqm encode` do next.
        if check(&m).is_err() {
            let _ = repair(&mut m);
        }
        if let Ok((paired, _)) = pair_triangles(&m) {
            if let Err(e) = check_pairing(&m, &paired) {
                panic!("a pairing that check_pairing refuses: {e}");
            }
        }
        if let Ok((bridged, _, _)) = pair_and_bridge(&m) {
            assert!(bridged.is_quad_only(), "bridging left a face that is not a quad");
            if check(&m).is_ok() {
                if let Err(e) = check_bridging(&m, &bridged) {
                    panic!("a bridging that check_bridging refuses: {e}");
                }
            }
        }
    }
});
