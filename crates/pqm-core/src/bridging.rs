//! Bridging: a mesh made quad-only by pairing its triangles
//! ([`crate::pairing`]) even where a perfect pairing does not exist, with a
//! few new vertices instead of the linear split of the whole mesh.
//!
//! A pairing can leave triangles alone: a part of the mesh with an odd
//! number of triangles (a UV island, a face group, a piece cut off by
//! non-manifold edges), a triangle among quads with no other triangle to
//! reach, a polygon of five or more corners cut into triangles. The linear
//! split ([`crate::subdivide::catmull_clark_split`]) would then make six
//! times the vertices everywhere; bridging changes only a strip of faces
//! per triangle left alone.
//!
//! # What [`pair_and_bridge`] does
//!
//! 1. **Polygons.** A face of five or more corners is cut into triangles
//!    by ear clipping in its best-fit plane (its Newell normal), so the
//!    pairing can join them again, with their neighbours or each other.
//! 2. **Pairing** ([`crate::pairing::pair_triangles`]'s steps; what a
//!    perfect pairing exists for goes no further).
//! 3. **Walks.** A triangle left alone and the lone triangle nearest it
//!    (in faces) are first moved towards each other for free: a lone triangle joins
//!    half of a neighbouring quad (across no seam, in its group, into a
//!    quad of positive quality) and the quad's other half is alone
//!    instead — the pairing's augmenting paths, which cannot end because
//!    a seam or group border is in the way. Each moves to the position
//!    nearest the other within [`WALK_LIMIT`] positions.
//! 4. **Strips.** Each triangle `T` left alone is then joined to another
//!    one or to a boundary edge along the strip of quads that adds the
//!    fewest vertices (a Dijkstra search across manifold edges, over
//!    quads entered across an edge):
//!    * `T` and the strip's first quad make one pentagon (they share an
//!      edge with no UV seam, in one group), and so does the other end's
//!      triangle with the last quad;
//!    * every edge the strip crosses between two of its polygons gets an
//!      **edge point** at its midpoint (so does the boundary edge a strip
//!      ends at); both faces beside the edge take it, so no T-junction;
//!    * each polygon of the strip then has six corners (a pentagon and one
//!      edge point, a quad and two, or triangle, quad and triangle with
//!      none) and is cut into two quads along the diagonal that makes the
//!      better quads, or, where every diagonal would make a quad with a
//!      straight corner (a quad whose two edge points are on adjacent
//!      edges), into three quads around a **face point** at its centre.
//!
//!    Where `T` has no quad to make a pentagon with (every edge a seam, a
//!    boundary or another lone triangle), it takes the edge point as a
//!    quad with a straight corner and is cut into two quads around a face
//!    point, a vertex of valence 2 (a doublet, which the coarsener removes
//!    first); [`BridgeReport::centre_ends`] counts these ends.
//!
//! New points interpolate what they are between: positions, texture
//! coordinates and normals per side of a seam, per-vertex scalars. Input
//! vertices keep their ids and positions; new ones come after them. Faces
//! keep the input order, the quads cut from a strip's polygon at the place
//! of its first face.
//!
//! A closed manifold part always has an even number of triangles (each
//! quad has 4 edge uses, each triangle 3, each edge 2), so its lone
//! triangles meet in pairs; a part with boundary can end strips there.
//! What still finds no strip (a closed part cut off by non-manifold edges,
//! or past [`BRIDGE_SEARCH_BUDGET_PER_FACE`]) is an error, and the caller
//! falls back to the linear split.
//!
//! Measured (`docs/figures-history.md`, session 25): spot's control cage
//! (16 pentagons, 4 triangles) gains 8 vertices where the split made 4×
//! its faces (file 0.37× the split's); a meshoptimizer-decimated
//! makehuman with its UV seams and groups 272 (2.8 %; file 0.23×); the
//! shared triangle meshes with random UV islands 1.5–5.0 %. Where most
//! triangles are alone (every triangle its own island) bridging adds
//! more vertices than the split, and `pqm encode` splits instead.

use crate::indexed::{FaceWriter, IndexedMesh};
use crate::pairing::{
    attrs, check_tables, face_groups, pair_partial, vertex_tables, PairingError, PairingReport,
};
use glam::{DVec2, DVec3};
use std::borrow::Cow;
use std::collections::HashMap;

/// Budget of the strip searches, in faces visited, per face of the mesh
/// (plus a fixed 2^20).
pub const BRIDGE_SEARCH_BUDGET_PER_FACE: usize = 64;

/// A strip polygon is cut along a diagonal when both its quads have a
/// scaled Jacobian of at least this (1 for rectangles); below it, the cut
/// around a face point is tried too and the better one taken.
pub const MIN_DIAGONAL_QUALITY: f64 = 0.1;

/// What a strip end at a face point (a triangle that merges with nothing)
/// costs the strip search, in new vertices: its face point, and 2 more
/// for the doublet it makes, so that a strip takes up to two more edge
/// points to end in a merge instead (2, 3 and 5 moved the new vertices of
/// the shared meshes with random UV islands by at most 1 %).
const CENTRE_END: u32 = 3;

/// What [`pair_and_bridge`] did beyond the pairing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BridgeReport {
    /// Faces of five or more corners cut into triangles (step 1).
    pub polygons: usize,
    /// Triangles those polygons were cut into (counted in the pairing
    /// report's `triangles` too).
    pub polygon_triangles: usize,
    /// Triangles the pairing left alone.
    pub lone: usize,
    /// Strips between two lone triangles.
    pub strips: usize,
    /// Strips from a lone triangle to a boundary edge.
    pub boundary_strips: usize,
    /// New vertices at edge midpoints.
    pub edge_points: usize,
    /// New vertices at polygon centres.
    pub face_points: usize,
    /// Strip ends where the lone triangle had no quad to join and took a
    /// face point of valence 2 (a doublet).
    pub centre_ends: usize,
    /// Quads re-paired to move lone triangles towards each other first
    /// (each a lone triangle and half a quad joined, the quad's other
    /// half alone instead; no new vertex).
    pub walk_steps: usize,
}

impl BridgeReport {
    /// Vertices added (edge and face points).
    pub fn new_vertices(&self) -> usize {
        self.edge_points + self.face_points
    }
}

/// The mesh made quad-only: faces of five or more corners cut into
/// triangles, triangles paired, and those left alone joined by strips
/// (see the module documentation); or why not. Input vertex ids and
/// positions are kept, new vertices come after them. With no polygon and
/// no lone triangle the result is [`crate::pairing::pair_triangles`]'s.
pub fn pair_and_bridge(
    mesh: &IndexedMesh,
) -> Result<(IndexedMesh, PairingReport, BridgeReport), PairingError> {
    check_tables(mesh)?;
    let mut report = BridgeReport::default();
    let (work, origin) = triangulate_polygons(mesh, &mut report)?;
    let (paired, pairing, lone) = pair_partial(&work)?;
    report.lone = lone.len();
    if lone.is_empty() {
        return Ok((paired, pairing, report));
    }
    let lone_faces: Vec<u32> = lone.iter().map(|l| l.1 as u32).collect();
    let mut strips = Strips::new(&paired, &lone_faces);
    strips.run(&lone_faces, &mut report);
    if let Some(&first) = strips.left.first() {
        // The first one left, as a face of the input.
        let f = lone
            .iter()
            .find(|l| l.1 == first as usize)
            .map_or(0, |l| l.0);
        return Err(PairingError::Unpaired {
            unpaired: strips.left.len(),
            triangles: pairing.triangles,
            first_face: origin.as_ref().map_or(f, |o| o[f] as usize),
        });
    }
    Ok((strips.finish(&paired), pairing, report))
}

