//! Simplification-based quad remeshing (the qCoarsen paper, section 5,
//! Fig. 7–8): turn any polygon mesh, of any genus, into a quad-only mesh
//! with adaptive, curvature-aware element sizes.
//!
//! # Pipeline
//!
//! 1. **Split** — one Catmull-Clark split with linear points
//!    ([`catmull_clark_split`] with [`SplitMode::Linear`]): every n-gon
//!    becomes n quads and the surface does not move. This is done even for
//!    quad-only input, so every input goes through the same pipeline (the
//!    split mesh has 4× the quads of a quad input; coarsening to the default
//!    ratio of 0.25 lands near the input's count again, with the
//!    coarsener's structure).
//! 2. **Coarsen** — qCoarsen ([`Coarsener::with_defaults`]: importance and
//!    direction field from the principal curvatures, feature curves from the
//!    dihedral angle and the boundary loops) down to `ratio` of the split
//!    mesh's faces, or until no legal step is left. The coarsener keeps the
//!    topology (components, boundary loops, genus) and the mesh quad-only.
//! 3. **Subdivide** — `levels` Catmull-Clark steps ([`SplitMode::CatmullClark`])
//!    of the coarse mesh: smooth, and ×4 faces per level.
//! 4. **Project** — every vertex of the subdivided mesh moves to its closest
//!    point on the *original* surface (the input triangulated like
//!    [`crate::metrics::hausdorff::triangulate`]), found through a
//!    [`Bvh`]; in parallel with rayon. Projection moves positions only, so
//!    the connectivity of step 3 — quad-only, manifold, same genus — is the
//!    output's.
//!
//! # Measurements
//!
//! [`RemeshResult`] describes three stages, each with face and vertex
//! counts, the valence structure ([`mod@crate::metrics::valence`]) and, when
//! [`RemeshOptions::measure`] is set, the symmetric sampled Hausdorff
//! distance to the input ([`mod@crate::metrics::hausdorff`], default sampling)
//! in units of the **input's bounding-box diagonal**: the split (the
//! pipeline's starting point; its distance is ~0 since the split does not
//! move the surface), the coarse mesh, and the output. Wall-clock seconds
//! of every phase are reported too.
//!
//! # Cost
//!
//! Dominated by the coarsening of the split mesh (`C` quads for `C` input
//! corners; fertility's 9,000 triangles give 27,000 quads) and, with
//! measurement on, by the Hausdorff sampling of the largest stage. Memory
//! grows as `4^levels` × the coarse mesh.

use crate::attributes::AttributeError;
use crate::bvh::{Bvh, BvhError};
use crate::coarsen::{CoarsenOptions, CoarsenReport, Coarsener, Smoothing};
use crate::mesh::{Mesh, MeshError};
use crate::metrics::hausdorff::{hausdorff, triangulate, HausdorffOptions, HausdorffStats};
use crate::metrics::valence::{valence, ValenceStats};
use crate::subdivide::{catmull_clark_split, SplitMode, SubdivideError};
use crate::IndexedMesh;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;
use thiserror::Error;

/// The largest `levels` accepted: each level multiplies the faces by 4.
pub const MAX_LEVELS: u32 = 6;

/// Parameters of [`remesh`].
#[derive(Clone, Debug, PartialEq)]
pub struct RemeshOptions {
    /// Target face count of the coarsening as a fraction of the split
    /// mesh's faces, in `(0, 1]` (default 0.25, the paper's "quarter of the
    /// original element count"). The coarsener may stop above it when no
    /// legal step is left.
    pub ratio: f64,
    /// Catmull-Clark subdivision steps after the coarsening, `0..=6`
    /// (default 1). With 0 the coarse mesh itself is projected.
    pub levels: u32,
    /// Dihedral angle in degrees above which an edge is a feature the
    /// coarsener keeps (default 60, as `pqm coarsen`; 180 turns it off).
    pub sharp_angle: f64,
    /// The coarsener's smoothing (default global, as the paper).
    pub smoothing: Smoothing,
    /// Measure the Hausdorff distance of every stage to the input (default
    /// true; the valence structure and counts are always reported).
    pub measure: bool,
}

impl Default for RemeshOptions {
    fn default() -> Self {
        RemeshOptions {
            ratio: 0.25,
            levels: 1,
            sharp_angle: 60.0,
            smoothing: Smoothing::Global,
            measure: true,
        }
    }
}

