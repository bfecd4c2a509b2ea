//! Scaled Jacobian: hand-made faces with known values, and invariants.

mod metrics_util;
use metrics_util as common;

use glam::{DQuat, DVec3};
use pqm_core::metrics::scaled_jacobian::{polygon_scaled_jacobian, scaled_jacobian, summarize};
use pqm_core::IndexedMesh;
use proptest::prelude::*;

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

#[test]
fn unit_square_is_one() {
    let sq = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
    assert!((polygon_scaled_jacobian(&sq) - 1.0).abs() < 1e-15);
    // A rectangle too: the measure ignores edge lengths.
    let rect = [v(0., 0., 0.), v(7., 0., 0.), v(7., 0.1, 0.), v(0., 0.1, 0.)];
    assert!((polygon_scaled_jacobian(&rect) - 1.0).abs() < 1e-12);
}

#[test]
fn rhombus_is_sine_of_its_angle() {
    for deg in [10.0f64, 30.0, 45.0, 60.0, 89.0, 120.0, 150.0] {
        let t = deg.to_radians();
        let a = v(0., 0., 0.);
        let b = v(1., 0., 0.);
        let d = v(t.cos(), t.sin(), 0.);
        let c = b + d;
        let sj = polygon_scaled_jacobian(&[a, b, c, d]);
        assert!((sj - t.sin()).abs() < 1e-12, "{deg}°: {sj} vs {}", t.sin());
    }
}

#[test]
fn dart_quad_is_negative() {
    // Non-convex "arrowhead": vertex 2 is pushed inside, its corner is reflex.
    let dart = [v(0., 0., 0.), v(2., 0., 0.), v(0.5, 0.5, 0.), v(0., 2., 0.)];
    let sj = polygon_scaled_jacobian(&dart);
    assert!(sj < 0.0, "{sj}");
    // The reflex corner's edges (−0.5, 1.5) and (1.5, −0.5) enclose 126.87° outside
    // the face (cos = −0.6), i.e. a 233.13° interior angle: sin = −0.8.
    assert!((sj + 0.8).abs() < 1e-12, "{sj}");
}

#[test]
fn folded_non_planar_quad_is_negative() {
    // A square whose corner 2 is folded back past the diagonal and lifted out
    // of the plane: its corner normal points against the average (Newell) normal.
    let folded = [
        v(0., 0., 0.),
        v(1., 0., 0.),
        v(0.25, 0.25, 0.3),
        v(0., 1., 0.),
    ];
    let sj = polygon_scaled_jacobian(&folded);
    assert!(sj < 0.0, "{sj}");
    // A mildly non-planar quad stays positive and close to its planar value.
    let bent = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.1), v(0., 1., 0.)];
    let sj = polygon_scaled_jacobian(&bent);
    assert!(sj > 0.9 && sj <= 1.0, "{sj}");
}

#[test]
fn triangles_and_ngons_use_the_same_corner_formula() {
    let eq = [v(0., 0., 0.), v(1., 0., 0.), v(0.5, 3f64.sqrt() / 2.0, 0.)];
    assert!((polygon_scaled_jacobian(&eq) - 60f64.to_radians().sin()).abs() < 1e-12);
    let right = [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)];
    assert!((polygon_scaled_jacobian(&right) - 45f64.to_radians().sin()).abs() < 1e-12);
    let hexagon: Vec<DVec3> = (0..6)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 6.0;
            v(a.cos(), a.sin(), 0.)
        })
        .collect();
    assert!((polygon_scaled_jacobian(&hexagon) - 120f64.to_radians().sin()).abs() < 1e-12);
}

#[test]
fn degenerate_faces_score_zero_or_negative_never_nan() {
    // Zero-length edge (vertices 1 and 2 coincide).
    let collapsed = [v(0., 0., 0.), v(1., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)];
    assert_eq!(polygon_scaled_jacobian(&collapsed), 0.0);
    // All corners on one point.
    assert_eq!(polygon_scaled_jacobian(&[v(1., 1., 1.); 4]), 0.0);
    // Collinear.
    assert_eq!(
        polygon_scaled_jacobian(&[v(0., 0., 0.), v(1., 0., 0.), v(2., 0., 0.)]),
        0.0
    );
    // Symmetric bow-tie: zero vector area, no orientation → counted as folded.
    let bowtie = [v(0., 0., 0.), v(1., 1., 0.), v(1., 0., 0.), v(0., 1., 0.)];
    assert!(polygon_scaled_jacobian(&bowtie) < 0.0);
    // NaN coordinates.
    let nan = [
        v(f64::NAN, 0., 0.),
        v(1., 0., 0.),
        v(1., 1., 0.),
        v(0., 1., 0.),
    ];
    assert_eq!(polygon_scaled_jacobian(&nan), 0.0);
    // Bad faces in a mesh: too short, out of range.
    let mut m = IndexedMesh::from_faces(
        vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.)],
        [[0u32, 1, 2]],
    );
    m.push_face(&[0, 1]);
    m.push_face(&[0, 1, 9]);
    let r = scaled_jacobian(&m);
    assert_eq!(r.per_face.len(), 3);
    assert_eq!(&r.per_face[1..], &[0.0, 0.0]);
    assert!(r.per_face.iter().all(|x| x.is_finite()));
}

