//! Every shared mesh loads with the V, F and face-size counts of
//! `shared/meshes/MANIFEST.md`, passes `check`, and `repair` leaves it alone
//! (except suzanne's two coincident vertices).

mod io_util;

use io_util::shared;
use pqm_core::io::{check, read_mesh, repair};

/// (file, V, F, quads, tris, other) from MANIFEST.md.
const MANIFEST: &[(&str, usize, usize, usize, usize, usize)] = &[
    ("quad/fandisk_quads.off", 766, 764, 764, 0, 0),
    ("quad/suzanne.obj", 507, 500, 468, 32, 0),
    ("quad/spot_quadrangulated.obj", 2930, 2928, 2928, 0, 0),
    ("quad/spot_control_mesh.obj", 188, 180, 160, 4, 16),
    ("quad/loki.obj", 27514, 27352, 27352, 0, 0),
    ("quad/makehuman_base.obj", 19158, 18486, 18486, 0, 0),
    ("quad/sword-quad-dominant.obj", 22293, 22465, 22117, 348, 0),
    ("tri/bunny.off", 34835, 69666, 0, 69666, 0),
    ("tri/fertility.off", 4494, 9000, 0, 9000, 0),
    ("tri/fandisk.off", 6475, 12946, 0, 12946, 0),
    ("large/amo.off", 90112, 180220, 0, 180220, 0),
    ("large/skull.obj", 49999, 100002, 0, 100002, 0),
];

#[test]
fn every_shared_mesh_loads_with_manifest_counts_and_passes_check() {
    for &(file, v, f, q, t, o) in MANIFEST {
        let path = shared(file);
        let m = read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.vertex_count(), v, "{file}: V");
        assert_eq!(m.face_count(), f, "{file}: F");
        assert_eq!(m.face_size_counts(), (q, t, o), "{file}: quads/tris/other");
        assert!(
            m.bounding_box()
                .is_some_and(|(lo, hi)| (hi - lo).min_element() > 0.0),
            "{file}"
        );
        if let Err(e) = check(&m) {
            panic!("{file}: check failed: {e}");
        }
    }
}

#[test]
fn repair_changes_nothing_on_clean_shared_meshes() {
    for &(file, v, f, ..) in MANIFEST {
        let mut m = read_mesh(&shared(file)).unwrap();
        let before = m.clone();
        let report = repair(&mut m);
        check(&m).unwrap_or_else(|e| panic!("{file}: {e} after repair ({report})"));
        if file.ends_with("suzanne.obj") {
            // Two coincident vertices: welded, then split again where they
            // would join two separate fans.
            assert_eq!(report.welded_vertices, 2, "{report}");
            assert_eq!(m.face_count(), f);
            assert_eq!(
                m.vertex_count(),
                v - report.welded_vertices + report.split_vertices
            );
        } else {
            assert!(!report.changed(), "{file}: {report}");
            assert_eq!(m, before, "{file}");
        }
    }
}

#[test]
fn obj_attributes_and_groups_of_shared_meshes() {
    // spot_quadrangulated: v/vt corners; suzanne: v//vn corners, `o`, mtllib, usemtl, s.
    let spot = read_mesh(&shared("quad/spot_quadrangulated.obj")).unwrap();
    assert_eq!(spot.corner_texcoords.len(), spot.indices.len());
    assert!(spot.corner_normals.is_empty());
    let suz = read_mesh(&shared("quad/suzanne.obj")).unwrap();
    assert_eq!(suz.corner_normals.len(), suz.indices.len());
    assert_eq!(suz.normals.len(), 499);
    assert_eq!(suz.groups, vec![("Suzanne".to_string(), 0)]);

    // makehuman: one group per `g` line, each starting where its faces start.
    let text = std::fs::read_to_string(shared("quad/makehuman_base.obj")).unwrap();
    let mut expected = Vec::new();
    let mut faces = 0u32;
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("g ") {
            expected.push((name.trim().to_string(), faces));
        } else if line.starts_with("f ") {
            faces += 1;
        }
    }
    let mh = read_mesh(&shared("quad/makehuman_base.obj")).unwrap();
    assert_eq!(expected.len(), 172);
    assert_eq!(mh.groups, expected);
    let body = mh.groups.iter().position(|g| g.0 == "body").unwrap();
    let end = mh
        .groups
        .get(body + 1)
        .map_or(mh.face_count() as u32, |g| g.1);
    assert_eq!(
        end - mh.groups[body].1,
        13378,
        "MANIFEST: body has 13,378 quads"
    );
}

#[test]
fn binary_off_positions_are_the_float32_values() {
    // amo.off is pmp's binary OFF; compare the first vertex with the raw bytes.
    let data = std::fs::read(shared("large/amo.off")).unwrap();
    let body = data.iter().position(|&b| b == b'\n').unwrap() + 1 + 12;
    let x = f32::from_le_bytes(data[body..body + 4].try_into().unwrap());
    let m = read_mesh(&shared("large/amo.off")).unwrap();
    assert_eq!(m.positions[0].x, f64::from(x));
}
