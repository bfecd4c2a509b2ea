//! The shared front half of `coarsen` and `encode`: read and check the
//! input, load the user's attributes, split non-quad meshes into quads, and
//! set up the [`Coarsener`].
//!
//! User attributes are read against the input *as read* (vertex indices of
//! the file). When the input goes through the linear split or bridging,
//! they are carried onto the quad mesh: per-vertex values travel as vertex
//! properties (edge points get the average of their endpoints, face points
//! the average of their face), and each feature polyline step `a → b`
//! becomes `a → edge point(s) → b` where the edge was cut. Original
//! vertices keep their indices.

use crate::ctx::{usage, Ctx};
use crate::util::mesh_input_format;
use anyhow::{anyhow, bail, Context};
use glam::DVec3;
use pqm_core::attributes::{
    importance_from_scalars, load_field_sidecar, load_importance_sidecar, remap_importance, Field,
};
use pqm_core::bridging::pair_and_bridge;
use pqm_core::coarsen::{Attributes, CoarsenOptions, Coarsener, Placement, Smoothing};
use pqm_core::features::{feature_edges_from_polylines, load_features, sharp_edges, FeatureCurves};
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use pqm_core::{io, IndexedMesh, Mesh, VertexId};
use std::path::{Path, PathBuf};

/// Smoothing mode on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmoothingArg {
    /// Only the relaxation each operator needs.
    None,
    /// Smooth the step's 1-ring after every step.
    Local,
    /// Smooth the whole coarse mesh once at the end (the paper's default).
    Global,
}

impl From<SmoothingArg> for Smoothing {
    fn from(s: SmoothingArg) -> Smoothing {
        match s {
            SmoothingArg::None => Smoothing::None,
            SmoothingArg::Local => Smoothing::Local,
            SmoothingArg::Global => Smoothing::Global,
        }
    }
}

/// Placement on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlacementArg {
    /// The paper's: QEM placement, relaxation and smoothing (best-shaped
    /// coarse quads; refining a level also moves a few vertices).
    Qem,
    /// Merged vertices keep their input positions and nothing else moves
    /// (Hoppe's half-edge collapse for quads): every level's vertices sit at
    /// input positions, so a .pqm stores each position once (files about
    /// half the size); coarse quads may have straight corners.
    Subset,
}

impl From<PlacementArg> for Placement {
    fn from(p: PlacementArg) -> Placement {
        match p {
            PlacementArg::Qem => Placement::Qem,
            PlacementArg::Subset => Placement::Subset,
        }
    }
}

/// Options of the coarsener shared by `pqm coarsen` and `pqm encode` (the
/// stop targets differ and are declared by each command).
#[derive(clap::Args, Clone, Debug)]
pub struct CoarsenerArgs {
    /// Importance map: a text file with one number per input vertex (`#`
    /// comments allowed), remapped to [1, 3]. Larger keeps elements smaller
    /// there. Default: from the curvature.
    #[arg(long, value_name = "FILE", help_heading = "Coarsener")]
    pub importance: Option<PathBuf>,
    /// Importance map from a per-vertex property of the input file (for
    /// example a PLY `quality` property).
    #[arg(
        long,
        value_name = "NAME",
        conflicts_with = "importance",
        help_heading = "Coarsener"
    )]
    pub importance_property: Option<String>,
    /// Direction field the quads align to: a text file with one `x y z`
    /// vector per input vertex or per face, or `x`, `y`, `z` for a constant
    /// axis. Default: principal curvature directions.
    #[arg(long, value_name = "FILE|x|y|z", help_heading = "Coarsener")]
    pub field: Option<String>,
    /// Feature polylines to keep: a text file, one polyline of 0-based input
    /// vertex indices per line (a closed curve repeats its first vertex).
    #[arg(long, value_name = "FILE", help_heading = "Coarsener")]
    pub features: Option<PathBuf>,
    /// Edges with a dihedral angle above DEG degrees are features; 180 turns
    /// automatic features off.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 60.0,
        help_heading = "Coarsener"
    )]
    pub sharp_angle: f64,
    /// Where merged vertices go. Default: `subset` for `pqm encode` (each
    /// position stored once), `qem` for `pqm coarsen` (the paper's).
    #[arg(long, value_enum, help_heading = "Coarsener")]
    pub placement: Option<PlacementArg>,
    /// Where vertices are smoothed (with `--placement qem`; default `global`,
    /// the paper's). `subset` placement never moves a vertex.
    #[arg(long, value_enum, help_heading = "Coarsener")]
    pub smoothing: Option<SmoothingArg>,
    /// Refuse non-quad input instead of making it quad-only (--triangles).
    #[arg(long, help_heading = "Coarsener")]
    pub no_subdivide: bool,
    /// How a triangle or mixed input becomes quad-only. `pair` (the
    /// default): adjacent triangles joined two by two, no new vertex, so
    /// the finest level is the input itself (each quad is two of its
    /// triangles, and `pqm encode` keeps each quad's diagonal so that a
    /// renderer draws exactly those) — on the shared triangle meshes
    /// 3.8–5.0× smaller files than `split` and 3–6× faster; the quads are as regular as the triangles
    /// allow; a triangle among quads pairs with another through the quads
    /// between them (re-pairing their halves). Polygons of five or more
    /// corners are cut into triangles first. A triangle no pairing can
    /// cover (an odd UV island or group, a pentagon's third triangle) is
    /// joined to another such triangle, or to the boundary, by a strip of
    /// quads cut at their edge midpoints: a few new vertices where the
    /// split would add them everywhere. Where even that fails, or would
    /// add more than a quarter of the input's vertices (most triangles
    /// alone), the input is split instead, with a note. `split`: each n-gon into n quads
    /// around new edge and face points (any input; about 6× the vertices
    /// of a triangle mesh, every level finer than the input; the files of
    /// sessions up to 23).
    #[arg(
        long,
        value_enum,
        default_value_t = TrianglesArg::Pair,
        help_heading = "Coarsener"
    )]
    pub triangles: TrianglesArg,
    /// Repair the input first (weld duplicates, drop unused vertices, split
    /// non-manifold vertices, re-orient) and report what changed.
    #[arg(long, help_heading = "Coarsener")]
    pub repair: bool,
}