/// With the mesh, the input face of each of its faces (when it changed).
type Triangulated<'a> = (Cow<'a, IndexedMesh>, Option<Vec<u32>>);

/// Step 1: the faces of five or more corners cut into triangles (ear
/// clipping in the best-fit plane), attributes carried per corner; the
/// mesh as it is when it has none. Faces of fewer than three corners are
/// an error.
fn triangulate_polygons<'a>(
    mesh: &'a IndexedMesh,
    report: &mut BridgeReport,
) -> Result<Triangulated<'a>, PairingError> {
    for f in 0..mesh.face_count() {
        let len = mesh.face(f).len();
        if len < 3 {
            return Err(PairingError::FaceSize { face: f, len });
        }
    }
    if mesh.faces().all(|f| f.len() <= 4) {
        return Ok((Cow::Borrowed(mesh), None));
    }
    let mut origin = Vec::new();
    // The mesh's edges: an ear's diagonal must not be one already (a
    // small closed part can bring two corners of a polygon together).
    let mut edges: std::collections::HashSet<(u32, u32)> = mesh
        .faces()
        .flat_map(|f| (0..f.len()).map(move |k| key(f[k], f[(k + 1) % f.len()])))
        .collect();
    let mut out = FaceWriter::new(vertex_tables(mesh), mesh);
    for (f, &group) in face_groups(mesh).iter().enumerate() {
        let face = mesh.face(f);
        let start = mesh.face_starts[f] as usize;
        let pieces: Vec<Vec<usize>> = if face.len() <= 4 {
            vec![(0..face.len()).collect()]
        } else {
            report.polygons += 1;
            let p: Vec<DVec3> = face.iter().map(|&v| mesh.positions[v as usize]).collect();
            let tris = ear_clip(&p, |i, j| edges.contains(&key(face[i], face[j])))
                .ok_or(PairingError::Polygon { face: f })?;
            report.polygon_triangles += tris.len();
            // Its diagonals are edges now, for the polygons after it.
            for t in &tris {
                for k in 0..3 {
                    edges.insert(key(face[t[k]], face[t[(k + 1) % 3]]));
                }
            }
            tris.iter().map(|t| t.to_vec()).collect()
        };
        for ks in pieces {
            let corners: Vec<usize> = ks.iter().map(|&k| start + k).collect();
            let v: Vec<u32> = ks.iter().map(|&k| face[k]).collect();
            out.push(
                group,
                &v,
                attrs(&mesh.corner_texcoords, &corners),
                attrs(&mesh.corner_normals, &corners),
            );
            origin.push(f as u32);
        }
    }
    Ok((Cow::Owned(out.finish()), Some(origin)))
}

/// Ear clipping of the polygon `p` (counter-clockwise about its Newell
/// normal): `p.len() − 2` triangles as corner positions, each
/// counter-clockwise. An ear is a convex corner whose triangle holds no
/// other remaining corner; where none is left (a polygon that folds over
/// itself in the plane), the most convex corner is cut. An ear whose
/// diagonal `is_edge` already (by corner positions) is cut only when no
/// other corner can be; `None` if one had to be. Quadratic per ear; past
/// [`EAR_CLIP_MAX`] corners, a fan.
fn ear_clip(p: &[DVec3], is_edge: impl Fn(usize, usize) -> bool) -> Option<Vec<[usize; 3]>> {
    let n = p.len();
    if n > EAR_CLIP_MAX {
        let fan: Vec<[usize; 3]> = (1..n - 1).map(|i| [0, i, i + 1]).collect();
        return (2..n - 1).all(|i| !is_edge(0, i)).then_some(fan);
    }
    let normal = crate::ops::newell_normal(p);
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let q: Vec<DVec2> = p.iter().map(|x| DVec2::new(x.dot(u), x.dot(v))).collect();
    let cross = |a: usize, b: usize, c: usize| (q[b] - q[a]).perp_dot(q[c] - q[a]);
    let mut left: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while left.len() > 3 {
        let m = left.len();
        let corner = |i: usize| (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
        let is_ear = |i: usize| {
            let (a, b, c) = corner(i);
            !is_edge(a, c)
                && cross(a, b, c) > 0.0
                && left.iter().all(|&x| {
                    x == a
                        || x == b
                        || x == c
                        || !(cross(a, b, x) >= 0.0
                            && cross(b, c, x) >= 0.0
                            && cross(c, a, x) >= 0.0)
                })
        };
        let i = (0..m).find(|&i| is_ear(i)).unwrap_or_else(|| {
            let free: Vec<usize> = (0..m)
                .filter(|&i| {
                    let (a, _, c) = corner(i);
                    !is_edge(a, c)
                })
                .collect();
            free.into_iter()
                .max_by(|&i, &j| {
                    let (a, b, c) = corner(i);
                    let (d, e, f) = corner(j);
                    cross(a, b, c).total_cmp(&cross(d, e, f))
                })
                .unwrap_or(usize::MAX)
        });
        if i == usize::MAX {
            return None;
        }
        let (a, b, c) = corner(i);
        out.push([a, b, c]);
        left.remove(i);
    }
    out.push([left[0], left[1], left[2]]);
    Some(out)
}

/// A lone triangle's position that is a face of its own (else the half of
/// a quad, 0 or 1).
const REAL: u8 = 2;

/// Positions a lone triangle's walk search visits at most.
pub const WALK_LIMIT: usize = 4096;

/// Polygons with more corners are cut as a fan (ear clipping is quadratic).
const EAR_CLIP_MAX: usize = 256;

const NONE: u32 = u32::MAX;

/// One corner of a face being rebuilt: vertex, texture coordinate and
/// normal index (`NONE` where the mesh has none).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Corner {
    v: u32,
    tc: u32,
    nc: u32,
}

/// The uses of an undirected edge by live faces: how many, whether it ever
/// had more than two (then it is never crossed), and the first two.
#[derive(Clone, Copy, Debug)]
struct EdgeUse {
    n: u32,
    over: bool,
    f: [(u32, u8); 2],
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// A face of a strip polygon, with the edge `(face, edge)` of the polygon
/// so far it joins across (`None` for the polygon's first face).
type Merged = (u32, Option<(u32, u8)>);

/// How a strip search ended.
#[derive(Clone, Copy, Debug)]
enum End {
    /// At another lone triangle `g`, across the last face's exit edge;
    /// `merge`: it and the last quad make one polygon.
    Lone { g: u32, merge: bool },
    /// At a boundary edge, the last face's exit edge.
    Boundary,
}

/// Step 3's working mesh: faces that strips rewrite, the edges' uses, the
/// points added.
struct Strips {
    positions: Vec<DVec3>,
    texcoords: Vec<[f64; 2]>,
    normals: Vec<DVec3>,
    scalars: Vec<(String, Vec<f64>)>,
    has_tc: bool,
    has_nc: bool,
    faces: Vec<Vec<Corner>>,
    alive: Vec<bool>,
    /// Output order: `(place of the face it replaced, sequence)`.
    order: Vec<(u32, u32)>,
    group: Vec<u32>,
    lone: Vec<bool>,
    edges: HashMap<(u32, u32), EdgeUse>,
    edge_point: HashMap<(u32, u32), u32>,
    tc_mid: HashMap<(u32, u32), u32>,
    nc_mid: HashMap<(u32, u32), u32>,
    budget: usize,
    sequence: u32,
    /// Lone triangles no strip joined.
    left: Vec<u32>,
    /// Lone triangles a walk moved to a new face, not yet joined.
    moved: Vec<u32>,
}

impl Strips {
    fn new(m: &IndexedMesh, lone: &[u32]) -> Strips {
        let nf = m.face_count();
        let has_tc = !m.corner_texcoords.is_empty();
        let has_nc = !m.corner_normals.is_empty();
        let faces: Vec<Vec<Corner>> = (0..nf)
            .map(|f| {
                let s = m.face_starts[f] as usize;
                m.face(f)
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| Corner {
                        v,
                        tc: if has_tc {
                            m.corner_texcoords[s + k]
                        } else {
                            NONE
                        },
                        nc: if has_nc {
                            m.corner_normals[s + k]
                        } else {
                            NONE
                        },
                    })
                    .collect()
            })
            .collect();
        let mut is_lone = vec![false; nf];
        for &f in lone {
            is_lone[f as usize] = true;
        }
        let mut s = Strips {
            positions: m.positions.clone(),
            texcoords: m.texcoords.clone(),
            normals: m.normals.clone(),
            scalars: m
                .vertex_scalars
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
            has_tc,
            has_nc,
            faces,
            alive: vec![true; nf],
            order: (0..nf as u32).map(|f| (f, 0)).collect(),
            group: face_groups(m).into_iter().map(|g| g as u32).collect(),
            lone: is_lone,
            edges: HashMap::with_capacity(nf * 2),
            edge_point: HashMap::new(),
            tc_mid: HashMap::new(),
            nc_mid: HashMap::new(),
            budget: BRIDGE_SEARCH_BUDGET_PER_FACE
                .saturating_mul(nf)
                .saturating_add(1 << 20),
            sequence: 0,
            left: Vec::new(),
            moved: Vec::new(),
        };
        for f in 0..nf {
            s.add_edges(f as u32);
        }
        s
    }

