//! Centroidal tangential smoothing: jitter reduction on a plane, staying on
//! a sphere, pinned vertices, importance weighting, local = global.

mod attributes_shapes;
use attributes_shapes::*;

use glam::DVec3;
use pqm_core::features::{sharp_edges, FeatureCurves};
use pqm_core::smoothing::{default_movable, smooth_global, smooth_vertices, smoothed_position};
use pqm_core::{Mesh, VertexId};

/// A 12 × 12 grid with interior vertices jittered in the plane by up to
/// `amp`, plus the unjittered positions.
fn jittered_grid(amp: f64) -> (Mesh, Vec<DVec3>) {
    let im = grid(12, 12);
    let reference = im.positions.clone();
    let mut m = mesh(&im);
    let mut rng = Rng(0x9e3779b97f4a7c15);
    for v in m.vertices().collect::<Vec<_>>() {
        if !m.is_boundary_vertex(v) {
            let d = DVec3::new(rng.signed(), rng.signed(), 0.0) * amp;
            m.set_position(v, m.position(v) + d);
        }
    }
    (m, reference)
}

fn rms_error(m: &Mesh, reference: &[DVec3]) -> f64 {
    let (mut s, mut n) = (0.0, 0.0);
    for v in m.vertices() {
        s += m.position(v).distance_squared(reference[v.idx()]);
        n += 1.0;
    }
    (s / n).sqrt()
}

#[test]
fn smoothing_a_jittered_plane_reduces_jitter_and_stays_planar() {
    let (mut m, reference) = jittered_grid(0.3);
    let before = rms_error(&m, &reference);
    let movable = default_movable(&m, None);
    let boundary: Vec<(VertexId, DVec3)> = m
        .vertices()
        .filter(|&v| m.is_boundary_vertex(v))
        .map(|v| (v, m.position(v)))
        .collect();
    smooth_global(&mut m, &[], &movable, 20);
    let after = rms_error(&m, &reference);
    assert!(after < 0.25 * before, "rms {before} → {after}");
    for v in m.vertices() {
        assert_eq!(m.position(v).z, 0.0, "left the plane at {v:?}");
    }
    for (v, p) in boundary {
        assert_eq!(m.position(v), p, "boundary vertex {v:?} moved");
    }
    m.validate().unwrap();
}

#[test]
fn smoothing_keeps_a_sphere_round() {
    let r = 2.0;
    let mut m = mesh(&quad_sphere(10, r));
    let mut rng = Rng(7);
    // tangential jitter only
    for v in m.vertices().collect::<Vec<_>>() {
        let p = m.position(v);
        let n = p.normalize();
        let (t1, t2) = n.any_orthonormal_pair();
        let q = p + (t1 * rng.signed() + t2 * rng.signed()) * 0.05;
        m.set_position(v, q.normalize() * r);
    }
    let movable = default_movable(&m, None);
    assert!(
        movable.iter().all(|&b| b),
        "a closed sphere has no boundary"
    );
    smooth_global(&mut m, &[], &movable, 10);
    let mut worst: f64 = 0.0;
    for v in m.vertices() {
        worst = worst.max((m.position(v).length() - r).abs());
    }
    // plain (unprojected) centroid averaging shrinks a sphere by about
    // edge²/R per step; the tangent projection keeps it within a fraction
    assert!(worst < 0.01 * r, "radius drift {worst}");

    // compare with averaging without projection, one step
    let m0 = mesh(&quad_sphere(10, r));
    let v = VertexId(0);
    let c: DVec3 = m0
        .vertex_faces(v)
        .map(|f| m0.face_centroid(f))
        .sum::<DVec3>()
        / m0.vertex_faces(v).count() as f64;
    let projected = smoothed_position(&m0, &[], v, |u| m0.position(u)).unwrap();
    assert!((projected.length() - r).abs() < (c.length() - r).abs());
}

