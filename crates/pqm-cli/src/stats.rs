//! Mesh statistics for the CLI (`pqm stats`, `--stats`).
//!
//! Temporary stand-in for `pqm_core::metrics::{mesh_stats, MeshStats}`
//! (same field names), computed with what `pqm_core::Mesh` offers; the
//! Hausdorff distance is not available here. Replaced by a re-export once the
//! metrics module is on main.

use pqm_core::ops::quad_scaled_jacobian;
use pqm_core::{IndexedMesh, Mesh};
use serde::Serialize;
use std::fmt;

/// Scaled Jacobian summary over the quads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ScaledJacobianStats {
    /// Median over the faces.
    pub median: f64,
    /// Minimum over the faces.
    pub worst: f64,
}

/// Vertex structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ValenceStats {
    /// Fraction of vertices with their ideal valence.
    pub ideal_fraction: f64,
    /// Vertices whose valence is not ideal.
    pub extraordinary: usize,
    /// Largest valence.
    pub worst: usize,
}

/// Symmetric Hausdorff distance, fractions of the reference's bbox diagonal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct HausdorffStats {
    /// Maximum distance.
    pub max: f64,
    /// Mean distance.
    pub mean: f64,
}

/// Quality and structure figures of a mesh.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshStats {
    pub vertices: usize,
    pub faces: usize,
    pub quads: usize,
    pub triangles: usize,
    pub other_faces: usize,
    pub boundary_loops: usize,
    pub components: usize,
    pub genus: i64,
    pub euler: i64,
    pub scaled_jacobian: ScaledJacobianStats,
    pub valence: ValenceStats,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hausdorff: Option<HausdorffStats>,
}

/// The statistics of `mesh` (the reference is ignored by this stand-in).
pub fn mesh_stats(mesh: &IndexedMesh, _reference: Option<&IndexedMesh>) -> MeshStats {
    let (quads, triangles, other_faces) = mesh.face_size_counts();
    let mut s = MeshStats {
        vertices: mesh.vertex_count(),
        faces: mesh.face_count(),
        quads,
        triangles,
        other_faces,
        boundary_loops: 0,
        components: 0,
        genus: 0,
        euler: 0,
        scaled_jacobian: ScaledJacobianStats::default(),
        valence: ValenceStats::default(),
        hausdorff: None,
    };
    let Ok(m) = Mesh::from_indexed(mesh) else {
        return s;
    };
    s.boundary_loops = m.boundary_loops().len();
    s.components = m.components().1;
    s.genus = m.genus();
    s.euler = m.euler_characteristic();
    let mut sj: Vec<f64> = m
        .faces()
        .map(|f| match m.quad_vertices(f) {
            Some(q) => quad_scaled_jacobian(q.map(|v| m.position(v))),
            None => 0.0,
        })
        .collect();
    sj.sort_by(f64::total_cmp);
    if !sj.is_empty() {
        s.scaled_jacobian = ScaledJacobianStats {
            median: sj[sj.len() / 2],
            worst: sj[0],
        };
    }
    let n = m.vertex_count();
    let ideal = m
        .vertices()
        .filter(|&v| m.valence(v) == m.ideal_valence(v))
        .count();
    s.valence = ValenceStats {
        ideal_fraction: if n > 0 { ideal as f64 / n as f64 } else { 0.0 },
        extraordinary: n - ideal,
        worst: m.vertices().map(|v| m.valence(v)).max().unwrap_or(0),
    };
    s
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
