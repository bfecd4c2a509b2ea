//! Properties of the procedural shapes: counts, Euler characteristic,
//! orientation (consistent and outward), closedness, valences.

mod subdivide_util;

use glam::DVec3;
use pqm_core::shapes::*;
use pqm_core::IndexedMesh;
use subdivide_util::*;

/// Every face's normal points away from `inside(face centroid)`.
fn assert_outward(m: &IndexedMesh, inside: impl Fn(DVec3) -> DVec3) {
    for (f, face) in m.faces().enumerate() {
        let c = centroid(m, face);
        let n = face_normal(m, face);
        assert!(n.dot(c - inside(c)) > 0.0, "face {f} points inward");
    }
}

fn assert_closed_oriented(m: &IndexedMesh) {
    assert!(m.is_quad_only());
    assert!(orientation_consistent(m), "a directed edge appears twice");
    assert!(is_closed(m), "mesh has boundary edges");
}

#[test]
fn cube_counts_orientation_and_size() {
    let size = 2.5;
    let m = cube(size);
    assert_eq!((m.vertex_count(), m.face_count()), (8, 6));
    assert_eq!(undirected_edges(&m).len(), 12);
    assert_eq!(euler(&m), 2);
    assert_closed_oriented(&m);
    assert_outward(&m, |_| DVec3::ZERO);
    for p in &m.positions {
        assert!((p.abs() - DVec3::splat(size / 2.0)).abs().max_element() < 1e-12);
    }
    for (a, b) in undirected_edges(&m) {
        let len = (m.positions[a as usize] - m.positions[b as usize]).length();
        assert!((len - size).abs() < 1e-12);
    }
    assert!(valences(&m).iter().all(|&v| v == 3));
}

#[test]
fn quad_sphere_counts_valences_and_radius() {
    for n in [1u32, 2, 3, 5, 8] {
        let r = 1.7;
        let m = quad_sphere(n, r);
        let n2 = (n * n) as usize;
        assert_eq!(m.face_count(), 6 * n2, "n = {n}");
        assert_eq!(m.vertex_count(), 6 * n2 + 2, "n = {n}");
        assert_eq!(euler(&m), 2);
        assert_eq!(components(&m), 1);
        assert_closed_oriented(&m);
        assert_outward(&m, |_| DVec3::ZERO);
        for p in &m.positions {
            assert!((p.length() - r).abs() < 1e-12);
        }
        let val = valences(&m);
        assert_eq!(val.iter().filter(|&&v| v == 3).count(), 8, "n = {n}");
        if n > 1 {
            assert_eq!(
                val.iter().filter(|&&v| v == 4).count(),
                m.vertex_count() - 8
            );
        }
    }
    // n = 0 is raised to 1.
    assert_eq!(quad_sphere(0, 1.0).face_count(), 6);
}

#[test]
fn box_grid_counts_valences_and_extent() {
    let size = DVec3::new(2.0, 1.3, 0.7);
    for n in [1u32, 2, 5] {
        let m = box_grid(n, size);
        let n2 = (n * n) as usize;
        assert_eq!((m.face_count(), m.vertex_count()), (6 * n2, 6 * n2 + 2));
        assert_eq!(euler(&m), 2);
        assert_closed_oriented(&m);
        assert_outward(&m, |_| DVec3::ZERO);
        for p in &m.positions {
            // on the box: inside it, and on one of its six sides
            let d = (p.abs() - size / 2.0).max_element();
            assert!(d.abs() < 1e-12, "n = {n}: {p} off the box");
        }
        let val = valences(&m);
        assert_eq!(val.iter().filter(|&&v| v == 3).count(), 8, "n = {n}");
        assert_eq!(
            val.iter().filter(|&&v| v == 4).count(),
            m.vertex_count() - 8
        );
    }
    assert_eq!(box_grid(0, DVec3::ONE).face_count(), 6);
}

#[test]
fn quad_sphere_quads_are_reasonably_uniform() {
    // The tan warp keeps the largest/smallest face area ratio small.
    let m = quad_sphere(16, 1.0);
    let areas: Vec<f64> = m.faces().map(|f| face_normal(&m, f).length()).collect();
    let (lo, hi) = areas
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), &a| (l.min(a), h.max(a)));
    assert!(hi / lo < 1.5, "area ratio {}", hi / lo);
}

#[test]
fn torus_counts_genus_and_orientation() {
    for (a, b) in [(3u32, 3u32), (8, 5), (24, 12)] {
        let (big, small) = (3.0, 1.0);
        let m = torus(a, b, big, small);
        assert_eq!(
            (m.vertex_count(), m.face_count()),
            ((a * b) as usize, (a * b) as usize)
        );
        assert_eq!(euler(&m), 0, "genus 1");
        assert_eq!(components(&m), 1);
        assert_closed_oriented(&m);
        assert!(valences(&m).iter().all(|&v| v == 4));
        // Outward = away from the nearest point of the centre circle. Only a
        // meaningful test when the faces are small compared to the tube.
        if a >= 8 {
            assert_outward(&m, |c| DVec3::new(c.x, c.y, 0.0).normalize() * big);
        }
        for p in &m.positions {
            let d = (p - DVec3::new(p.x, p.y, 0.0).normalize() * big).length();
            assert!((d - small).abs() < 1e-12);
        }
    }
}