#[test]
fn feature_vertices_and_pinned_vertices_do_not_move() {
    let mut m = mesh(&cube_lattice(4, |p| p));
    let edges = sharp_edges(&m, 60.0);
    let fc = FeatureCurves::new(&m, &edges, true).unwrap();
    let movable = default_movable(&m, Some(&fc));
    let mut rng = Rng(3);
    let mut pinned = Vec::new();
    for v in m.vertices().collect::<Vec<_>>() {
        if !movable[v.idx()] {
            pinned.push((v, m.position(v)));
        } else {
            // jitter within the cube face (the face normal is the axis with |coord| = 1)
            let p = m.position(v);
            let axis = p.abs().max_position();
            let mut d = DVec3::new(rng.signed(), rng.signed(), rng.signed()) * 0.1;
            d[axis] = 0.0;
            m.set_position(v, p + d);
        }
    }
    assert_eq!(
        pinned.len(),
        12 * 3 + 8,
        "cube edges and corners are features"
    );
    smooth_global(&mut m, &[], &movable, 5);
    for (v, p) in pinned {
        assert_eq!(m.position(v), p);
    }
    // the cube faces stay flat: the moved vertices keep their face coordinate
    for v in m.vertices() {
        assert!((m.position(v).abs().max_element() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn importance_pulls_vertices_towards_important_faces() {
    let im = grid(4, 4);
    let m = mesh(&im);
    let center = VertexId(grid_id(4, 2, 2));
    let p0 = m.position(center);
    // uniform importance: a regular grid is a fixed point
    let uniform = smoothed_position(&m, &[], center, |u| m.position(u)).unwrap();
    assert!((uniform - p0).length() < 1e-12);
    // important vertices on the +x side attract the vertex towards +x
    let mut imp = vec![1.0; m.vertex_capacity()];
    for j in 0..=4 {
        imp[grid_id(4, 3, j) as usize] = 3.0;
        imp[grid_id(4, 4, j) as usize] = 3.0;
    }
    let pulled = smoothed_position(&m, &imp, center, |u| m.position(u)).unwrap();
    assert!(pulled.x > p0.x + 0.05 && (pulled.y - p0.y).abs() < 1e-12 && pulled.z == 0.0);
    // bad entries count as 1
    let mut bad = vec![1.0; m.vertex_capacity()];
    bad[0] = f64::NAN;
    bad[1] = -2.0;
    assert_eq!(
        smoothed_position(&m, &bad, VertexId(grid_id(4, 1, 1)), |u| m.position(u)),
        smoothed_position(&m, &[], VertexId(grid_id(4, 1, 1)), |u| m.position(u))
    );
}

#[test]
fn local_smoothing_matches_global_and_is_order_independent() {
    let (m, _) = jittered_grid(0.3);
    let movable = default_movable(&m, None);
    let all: Vec<VertexId> = m.vertices().collect();
    let local = smooth_vertices(&m, &[], &movable, &all, 4);
    let mut g = m.clone();
    smooth_global(&mut g, &[], &movable, 4);
    assert_eq!(local.len(), all.iter().filter(|v| movable[v.idx()]).count());
    for &(v, p) in &local {
        assert!((g.position(v) - p).length() < 1e-12);
    }
    // reversed list with duplicates and unmovable vertices: same positions,
    // in the order of first appearance, each once
    let mut list: Vec<VertexId> = all.iter().rev().copied().collect();
    list.extend_from_slice(&all[..10]);
    let other = smooth_vertices(&m, &[], &movable, &list, 4);
    assert_eq!(other.len(), local.len());
    let expected: Vec<VertexId> = all
        .iter()
        .rev()
        .copied()
        .filter(|v| movable[v.idx()])
        .collect();
    assert_eq!(other.iter().map(|e| e.0).collect::<Vec<_>>(), expected);
    for (v, p) in other {
        assert_eq!(g.position(v), p);
    }
    // a subset: unlisted vertices are fixed, listed ones move
    let some = [VertexId(grid_id(12, 5, 5)), VertexId(grid_id(12, 6, 5))];
    let moved = smooth_vertices(&m, &[], &movable, &some, 1);
    assert_eq!(moved.len(), 2);
    for (v, p) in moved {
        let expect = smoothed_position(&m, &[], v, |u| m.position(u)).unwrap();
        assert_eq!(p, expect);
    }
    assert!(
        smooth_vertices(&m, &[], &[], &some, 3).is_empty(),
        "nothing movable"
    );
}
