//! Property tests of bridging (`pqm_core::bridging`): whatever a pairing
//! leaves alone — triangles in odd UV islands, triangles next to holes,
//! polygons of five or more corners — `pair_and_bridge` makes a quad-only
//! mesh of any valid manifold input, with the input's vertices first and
//! new ones only at edge midpoints and face centres (`check_bridging`),
//! and where a perfect pairing exists it adds nothing; on hostile face
//! soups it never panics.

mod common;

use glam::DVec3;
use pqm_core::bridging::{check_bridging, pair_and_bridge};
use pqm_core::pairing::{pair_triangles, PairingError};
use pqm_core::{shapes, IndexedMesh, Mesh};
use proptest::prelude::*;

/// A quad shape from the strategy's numbers.
fn shape(kind: u8, n: u32) -> IndexedMesh {
    match kind % 4 {
        0 => shapes::quad_sphere(n.max(2), 1.0),
        1 => shapes::torus(3 * n.max(2), n.max(3), 2.0, 0.7),
        2 => shapes::grid(n.max(1), n.max(1) + 2, 1.0, 1.5),
        _ => shapes::box_grid(n.max(1), DVec3::new(1.0, 0.5, 2.0)),
    }
}

fn mix(x: u64) -> u64 {
    let x = x.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    (x ^ (x >> 29)).wrapping_mul(0xbf58_476d_1ce4_e5b9)
}

/// Gives the faces texture coordinates by UV island: a face's island is
/// its centroid's cell in a grid of `cells` per unit, so islands are
/// patches of any parity, seams between them. `uv = (x + 3 i, y)` for
/// island `i`, one texture coordinate per vertex and island.
fn with_islands(m: &mut IndexedMesh, cells: f64) {
    let nv = m.vertex_count() as u32;
    let island = |f: &[u32]| -> u32 {
        let c = f.iter().map(|&v| m.positions[v as usize]).sum::<DVec3>() / f.len() as f64;
        let cell = (c * cells).floor();
        (mix(cell.x as i64 as u64 ^ mix(cell.y as i64 as u64 ^ mix(cell.z as i64 as u64))) % 5)
            as u32
    };
    let islands: Vec<u32> = m.faces().map(island).collect();
    m.texcoords = (0..5u32)
        .flat_map(|i| m.positions.iter().map(move |p| [p.x + 3.0 * i as f64, p.y]))
        .collect();
    m.corner_texcoords = (0..m.face_count())
        .flat_map(|f| {
            let off = islands[f] * nv;
            m.face(f).iter().map(move |&v| v + off).collect::<Vec<_>>()
        })
        .collect();
}

