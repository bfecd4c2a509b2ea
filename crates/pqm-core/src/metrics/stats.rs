//! [`MeshStats`]: every Table 1 figure of the qCoarsen paper in one record.
//!
//! The record serialises with serde (field names as below) and prints as a
//! two-column table with `Display`. Definitions live in the metric modules:
//! [`mod@super::topology`], [`mod@super::scaled_jacobian`], [`mod@super::valence`],
//! [`mod@super::hausdorff`].

use super::hausdorff::{hausdorff, HausdorffOptions, HausdorffStats};
use super::scaled_jacobian::{scaled_jacobian, ScaledJacobianStats};
use super::topology::topology;
use super::valence::{valence, ValenceStats};
use crate::IndexedMesh;
use serde::Serialize;
use std::fmt;

/// Quality and structure figures of a mesh.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshStats {
    /// Number of positions in the mesh (`vertex_count()`, referenced or not).
    pub vertices: usize,
    /// Number of faces (`face_count()`).
    pub faces: usize,
    /// Faces with 4 corners.
    pub quads: usize,
    /// Faces with 3 corners.
    pub triangles: usize,
    /// Faces with any other number of corners.
    pub other_faces: usize,
    /// Boundary loops (see [`mod@super::topology`]).
    pub boundary_loops: usize,
    /// Connected components.
    pub components: usize,
    /// Genus, summed over the components.
    pub genus: i64,
    /// Euler characteristic `V − E + F` over referenced vertices and usable faces.
    pub euler: i64,
    /// Scaled Jacobian `{median, worst}` over all faces.
    pub scaled_jacobian: ScaledJacobianStats,
    /// Vertex structure `{ideal_fraction, extraordinary, worst}`.
    pub valence: ValenceStats,
    /// Irregular vertices the topology forces on a doublet-free quad mesh
    /// (8 per closed sphere; see [`mod@super::topology`]): `extraordinary` can
    /// never go below it, so it bounds the ideal fraction any coarsening
    /// can reach at a given vertex count.
    pub forced_irregular: usize,
    /// Symmetric Hausdorff `{max, mean}` to the reference, in units of the
    /// reference's bounding-box diagonal; only present when a reference is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hausdorff: Option<HausdorffStats>,
}

/// Computes the [`MeshStats`] of `mesh`; with a `reference`, also the symmetric
/// Hausdorff distance to it (default [`HausdorffOptions`]).
pub fn mesh_stats(mesh: &IndexedMesh, reference: Option<&IndexedMesh>) -> MeshStats {
    let (quads, triangles, other_faces) = mesh.face_size_counts();
    let topo = topology(mesh);
    MeshStats {
        vertices: mesh.vertex_count(),
        faces: mesh.face_count(),
        quads,
        triangles,
        other_faces,
        boundary_loops: topo.boundary_loops,
        components: topo.components,
        genus: topo.genus,
        euler: topo.euler,
        scaled_jacobian: scaled_jacobian(mesh).stats,
        valence: valence(mesh).stats,
        forced_irregular: topo.forced_irregular,
        hausdorff: reference.map(|r| hausdorff(mesh, r, &HausdorffOptions::default()).symmetric),
    }
}

impl fmt::Display for MeshStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let row = |f: &mut fmt::Formatter<'_>, name: &str, value: String| {
            writeln!(f, "{name:<24} {value}")
        };
        row(f, "vertices", self.vertices.to_string())?;
        row(
            f,
            "faces",
            format!(
                "{} ({} quads, {} triangles, {} other)",
                self.faces, self.quads, self.triangles, self.other_faces
            ),
        )?;
        row(f, "components", self.components.to_string())?;
        row(f, "boundary loops", self.boundary_loops.to_string())?;
        row(f, "genus", self.genus.to_string())?;
        row(f, "euler characteristic", self.euler.to_string())?;
        row(
            f,
            "scaled jacobian",
            format!(
                "median {:.3}, worst {:.3}",
                self.scaled_jacobian.median, self.scaled_jacobian.worst
            ),
        )?;
        row(
            f,
            "valence",
            format!(
                "{:.1}% ideal, {} extraordinary, worst {}",
                100.0 * self.valence.ideal_fraction,
                self.valence.extraordinary,
                self.valence.worst
            ),
        )?;
        if self.forced_irregular > 0 {
            row(
                f,
                "forced irregular",
                format!(
                    "{} (the least a quad mesh of this topology has without valence-2 vertices)",
                    self.forced_irregular
                ),
            )?;
        }
        if let Some(h) = &self.hausdorff {
            row(
                f,
                "hausdorff (x bbox diag)",
                format!("max {:.3e}, mean {:.3e}", h.max, h.mean),
            )?;
        }
        Ok(())
    }
}