/// `--triangles`: how a non-quad input becomes quad-only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TrianglesArg {
    /// The linear split (`pqm_core::subdivide`).
    Split,
    /// Triangle pairing (`pqm_core::pairing`) and strips for what it
    /// leaves alone (`pqm_core::bridging`), else the split.
    Pair,
}

/// How the coarsener's quad mesh came from the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum QuadConversion {
    /// The input was quad-only.
    None,
    /// Triangles joined in pairs: the same vertices.
    Paired,
    /// Triangles joined in pairs, and those left alone by strips of quads
    /// cut at edge midpoints: a few new vertices after the input's.
    Bridged,
    /// The linear split: new vertices after the input's.
    Split,
}

impl Prepared {
    /// True when the input went through the linear split.
    pub fn split(&self) -> bool {
        self.conversion == QuadConversion::Split
    }
}

impl QuadConversion {
    /// Whether the quad mesh has vertices after the input's (edge and face
    /// points, pqm's own).
    pub fn adds_vertices(self) -> bool {
        matches!(self, QuadConversion::Split | QuadConversion::Bridged)
    }
}

/// The placement (`default` unless `--placement` is given) and the smoothing
/// it allows: `subset` never moves a vertex, so `--smoothing local|global`
/// with it is a usage error (exit code 2).
pub fn placement_and_smoothing(
    args: &CoarsenerArgs,
    default: Placement,
) -> anyhow::Result<(Placement, Smoothing)> {
    let placement = args.placement.map_or(default, Placement::from);
    let smoothing = match (placement, args.smoothing) {
        (Placement::Subset, Some(s @ (SmoothingArg::Local | SmoothingArg::Global))) => {
            let name = if s == SmoothingArg::Local {
                "local"
            } else {
                "global"
            };
            return Err(usage(format!(
                "--smoothing {name} moves vertices, which --placement subset never does \
                 (use --placement qem, or leave --smoothing out)"
            )));
        }
        (Placement::Subset, _) => Smoothing::None,
        (Placement::Qem, s) => s.unwrap_or(SmoothingArg::Global).into(),
    };
    Ok((placement, smoothing))
}

/// Bridging (`--triangles pair`) may add at most 1/this of the input's
/// vertices; past it the input is split (the shared and decimated meshes
/// need 0–5 %, a mesh whose every triangle is its own UV island 3.7×).
const MAX_BRIDGED_SHARE: usize = 4;

/// Name of the vertex properties used to carry user attributes through the split.
const IMPORTANCE_KEY: &str = "pqm:importance";
const FIELD_KEYS: [&str; 3] = ["pqm:field_x", "pqm:field_y", "pqm:field_z"];

