//! BVH closest-point queries against brute force.

use glam::DVec3;
use pqm_core::bvh::{closest_point_on_triangle, Bvh, BvhError};
use proptest::prelude::*;

fn brute_force(positions: &[DVec3], tris: &[[u32; 3]], p: DVec3) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            (p - closest_point_on_triangle(p, a, b, c)).length_squared()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Distance from `p` to triangle `abc`, by a fine barycentric scan (an
/// independent check of `closest_point_on_triangle`, good to ~1e-3).
fn scanned_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let n = 200;
    let mut best = f64::INFINITY;
    for i in 0..=n {
        for j in 0..=(n - i) {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            best = best.min((a + (b - a) * u + (c - a) * v - p).length());
        }
    }
    best
}

fn arb_point(r: f64) -> impl Strategy<Value = DVec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn closest_point_matches_brute_force(
        positions in proptest::collection::vec(arb_point(10.0), 3..60),
        raw_tris in proptest::collection::vec((0usize..1000, 0usize..1000, 0usize..1000), 1..80),
        queries in proptest::collection::vec(arb_point(15.0), 1..40),
    ) {
        let n = positions.len();
        // Random index triples include repeated vertices: degenerate triangles.
        let tris: Vec<[u32; 3]> = raw_tris.iter().map(|&(a, b, c)| [(a % n) as u32, (b % n) as u32, (c % n) as u32]).collect();
        let bvh = Bvh::build(&positions, &tris).unwrap();
        prop_assert_eq!(bvh.triangle_count(), tris.len());
        let mut hint = 0;
        for &p in &queries {
            let (q, t, d2) = bvh.closest_point(p).unwrap();
            let expected = brute_force(&positions, &tris, p);
            prop_assert!((d2 - expected).abs() <= 1e-9 * (1.0 + expected), "{d2} vs {expected}");
            prop_assert!(((p - q).length_squared() - d2).abs() <= 1e-9 * (1.0 + d2));
            // The point lies on the reported triangle.
            let [a, b, c] = tris[t].map(|v| positions[v as usize]);
            prop_assert!((closest_point_on_triangle(q, a, b, c) - q).length() < 1e-7);
            // A hint (good or bad) does not change the answer.
            let (_, _, d2h) = bvh.closest_point_hinted(p, hint).unwrap();
            prop_assert!((d2h - d2).abs() <= 1e-12 * (1.0 + d2));
            hint = (hint + 7) % tris.len();
        }
    }

    #[test]
    fn triangle_closest_point_matches_scan(
        a in arb_point(1.0), b in arb_point(1.0), c in arb_point(1.0), p in arb_point(2.0),
    ) {
        let q = closest_point_on_triangle(p, a, b, c);
        let d = (p - q).length();
        let scan = scanned_distance(p, a, b, c);
        // The scan only over-estimates; the grid spacing bounds its error.
        let h = ((b - a).length() + (c - a).length()) / 200.0;
        prop_assert!(d <= scan + 1e-12, "{d} > scan {scan}");
        prop_assert!(scan - d <= h + 1e-12, "{d} vs scan {scan}");
    }
}

#[test]
fn large_grid_queries_match_brute_force() {
    // Many triangles in a regular pattern (lots of equal centroid coordinates).
    let n = 40;
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64, j as f64);
            positions.push(DVec3::new(x, y, (x * 0.3).sin() * (y * 0.2).cos()));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut tris = Vec::new();
    for j in 0..n {
        for i in 0..n {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let bvh = Bvh::build(&positions, &tris).unwrap();
    let mut state = 12345u64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..300 {
        let p = DVec3::new(rnd() * 50.0 - 5.0, rnd() * 50.0 - 5.0, rnd() * 10.0 - 5.0);
        let (_, _, d2) = bvh.closest_point(p).unwrap();
        let expected = brute_force(&positions, &tris, p);
        assert!((d2 - expected).abs() <= 1e-9 * (1.0 + expected));
    }
}

#[test]
fn errors_and_empty_inputs() {
    let pos = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
    let err = Bvh::build(&pos, &[[0, 1, 2], [0, 1, 3]]).unwrap_err();
    assert_eq!(
        err,
        BvhError::IndexOutOfRange {
            triangle: 1,
            vertex: 3,
            count: 3
        }
    );
    assert!(err.to_string().contains("triangle 1 references vertex 3"));
    let nan = vec![DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0)];
    assert_eq!(
        Bvh::build(&nan, &[[0, 1, 2]]).unwrap_err(),
        BvhError::NonFinite {
            triangle: 0,
            vertex: 2
        }
    );
    let empty = Bvh::build(&pos, &[]).unwrap();
    assert!(empty.is_empty());
    assert_eq!(empty.closest_point(DVec3::ONE), None);
    let one = Bvh::build(&pos, &[[0, 1, 2]]).unwrap();
    assert_eq!(one.closest_point(DVec3::splat(f64::NAN)), None);
    let (q, t, d2) = one.closest_point(DVec3::new(0.25, 0.25, 2.0)).unwrap();
    assert_eq!((q, t, d2), (DVec3::new(0.25, 0.25, 0.0), 0, 4.0));
    // An out-of-range hint is ignored.
    assert_eq!(
        one.closest_point_hinted(DVec3::new(0.25, 0.25, 2.0), 99)
            .unwrap()
            .2,
        4.0
    );
}