    fn edge(&self, f: u32, k: usize) -> (u32, u32) {
        let face = &self.faces[f as usize];
        (face[k].v, face[(k + 1) % face.len()].v)
    }

    fn add_edges(&mut self, f: u32) {
        for k in 0..self.faces[f as usize].len() {
            let (a, b) = self.edge(f, k);
            let e = self.edges.entry(key(a, b)).or_insert(EdgeUse {
                n: 0,
                over: false,
                f: [(NONE, 0); 2],
            });
            if (e.n as usize) < 2 {
                e.f[e.n as usize] = (f, k as u8);
            } else {
                e.over = true;
            }
            e.n += 1;
        }
    }

    fn remove_edges(&mut self, f: u32) {
        for k in 0..self.faces[f as usize].len() {
            let (a, b) = self.edge(f, k);
            let kk = key(a, b);
            let Some(e) = self.edges.get_mut(&kk) else {
                continue;
            };
            e.n = e.n.saturating_sub(1);
            if !e.over {
                if e.f[0].0 == f {
                    e.f[0] = e.f[1];
                }
                e.f[1] = (NONE, 0);
            }
            if e.n == 0 {
                self.edges.remove(&kk);
            }
        }
    }

    /// The face across edge `k` of `f` and that edge's index in it, if the
    /// edge is manifold and consistently oriented.
    fn across(&self, f: u32, k: usize) -> Option<(u32, usize)> {
        let (a, b) = self.edge(f, k);
        let e = self.edges.get(&key(a, b))?;
        if e.n != 2 || e.over {
            return None;
        }
        let (g, kg) = if e.f[0].0 == f { e.f[1] } else { e.f[0] };
        if g == f || g == NONE {
            return None;
        }
        (self.edge(g, kg as usize) == (b, a)).then_some((g, kg as usize))
    }

    fn is_boundary(&self, f: u32, k: usize) -> bool {
        let (a, b) = self.edge(f, k);
        self.edges
            .get(&key(a, b))
            .is_some_and(|e| e.n == 1 && !e.over)
    }

    /// Whether faces `f` and `g`, across `f`'s edge `k` and `g`'s edge
    /// `kg`, may become one polygon: one group, the same texture
    /// coordinates at the edge's ends, and no other vertex in common.
    fn mergeable(&self, f: u32, k: usize, g: u32, kg: usize) -> bool {
        let (x, y) = (&self.faces[f as usize], &self.faces[g as usize]);
        if self.group[f as usize] != self.group[g as usize]
            || x[k].tc != y[(kg + 1) % y.len()].tc
            || x[(k + 1) % x.len()].tc != y[kg].tc
        {
            return false;
        }
        let shared = x.iter().filter(|c| y.iter().any(|d| d.v == c.v)).count();
        shared == 2
    }

    /// The corners of a lone triangle's position: face `p.0` itself
    /// (`p.1 == REAL`), or half `p.1` of quad `p.0` (0: corners 0, 1, 2;
    /// 1: corners 2, 3, 0).
    fn triangle_at(&self, p: (u32, u8)) -> Vec<Corner> {
        let f = &self.faces[p.0 as usize];
        match p.1 {
            REAL => f.clone(),
            0 => vec![f[0], f[1], f[2]],
            _ => vec![f[2], f[3], f[0]],
        }
    }

    fn centroid(&self, corners: &[Corner]) -> DVec3 {
        corners
            .iter()
            .map(|c| self.positions[c.v as usize])
            .sum::<DVec3>()
            / corners.len() as f64
    }

    /// One walk step from the lone triangle at `p` across its outer edge
    /// `(f, k)` (an edge of face `f`): the quad `g` across it joins the
    /// triangle with its half at that edge (one group, no seam between,
    /// no third vertex in common, a quad of positive quality, and `g`'s
    /// diagonal no edge already), and its other half is alone instead.
    /// The new position and the joined quad's corners.
    fn walk_step(&self, p: (u32, u8), f: u32, k: usize) -> Option<((u32, u8), Vec<Corner>)> {
        let (g, kg) = self.across(f, k)?;
        let q = &self.faces[g as usize];
        if q.len() != 4 || self.lone[g as usize] || self.group[f as usize] != self.group[g as usize]
        {
            return None;
        }
        let x = &self.faces[f as usize];
        if x[k].tc != q[(kg + 1) % 4].tc || x[(k + 1) % x.len()].tc != q[kg].tc {
            return None;
        }
        if self.edges.contains_key(&key(q[0].v, q[2].v)) {
            return None;
        }
        let tri = self.triangle_at(p);
        if tri.iter().filter(|c| q.iter().any(|d| d.v == c.v)).count() != 2 {
            return None;
        }
        let h = (kg >= 2) as u8;
        let half = self.triangle_at((g, h));
        let (a, b) = (x[k].v, x[(k + 1) % x.len()].v);
        let mut joined = union(&tri, &half, a, b)?;
        if joined.len() != 4 {
            return None;
        }
        // As the pairing writes a pair: the shared edge `a–b` is the
        // diagonal from corner 0, so the quad is still two input
        // triangles across `q0–q2` (and a later walk splits it there).
        let at_a = joined.iter().position(|c| c.v == a)?;
        joined.rotate_left(at_a);
        let quality = crate::ops::quad_scaled_jacobian(
            [0, 1, 2, 3].map(|i| self.positions[joined[i].v as usize]),
        );
        (quality > 0.0).then_some(((g, 1 - h), joined))
    }

    /// The outer edges of a lone triangle's position, as `(face, edge)`:
    /// a real triangle's three, a half's two edges of its quad.
    fn outer_edges(p: (u32, u8)) -> Vec<(u32, usize)> {
        match p.1 {
            REAL => (0..3).map(|k| (p.0, k)).collect(),
            h => vec![(p.0, 2 * h as usize), (p.0, 2 * h as usize + 1)],
        }
    }