/// Reads a mesh, naming the file in every error, and checks it. With
/// `repair`, repairs it first and reports the changes as a note. The error
/// for a defect reads `spot.obj: face 812 repeats vertex 40`.
pub fn load_mesh(path: &Path, repair: bool, ctx: &Ctx) -> anyhow::Result<IndexedMesh> {
    mesh_input_format(path)?;
    let mut mesh = io::read_mesh(path).map_err(|e| anyhow!("{e}"))?;
    if repair {
        let report = io::repair(&mut mesh);
        if report.changed() {
            ctx.note(format!("{}: repaired: {report}", path.display()));
        } else {
            ctx.note(format!("{}: repair: nothing to change", path.display()));
        }
    }
    if let Err(e) = io::check(&mesh) {
        let hint = if repair { "" } else { " (--repair may fix it)" };
        bail!("{}: {e}{hint}", path.display());
    }
    Ok(mesh)
}

/// The quad mesh given to the coarsener, and what happened on the way.
pub struct Prepared {
    /// The input as read (after `--repair`).
    pub input: IndexedMesh,
    /// How the quad mesh came from the input.
    pub conversion: QuadConversion,
    /// The coarsener, set up and not yet run.
    pub coarsener: Coarsener,
    /// Faces of the coarsener's input.
    pub quad_faces: usize,
    /// What the input holds that the coarsener's mesh does not carry
    /// (see [`dropped_attributes`]); said in a note when not empty.
    pub dropped: Vec<&'static str>,
}

/// The input's data that the coarsener's levels (and so `.pqm` files and
/// `pqm coarsen`'s output) do not carry: they hold positions and quads
/// only. Per-corner texture coordinates and normals, and face groups when
/// there are several; a single group or object name is no loss worth
/// naming.
pub fn dropped_attributes(mesh: &IndexedMesh) -> Vec<&'static str> {
    let mut out = Vec::new();
    if !mesh.corner_texcoords.is_empty() {
        out.push("texture coordinates");
    }
    if !mesh.corner_normals.is_empty() {
        out.push("normals");
    }
    if mesh.groups.len() > 1 {
        out.push("face groups");
    }
    out
}

