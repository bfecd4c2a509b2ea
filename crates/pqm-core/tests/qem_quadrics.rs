//! Quadric error metrics: plane and triangle quadrics, additivity, the
//! conditioning test of the optimal point, vertex quadrics of quad meshes
//! and `best_position`.

mod attributes_shapes;
use attributes_shapes::*;

use glam::DVec3;
use pqm_core::qem::{best_position, face_quadric, vertex_quadrics, Quadric};
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn plane_quadric_is_squared_distance() {
    let n = DVec3::new(1.0, 2.0, -2.0).normalize();
    let d = -0.7;
    let q = Quadric::from_plane(n, d);
    for p in [DVec3::ZERO, DVec3::new(3.0, -1.0, 2.0), n * 0.7] {
        let dist = n.dot(p) + d;
        assert!(close(q.evaluate(p), dist * dist, 1e-12));
    }
    assert_eq!(Quadric::default(), Quadric::ZERO);
    assert_eq!(Quadric::ZERO.evaluate(DVec3::new(5.0, 6.0, 7.0)), 0.0);
}

#[test]
fn triangle_quadric_is_area_weighted() {
    let (p0, p1, p2) = (
        DVec3::ZERO,
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 3.0, 0.0),
    );
    let q = Quadric::from_triangle(p0, p1, p2);
    // area 3, plane z = 0
    assert!(close(
        q.evaluate(DVec3::new(7.0, -2.0, 0.5)),
        3.0 * 0.25,
        1e-12
    ));
    assert_eq!(q.evaluate(DVec3::new(-4.0, 9.0, 0.0)), 0.0);
    // degenerate triangle: no error anywhere
    let z = Quadric::from_triangle(p0, p1, p1 * 2.0);
    assert_eq!(z, Quadric::ZERO);
}

#[test]
fn optimal_point_needs_three_independent_planes() {
    let corner = DVec3::new(1.0, -2.0, 3.0);
    let px = Quadric::from_plane(DVec3::X, -corner.x);
    let py = Quadric::from_plane(DVec3::Y, -corner.y);
    let pz = Quadric::from_plane(DVec3::Z, -corner.z);
    assert_eq!(
        px.optimal_point(),
        None,
        "a single plane does not fix a point"
    );
    assert_eq!(
        (px + py).optimal_point(),
        None,
        "a crease does not fix a point"
    );
    let p = (px + py + pz)
        .optimal_point()
        .expect("corner is well conditioned");
    assert!((p - corner).length() < 1e-12);
    // nearly coplanar planes (normals within 1e-4 rad) are rejected
    let tilt = |a: f64| Quadric::from_plane(DVec3::new(a.sin(), 0.0, a.cos()), 0.0);
    let flat =
        tilt(0.0) + tilt(1e-4) + Quadric::from_plane(DVec3::new(0.0, 1e-4, 1.0).normalize(), 0.0);
    assert_eq!(flat.optimal_point(), None);
    assert_eq!(Quadric::ZERO.optimal_point(), None);
}

#[test]
fn cube_vertex_quadrics_pin_the_corners() {
    let m = mesh(&cube_lattice(2, |p| p));
    let qs = vertex_quadrics(&m);
    assert_eq!(qs.len(), m.vertex_capacity());
    let mut corners = 0;
    for v in m.vertices() {
        let q = qs[v.idx()];
        let p = m.position(v);
        assert!(q.evaluate(p) < 1e-12, "the vertex lies on its planes");
        assert!(q.evaluate(p * 1.1) > 1e-4);
        if p.abs().min_element() > 0.5 {
            corners += 1;
            let o = q.optimal_point().expect("three faces meet at a corner");
            assert!((o - p).length() < 1e-9);
        } else if p.abs().cmpgt(DVec3::splat(0.5)).bitmask().count_ones() == 1 {
            // face centres: one plane only
            assert_eq!(q.optimal_point(), None);
        }
    }
    assert_eq!(corners, 8);
}

#[test]
fn quad_quadric_weights_both_diagonals() {
    // A non-planar quad: the two diagonal splits give different planes; the
    // face quadric must be symmetric under relabelling the quad's corners.
    let pos = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.3),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.3),
    ];
    let a = mesh(&pqm_core::IndexedMesh::from_faces(
        pos.clone(),
        [[0u32, 1, 2, 3]],
    ));
    let b = mesh(&pqm_core::IndexedMesh::from_faces(pos, [[1u32, 2, 3, 0]]));
    let (qa, qb) = (
        face_quadric(&a, pqm_core::FaceId(0)),
        face_quadric(&b, pqm_core::FaceId(0)),
    );
    for p in [DVec3::new(0.3, 0.2, 0.9), DVec3::new(-1.0, 2.0, 0.1)] {
        assert!(close(qa.evaluate(p), qb.evaluate(p), 1e-12));
    }
    // planar quad: total weight is its area (2 × 3 rectangle → area 6)
    let r = mesh(&pqm_core::IndexedMesh::from_faces(
        vec![
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 3.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        ],
        [[0u32, 1, 2, 3]],
    ));
    let q = face_quadric(&r, pqm_core::FaceId(0));
    assert!(close(q.evaluate(DVec3::new(0.0, 0.0, 1.0)), 6.0, 1e-12));
}