/// Why [`remesh`] failed.
#[derive(Debug, Error)]
pub enum RemeshError {
    /// An option is out of range.
    #[error("invalid remesh option: {0}")]
    Options(String),
    /// The input cannot be split (degenerate or malformed faces).
    #[error("cannot split the input into quads: {0}")]
    Split(#[from] SubdivideError),
    /// The split input is not a manifold, consistently oriented mesh.
    #[error("the input is not a valid polygon mesh: {0}")]
    Mesh(#[from] MeshError),
    /// The coarsener's attributes or feature curves could not be set up.
    #[error("cannot set up the coarsener: {0}")]
    Attributes(#[from] AttributeError),
    /// The input's surface cannot be used for projection (non-finite
    /// coordinates, ...).
    #[error("cannot build the projection BVH of the input: {0}")]
    Bvh(#[from] BvhError),
}

/// Figures of one stage of the pipeline.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageStats {
    /// Number of faces (all quads after the split).
    pub faces: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Vertex structure: ideal fraction, extraordinary count, worst valence.
    pub valence: ValenceStats,
    /// Symmetric Hausdorff `{max, mean}` to the input, in units of the
    /// input's bounding-box diagonal (`None` unless measured).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hausdorff: Option<HausdorffStats>,
}

/// Wall-clock seconds of each phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RemeshTiming {
    /// The linear Catmull-Clark split.
    pub split: f64,
    /// Coarsener setup (curvature, features) and run.
    pub coarsen: f64,
    /// Catmull-Clark subdivision.
    pub subdivide: f64,
    /// BVH build and projection.
    pub project: f64,
    /// Measurements (valence, Hausdorff) of all stages.
    pub measure: f64,
    /// Everything.
    pub total: f64,
}

/// Output of [`remesh`].
#[derive(Clone, Debug)]
pub struct RemeshResult {
    /// The remeshed quad-only mesh.
    pub mesh: IndexedMesh,
    /// The split input (pipeline start).
    pub split: StageStats,
    /// The coarsened mesh, before subdivision and projection.
    pub coarse: StageStats,
    /// The output.
    pub output: StageStats,
    /// What the coarsener did (operator counts, stop reason, error bound).
    pub coarsen: CoarsenReport,
    /// Seconds per phase.
    pub timing: RemeshTiming,
}

/// A phase of the pipeline, reported to the progress callback of
/// [`remesh_with_progress`] when it starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RemeshPhase {
    /// Linear split of the input.
    Split,
    /// Coarsening; the payload is the current face count (reported now and
    /// then while it runs).
    Coarsen(usize),
    /// Catmull-Clark subdivision.
    Subdivide,
    /// Projection onto the input.
    Project,
    /// Valence and Hausdorff measurements.
    Measure,
}

/// Remeshes `input` (see the module documentation).
pub fn remesh(input: &IndexedMesh, opts: &RemeshOptions) -> Result<RemeshResult, RemeshError> {
    remesh_with_progress(input, opts, &mut |_| {})
}

/// [`remesh`] with a callback told about each phase (and the face count
/// while coarsening), for progress bars.
pub fn remesh_with_progress(
    input: &IndexedMesh,
    opts: &RemeshOptions,
    progress: &mut dyn FnMut(RemeshPhase),
) -> Result<RemeshResult, RemeshError> {
    if !(opts.ratio > 0.0 && opts.ratio <= 1.0) {
        return Err(RemeshError::Options(format!(
            "ratio {} is not in (0, 1]",
            opts.ratio
        )));
    }
    if opts.levels > MAX_LEVELS {
        return Err(RemeshError::Options(format!(
            "{} subdivision levels is more than the {MAX_LEVELS} allowed (each one multiplies the faces by 4)",
            opts.levels
        )));
    }
    if !(0.0..=180.0).contains(&opts.sharp_angle) {
        return Err(RemeshError::Options(format!(
            "sharp angle {} is not in [0, 180] degrees",
            opts.sharp_angle
        )));
    }
    let start = Instant::now();
    let mut timing = RemeshTiming::default();

    progress(RemeshPhase::Split);
    let t = Instant::now();
    let split = catmull_clark_split(input, SplitMode::Linear)?;
    let split_mesh = Mesh::from_indexed(&split)?;
    timing.split = t.elapsed().as_secs_f64();

    progress(RemeshPhase::Coarsen(split.face_count()));
    let t = Instant::now();
    let copts = CoarsenOptions {
        target_ratio: Some(opts.ratio),
        smoothing: opts.smoothing,
        ..CoarsenOptions::default()
    };
    let mut coarsener = Coarsener::with_defaults(split_mesh, opts.sharp_angle, &[], copts)?;
    let report = coarsener.run(&mut |faces| progress(RemeshPhase::Coarsen(faces)));
    let (coarse, _) = coarsener.mesh().to_indexed();
    drop(coarsener);
    timing.coarsen = t.elapsed().as_secs_f64();

    progress(RemeshPhase::Subdivide);
    let t = Instant::now();
    let mut out = coarse.clone();
    for _ in 0..opts.levels {
        out = catmull_clark_split(&out, SplitMode::CatmullClark)?;
    }
    timing.subdivide = t.elapsed().as_secs_f64();

    progress(RemeshPhase::Project);
    let t = Instant::now();
    project_onto(&mut out, input)?;
    timing.project = t.elapsed().as_secs_f64();

    progress(RemeshPhase::Measure);
    let t = Instant::now();
    let stage = |m: &IndexedMesh| StageStats {
        faces: m.face_count(),
        vertices: m.vertex_count(),
        valence: valence(m).stats,
        hausdorff: opts
            .measure
            .then(|| hausdorff(m, input, &HausdorffOptions::default()).symmetric),
    };
    let (split_stats, (coarse_stats, out_stats)) = rayon::join(
        || stage(&split),
        || rayon::join(|| stage(&coarse), || stage(&out)),
    );
    timing.measure = t.elapsed().as_secs_f64();
    timing.total = start.elapsed().as_secs_f64();

    Ok(RemeshResult {
        mesh: out,
        split: split_stats,
        coarse: coarse_stats,
        output: out_stats,
        coarsen: report,
        timing,
    })
}

/// Moves every vertex of `mesh` to its closest point on the surface of
/// `surface` (triangulated; quads split along the shorter diagonal). The
/// connectivity of `mesh` is untouched.
pub fn project_onto(mesh: &mut IndexedMesh, surface: &IndexedMesh) -> Result<(), RemeshError> {
    let tris = triangulate(surface);
    let bvh = Bvh::build(&surface.positions, &tris)?;
    if bvh.is_empty() {
        return Err(RemeshError::Options(
            "the surface to project onto has no usable face".into(),
        ));
    }
    mesh.positions.par_iter_mut().for_each(|p| {
        // `None` only for a non-finite point; such a vertex stays put.
        if let Some((q, _, _)) = bvh.closest_point(*p) {
            *p = q;
        }
    });
    Ok(())
}