#[test]
fn grid_is_open_planar_with_one_boundary_loop() {
    let (nx, ny, sx, sy) = (7u32, 4u32, 3.5, 2.0);
    let m = grid(nx, ny, sx, sy);
    assert_eq!(m.vertex_count(), ((nx + 1) * (ny + 1)) as usize);
    assert_eq!(m.face_count(), (nx * ny) as usize);
    assert!(m.is_quad_only());
    assert!(orientation_consistent(&m));
    assert_eq!(euler(&m), 1);
    assert_eq!(boundary_loops(&m), 1);
    assert_eq!(boundary_edges(&m).len(), (2 * (nx + ny)) as usize);
    for f in m.faces() {
        let n = face_normal(&m, f);
        assert!(
            n.z > 0.0 && n.x.abs() + n.y.abs() < 1e-12,
            "faces must face +z"
        );
    }
    let (lo, hi) = m.bounding_box().unwrap();
    assert!((lo - DVec3::new(-sx / 2.0, -sy / 2.0, 0.0)).length() < 1e-12);
    assert!((hi - DVec3::new(sx / 2.0, sy / 2.0, 0.0)).length() < 1e-12);
    // Boundary vertices are exactly those on the rectangle's border.
    for (a, _) in boundary_edges(&m) {
        let p = m.positions[a as usize];
        let on_x = (p.x.abs() - sx / 2.0).abs() < 1e-12;
        let on_y = (p.y.abs() - sy / 2.0).abs() < 1e-12;
        assert!(
            on_x || on_y,
            "boundary vertex {a} at {p} is inside the rectangle"
        );
    }
}

#[test]
fn height_grid_lifts_vertices() {
    let f = |x: f64, y: f64| (3.0 * x).sin() * y;
    let m = height_grid(6, 9, f);
    let flat = grid(6, 9, 1.0, 1.0);
    assert_eq!(m.indices, flat.indices);
    for (p, q) in m.positions.iter().zip(&flat.positions) {
        assert_eq!((p.x, p.y), (q.x, q.y));
        assert!((p.z - f(p.x, p.y)).abs() < 1e-15);
    }
}

#[test]
fn two_components_are_disjoint_closed_pieces() {
    let m = two_components();
    assert_eq!(components(&m), 2);
    assert_eq!(euler(&m), 4);
    assert_eq!((m.vertex_count(), m.face_count()), (106, 102));
    assert_closed_oriented(&m);
    let cube_part = &m.positions[..8];
    let sphere_part = &m.positions[8..];
    let cube_max_x = cube_part.iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let sphere_min_x = sphere_part.iter().map(|p| p.x).fold(f64::MAX, f64::min);
    assert!(cube_max_x < sphere_min_x, "components overlap");
}

#[test]
fn noisy_is_deterministic_and_bounded() {
    let base = quad_sphere(4, 1.0);
    let a = noisy(&base, 0.01, 42);
    let b = noisy(&base, 0.01, 42);
    let c = noisy(&base, 0.01, 43);
    assert_eq!(a, b);
    assert_ne!(a.positions, c.positions);
    assert_eq!(a.indices, base.indices);
    let mut max_off = 0.0f64;
    for (p, q) in a.positions.iter().zip(&base.positions) {
        let d = (p - q).abs().max_element();
        assert!(d <= 0.01);
        max_off = max_off.max(d);
    }
    assert!(
        max_off > 0.005,
        "noise should use most of its range, got {max_off}"
    );
}

#[test]
fn bumpy_torus_keeps_torus_topology() {
    let m = bumpy_torus(32, 16, 3.0, 1.0, 0.3, 9);
    let t = torus(32, 16, 3.0, 1.0);
    assert_eq!(m.indices, t.indices);
    assert_eq!(m, bumpy_torus(32, 16, 3.0, 1.0, 0.3, 9));
    assert_ne!(
        m.positions,
        bumpy_torus(32, 16, 3.0, 1.0, 0.3, 10).positions
    );
    assert_closed_oriented(&m);
    assert_outward(&m, |c| DVec3::new(c.x, c.y, 0.0).normalize() * 3.0);
    let radii: Vec<f64> = m
        .positions
        .iter()
        .map(|p| (p - DVec3::new(p.x, p.y, 0.0).normalize() * 3.0).length())
        .collect();
    assert!(radii
        .iter()
        .all(|&r| (0.7 - 1e-9..=1.3 + 1e-9).contains(&r)));
    assert!(
        radii.iter().any(|&r| (r - 1.0).abs() > 0.05),
        "no visible bumps"
    );
}