    /// Where lone triangle `t` can be moved at no cost, by re-pairing the
    /// quads along a walk (the pairing's augmenting paths, across seams
    /// and groups never): breadth first, each quad once, at most
    /// [`WALK_LIMIT`] positions; each with the position it came from.
    fn reach(&self, t: u32) -> Vec<((u32, u8), usize)> {
        let mut out = vec![((t, REAL), usize::MAX)];
        let mut used: std::collections::HashSet<u32> = std::collections::HashSet::new();
        let mut i = 0;
        while i < out.len() && out.len() < WALK_LIMIT {
            let p = out[i].0;
            for (f, k) in Self::outer_edges(p) {
                if let Some((next, _)) = self.walk_step(p, f, k) {
                    if used.insert(next.0) {
                        out.push((next, i));
                    }
                }
            }
            i += 1;
        }
        out
    }

    /// Moves lone triangle `t` to the position of `reach` nearest `to`
    /// (re-pairing the quads on the way); the lone triangle's face then.
    fn walk_toward(&mut self, t: u32, to: DVec3) -> u32 {
        let reach = self.reach(t);
        let dist = |p: (u32, u8), s: &Strips| s.centroid(&s.triangle_at(p)).distance_squared(to);
        let mut best = 0;
        for i in 1..reach.len() {
            if dist(reach[i].0, self) < dist(reach[best].0, self) {
                best = i;
            }
        }
        let mut chain = Vec::new();
        let mut i = best;
        while i != usize::MAX {
            chain.push(reach[i].0);
            i = reach[i].1;
        }
        chain.reverse();
        let mut cur = t;
        for &(g, h) in &chain[1..] {
            // The step from the lone face `cur` into `g`.
            let Some((f, k)) = (0..3)
                .map(|k| (cur, k))
                .find(|&(f, k)| self.across(f, k).is_some_and(|x| x.0 == g))
            else {
                break;
            };
            let Some((next, joined)) = self.walk_step((cur, REAL), f, k) else {
                break;
            };
            debug_assert_eq!(next, (g, h));
            let tri = self.triangle_at(next);
            let (place, group) = (self.order[g as usize].0, self.group[g as usize]);
            for old in [cur, g] {
                self.remove_edges(old);
                self.alive[old as usize] = false;
                self.lone[old as usize] = false;
            }
            for (face, lone) in [(joined, false), (tri, true)] {
                self.sequence += 1;
                let id = self.faces.len() as u32;
                self.faces.push(face);
                self.alive.push(true);
                self.order.push((place, self.sequence));
                self.group.push(group);
                self.lone.push(lone);
                self.add_edges(id);
            }
            cur = self.faces.len() as u32 - 1;
        }
        cur
    }

    /// Joins the lone triangles `lone` (faces of the mesh `new` was
    /// given), walks and strips, in this order.
    fn run(&mut self, lone: &[u32], report: &mut BridgeReport) {
        let mut start = lone.iter().copied();
        // Lone triangles a walk moved to a new face come first.
        while let Some(t) = self.moved.pop().or_else(|| start.next()) {
            if !self.alive[t as usize] || !self.lone[t as usize] {
                continue; // joined as another strip's end, or moved
            }
            let t = self.walk_together(t, report);
            let found = self.search(t);
            let done = found.is_some_and(|(path, end)| self.apply(t, &path, end, report));
            if !done {
                self.left.push(t);
            }
        }
    }

    /// Moves lone triangle `t` and the lone triangle nearest it (in
    /// faces) towards each other, each as far as its walks go (see [`Strips::reach`]),
    /// so that the strip between them is short; `t`'s face then.
    fn walk_together(&mut self, t: u32, report: &mut BridgeReport) -> u32 {
        let at = |f: u32, s: &Strips| s.centroid(&s.faces[f as usize]);
        let Some(g) = self.nearest_lone(t) else {
            return t;
        };
        let faces_before = self.faces.len();
        let t = self.walk_toward(t, at(g, self));
        let moved = self.walk_toward(g, at(t, self));
        if moved != g {
            self.moved.push(moved);
        }
        report.walk_steps += (self.faces.len() - faces_before) / 2;
        t
    }

    /// The lone triangle nearest `t` across the faces (breadth first
    /// across manifold edges, at most [`WALK_LIMIT`] faces: a global scan
    /// per lone triangle would be quadratic where most triangles are
    /// alone).
    fn nearest_lone(&self, t: u32) -> Option<u32> {
        let mut seen: std::collections::HashSet<u32> = std::collections::HashSet::from([t]);
        let mut queue = std::collections::VecDeque::from([t]);
        while let Some(f) = queue.pop_front() {
            if seen.len() > WALK_LIMIT {
                break;
            }
            for k in 0..self.faces[f as usize].len() {
                let Some((g, _)) = self.across(f, k) else {
                    continue;
                };
                if seen.insert(g) {
                    if self.lone[g as usize] {
                        return Some(g);
                    }
                    queue.push_back(g);
                }
            }
        }
        None
    }