#[test]
fn flat_grid_quadrics_fall_back_to_candidates() {
    let m = mesh(&grid(4, 4));
    let qs = vertex_quadrics(&m);
    let (a, b) = (pqm_core::VertexId(6), pqm_core::VertexId(12));
    let q = qs[a.idx()] + qs[b.idx()];
    assert_eq!(q.optimal_point(), None);
    let (pa, pb) = (m.position(a), m.position(b));
    let mid = (pa + pb) / 2.0;
    // all candidates lie on the plane: the first of least error (pa) wins
    assert_eq!(best_position(&q, &[pa, pb, mid]), pa);
    // a candidate off the plane loses
    let off = mid + DVec3::Z;
    assert_eq!(best_position(&q, &[off, mid]), mid);
}

#[test]
fn best_position_uses_a_nearby_optimum_and_rejects_a_far_one() {
    let corner = DVec3::new(1.0, 1.0, 1.0);
    let q = Quadric::from_plane(DVec3::X, -1.0)
        + Quadric::from_plane(DVec3::Y, -1.0)
        + Quadric::from_plane(DVec3::Z, -1.0);
    let near = [DVec3::new(0.9, 1.0, 1.0), DVec3::new(1.0, 0.8, 1.1)];
    assert!((best_position(&q, &near) - corner).length() < 1e-12);
    // candidates far from the optimum relative to their spread
    let far = [DVec3::new(10.0, 10.0, 10.0), DVec3::new(10.1, 10.0, 10.0)];
    assert_eq!(best_position(&q, &far), far[0]);
    assert!((best_position(&q, &[]) - corner).length() < 1e-12);
}

#[test]
fn sphere_optimal_points_stay_near_the_surface() {
    let r = 1.0;
    let m = mesh(&quad_sphere(8, r));
    let qs = vertex_quadrics(&m);
    // merging the endpoints of every edge: the chosen point is near the
    // sphere and at most as bad as the best endpoint/midpoint
    for h in m.halfedges() {
        let (a, b) = (m.from_vertex(h), m.to_vertex(h));
        if a > b {
            continue;
        }
        let q = qs[a.idx()] + qs[b.idx()];
        let (pa, pb) = (m.position(a), m.position(b));
        let cands = [pa, pb, (pa + pb) / 2.0];
        let p = best_position(&q, &cands);
        let best_cand = cands
            .iter()
            .map(|&c| q.evaluate(c))
            .fold(f64::INFINITY, f64::min);
        assert!(q.evaluate(p) <= best_cand * (1.0 + 1e-9) + 1e-15);
        assert!(
            (p.length() - r).abs() < 0.05,
            "{p:?} is {} from the centre",
            p.length()
        );
    }
}

fn arb_vec() -> impl Strategy<Value = DVec3> {
    prop::array::uniform3(-10.0f64..10.0).prop_map(DVec3::from)
}

proptest! {
    #[test]
    fn quadrics_add_and_are_nonnegative(
        tris in prop::collection::vec((arb_vec(), arb_vec(), arb_vec()), 1..6),
        p in arb_vec(),
        w in 0.0f64..5.0,
    ) {
        let qs: Vec<Quadric> = tris.iter().map(|&(a, b, c)| Quadric::from_triangle(a, b, c)).collect();
        let mut sum = Quadric::ZERO;
        for q in &qs {
            sum += *q;
        }
        let total: f64 = qs.iter().map(|q| q.evaluate(p)).sum();
        prop_assert!(close(sum.evaluate(p), total, 1e-9));
        prop_assert!(sum.evaluate(p) >= 0.0);
        prop_assert!(close((sum * w).evaluate(p), w * total, 1e-9));
    }

    #[test]
    fn optimal_point_is_a_minimum(
        tris in prop::collection::vec((arb_vec(), arb_vec(), arb_vec()), 3..8),
        dirs in prop::collection::vec(arb_vec(), 4),
    ) {
        let mut q = Quadric::ZERO;
        for &(a, b, c) in &tris {
            q += Quadric::from_triangle(a, b, c);
        }
        if let Some(o) = q.optimal_point() {
            let e0 = q.evaluate(o);
            for d in dirs {
                let e1 = q.evaluate(o + d * 1e-2);
                prop_assert!(e1 >= e0 - 1e-9 * (1.0 + e0), "{e1} < {e0}");
            }
        }
    }
}
