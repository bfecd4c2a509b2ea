//! Boundary runs: the qeMerge that shortens a boundary loop.
//!
//! Feature rule 1 lets at most two feature vertices merge, and only along a
//! feature edge. A boundary loop is a feature curve, and the one qeMerge
//! that removes boundary vertices — across an interior edge `a–d` whose
//! endpoint `a` is a boundary vertex of valence 3, so that `b` and `f` are
//! `a`'s two neighbours along the boundary — merges three feature vertices,
//! `b, f → a`. Under rule 1 alone no boundary vertex ever went: loki's four
//! loops kept all 328 of their vertices down to 2,000 faces, and the quads
//! along them fanned from that dense boundary into the coarse interior —
//! 113 of its 440 interior defects sat next to the boundary.
//!
//! **Boundary run** (ours; the paper's rule 1 speaks of two merging feature
//! points): three vertices merging into the middle one of a run `b – a – f`
//! of boundary edges of one curve are two merges along the curve, each of
//! consecutive vertices, so the curve is not pinched. The survivor keeps
//! `a`'s position (it is on the input boundary), and neither `b` nor `f`
//! may be a feature corner (a corner never moves, and `a` would have to go
//! to it). Rules 2 and 3 are checked after the step as for any merge
//! ([`super::features::FeatureState::check_after`]): the loop loses two
//! edges and must keep three. Only boundary runs: on an interior sharp
//! curve the same merge re-fans the quads on the curve's other side; let
//! through there too, it took fandisk from 453 to 279 faces at 70.1 %
//! ideal (floor 81 %) and loki only 0.2 points further.
//!
//! Loki → 2,000 faces: boundary 328 → 74–80 vertices, ideal fraction
//! 78.2 → 82.3 %, Scaled Jacobian median 0.793 → 0.842 (with the fix
//! phases, [`super::fix_phase`]: 84.8 %, 0.858).
//!
//! Invariant: every group this allows is one [`FeatureState::check_group`]
//! refuses only for having three feature vertices; everything else is its
//! verdict unchanged.
//!
//! [`FeatureState::check_group`]: super::features::FeatureState::check_group

use super::features::GroupConstraint;
use super::{Coarsener, MAX_SURFACE_DEVIATION};
use crate::mesh::VertexId;
use crate::ops::Reject;

/// The refusal [`super::features::FeatureState::check_group`] gives a
/// group of three feature vertices (the one case a boundary run overrides).
const THREE_FEATURES: &str = "more than two feature vertices would merge";

impl Coarsener {
    /// Feature rule 1 for a qeMerge endpoint's group: `b` and `f` merge
    /// into `a`. [`super::features::FeatureState::check_group`], except that
    /// a boundary run (see the module docs) is allowed, pinned at `a`.
    pub(super) fn qe_endpoint_group(
        &self,
        a: VertexId,
        b: VertexId,
        f: VertexId,
    ) -> Result<GroupConstraint, Reject> {
        match self.features.check_group(&[a, b, f]) {
            Err(Reject::Feature(why)) if why == THREE_FEATURES && self.is_boundary_run(a, b, f) => {
                Ok(GroupConstraint::Pinned(a))
            }
            r => r,
        }
    }

    /// Whether `b – a – f` is a run of two boundary edges that are feature
    /// edges, with no feature corner at `b` or `f`, where the boundary
    /// keeps its shape: neither `b` nor `f` is a geometric corner (ideal
    /// valence 2: a grid's corner would be cut off) and each lies within
    /// [`MAX_SURFACE_DEVIATION`] of the boundary segment that replaces it
    /// (`b`'s other boundary neighbour to `a`; the vertex's quadric, which
    /// [`Coarsener::surface_deviation`] bounds, holds no boundary line).
    fn is_boundary_run(&self, a: VertexId, b: VertexId, f: VertexId) -> bool {
        let m = &self.mesh;
        let fs = &self.features;
        let boundary_edge = |u: VertexId, v: VertexId| {
            m.find_halfedge(u, v)
                .is_some_and(|h| m.is_boundary_halfedge(h) || m.is_boundary_halfedge(m.twin(h)))
        };
        let runs = b != f
            && boundary_edge(a, b)
            && boundary_edge(a, f)
            && fs.is_feature_edge(a, b)
            && fs.is_feature_edge(a, f)
            && !fs.is_corner(b)
            && !fs.is_corner(f);
        runs && [b, f].into_iter().all(|x| self.boundary_keeps_shape(a, x))
    }