/// Reads `path` and sets up the coarsener with `args` and `opts`.
pub fn prepare(
    path: &Path,
    args: &CoarsenerArgs,
    opts: CoarsenOptions,
    ctx: &Ctx,
) -> anyhow::Result<Prepared> {
    let input = load_mesh(path, args.repair, ctx)?;
    let name = path.display().to_string();
    let dropped = dropped_attributes(&input);
    if !dropped.is_empty() {
        ctx.note(format!(
            "{name}: its {} are not kept: pqm's levels hold positions and quads only \
             (pairing and bridging respect the seams and groups, so the quads never mix two)",
            dropped.join(" and ")
        ));
    }
    let mut work = input.clone();

    // User attributes, read against the input's vertex indices.
    let importance = match (&args.importance, &args.importance_property) {
        (Some(file), _) => Some(load_importance_sidecar(file, work.vertex_count())?),
        (None, Some(prop)) => {
            Some(importance_from_scalars(&work, prop).map_err(|e| anyhow!("{name}: {e}"))?)
        }
        _ => None,
    };
    if let Some(v) = importance {
        work.vertex_scalars.insert(IMPORTANCE_KEY.into(), v);
    }
    let axis_field = match args.field.as_deref() {
        Some(f)
            if ["x", "y", "z"].contains(&f.to_ascii_lowercase().as_str())
                && !Path::new(f).exists() =>
        {
            Some(f.to_string())
        }
        Some(f) => {
            let mesh = Mesh::from_indexed(&work).map_err(|e| anyhow!("{name}: {e}"))?;
            let field = load_field_sidecar(Path::new(f), &mesh)?;
            for (k, key) in FIELD_KEYS.iter().enumerate() {
                let comp = (0..work.vertex_count())
                    .map(|v| field.at(VertexId(v as u32))[k])
                    .collect();
                work.vertex_scalars.insert((*key).into(), comp);
            }
            None
        }
        None => None,
    };
    let mut polylines = match &args.features {
        Some(file) => load_features(file, work.vertex_count())?,
        None => Vec::new(),
    };

    // Non-quad input: triangles paired (`--triangles pair`), else one
    // linear split (the surface does not change either way).
    let mut conversion = QuadConversion::None;
    if !work.is_quad_only() {
        let (q, t, o) = work.face_size_counts();
        if args.no_subdivide {
            bail!(
                "{name}: not a quad mesh ({q} quads, {t} triangles, {o} other polygons) and \
                 --no-subdivide was given (without it, the input is made quad-only first: \
                 see --triangles)"
            );
        }
        let before = work.face_count();
        if args.triangles == TrianglesArg::Pair {
            match pair_and_bridge(&work) {
                // Where most triangles are alone (every triangle its own
                // UV island), the strips would add about as many vertices
                // as the split and leave a doublet at every end: split.
                Ok((_, _, b)) if b.new_vertices() > work.vertex_count() / MAX_BRIDGED_SHARE => ctx
                    .note(format!(
                        "{name}: {} of the triangles have no partner (seams or groups between \
                         them); strips would add {} vertices, more than 1/{MAX_BRIDGED_SHARE} of \
                         the input's {}: split instead",
                        b.lone,
                        b.new_vertices(),
                        work.vertex_count()
                    )),
                Ok((paired, r, b)) if Mesh::from_indexed(&paired).is_ok() => {
                    let mut repaired = match r.repaired_quads {
                        0 => String::new(),
                        n => format!(", {n} of the input's quads re-paired on the way"),
                    };
                    if r.doublets_avoided > 0 {
                        repaired += &format!(
                            ", {} pairs refused that made two quads share two edges",
                            r.doublets_avoided
                        );
                    }
                    if r.doublets_left > 0 {
                        repaired += &format!(", {} such quads left", r.doublets_left);
                    }
                    let polygons = match b.polygons {
                        0 => String::new(),
                        n => format!(
                            "cut {n} polygons of five or more corners into {} triangles; ",
                            b.polygon_triangles
                        ),
                    };
                    let strips = if b.lone == 0 {
                        "no new vertex".to_string()
                    } else {
                        let n = b.strips + b.boundary_strips;
                        format!(
                            "{} triangles no pairing covers joined by {n} strip{} ({} to the \
                             boundary) with {} new vertices ({} edge midpoints, {} face centres)",
                            b.lone,
                            if n == 1 { "" } else { "s" },
                            b.boundary_strips,
                            b.new_vertices(),
                            b.edge_points,
                            b.face_points
                        )
                    };
                    ctx.note(format!(
                        "{name}: not quad-only ({q} quads, {t} triangles, {o} other); {polygons}\
                         joined the triangles in {} pairs ({} by shape, {} through augmenting \
                         paths, {} folded or not convex{repaired}), {strips}: {before} faces -> \
                         {} quads",
                        r.pairs,
                        r.greedy_pairs,
                        r.pairs.saturating_sub(r.greedy_pairs),
                        r.folded,
                        paired.face_count()
                    ));
                    work = paired;
                    conversion = if b.new_vertices() == 0 {
                        QuadConversion::Paired
                    } else {
                        QuadConversion::Bridged
                    };
                }
                Ok(_) => ctx.note(format!(
                    "{name}: the paired triangles do not make a valid quad mesh; split instead"
                )),
                Err(e) => ctx.note(format!(
                    "{name}: cannot pair the triangles ({e}); split instead"
                )),
            }
        }
        if conversion == QuadConversion::None {
            work = catmull_clark_split(&work, SplitMode::Linear)
                .map_err(|e| anyhow!("{name}: {e}"))?;
            conversion = QuadConversion::Split;
            ctx.note(format!(
                "{name}: not quad-only ({q} quads, {t} triangles, {o} other); split each n-gon \
                 into n quads with linear points (surface unchanged): {before} faces -> {} quads",
                work.face_count()
            ));
        }
    }
    let mesh = Mesh::from_indexed(&work).map_err(|e| anyhow!("{name}: {e}"))?;
    if conversion.adds_vertices() && !polylines.is_empty() {
        polylines = polylines
            .iter()
            .map(|p| split_polyline(&mesh, p, input.vertex_count()))
            .collect::<anyhow::Result<_>>()
            .with_context(|| format!("{}", args.features.as_deref().unwrap_or(path).display()))?;
    }

    // Attributes: curvature by default, the user's where given.
    let mut attrs = Attributes::from_curvature(&mesh);
    if let Some(v) = work.vertex_scalars.get(IMPORTANCE_KEY) {
        attrs.importance = remap_importance(v);
    }
    if let Some(axis) = axis_field {
        attrs.field = Field::from_axis_name(&mesh, &axis)?.dirs;
    } else if let (Some(x), Some(y), Some(z)) = (
        work.vertex_scalars.get(FIELD_KEYS[0]),
        work.vertex_scalars.get(FIELD_KEYS[1]),
        work.vertex_scalars.get(FIELD_KEYS[2]),
    ) {
        attrs.field = (0..x.len()).map(|i| DVec3::new(x[i], y[i], z[i])).collect();
    }

    let mut edges = sharp_edges(&mesh, args.sharp_angle);
    edges.extend(
        feature_edges_from_polylines(&mesh, &polylines).map_err(|e| {
            anyhow!(
                "{}: {e}",
                args.features.as_deref().unwrap_or(path).display()
            )
        })?,
    );
    let curves = FeatureCurves::new(&mesh, &edges, true).map_err(|e| anyhow!("{name}: {e}"))?;
    ctx.verbose(format!(
        "{name}: {} feature curves ({} sharp edges at {}°, {} annotated polylines)",
        curves.curve_count(),
        sharp_edges(&mesh, args.sharp_angle).len(),
        args.sharp_angle,
        polylines.len()
    ));
    let quad_faces = mesh.face_count();
    let (placement, smoothing) = placement_and_smoothing(args, opts.placement)?;
    let opts = CoarsenOptions {
        smoothing,
        placement,
        ..opts
    };
    let coarsener = Coarsener::new(mesh, attrs, &curves, opts);
    Ok(Prepared {
        input,
        conversion,
        coarsener,
        quad_faces,
        dropped,
    })
}