    /// The strip from lone triangle `t` that adds the fewest vertices
    /// (Dijkstra over quads entered across an edge): the faces on it in
    /// order, each with the edge it is left by (the last one's being the
    /// end's), and how it ends. Costs, in new vertices: an edge point per
    /// edge crossed that is not merged across; a face point for a quad
    /// left across an edge next to the one it was entered by (its
    /// hexagon has no diagonal without a straight corner), except the
    /// quad `t` merged with; a face point for an end triangle that merges
    /// with nothing. Ties go to the search order (edge order, first
    /// found).
    fn search(&mut self, t: u32) -> Option<(Vec<(u32, u8)>, End)> {
        use std::cmp::Reverse;
        use std::collections::BinaryHeap;
        /// What a state was reached from: `(previous quad, its entry
        /// edge)` or `t` (`NONE`), and the edge it was left by.
        #[derive(Clone, Copy)]
        struct Reached {
            cost: u32,
            prev: (u32, u8),
            exit: u8,
            /// `t` merged with this quad (the first of the strip).
            merged: bool,
        }
        let mut reached: HashMap<(u32, u8), Reached> = HashMap::new();
        let mut faces_seen: std::collections::HashSet<u32> = std::collections::HashSet::new();
        // Queue items, cheapest first, then in the order pushed: a state
        // (a quad and its entry edge), or an end (an index into `ends`:
        // the last face, its exit edge, how the strip ends there, and the
        // state it was reached from, `t_state` for `t` itself).
        type Queued = (Reverse<u32>, Reverse<u64>, u8, (u32, u8));
        let mut heap: BinaryHeap<Queued> = BinaryHeap::new();
        let mut ends: Vec<(u32, u8, End, (u32, u8))> = Vec::new();
        let mut order = 0u64;
        let mut push = |heap: &mut BinaryHeap<_>, cost: u32, kind: u8, item: (u32, u8)| {
            order += 1;
            heap.push((Reverse(cost), Reverse(order), kind, item));
        };
        const STATE: u8 = 0;
        const FINISH: u8 = 1;
        let t_state = (NONE, 0u8);
        for k in 0..3u8 {
            if self.is_boundary(t, k as usize) {
                ends.push((t, k, End::Boundary, t_state));
                push(
                    &mut heap,
                    1 + CENTRE_END,
                    FINISH,
                    (ends.len() as u32 - 1, 0),
                );
                continue;
            }
            let Some((g, kg)) = self.across(t, k as usize) else {
                continue;
            };
            if self.lone[g as usize] {
                ends.push((t, k, End::Lone { g, merge: false }, t_state));
                push(
                    &mut heap,
                    1 + 2 * CENTRE_END,
                    FINISH,
                    (ends.len() as u32 - 1, 0),
                );
            } else if self.faces[g as usize].len() == 4 {
                let merged = self.mergeable(t, k as usize, g, kg);
                let cost = if merged { 0 } else { 1 + CENTRE_END };
                let key = (g, kg as u8);
                if reached.get(&key).is_none_or(|r| cost < r.cost) {
                    reached.insert(
                        key,
                        Reached {
                            cost,
                            prev: t_state,
                            exit: k,
                            merged,
                        },
                    );
                    faces_seen.insert(g);
                    push(&mut heap, cost, STATE, key);
                }
            }
        }
        while let Some((Reverse(cost), _, kind, item)) = heap.pop() {
            if self.budget == 0 {
                return None;
            }
            self.budget -= 1;
            if kind == FINISH {
                let (last, k_end, end, mut cur) = ends[item.0 as usize];
                let mut path = vec![(last, k_end)];
                while cur != t_state {
                    let r = reached[&cur];
                    path.push((if r.prev == t_state { t } else { r.prev.0 }, r.exit));
                    cur = r.prev;
                }
                path.reverse();
                return Some((path, end));
            }
            let s = reached[&item];
            if s.cost < cost {
                continue; // reached more cheaply since
            }
            let (f, kin) = item;
            // The faces on this state's strip (a strip never enters a
            // face twice).
            let on_strip = |g: u32, reached: &HashMap<(u32, u8), Reached>| {
                let mut cur = item;
                loop {
                    if cur.0 == g {
                        return true;
                    }
                    let r = reached[&cur];
                    if r.prev == t_state {
                        return g == t;
                    }
                    cur = r.prev;
                }
            };
            for k in 0..4u8 {
                if k == kin {
                    continue;
                }
                let turn = (!s.merged && (k + 4 - kin) % 4 != 2) as u32;
                if self.is_boundary(f, k as usize) {
                    ends.push((f, k, End::Boundary, item));
                    push(
                        &mut heap,
                        cost + 1 + turn,
                        FINISH,
                        (ends.len() as u32 - 1, 0),
                    );
                    continue;
                }
                let Some((g, kg)) = self.across(f, k as usize) else {
                    continue;
                };
                if g == t {
                    continue;
                }
                if self.lone[g as usize] {
                    // With `t` merged into `f` too, `g`'s far corner must
                    // not be one of `t`'s (the hexagon would repeat it).
                    let far = self.faces[g as usize][(kg + 2) % 3].v;
                    let merge = self.mergeable(f, k as usize, g, kg)
                        && !(s.merged && self.faces[t as usize].iter().any(|d| d.v == far));
                    ends.push((f, k, End::Lone { g, merge }, item));
                    let c = if merge {
                        cost
                    } else {
                        cost + 1 + turn + CENTRE_END
                    };
                    push(&mut heap, c, FINISH, (ends.len() as u32 - 1, 0));
                    continue;
                }
                if self.faces[g as usize].len() != 4 {
                    continue;
                }
                let key = (g, kg as u8);
                let c = cost + 1 + turn;
                if reached.get(&key).is_some_and(|r| r.cost <= c) {
                    continue;
                }
                if faces_seen.contains(&g) && on_strip(g, &reached) {
                    continue;
                }
                reached.insert(
                    key,
                    Reached {
                        cost: c,
                        prev: item,
                        exit: k,
                        merged: false,
                    },
                );
                faces_seen.insert(g);
                push(&mut heap, c, STATE, key);
            }
        }
        None
    }

    /// Rebuilds the strip `path` (from `t`, each face with the edge it is
    /// left by) ending at `end`; false (and nothing changed) if a polygon
    /// of it would repeat a vertex.
    fn apply(&mut self, t: u32, path: &[(u32, u8)], end: End, report: &mut BridgeReport) -> bool {
        let t_merges = path.len() > 1 && {
            let (q, _) = path[1];
            let k = path[0].1 as usize;
            let kq = self.across(t, k).map(|x| x.1);
            kq.is_some_and(|kq| self.mergeable(t, k, q, kq))
        };
        // Clusters of faces that become one polygon, in strip order, each
        // with the directed edges they are merged across.
        let mut clusters: Vec<Vec<Merged>> = Vec::new();
        for (i, &(f, _)) in path.iter().enumerate() {
            if i == 1 && t_merges {
                let (p, k) = path[0];
                clusters[0].push((f, Some((p, k))));
            } else {
                clusters.push(vec![(f, None)]);
            }
        }
        let (g_end, g_merges) = match end {
            End::Lone { g, merge } => (Some(g), merge && path.len() > 1),
            End::Boundary => (None, false),
        };
        if let Some(g) = g_end {
            let (last, k) = *path.last().expect("a strip has a face");
            if g_merges {
                clusters
                    .last_mut()
                    .expect("a strip has a face")
                    .push((g, Some((last, k))));
            } else {
                clusters.push(vec![(g, None)]);
            }
        }
        // The edges that get a point: every crossing not merged across,
        // and the boundary edge at the end.
        let mut points: Vec<(u32, u32)> = Vec::new();
        for (i, &(f, k)) in path.iter().enumerate() {
            let merged = (i == 0 && t_merges) || (i + 1 == path.len() && g_merges);
            if !merged {
                let (a, b) = self.edge(f, k as usize);
                points.push(key(a, b));
            }
        }
        // Build the polygons first: nothing changes unless all are sound.
        let mut polygons: Vec<(Vec<Corner>, Vec<bool>)> = Vec::new();
        for c in &clusters {
            let mut poly = self.faces[c[0].0 as usize].clone();
            for &(g, across) in &c[1..] {
                let (p, k) = across.expect("a merged face names its edge");
                let (a, b) = self.edge(p, k as usize);
                let Some(merged) = union(&poly, &self.faces[g as usize], a, b) else {
                    return false;
                };
                poly = merged;
            }
            let mut vs: Vec<u32> = poly.iter().map(|c| c.v).collect();
            vs.sort_unstable();
            if vs.windows(2).any(|w| w[0] == w[1]) {
                return false;
            }
            let mut out = Vec::with_capacity(poly.len() + 2);
            let mut inserted = Vec::with_capacity(poly.len() + 2);
            for i in 0..poly.len() {
                let (x, y) = (poly[i], poly[(i + 1) % poly.len()]);
                out.push(x);
                inserted.push(false);
                if points.contains(&key(x.v, y.v)) {
                    out.push(Corner { v: NONE, ..x });
                    inserted.push(true);
                }
            }
            if out.len() != 4 && out.len() != 6 {
                return false;
            }
            polygons.push((out, inserted));
        }
        // Commit: the points, the quads, the edges. A point is shared by
        // the two sides of its edge within this strip only: a later strip
        // may cut a new edge between the same two vertices (a diagonal),
        // whose point must be a new vertex.
        self.edge_point.clear();
        self.tc_mid.clear();
        self.nc_mid.clear();
        for (poly, inserted) in &mut polygons {
            let n = poly.len();
            for i in 0..n {
                if inserted[i] {
                    let (x, y) = (poly[(i + n - 1) % n], poly[(i + 1) % n]);
                    poly[i] = self.edge_point(x, y, report);
                }
            }
        }
        match end {
            End::Lone { .. } => report.strips += 1,
            End::Boundary => report.boundary_strips += 1,
        }
        report.centre_ends += (!t_merges) as usize + (g_end.is_some() && !g_merges) as usize;
        for (c, (poly, inserted)) in clusters.iter().zip(polygons) {
            let first = c[0].0 as usize;
            let (place, group) = (self.order[first].0, self.group[first]);
            for &(f, _) in c {
                self.remove_edges(f);
                self.alive[f as usize] = false;
                self.lone[f as usize] = false;
            }
            for quad in self.cut(&poly, &inserted, report) {
                self.sequence += 1;
                let f = self.faces.len() as u32;
                self.faces.push(quad.to_vec());
                self.alive.push(true);
                self.order.push((place, self.sequence));
                self.group.push(group);
                self.lone.push(false);
                self.add_edges(f);
            }
        }
        true
    }

