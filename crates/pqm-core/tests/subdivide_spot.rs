//! Split of Spot's control cage (160 quads, 4 triangles, 16 pentagons; closed,
//! genus 0, V = 188, F = 180 per shared/meshes/MANIFEST.md).

mod subdivide_util;

use pqm_core::subdivide::{catmull_clark, catmull_clark_split, SplitMode};
use subdivide_util::*;

#[test]
fn spot_control_mesh_splits_into_732_quads() {
    let m = load_obj(&shared_mesh("quad/spot_control_mesh.obj"));
    assert_eq!((m.vertex_count(), m.face_count()), (188, 180));
    let sizes = m.faces().fold([0usize; 8], |mut acc, f| {
        acc[f.len().min(7)] += 1;
        acc
    });
    assert_eq!((sizes[3], sizes[4], sizes[5]), (4, 160, 16));
    assert_eq!(euler(&m), 2);
    let edges = undirected_edges(&m).len();
    assert_eq!(edges, 366);

    for mode in [SplitMode::Linear, SplitMode::CatmullClark] {
        let s = catmull_clark_split(&m, mode).unwrap();
        assert_eq!(s.face_count(), 160 * 4 + 4 * 3 + 16 * 5);
        assert_eq!(s.face_count(), 732);
        assert_eq!(s.vertex_count(), 188 + edges + 180);
        assert!(s.is_quad_only());
        assert!(orientation_consistent(&s));
        assert!(is_closed(&s));
        assert_eq!(euler(&s), 2);
        assert_eq!(components(&s), 1);
        // Texcoords ride along, one per output corner, all in range.
        assert_eq!(s.corner_texcoords.len(), 4 * 732);
        assert!(s
            .corner_texcoords
            .iter()
            .all(|&t| (t as usize) < s.texcoords.len()));
        // Every output point is a convex combination of input points.
        let (lo, hi) = m.bounding_box().unwrap();
        for p in &s.positions {
            assert!(p.cmpge(lo - 1e-12).all() && p.cmple(hi + 1e-12).all());
        }
    }

    // Two CC levels: after the first everything is a quad, so ×4.
    let s2 = catmull_clark(&m, 2, SplitMode::CatmullClark).unwrap();
    assert_eq!(s2.face_count(), 4 * 732);
    assert_eq!(euler(&s2), 2);
    assert!(orientation_consistent(&s2));
    // After the first step, every extraordinary vertex is an original vertex
    // or a face point of a non-quad; the irregular count therefore stays
    // the same from level 1 to level 2.
    let irregular =
        |mesh: &pqm_core::IndexedMesh| valences(mesh).iter().filter(|&&v| v != 4).count();
    let s1 = catmull_clark_split(&m, SplitMode::CatmullClark).unwrap();
    assert_eq!(irregular(&s1), irregular(&s2));
    assert_eq!(irregular(&s1), irregular(&m) + 4 + 16);
}