/// Maps a polyline of input vertices onto the quad mesh after a split or
/// bridging, which cut edges at their midpoints (new vertices, indices `>=
/// original_vertices`): each step `a → b` is the edge `ab` if it is still
/// one, else the shortest chain of new vertices on the segment `ab` (an
/// edge cut once or, by two strips, twice).
fn split_polyline(mesh: &Mesh, poly: &[u32], original_vertices: usize) -> anyhow::Result<Vec<u32>> {
    let mut out = Vec::with_capacity(poly.len() * 2);
    for w in poly.windows(2) {
        let (a, b) = (VertexId(w[0]), VertexId(w[1]));
        let chain = edge_chain(mesh, a, b, original_vertices).with_context(|| {
            format!("feature polyline: vertices {a} and {b} are not joined by a mesh edge")
        })?;
        if out.is_empty() {
            out.push(a.0);
        }
        out.extend(chain.iter().map(|v| v.0));
    }
    Ok(out)
}

/// The vertices after `a` up to `b` along the edge `ab` as the mesh has it
/// now: `[b]` if it is an edge, else through new vertices on the segment
/// (breadth first, at most 8 steps).
fn edge_chain(mesh: &Mesh, a: VertexId, b: VertexId, original: usize) -> Option<Vec<VertexId>> {
    let (pa, pb) = (mesh.position(a), mesh.position(b));
    let len = (pb - pa).length();
    let on_segment = |v: VertexId| {
        let p = mesh.position(v);
        ((p - pa).length() + (pb - p).length() - len).abs() <= 1e-9 * len.max(1e-300)
    };
    let mut parent: std::collections::HashMap<VertexId, VertexId> = Default::default();
    let mut frontier = vec![a];
    for _ in 0..8 {
        let mut next = Vec::new();
        for &v in &frontier {
            for w in mesh.vertex_ring(v) {
                if w == b {
                    let mut chain = vec![b];
                    let mut x = v;
                    while x != a {
                        chain.push(x);
                        x = parent[&x];
                    }
                    chain.reverse();
                    return Some(chain);
                }
                if w.idx() >= original && w != a && !parent.contains_key(&w) && on_segment(w) {
                    parent.insert(w, v);
                    next.push(w);
                }
            }
        }
        frontier = next;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feature_polylines_follow_edges_cut_by_a_strip_or_the_split() {
        // A pentagon: cut into three triangles, two paired, the third
        // joined to the boundary by an edge point on one of its edges.
        let m = pqm_core::shapes::regular_polygon(5);
        let ring = [0u32, 1, 2, 3, 4, 0];
        let (bridged, _, r) = pair_and_bridge(&m).unwrap();
        assert_eq!(r.edge_points, 1);
        let split = catmull_clark_split(&m, SplitMode::Linear).unwrap();
        for (quads, new) in [(bridged, 1), (split, 5)] {
            let mesh = Mesh::from_indexed(&quads).unwrap();
            let out = split_polyline(&mesh, &ring, 5).unwrap();
            // The whole boundary, once around, through the new points.
            assert_eq!(out.len(), ring.len() + new);
            assert_eq!(out.iter().filter(|&&v| v >= 5).count(), new);
            for w in out.windows(2) {
                let (a, b) = (VertexId(w[0]), VertexId(w[1]));
                assert!(mesh.find_halfedge(a, b).is_some() || mesh.find_halfedge(b, a).is_some());
            }
        }
    }
}