    /// The point at the midpoint of the edge `x → y` as seen from one side:
    /// the vertex shared by both sides, texture coordinate and normal
    /// interpolated from this side's.
    fn edge_point(&mut self, x: Corner, y: Corner, report: &mut BridgeReport) -> Corner {
        let kk = key(x.v, y.v);
        let v = match self.edge_point.get(&kk) {
            Some(&v) => v,
            None => {
                let v = self.new_vertex(&[kk.0, kk.1]);
                self.edge_point.insert(kk, v);
                report.edge_points += 1;
                v
            }
        };
        Corner {
            v,
            tc: self.mid_tc(&[x.tc, y.tc], true),
            nc: self.mid_nc(&[x.nc, y.nc], true),
        }
    }

    /// A new vertex at the mean of `of`'s positions and scalars.
    fn new_vertex(&mut self, of: &[u32]) -> u32 {
        let n = of.len() as f64;
        let p = if of.len() == 2 {
            (self.positions[of[0] as usize] + self.positions[of[1] as usize]) * 0.5
        } else {
            of.iter()
                .map(|&v| self.positions[v as usize])
                .sum::<DVec3>()
                / n
        };
        self.positions.push(p);
        for (_, s) in &mut self.scalars {
            let x = of.iter().map(|&v| s[v as usize]).sum::<f64>() / n;
            s.push(x);
        }
        self.positions.len() as u32 - 1
    }

    /// The texture coordinate at the mean of `of` (shared between the
    /// faces beside an edge when `cache`).
    fn mid_tc(&mut self, of: &[u32], cache: bool) -> u32 {
        if !self.has_tc {
            return NONE;
        }
        let mean = |v: &[[f64; 2]]| {
            let n = v.len() as f64;
            [0, 1].map(|a| v.iter().map(|t| t[a]).sum::<f64>() / n)
        };
        interpolated(
            &mut self.texcoords,
            cache.then_some(&mut self.tc_mid),
            of,
            mean,
        )
    }

    /// The normal along the mean of `of` (shared as [`Strips::mid_tc`]).
    fn mid_nc(&mut self, of: &[u32], cache: bool) -> u32 {
        if !self.has_nc {
            return NONE;
        }
        let mean = |v: &[DVec3]| v.iter().sum::<DVec3>().normalize_or_zero();
        interpolated(
            &mut self.normals,
            cache.then_some(&mut self.nc_mid),
            of,
            mean,
        )
    }

    /// Cuts a strip polygon of 4 or 6 corners (`inserted` marks its edge
    /// points) into quads: along the best diagonal, else around a face
    /// point, whichever makes the better worst quad.
    fn cut(
        &mut self,
        poly: &[Corner],
        inserted: &[bool],
        report: &mut BridgeReport,
    ) -> Vec<[Corner; 4]> {
        let n = poly.len();
        let pos = |c: &Corner, s: &Strips| s.positions[c.v as usize];
        let quality =
            |q: &[Corner; 4], s: &Strips| crate::ops::quad_scaled_jacobian(q.map(|c| pos(&c, s)));
        let at = |i: usize| poly[i % n];
        let mut best: Option<(f64, Vec<[Corner; 4]>)> = None;
        if n == 6 {
            for j in 0..3 {
                // A diagonal that is an edge already (a small closed part
                // can bring two corners together twice) would join three
                // faces at it.
                if self.edges.contains_key(&key(at(j).v, at(j + 3).v)) {
                    continue;
                }
                let a = [at(j), at(j + 1), at(j + 2), at(j + 3)];
                let b = [at(j + 3), at(j + 4), at(j + 5), at(j)];
                let q = quality(&a, self).min(quality(&b, self));
                if best.as_ref().is_none_or(|b| q > b.0) {
                    best = Some((q, vec![a, b]));
                }
            }
        } else if !inserted.contains(&true) {
            return vec![[poly[0], poly[1], poly[2], poly[3]]];
        }
        if best.as_ref().is_some_and(|b| b.0 >= MIN_DIAGONAL_QUALITY) {
            return best.map(|b| b.1).unwrap_or_default();
        }
        // Around a face point at the mean of the polygon's own corners.
        let own: Vec<Corner> = poly
            .iter()
            .zip(inserted)
            .filter(|(_, &i)| !i)
            .map(|(c, _)| *c)
            .collect();
        let p_pos = own
            .iter()
            .map(|c| self.positions[c.v as usize])
            .sum::<DVec3>()
            / own.len() as f64;
        let options: Vec<Vec<[usize; 3]>> = if n == 6 {
            vec![
                vec![[0, 1, 2], [2, 3, 4], [4, 5, 0]],
                vec![[1, 2, 3], [3, 4, 5], [5, 0, 1]],
            ]
        } else {
            // A triangle with one edge point at corner `i`: the quads
            // (i − 1, i, p, i + 2) and (i, i + 1, i + 2, p).
            let i = inserted.iter().position(|&x| x).unwrap_or(0);
            vec![vec![[(i + 3) % 4, i, 4], [i, (i + 1) % 4, (i + 2) % 4]]]
        };
        let mut centre: Option<(f64, Vec<[usize; 3]>)> = None;
        for o in options {
            let mut q = f64::INFINITY;
            for tri in &o {
                let ps = if n == 4 && tri[2] == 4 {
                    // (i − 1, i, p, i + 2)
                    let i = tri[1];
                    [
                        pos(&at(tri[0]), self),
                        pos(&at(i), self),
                        p_pos,
                        pos(&at(i + 2), self),
                    ]
                } else if n == 4 {
                    [
                        pos(&at(tri[0]), self),
                        pos(&at(tri[1]), self),
                        pos(&at(tri[2]), self),
                        p_pos,
                    ]
                } else {
                    [
                        p_pos,
                        pos(&at(tri[0]), self),
                        pos(&at(tri[1]), self),
                        pos(&at(tri[2]), self),
                    ]
                };
                q = q.min(crate::ops::quad_scaled_jacobian(ps));
            }
            if centre.as_ref().is_none_or(|c| q > c.0) {
                centre = Some((q, o));
            }
        }
        let (cq, co) = centre.expect("at least one option");
        if best.as_ref().is_some_and(|b| b.0 >= cq) {
            return best.map(|b| b.1).unwrap_or_default();
        }
        // The face point.
        let vs: Vec<u32> = own.iter().map(|c| c.v).collect();
        let v = self.new_vertex(&vs);
        report.face_points += 1;
        let tcs: Vec<u32> = own.iter().map(|c| c.tc).collect();
        let ncs: Vec<u32> = own.iter().map(|c| c.nc).collect();
        let p = Corner {
            v,
            tc: self.mid_tc(&tcs, false),
            nc: self.mid_nc(&ncs, false),
        };
        co.iter()
            .map(|tri| {
                if n == 4 && tri[2] == 4 {
                    [at(tri[0]), at(tri[1]), p, at(tri[1] + 2)]
                } else if n == 4 {
                    [at(tri[0]), at(tri[1]), at(tri[2]), p]
                } else {
                    [p, at(tri[0]), at(tri[1]), at(tri[2])]
                }
            })
            .collect()
    }