    /// `x`, a boundary neighbour of `a` merging into it, is no geometric
    /// corner and lies within [`MAX_SURFACE_DEVIATION`] of the segment from
    /// its other boundary neighbour to `a`.
    fn boundary_keeps_shape(&self, a: VertexId, x: VertexId) -> bool {
        let m = &self.mesh;
        if m.ideal_valence(x) != 3 {
            return false;
        }
        let Some(y) = m
            .outgoing(x)
            .filter(|&h| m.is_boundary_halfedge(h) || m.is_boundary_halfedge(m.twin(h)))
            .map(|h| m.to_vertex(h))
            .find(|&y| y != a)
        else {
            return false;
        };
        let (p, s, t) = (m.position(x), m.position(y), m.position(a));
        let st = t - s;
        let u = ((p - s).dot(st) / st.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        (p - (s + st * u)).length() <= MAX_SURFACE_DEVIATION * self.diag
    }
}

#[cfg(test)]
mod tests {
    use super::super::{CoarsenOptions, Coarsener, Placement};
    use crate::mesh::Mesh;
    use crate::shapes;

    fn boundary_vertices(m: &Mesh) -> usize {
        m.vertices().filter(|&v| m.is_boundary_vertex(v)).count()
    }

    /// A grid's boundary gets coarser too: with boundary runs the
    /// coarsened grid has fewer boundary vertices than the input (without
    /// them it kept every one), and still one loop, quad-only and valid,
    /// under both placements; the records replay to the input.
    #[test]
    fn boundary_runs_shorten_the_boundary() {
        let src = shapes::grid(12, 10, 1.2, 1.0);
        for placement in [Placement::Qem, Placement::Subset] {
            let mesh = Mesh::from_indexed(&src).unwrap();
            let before = boundary_vertices(&mesh);
            let opts = CoarsenOptions {
                target_faces: Some(30),
                placement,
                ..Default::default()
            };
            let mut c = Coarsener::with_defaults(mesh, 180.0, &[], opts).expect("features");
            let curves = c.features().live_curves();
            c.run(&mut |_| {});
            let m = c.mesh();
            m.validate().unwrap();
            assert!(m.faces().all(|f| m.face_degree(f) == 4));
            assert_eq!(c.features().live_curves(), curves);
            let after = boundary_vertices(m);
            assert!(
                after < before,
                "{placement:?}: boundary {before} -> {after} vertices"
            );
            let pm = c.to_progressive();
            pm.validate().unwrap();
            assert_eq!(pm.level(pm.records.len()).face_count(), src.face_count());
        }
    }

    /// Only boundary runs are let through: an interior vertex with its two
    /// neighbours along a row is not one, nor is a run ending at a corner.
    #[test]
    fn only_boundary_runs() {
        let src = shapes::grid(4, 4, 1.0, 1.0);
        let mesh = Mesh::from_indexed(&src).unwrap();
        let c = Coarsener::with_defaults(mesh, 180.0, &[], CoarsenOptions::default())
            .expect("features");
        let m = c.mesh();
        // grid vertex (i, j) has id j * 5 + i
        let v = |i: u32, j: u32| crate::mesh::VertexId(j * 5 + i);
        // along the bottom row, away from the corners: a run
        assert!(c.is_boundary_run(v(2, 0), v(1, 0), v(3, 0)));
        assert!(c.qe_endpoint_group(v(2, 0), v(1, 0), v(3, 0)).is_ok());
        // ending at the grid's corner (0, 0): not one (a closed loop has
        // no feature corner, but the boundary turns there)
        assert!(!c.is_boundary_run(v(1, 0), v(0, 0), v(2, 0)));
        assert!(c.qe_endpoint_group(v(1, 0), v(0, 0), v(2, 0)).is_err());
        // interior vertices are no feature: rule 1 alone decides
        assert!(!m.is_boundary_vertex(v(2, 2)));
        assert!(c.qe_endpoint_group(v(2, 2), v(1, 2), v(3, 2)).is_ok());
        assert!(!c.is_boundary_run(v(2, 2), v(1, 2), v(3, 2)));
    }
}