#[test]
fn summary_is_median_and_minimum() {
    let s = summarize(&[0.9, 0.1, 0.5, 1.0]);
    assert_eq!(s.worst, 0.1);
    assert!((s.median - 0.7).abs() < 1e-15);
    let s = summarize(&[0.3, -0.2, 0.8]);
    assert_eq!((s.median, s.worst), (0.3, -0.2));
    let grid = common::grid(5, 4, |_, _| 0.0);
    let r = scaled_jacobian(&grid);
    assert_eq!(r.per_face.len(), 20);
    assert!((r.stats.median - 1.0).abs() < 1e-12 && (r.stats.worst - 1.0).abs() < 1e-12);
}

#[test]
fn real_quad_mesh_is_mostly_well_shaped() {
    // Spot's quadrangulation is a good quad mesh: every face is convex.
    let r = scaled_jacobian(&common::load_shared("quad/spot_quadrangulated.obj"));
    assert_eq!(r.per_face.len(), 2928);
    assert!(r.stats.median > 0.8, "{:?}", r.stats);
    assert!(
        r.stats.worst > 0.0 && r.stats.worst <= r.stats.median,
        "{:?}",
        r.stats
    );
}

fn arb_point() -> impl Strategy<Value = DVec3> {
    (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0).prop_map(|(x, y, z)| v(x, y, z))
}

proptest! {
    #[test]
    fn bounded_and_invariant_under_similarity(
        quad in proptest::array::uniform4(arb_point()),
        axis in arb_point(),
        angle in 0.0f64..std::f64::consts::TAU,
        scale in 0.01f64..100.0,
        shift in arb_point(),
    ) {
        let sj = polygon_scaled_jacobian(&quad);
        prop_assert!(sj.is_finite() && (-1.0..=1.0).contains(&sj));
        prop_assume!(axis.length() > 1e-3);
        let rot = DQuat::from_axis_angle(axis.normalize(), angle);
        let moved: Vec<DVec3> = quad.iter().map(|&p| rot * p * scale + shift).collect();
        prop_assert!((polygon_scaled_jacobian(&moved) - sj).abs() < 1e-6);
        // Starting the corner cycle elsewhere does not change the face value.
        let rolled = [quad[1], quad[2], quad[3], quad[0]];
        prop_assert!((polygon_scaled_jacobian(&rolled) - sj).abs() < 1e-12);
    }

    #[test]
    fn orientation_reversal_keeps_the_value(quad in proptest::array::uniform4(arb_point())) {
        // Reversing the corners flips the Newell normal and every corner cross
        // product together, so the value is unchanged.
        let reversed: Vec<DVec3> = quad.iter().rev().copied().collect();
        let (a, b) = (polygon_scaled_jacobian(&quad), polygon_scaled_jacobian(&reversed));
        prop_assert!((a - b).abs() < 1e-9, "{a} {b}");
    }

    #[test]
    fn convex_quads_are_positive(gaps in proptest::array::uniform3(0.2f64..2.9), r in 0.1f64..10.0) {
        // Four points on a circle, counter-clockwise, every arc below π: a convex quad.
        let last = std::f64::consts::TAU - gaps.iter().sum::<f64>();
        prop_assume!(last > 0.2 && last < 2.9);
        let mut t = 0.0f64;
        let mut quad = Vec::new();
        for g in [gaps[0], gaps[1], gaps[2], last] {
            quad.push(v(r * t.cos(), r * t.sin(), 0.0));
            t += g;
        }
        let sj = polygon_scaled_jacobian(&quad);
        prop_assert!(sj > 0.0, "{sj}");
        // Same quad seen from below (clockwise) is still the same face: also positive.
        let mirrored: Vec<DVec3> = quad.iter().map(|p| v(p.x, -p.y, p.z)).collect();
        prop_assert!(polygon_scaled_jacobian(&mirrored) > 0.0);
    }
}