    /// The result as an indexed mesh (faces in input order).
    fn finish(self, m: &IndexedMesh) -> IndexedMesh {
        let mut live: Vec<u32> = (0..self.faces.len() as u32)
            .filter(|&f| self.alive[f as usize])
            .collect();
        live.sort_by_key(|&f| self.order[f as usize]);
        let tables = IndexedMesh {
            positions: self.positions,
            texcoords: self.texcoords,
            normals: self.normals,
            vertex_scalars: self.scalars.into_iter().collect(),
            ..IndexedMesh::new()
        };
        let mut out = FaceWriter::new(tables, m);
        for &f in &live {
            let face = &self.faces[f as usize];
            let v: Vec<u32> = face.iter().map(|c| c.v).collect();
            out.push(
                self.group[f as usize] as usize,
                &v,
                face.iter().map(|c| c.tc),
                face.iter().map(|c| c.nc),
            );
        }
        out.finish()
    }
}

/// A new entry of `table`, `mean` of the entries `of`; with a `cache`
/// keyed by the first two of `of`, the entry made before for the same
/// two (an edge point's attribute, shared by the two faces beside it
/// where they share the attribute too).
fn interpolated<T: Copy>(
    table: &mut Vec<T>,
    cache: Option<&mut HashMap<(u32, u32), u32>>,
    of: &[u32],
    mean: impl Fn(&[T]) -> T,
) -> u32 {
    let kk = key(of[0], of[1]);
    if let Some(&i) = cache.as_ref().and_then(|c| c.get(&kk)) {
        return i;
    }
    let values: Vec<T> = of.iter().map(|&i| table[i as usize]).collect();
    table.push(mean(&values));
    let i = table.len() as u32 - 1;
    if let Some(c) = cache {
        c.insert(kk, i);
    }
    i
}

/// The polygon `poly` joined with face `g` across the directed edge `a →
/// b` of `poly` (which `g` runs `b → a`): `poly` up to `a`, `g`'s other
/// corners, then `poly` from `b` on.
fn union(poly: &[Corner], g: &[Corner], a: u32, b: u32) -> Option<Vec<Corner>> {
    let n = poly.len();
    let i = (0..n).find(|&i| poly[i].v == a && poly[(i + 1) % n].v == b)?;
    let m = g.len();
    let j = (0..m).find(|&j| g[j].v == b && g[(j + 1) % m].v == a)?;
    let mut out = Vec::with_capacity(n + m - 2);
    out.extend((0..=i).map(|x| poly[x]));
    out.extend((2..m).map(|x| g[(j + x) % m]));
    out.extend((i + 1..n).map(|x| poly[x]));
    Some(out)
}