/// Faces of a mesh joined at random across shared edges into polygons
/// (each join takes out one edge): about `joins` of them.
fn polygons_at_random(m: &IndexedMesh, joins: usize, seed: u64) -> IndexedMesh {
    use std::collections::HashMap;
    let mut faces: Vec<Option<Vec<u32>>> = m.faces().map(|f| Some(f.to_vec())).collect();
    let mut done = 0;
    for round in 0..joins * 8 {
        if done == joins {
            break;
        }
        let mut by_edge: HashMap<(u32, u32), usize> = HashMap::new();
        for (i, f) in faces.iter().enumerate() {
            if let Some(f) = f {
                for k in 0..f.len() {
                    by_edge.insert((f[k], f[(k + 1) % f.len()]), i);
                }
            }
        }
        let live: Vec<usize> = (0..faces.len()).filter(|&i| faces[i].is_some()).collect();
        let i = live[(mix(seed ^ round as u64) % live.len() as u64) as usize];
        let f = faces[i].clone().unwrap();
        let k = (mix(seed.wrapping_add(round as u64)) % f.len() as u64) as usize;
        let (a, b) = (f[k], f[(k + 1) % f.len()]);
        let Some(&j) = by_edge.get(&(b, a)) else {
            continue;
        };
        let g = faces[j].clone().unwrap();
        if j == i || f.iter().filter(|v| g.contains(v)).count() != 2 {
            continue;
        }
        // f up to a, g's corners after a, then f from b on.
        let jb = g.iter().position(|&v| v == b).unwrap();
        let mut joined: Vec<u32> = f[..=k].to_vec();
        joined.extend((2..g.len()).map(|x| g[(jb + x) % g.len()]));
        joined.extend(f[k + 1..].iter().copied());
        faces[i] = Some(joined);
        faces[j] = None;
        done += 1;
    }
    IndexedMesh::from_faces(m.positions.clone(), faces.into_iter().flatten())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn odd_uv_islands_and_holes_are_bridged(
        kind in 0u8..4, n in 1u32..6, seed in any::<u64>(), cells in 0.5f64..4.0,
        drop in prop::collection::vec(any::<u32>(), 0..5),
    ) {
        let tris = shapes::triangulated(&shape(kind, n), seed);
        let nf = tris.face_count();
        let mut gone: Vec<usize> = drop.iter().map(|&d| d as usize % nf).collect();
        gone.sort_unstable();
        gone.dedup();
        let faces: Vec<&[u32]> = (0..nf).filter(|f| gone.binary_search(f).is_err()).map(|f| tris.face(f)).collect();
        let mut m = IndexedMesh::from_faces(tris.positions.clone(), faces);
        with_islands(&mut m, cells);
        let valid = Mesh::from_indexed(&m).is_ok();
        match pair_and_bridge(&m) {
            Ok((out, p, r)) => {
                check_bridging(&m, &out).map_err(TestCaseError::fail)?;
                prop_assert_eq!(r.polygons, 0);
                prop_assert!(r.strips * 2 + r.boundary_strips <= r.lone + r.strips);
                prop_assert_eq!(r.lone, 2 * r.strips + r.boundary_strips);
                prop_assert_eq!(p.triangles, m.face_count());
                if r.lone == 0 {
                    prop_assert_eq!(out.vertex_count(), m.vertex_count());
                }
            }
            // A valid manifold mesh always bridges (its closed parts have
            // an even number of triangles; its open ones a boundary).
            Err(e) => prop_assert!(!valid, "a valid mesh failed: {e}"),
        }
    }

    #[test]
    fn polygons_among_quads_and_triangles_are_cut_and_bridged(
        kind in 0u8..4, n in 2u32..6, seed in any::<u64>(), joins in 1usize..8, tri in any::<bool>(),
    ) {
        let base = shape(kind, n);
        let base = if tri { shapes::triangulated(&base, seed) } else { base };
        let m = polygons_at_random(&base, joins, seed);
        let (out, _, r) = match pair_and_bridge(&m) {
            Ok(x) => x,
            // A polygon wrapped around a thin tube (the torus of three
            // segments around) may have no diagonal that is not an edge.
            Err(PairingError::Polygon { face }) => {
                prop_assert!(m.face(face).len() > 4);
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(e.to_string())),
        };
        check_bridging(&m, &out).map_err(TestCaseError::fail)?;
        let polygons = m.faces().filter(|f| f.len() > 4).count();
        prop_assert_eq!(r.polygons, polygons);
    }

    #[test]
    fn where_a_pairing_exists_nothing_is_added(
        kind in 0u8..4, n in 1u32..6, seed in any::<u64>(),
    ) {
        let tris = shapes::triangulated(&shape(kind, n), seed);
        let (paired, _) = pair_triangles(&tris).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let (out, _, r) = pair_and_bridge(&tris).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(r.new_vertices(), 0);
        prop_assert_eq!(out, paired);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any soup of faces (repeated and out-of-range indices, faces of any
    /// size, NaN positions) gives an error or a quad mesh, never a panic;
    /// from a valid mesh, one `check_bridging` accepts.
    #[test]
    fn any_face_soup_bridges_or_is_refused(
        nv in 0usize..12,
        faces in prop::collection::vec(prop::collection::vec(0u32..14, 0..8), 0..14),
        nan in any::<bool>(),
        texcoords in prop::collection::vec(0u32..3, 0..40),
    ) {
        let m = common::face_soup(nv, &faces, nan, &texcoords);
        if let Ok((out, _, _)) = pair_and_bridge(&m) {
            prop_assert!(out.is_quad_only());
            if Mesh::from_indexed(&m).is_ok() {
                check_bridging(&m, &out).map_err(TestCaseError::fail)?;
            }
        }
    }
}