/// Checks that `out` is a bridging of `input` (callable from tests):
/// all quads; `input`'s positions first, bit for bit; the same Euler
/// characteristic; the same boundary once the edge points on it are taken
/// out, each of them exactly the midpoint of its two boundary neighbours;
/// every interior new vertex the midpoint of two of its neighbours (an
/// edge point) or inside the box of its neighbours and theirs (a face
/// point, or an edge point whose edge was split again); and,
/// when `input` is a valid half-edge mesh, a valid one too.
pub fn check_bridging(input: &IndexedMesh, out: &IndexedMesh) -> Result<(), String> {
    use std::collections::{BTreeSet, HashSet};
    if !out.is_quad_only() {
        return Err("a face is not a quad".into());
    }
    let n = input.vertex_count();
    let bits = |p: &[DVec3]| -> Vec<[u64; 3]> {
        p.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    if out.vertex_count() < n || bits(&out.positions[..n]) != bits(&input.positions) {
        return Err("the input's positions are not kept first".into());
    }
    // Undirected edges with their use counts.
    let edges = |m: &IndexedMesh| {
        let mut e: HashMap<(u32, u32), u32> = HashMap::new();
        for f in m.faces() {
            for k in 0..f.len() {
                *e.entry(key(f[k], f[(k + 1) % f.len()])).or_default() += 1;
            }
        }
        e
    };
    let (ein, eout) = (edges(input), edges(out));
    let euler = |m: &IndexedMesh, e: &HashMap<(u32, u32), u32>| {
        let used: HashSet<u32> = m.indices.iter().copied().collect();
        used.len() as i64 - e.len() as i64 + m.face_count() as i64
    };
    if euler(input, &ein) != euler(out, &eout) {
        return Err(format!(
            "the Euler characteristic changed: {} -> {}",
            euler(input, &ein),
            euler(out, &eout)
        ));
    }
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); out.vertex_count()];
    for &(a, b) in eout.keys() {
        neighbours[a as usize].push(b);
        neighbours[b as usize].push(a);
    }
    let pos = |v: u32| out.positions[v as usize];
    let is_mid = |v: u32, a: u32, b: u32| bits(&[(pos(a) + pos(b)) * 0.5]) == bits(&[pos(v)]);
    // The boundary, edge points taken out (an edge split twice loses its
    // inner point first).
    let mut boundary: BTreeSet<(u32, u32)> = eout
        .iter()
        .filter(|&(_, &c)| c == 1)
        .map(|(&e, _)| e)
        .collect();
    loop {
        let mut by_vertex: HashMap<u32, Vec<u32>> = HashMap::new();
        for &(a, b) in &boundary {
            by_vertex.entry(a).or_default().push(b);
            by_vertex.entry(b).or_default().push(a);
        }
        let Some((&m, ab)) = by_vertex
            .iter()
            .filter(|(&m, ab)| m as usize >= n && ab.len() == 2)
            .min_by_key(|(&m, _)| std::cmp::Reverse(m))
        else {
            if let Some(m) = by_vertex.keys().find(|&&m| m as usize >= n) {
                return Err(format!(
                    "new vertex {m} is on the boundary but not an edge point of it"
                ));
            }
            break;
        };
        let (a, b) = (ab[0], ab[1]);
        if !is_mid(m, a, b) {
            return Err(format!(
                "boundary point {m} is not the midpoint of {a} and {b}"
            ));
        }
        boundary.remove(&key(a, m));
        boundary.remove(&key(m, b));
        boundary.insert(key(a, b));
    }
    let want: BTreeSet<(u32, u32)> = ein
        .iter()
        .filter(|&(_, &c)| c == 1)
        .map(|(&e, _)| e)
        .collect();
    if boundary != want {
        return Err("the boundary changed".into());
    }
    for v in n as u32..out.vertex_count() as u32 {
        let nb = &neighbours[v as usize];
        if nb.is_empty() {
            return Err(format!("new vertex {v} is in no face"));
        }
        let midpoint = nb
            .iter()
            .enumerate()
            .any(|(i, &a)| nb[i + 1..].iter().any(|&b| is_mid(v, a, b)));
        // A face point is the mean of its polygon's corners, which are
        // its neighbours and theirs (an edge point split again is too).
        let ring2 = nb
            .iter()
            .flat_map(|&a| neighbours[a as usize].iter().copied().chain([a]));
        let (lo, hi) = ring2.fold((pos(nb[0]), pos(nb[0])), |(lo, hi), a| {
            (lo.min(pos(a)), hi.max(pos(a)))
        });
        let slack = (hi - lo).max_element() * 1e-9;
        let inside = pos(v).cmpge(lo - slack).all() && pos(v).cmple(hi + slack).all();
        if !midpoint && !inside {
            return Err(format!(
                "new vertex {v} is neither an edge point nor among its neighbours"
            ));
        }
    }
    crate::pairing::valid_if_input_is(input, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// Total area of the quads, each split along `q0–q2` (the fixtures
    /// are planar, so either diagonal gives the same).
    fn area(m: &IndexedMesh) -> f64 {
        m.faces()
            .map(|f| {
                let p = |k: usize| m.positions[f[k] as usize];
                (1..f.len() - 1)
                    .map(|k| (p(k) - p(0)).cross(p(k + 1) - p(0)).length() / 2.0)
                    .sum::<f64>()
            })
            .sum()
    }

    #[test]
    fn a_pentagon_becomes_quads_through_its_boundary() {
        let m = shapes::regular_polygon(5);
        let (out, _, r) = pair_and_bridge(&m).unwrap();
        assert_eq!((r.polygons, r.polygon_triangles, r.lone), (1, 3, 1));
        assert_eq!(r.boundary_strips, 1);
        check_bridging(&m, &out).unwrap();
        assert!((area(&out) - area(&m)).abs() < 1e-12);
        // Only the boundary edge the strip ends at gained a point.
        assert_eq!(r.edge_points, 1);
        assert_eq!(r.face_points, 0);
    }

    #[test]
    fn two_triangles_on_adjacent_edges_of_a_quad_make_a_hexagon_of_two_quads() {
        // The quad's halves are across 0–2, and both triangles touch the
        // half (0, 1, 2): no pairing exists, but the three faces make a
        // hexagon, cut into two quads with no new vertex.
        let m = IndexedMesh::from_faces(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(0.5, -0.5, 0.0),
                DVec3::new(1.5, 0.5, 0.0),
            ],
            [vec![0u32, 1, 2, 3], vec![1, 0, 4], vec![2, 1, 5]],
        );
        assert!(crate::pairing::pair_triangles(&m).is_err());
        let (out, _, r) = pair_and_bridge(&m).unwrap();
        assert_eq!((r.lone, r.strips, r.new_vertices()), (2, 1, 0));
        assert_eq!(out.face_count(), 2);
        check_bridging(&m, &out).unwrap();
        assert!((area(&out) - area(&m)).abs() < 1e-12);
        for f in out.faces() {
            let q = [f[0], f[1], f[2], f[3]].map(|v| out.positions[v as usize]);
            assert!(crate::ops::quad_scaled_jacobian(q) > 0.0);
        }
    }

    /// A triangulated grid whose triangles in `island` have texture
    /// coordinates of their own: `uv = (x + 10, y)` there, `(x, y)`
    /// elsewhere, so the island's border is a seam.
    fn grid_with_island(nx: u32, ny: u32, island: impl Fn(usize) -> bool) -> IndexedMesh {
        let mut m = shapes::triangulated(&shapes::grid(nx, ny, 1.0, 1.0), 7);
        let nv = m.vertex_count() as u32;
        m.texcoords = m
            .positions
            .iter()
            .map(|p| [p.x, p.y])
            .chain(m.positions.iter().map(|p| [p.x + 10.0, p.y]))
            .collect();
        m.corner_texcoords = (0..m.face_count())
            .flat_map(|f| {
                let off = if island(f) { nv } else { 0 };
                m.face(f).iter().map(move |&v| v + off).collect::<Vec<_>>()
            })
            .collect();
        m
    }

    #[test]
    fn an_odd_uv_island_is_bridged_across_its_seam() {
        // Seven triangles in the island: no pairing can cover it.
        let m = grid_with_island(4, 3, |f| f < 7);
        assert!(crate::pairing::pair_triangles(&m).is_err());
        let (out, _, r) = pair_and_bridge(&m).unwrap();
        assert!(r.lone >= 2, "{r:?}");
        check_bridging(&m, &out).unwrap();
        assert!((area(&out) - area(&m)).abs() < 1e-12);
        // No quad takes texture coordinates from both sides of the seam,
        // and every corner's are its position's on its side.
        for f in 0..out.face_count() {
            let s = out.face_starts[f] as usize;
            let offsets: Vec<f64> = (0..4)
                .map(|k| {
                    let uv = out.texcoords[out.corner_texcoords[s + k] as usize];
                    let p = out.positions[out.indices[s + k] as usize];
                    assert!((uv[1] - p.y).abs() < 1e-12);
                    uv[0] - p.x
                })
                .collect();
            assert!(offsets.iter().all(|o| (o - offsets[0]).abs() < 1e-12));
            assert!(offsets[0].abs() < 1e-12 || (offsets[0] - 10.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_polygon_with_no_diagonal_that_is_not_an_edge_is_refused_by_name() {
        // A torus three quads around: its octagon (face 4) wraps the tube,
        // and every way to cut it repeats an edge of the mesh.
        let m = shapes::uncuttable_polygons();
        assert!(crate::mesh::Mesh::from_indexed(&m).is_ok());
        assert_eq!(
            pair_and_bridge(&m).unwrap_err(),
            PairingError::Polygon { face: 4 }
        );
    }

    #[test]
    fn a_lone_triangle_walks_by_re_pairing_with_no_new_vertex() {
        // A strip of 6 unit quads, triangulated, and one more triangle at
        // its left end: 13 triangles, one left alone.
        let mut p: Vec<DVec3> = (0..14)
            .map(|i| DVec3::new((i % 7) as f64, (i / 7) as f64, 0.0))
            .collect();
        p.push(DVec3::new(-1.0, 0.5, 0.0));
        let mut faces: Vec<[u32; 3]> = (0..6u32)
            .flat_map(|i| [[i, i + 1, i + 8], [i, i + 8, i + 7]])
            .collect();
        faces.push([0, 7, 14]);
        let m = IndexedMesh::from_faces(p, faces);
        let (paired, _, lone) = pair_partial(&m).unwrap();
        assert_eq!(lone.len(), 1);
        let mut s = Strips::new(&paired, &[lone[0].1 as u32]);
        let t = lone[0].1 as u32;
        let before = s.centroid(&s.faces[t as usize]);
        // Towards the far end.
        let to = DVec3::new(if before.x < 3.0 { 7.0 } else { -2.0 }, 0.5, 0.0);
        let t2 = s.walk_toward(t, to);
        let after = s.centroid(&s.faces[t2 as usize]);
        assert!(
            after.distance(to) < before.distance(to) - 2.0,
            "{before} -> {after}"
        );
        assert!(s.lone[t2 as usize] && s.faces[t2 as usize].len() == 3);
        // No new vertex; the live faces are the input's triangles, each
        // quad two of them.
        assert_eq!(s.positions.len(), m.vertex_count());
        let out = IndexedMesh::from_faces(
            m.positions.clone(),
            (0..s.faces.len())
                .filter(|&f| s.alive[f])
                .map(|f| s.faces[f].iter().map(|c| c.v).collect::<Vec<_>>()),
        );
        let mut want: Vec<[u32; 3]> = m.faces().map(|f| [f[0], f[1], f[2]]).collect();
        let mut got: Vec<[u32; 3]> = Vec::new();
        for f in out.faces() {
            got.push([f[0], f[1], f[2]]);
            if f.len() == 4 {
                got.push([f[2], f[3], f[0]]);
            }
        }
        let canon = |v: &mut Vec<[u32; 3]>| {
            for t in v.iter_mut() {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                *t = [t[k], t[(k + 1) % 3], t[(k + 2) % 3]];
            }
            v.sort_unstable();
        };
        canon(&mut want);
        canon(&mut got);
        assert_eq!(got, want);
        assert!(crate::mesh::Mesh::from_indexed(&out).is_ok());
    }

    #[test]
    fn triangles_that_can_join_nothing_get_face_points() {
        // Every triangle of a closed mesh its own UV island: no pair is
        // allowed anywhere, every triangle ends a strip at a face point.
        let mut m = shapes::triangulated(&shapes::cube(1.0), 3);
        m.texcoords = (0..m.indices.len()).map(|i| [i as f64, 0.0]).collect();
        m.corner_texcoords = (0..m.indices.len() as u32).collect();
        let (out, _, r) = pair_and_bridge(&m).unwrap();
        assert_eq!(r.lone, 12);
        assert!(r.centre_ends > 0);
        check_bridging(&m, &out).unwrap();
    }
}
