//! Triangle pairing: a triangle (or triangle-and-quad) mesh made quad-only
//! by joining adjacent triangles two by two, with no new vertex.
//!
//! The other way to make such a mesh quad-only is the linear split
//! ([`crate::subdivide::catmull_clark_split`]): every triangle becomes three
//! quads around new edge and face points, so the quad mesh has about six
//! times the input's vertices and three times its triangles. Pairing keeps
//! the input's vertices, ids and positions, and each quad is two input
//! triangles, which a renderer splitting the quad along that shared edge
//! draws again exactly: the finest level of a progressive file is the
//! input. A pairing is a perfect matching of the triangles' dual graph; a
//! closed manifold triangle mesh always has one (Petersen's theorem: the
//! dual is cubic and bridgeless), a mesh with boundary or an odd number of
//! triangles in a part may not.
//!
//! # What [`pair_triangles`] does
//!
//! 1. **Candidates.** Two triangles can pair across an edge that exactly
//!    these two share, in opposite directions (consistent orientation),
//!    when their far corners differ, they are in the same face group, and
//!    their texture coordinate indices (where the mesh has them) agree at
//!    the edge's two ends, so the quad carries no UV seam inside it
//!    (normals are not compared: flat shading gives each face its own).
//!    An input quad counts as its two triangles across `q0–q2`, paired
//!    with each other from the start. The quad of triangles `(a, b, c)`
//!    and `(b, a, d)` is `(a, d, b, c)`, oriented as they are.
//! 2. **Greedy by shape.** Candidates sorted by the quad's quality — the
//!    quality metric's scaled Jacobian (1 for a rectangle, ≤ 0 for a quad
//!    folded or not convex) — best
//!    first, ties by edge order; each joins two free triangles if its
//!    quality is positive.
//! 3. **Augmenting paths.** Each triangle left alone looks for a path of
//!    candidate edges, alternately unpaired and paired, to another one,
//!    and flips the path: one more pair. First breadth first, which cannot
//!    pass an odd cycle of the alternating tree; then, from the triangles
//!    still alone, Edmonds' blossom search, which finds a path whenever
//!    one exists. Each over candidates of positive quality first, then
//!    over any; all within [`SEARCH_BUDGET_PER_TRIANGLE`] visits per
//!    triangle. A path from a triangle among quads to another one runs
//!    through the quads between them and re-pairs their halves (the
//!    quad-dominant sword: 348 triangles, 2,706 of its 22,117 quads
//!    re-paired).
//! 4. **Doublets.** A quad that shares two edges with a neighbour (the
//!    triangles around a vertex of triangle valence 3 or 4 paired among
//!    themselves, leaving the vertex in two quads) is refused: its pair's
//!    edge is barred and its two triangles go through step 3 again, for
//!    up to [`DOUBLET_ROUNDS`] rounds. Where that leaves a triangle alone,
//!    the round before is kept and its doublets reported (the bunny: 21
//!    refused, 1 left; the skull 353 and 95).
//! 5. **Output.** Faces in input order: a quad whose halves stayed
//!    together as it is, any other pair at its first triangle's place.
//!
//! If triangles stay unpaired, or a face has more than four corners, the
//! result is an error. [`crate::bridging::pair_and_bridge`] goes on from
//! there: it cuts polygons into triangles first and joins the triangles
//! left alone by strips of quads, with a few new vertices.
//!
//! An input quad whose diagonal `q0–q2` is also an edge elsewhere (a small
//! closed part) stays whole: re-pairing its halves would give that edge
//! three or four faces.
//!
//! Measured (`pqm encode`, paired against `--triangles split`;
//! `docs/figures-history.md`, session 24): every triangle and
//! quad-dominant mesh among the shared meshes pairs completely, and its
//! `.pqm` file is 3.1–5.1× smaller.

use crate::indexed::{FaceWriter, IndexedMesh};
use glam::DVec3;
use std::collections::{HashMap, VecDeque};
use thiserror::Error;

/// Budget of the augmenting-path searches, in triangles visited, per
/// triangle of the mesh (plus a fixed 2^20): past it the searches stop and
/// the triangles left alone are reported. A search may cross the whole
/// mesh (the skull's last ones do: a cap of 2^16 visits per search left
/// two of its triangles alone).
pub const SEARCH_BUDGET_PER_TRIANGLE: usize = 256;

/// Why a mesh cannot be paired into quads.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum PairingError {
    /// `face_starts` is not an offset table of `indices`, a face names a
    /// vertex that does not exist, or a per-corner table is not one entry
    /// per corner.
    #[error("malformed mesh: {0}")]
    Malformed(String),
    /// A face with other than three or four corners.
    #[error("face {face} has {len} vertices (pairing joins triangles; quads stay as they are)")]
    FaceSize {
        /// The face.
        face: usize,
        /// Its number of corners.
        len: usize,
    },
    /// A face of five or more corners that cannot be cut into triangles
    /// without a diagonal that is already an edge of the mesh (a polygon
    /// wrapped around a thin part).
    #[error("face {face} cannot be cut into triangles without repeating an edge of the mesh")]
    Polygon {
        /// The face.
        face: usize,
    },
    /// Triangles no pairing found a partner for.
    #[error("{unpaired} of {triangles} triangles have no partner (the first: face {first_face})")]
    Unpaired {
        /// How many.
        unpaired: usize,
        /// Triangles in the mesh.
        triangles: usize,
        /// The first of them, as an input face index.
        first_face: usize,
    },
}

/// What [`pair_triangles`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PairingReport {
    /// Triangles in the input.
    pub triangles: usize,
    /// Quads made of two triangles (input quads kept whole not counted).
    pub pairs: usize,
    /// Pairs the greedy pass made (the rest came from augmenting paths).
    pub greedy_pairs: usize,
    /// Made quads whose quality is not positive (folded or not convex):
    /// pairs only the second augmenting pass could make.
    pub folded: usize,
    /// Input quads whose halves went to other pairs: an augmenting path
    /// from a triangle among quads to another one re-pairs the quads on
    /// its way (each half joins the next triangle along it).
    pub repaired_quads: usize,
    /// Pairs refused because their quad shared two edges with a neighbour
    /// (step 4), their triangles paired again.
    pub doublets_avoided: usize,
    /// Pairs whose quad still shares two edges with a neighbour: after
    /// [`DOUBLET_ROUNDS`] rounds, or where refusing them left a triangle
    /// with no partner (the pairing before that round is kept). The mesh
    /// is valid with them (`Mesh::validate_structure`); the coarsener
    /// removes doublets as it goes.
    pub doublets_left: usize,
}

/// A pair of triangles across one edge: the quad and its quality.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    quality: f64,
    t: [u32; 2],
    quad: [u32; 4],
}

/// The quality of quad `q`: its scaled Jacobian, the quality metric's own
/// ([`crate::ops::quad_scaled_jacobian`]): 1 for a rectangle, ≤ 0 for a
/// quad folded, not convex or degenerate.
fn quad_quality(positions: &[DVec3], q: [u32; 4]) -> f64 {
    crate::ops::quad_scaled_jacobian(q.map(|i| positions[i as usize]))
}

/// The mesh with its triangles joined in pairs (see the module
/// documentation), or why not. Positions, vertex ids, per-vertex scalars
/// and the texture coordinate and normal tables are kept; faces keep their
/// input order (a pair at its first triangle's place), groups their names.
pub fn pair_triangles(mesh: &IndexedMesh) -> Result<(IndexedMesh, PairingReport), PairingError> {
    let (out, report, lone) = pair_partial(mesh)?;
    match lone.first() {
        None => Ok((out, report)),
        Some(&(first_face, _)) => Err(PairingError::Unpaired {
            unpaired: lone.len(),
            triangles: report.triangles,
            first_face,
        }),
    }
}

/// [`pair_partial`]'s result: the mesh, the report, the triangles left
/// alone as `(input face, output face)`.
pub(crate) type PartialPairing = (IndexedMesh, PairingReport, Vec<(usize, usize)>);

/// [`pair_triangles`], but triangles left alone are kept in the output as
/// triangles (at their input places) instead of failing: with them, each
/// as `(input face, output face)`. The doublet rounds may not leave more
/// triangles alone than the first round's searches did. For
/// [`crate::bridging`], which joins them.
pub(crate) fn pair_partial(mesh: &IndexedMesh) -> Result<PartialPairing, PairingError> {
    check_tables(mesh)?;
    let nf = mesh.face_count();
    // The units: each triangle, and each quad as its two triangles across
    // `q0–q2` (corner positions `[0, 1, 2]` and `[2, 3, 0]`), in face order.
    let mut units: Vec<Unit> = Vec::with_capacity(2 * nf);
    let mut triangles = 0usize;
    for f in 0..nf {
        let face = mesh.face(f);
        let at = |ks: [usize; 3]| Unit {
            face: f as u32,
            v: ks.map(|k| face[k]),
            corner: ks.map(|k| mesh.face_starts[f] as usize + k),
        };
        match face.len() {
            3 => {
                units.push(at([0, 1, 2]));
                triangles += 1;
            }
            4 => units.extend([at([0, 1, 2]), at([2, 3, 0])]),
            len => return Err(PairingError::FaceSize { face: f, len }),
        }
    }
    let group_of = face_groups(mesh);
    // Directed edges of the units, by undirected key: `(unit, corner)` of
    // each use; a candidate is an edge with exactly two opposite uses.
    // (The first two uses and the count: only an edge of exactly two
    // uses is a candidate.)
    let mut uses: HashMap<(u32, u32), EdgeUses> = HashMap::with_capacity(units.len() * 2);
    let mut keys: Vec<(u32, u32)> = Vec::with_capacity(units.len() * 3 / 2);
    for (t, u) in units.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (u.v[k], u.v[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let (n, first) = uses.entry(key).or_insert_with(|| {
                keys.push(key);
                (0, [(0, 0); 2])
            });
            if let Some(slot) = first.get_mut(*n as usize) {
                *slot = (t as u32, k as u8);
            }
            *n += 1;
        }
    }
    // Texture coordinates must agree at the shared edge's ends (a UV seam
    // inside a quad would map it wrongly); normals are not compared: a
    // flat-shaded mesh has one per face, and the quad takes each corner's
    // from one of its triangles.
    let attrs_agree = |c1: usize, c2: usize| {
        mesh.corner_texcoords.is_empty() || mesh.corner_texcoords[c1] == mesh.corner_texcoords[c2]
    };
    let mut cands: Vec<Candidate> = Vec::new();
    let mut mate = vec![u32::MAX; units.len()];
    // An input quad's own two halves: paired from the start, as the quad
    // with its corners as they are.
    for t in 1..units.len() {
        let (x, y) = (&units[t - 1], &units[t]);
        if x.face == y.face {
            let q = mesh.face(x.face as usize);
            let quad = [q[0], q[1], q[2], q[3]];
            mate[t - 1] = t as u32;
            mate[t] = t as u32 - 1;
            cands.push(Candidate {
                quality: quad_quality(&mesh.positions, quad),
                t: [t as u32 - 1, t as u32],
                quad,
            });
        }
    }
    // An input quad whose diagonal `q0–q2` is an edge elsewhere too (a
    // small closed part can bring two corners together twice) stays whole:
    // re-pairing its halves would make that diagonal an edge of three or
    // four faces.
    let locked = |u: &Unit| {
        let f = u.face as usize;
        let q = mesh.face(f);
        q.len() == 4 && uses[&(q[0].min(q[2]), q[0].max(q[2]))].0 != 2
    };
    for key in &keys {
        let (2, [(t1, k1), (t2, k2)]) = uses[key] else {
            continue;
        };
        let (x, y) = (&units[t1 as usize], &units[t2 as usize]);
        if x.face == y.face
            || group_of[x.face as usize] != group_of[y.face as usize]
            || locked(x)
            || locked(y)
        {
            continue;
        }
        let (k1, k2) = (k1 as usize, k2 as usize);
        let (a, b, c) = (x.v[k1], x.v[(k1 + 1) % 3], x.v[(k1 + 2) % 3]);
        let d = y.v[(k2 + 2) % 3];
        // `y` must run b → a.
        if y.v[k2] != b || y.v[(k2 + 1) % 3] != a || c == d || a == b {
            continue;
        }
        let (ca, cb) = (x.corner[k1], x.corner[(k1 + 1) % 3]);
        if !attrs_agree(ca, y.corner[(k2 + 1) % 3]) || !attrs_agree(cb, y.corner[k2]) {
            continue;
        }
        let quad = [a, d, b, c];
        cands.push(Candidate {
            quality: quad_quality(&mesh.positions, quad),
            t: [t1, t2],
            quad,
        });
    }
    // Best first; the sort is stable, so ties keep edge order.
    let mut order: Vec<u32> = (0..cands.len() as u32).collect();
    order.sort_by(|&i, &j| {
        cands[j as usize]
            .quality
            .total_cmp(&cands[i as usize].quality)
    });
    let mut report = PairingReport {
        triangles,
        ..PairingReport::default()
    };
    for &i in &order {
        let c = cands[i as usize];
        let [t1, t2] = c.t;
        if c.quality > 0.0 && mate[t1 as usize] == u32::MAX && mate[t2 as usize] == u32::MAX {
            mate[t1 as usize] = t2;
            mate[t2 as usize] = t1;
            report.greedy_pairs += 1;
        }
    }
    // Adjacency over candidates: `(other unit, candidate)` per unit.
    let mut adj: Vec<Vec<(u32, u32)>> = vec![Vec::new(); units.len()];
    for (i, c) in cands.iter().enumerate() {
        adj[c.t[0] as usize].push((c.t[1], i as u32));
        adj[c.t[1] as usize].push((c.t[0], i as u32));
    }
    let mut budget = SEARCH_BUDGET_PER_TRIANGLE
        .saturating_mul(units.len())
        .saturating_add(1 << 20);
    // Step 4: pairs whose quad would share two edges with a neighbour (a
    // doublet: a vertex of triangle valence 3 or 4 whose triangles paired
    // among themselves) are refused and their triangles paired again,
    // round after round.
    let mut forbidden = vec![false; cands.len()];
    let mut quad_of = vec![u32::MAX; units.len()];
    // The last complete pairing and its doublets: what the result falls
    // back to when refusing this round's pairs leaves a triangle alone.
    let mut last: Option<(Vec<u32>, Vec<u32>, usize)> = None;
    let mut allowed_alone: Option<usize> = None;
    for round in 0..=DOUBLET_ROUNDS {
        let open = |i: u32, positive_only: bool| {
            !forbidden[i as usize] && (!positive_only || cands[i as usize].quality > 0.0)
        };
        for positive_only in [true, false] {
            augment(&mut mate, &adj, &mut budget, |i| open(i, positive_only));
        }
        // What the plain searches missed (a path through an odd cycle).
        if mate.contains(&u32::MAX) {
            for positive_only in [true, false] {
                blossom_augment(&mut mate, &adj, &mut budget, |i| open(i, positive_only));
            }
        }
        // Triangles the first round's searches left alone stay allowed
        // (the caller bridges them or fails); a round that leaves more
        // than those is undone: the round before is kept, doublets and
        // all. (Taking back only the refusals next to the triangles newly
        // alone and searching again, up to four times, was tried: it
        // kept no more refusals on the bunny, the skull or a decimated
        // loki.)
        let alone = mate.iter().filter(|&&m| m == u32::MAX).count();
        if alone > *allowed_alone.get_or_insert(alone) {
            if let Some((m, q, left)) = last.take() {
                (mate, quad_of, report.doublets_left) = (m, q, left);
                report.doublets_avoided = report.doublets_avoided.saturating_sub(left);
            }
            break;
        }
        // The candidate of each unit's pair.
        for (t, list) in adj.iter().enumerate() {
            for &(o, i) in list {
                if mate[t] == o && !forbidden[i as usize] {
                    quad_of[t] = i;
                }
            }
        }
        let bad = doublet_pairs(&units, &mate, &quad_of, &cands);
        if bad.is_empty() {
            break;
        }
        if round == DOUBLET_ROUNDS {
            report.doublets_left = bad.len();
            break;
        }
        last = Some((mate.clone(), quad_of.clone(), bad.len()));
        for &i in &bad {
            forbidden[i as usize] = true;
            let [a, b] = cands[i as usize].t;
            mate[a as usize] = u32::MAX;
            mate[b as usize] = u32::MAX;
        }
        report.doublets_avoided += bad.len();
    }
    let mut out = FaceWriter::new(vertex_tables(mesh), mesh);
    let mut lone = Vec::new();
    for t in 0..units.len() {
        let o = mate[t] as usize;
        if mate[t] == u32::MAX {
            // Alone: the triangle as it is.
            let u = &units[t];
            let f = u.face as usize;
            lone.push((f, out.face_count()));
            out.push(
                group_of[f],
                &u.v,
                attrs(&mesh.corner_texcoords, &u.corner),
                attrs(&mesh.corner_normals, &u.corner),
            );
            continue;
        }
        if o < t {
            continue; // emitted with the pair's first unit
        }
        let c = cands[quad_of[t] as usize];
        let (u, w) = (&units[t], &units[o]);
        // Each corner's attributes from the unit that has it (the shared
        // corners agree).
        let pick = |v: u32| {
            for x in [u, w] {
                if let Some(k) = x.v.iter().position(|&y| y == v) {
                    return x.corner[k];
                }
            }
            unreachable!("a quad corner is a corner of its two triangles")
        };
        let corners = c.quad.map(pick);
        if u.face != w.face {
            report.pairs += 1;
            report.folded += (c.quality <= 0.0) as usize;
            // A quad's half paired with another unit: that quad is
            // re-paired (counted once, at its first half).
            for x in [t, o] {
                let f = units[x].face as usize;
                if mesh.face(f).len() == 4 && units[x].corner[0] == mesh.face_starts[f] as usize {
                    report.repaired_quads += 1;
                }
            }
        }
        out.push(
            group_of[u.face as usize],
            &c.quad,
            attrs(&mesh.corner_texcoords, &corners),
            attrs(&mesh.corner_normals, &corners),
        );
    }
    let out = out.finish();
    Ok((out, report, lone))
}

/// A mesh with `mesh`'s vertex and attribute tables and no face: what a
/// conversion that keeps every vertex writes its faces into.
pub(crate) fn vertex_tables(mesh: &IndexedMesh) -> IndexedMesh {
    IndexedMesh {
        positions: mesh.positions.clone(),
        texcoords: mesh.texcoords.clone(),
        normals: mesh.normals.clone(),
        vertex_scalars: mesh.vertex_scalars.clone(),
        ..IndexedMesh::new()
    }
}

/// The entries of the per-corner table `table` at `corners` (lazily: an
/// empty table is never read).
pub(crate) fn attrs<'t>(table: &'t [u32], corners: &'t [usize]) -> impl Iterator<Item = u32> + 't {
    corners.iter().map(move |&c| table[c])
}

/// Rounds of step 4 (refused pairs, then the searches again) before the
/// doublets left are reported ([`PairingReport::doublets_left`]).
pub const DOUBLET_ROUNDS: usize = 16;

/// Step 4's check: the made pairs (not an input quad kept whole) whose
/// quad shares more than one edge with one neighbour, as candidate
/// indices, sorted; of two such quads the one of lower quality (both
/// made), else the made one. Input quads that already shared two edges
/// are left as they are.
fn doublet_pairs(units: &[Unit], mate: &[u32], quad_of: &[u32], cands: &[Candidate]) -> Vec<u32> {
    const NONE: u32 = u32::MAX;
    let first = |t: usize| mate[t] != NONE && (mate[t] as usize) > t;
    let quad = |t: usize| cands[quad_of[t] as usize].quad;
    let mut sides: HashMap<(u32, u32), [u32; 2]> = HashMap::with_capacity(2 * units.len());
    for t in (0..units.len()).filter(|&t| first(t)) {
        let q = quad(t);
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) & 3]);
            let e = sides.entry((a.min(b), a.max(b))).or_insert([NONE; 2]);
            let slot = (e[0] != NONE) as usize;
            e[slot] = t as u32;
        }
    }
    let made = |t: usize| units[t].face != units[mate[t] as usize].face;
    let mut out = Vec::new();
    for t in (0..units.len()).filter(|&t| first(t)) {
        let q = quad(t);
        let mut across = [NONE; 4];
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) & 3]);
            let e = sides[&(a.min(b), a.max(b))];
            across[k] = if e[0] == t as u32 { e[1] } else { e[0] };
        }
        for k in 0..4 {
            let n = across[k];
            if n == NONE || !across[k + 1..].contains(&n) {
                continue;
            }
            let n = n as usize;
            let pick = match (made(t), made(n)) {
                (true, true) => {
                    if cands[quad_of[n] as usize].quality < cands[quad_of[t] as usize].quality {
                        n
                    } else {
                        t
                    }
                }
                (true, false) => t,
                (false, true) => n,
                (false, false) => continue,
            };
            out.push(quad_of[pick]);
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// An edge's uses by the units: how many, and the first two `(unit,
/// corner)`.
type EdgeUses = (u32, [(u32, u8); 2]);

/// One triangle of [`pair_triangles`]: an input triangle or half of an
/// input quad; its vertices and their corner positions in `indices`.
#[derive(Clone, Copy, Debug)]
struct Unit {
    face: u32,
    v: [u32; 3],
    corner: [usize; 3],
}

/// The shape checks that make every index below safe: offsets from 0 to
/// `indices.len()`, never decreasing; vertex indices in range; per-corner
/// tables empty or one entry per corner.
pub(crate) fn check_tables(mesh: &IndexedMesh) -> Result<(), PairingError> {
    let fs = &mesh.face_starts;
    let n = mesh.indices.len();
    if fs.first() != Some(&0)
        || fs.last().map(|&l| l as usize) != Some(n)
        || fs.windows(2).any(|w| w[0] > w[1])
    {
        return Err(PairingError::Malformed(
            "face_starts is not an offset table of the indices".into(),
        ));
    }
    let nv = mesh.vertex_count();
    for f in 0..mesh.face_count() {
        if let Some(&v) = mesh.face(f).iter().find(|&&v| v as usize >= nv) {
            return Err(PairingError::Malformed(format!(
                "face {f} references vertex {v}, but the mesh has {nv} vertices"
            )));
        }
    }
    for (name, t) in [
        ("corner_texcoords", &mesh.corner_texcoords),
        ("corner_normals", &mesh.corner_normals),
    ] {
        if !t.is_empty() && t.len() != n {
            return Err(PairingError::Malformed(format!(
                "{name} has {} entries for {n} corners",
                t.len()
            )));
        }
    }
    Ok(())
}

/// Per face, the index of its group in `mesh.groups` (0 for every face
/// when the mesh has none; faces before the first group share the first).
pub(crate) fn face_groups(mesh: &IndexedMesh) -> Vec<usize> {
    let mut out = vec![0usize; mesh.face_count()];
    for (g, w) in mesh.groups.iter().enumerate() {
        let start = w.1 as usize;
        let end = mesh
            .groups
            .get(g + 1)
            .map_or(mesh.face_count(), |n| n.1 as usize);
        for o in out.iter_mut().take(end.min(mesh.face_count())).skip(start) {
            *o = g;
        }
    }
    out
}

/// Step 3: for each unpaired triangle, a breadth-first search over the
/// candidates `allowed` keeps for an alternating path to another unpaired
/// one, flipped when found; each visit spends one of `budget`, and none is
/// left, no search starts or goes on. Every triangle is in the tree once (`seen`),
/// so a found path is simple and the flip keeps `mate` a matching.
fn augment(
    mate: &mut [u32],
    adj: &[Vec<(u32, u32)>],
    budget: &mut usize,
    allowed: impl Fn(u32) -> bool,
) {
    const NONE: u32 = u32::MAX;
    let n = mate.len();
    // `seen` stamps per search, so no clearing between searches.
    let mut seen = vec![u32::MAX; n];
    let mut parent = vec![NONE; n];
    let mut queue = VecDeque::new();
    for root in 0..n {
        if mate[root] != NONE {
            continue;
        }
        if *budget == 0 {
            return;
        }
        let stamp = root as u32;
        seen[root] = stamp;
        parent[root] = NONE;
        queue.clear();
        queue.push_back(root as u32);
        let mut found = NONE;
        'search: while let Some(x) = queue.pop_front() {
            for &(y, i) in &adj[x as usize] {
                if seen[y as usize] == stamp || !allowed(i) {
                    continue;
                }
                if mate[y as usize] == NONE {
                    parent[y as usize] = x;
                    found = y;
                    break 'search;
                }
                let z = mate[y as usize];
                if seen[z as usize] == stamp {
                    continue;
                }
                seen[y as usize] = stamp;
                seen[z as usize] = stamp;
                parent[y as usize] = x;
                queue.push_back(z);
                *budget = budget.saturating_sub(2);
                if *budget == 0 {
                    break 'search;
                }
            }
        }
        if found == NONE {
            continue;
        }
        // Flip: `f` pairs with its parent `x`; `x`'s old partner (through
        // which the search reached `x`) continues the path.
        let mut f = found;
        loop {
            let x = parent[f as usize];
            let old = mate[x as usize];
            mate[f as usize] = x;
            mate[x as usize] = f;
            if old == NONE {
                break;
            }
            f = old;
        }
    }
}

/// Step 3, for the triangles [`augment`]'s searches left alone: Edmonds'
/// blossom search from each, which finds an augmenting path whenever one
/// exists (an odd cycle of the alternating tree is contracted to its base
/// and searched through), over the candidates `allowed` keeps. Only the
/// entries a search touched are reset after it, so a search costs what it
/// visits (each contraction walks the touched list); visits spend
/// `budget`, as in [`augment`].
fn blossom_augment(
    mate: &mut [u32],
    adj: &[Vec<(u32, u32)>],
    budget: &mut usize,
    allowed: impl Fn(u32) -> bool,
) {
    const NONE: u32 = u32::MAX;
    let n = mate.len();
    let mut used = vec![false; n];
    let mut parent = vec![NONE; n];
    let mut base: Vec<u32> = (0..n as u32).collect();
    let mut in_blossom = vec![false; n];
    let mut on_path = vec![false; n];
    let mut touched: Vec<u32> = Vec::new();
    let mut queue = VecDeque::new();
    for root in 0..n as u32 {
        if mate[root as usize] != NONE {
            continue;
        }
        if *budget == 0 {
            return;
        }
        touched.clear();
        queue.clear();
        used[root as usize] = true;
        touched.push(root);
        queue.push_back(root);
        let mut found = NONE;
        'search: while let Some(v) = queue.pop_front() {
            for &(to, i) in &adj[v as usize] {
                if !allowed(i) || base[v as usize] == base[to as usize] || mate[v as usize] == to {
                    continue;
                }
                *budget = budget.saturating_sub(1);
                if *budget == 0 {
                    break 'search;
                }
                let m_to = mate[to as usize];
                if to == root || (m_to != NONE && parent[m_to as usize] != NONE) {
                    // An odd cycle: contract it to the base of `v` and `to`.
                    let b = lowest_common_base(v, to, mate, &parent, &base, &mut on_path);
                    for x in [v, to] {
                        mark_blossom(
                            x,
                            b,
                            if x == v { to } else { v },
                            mate,
                            &mut parent,
                            &base,
                            &mut in_blossom,
                            &mut touched,
                        );
                    }
                    *budget = budget.saturating_sub(touched.len());
                    for &x in &touched {
                        let x = x as usize;
                        if in_blossom[base[x] as usize] {
                            base[x] = b;
                            if !used[x] {
                                used[x] = true;
                                queue.push_back(x as u32);
                            }
                        }
                    }
                    for &x in &touched {
                        in_blossom[x as usize] = false;
                    }
                } else if parent[to as usize] == NONE {
                    parent[to as usize] = v;
                    touched.push(to);
                    if m_to == NONE {
                        found = to;
                        break 'search;
                    }
                    used[m_to as usize] = true;
                    touched.push(m_to);
                    queue.push_back(m_to);
                }
            }
        }
        if found != NONE {
            // Flip the path root … found (`parent` then `mate`, alternately).
            let mut f = found;
            while f != NONE {
                let p = parent[f as usize];
                let next = mate[p as usize];
                mate[f as usize] = p;
                mate[p as usize] = f;
                f = next;
            }
        }
        for &x in &touched {
            let x = x as usize;
            used[x] = false;
            parent[x] = NONE;
            base[x] = x as u32;
        }
    }
}

/// The base where the alternating-tree paths of `a` and `b` (through
/// `mate` then `parent`, blossoms by their base) meet; `on_path` is left
/// all false.
fn lowest_common_base(
    a: u32,
    b: u32,
    mate: &[u32],
    parent: &[u32],
    base: &[u32],
    on_path: &mut [bool],
) -> u32 {
    const NONE: u32 = u32::MAX;
    let mut marked = Vec::new();
    let mut x = a;
    loop {
        x = base[x as usize];
        on_path[x as usize] = true;
        marked.push(x);
        if mate[x as usize] == NONE {
            break;
        }
        x = parent[mate[x as usize] as usize];
    }
    let mut y = b;
    let found = loop {
        y = base[y as usize];
        if on_path[y as usize] {
            break y;
        }
        y = parent[mate[y as usize] as usize];
    };
    for m in marked {
        on_path[m as usize] = false;
    }
    found
}

/// Marks the blossom's bases on the path from `v` down to base `b`, and
/// points the path's `parent` links across the cycle (`child`: the vertex
/// on the other side of the edge that closed it).
#[allow(clippy::too_many_arguments)]
fn mark_blossom(
    mut v: u32,
    b: u32,
    mut child: u32,
    mate: &[u32],
    parent: &mut [u32],
    base: &[u32],
    in_blossom: &mut [bool],
    touched: &mut Vec<u32>,
) {
    while base[v as usize] != b {
        let m = mate[v as usize];
        in_blossom[base[v as usize] as usize] = true;
        in_blossom[base[m as usize] as usize] = true;
        touched.push(base[v as usize]);
        touched.push(base[m as usize]);
        parent[v as usize] = child;
        child = m;
        v = parent[m as usize];
    }
}

/// Checks that `paired` is a pairing of `input` (callable from tests): all
/// quads; the same positions; every quad either one of `input`'s quads as
/// it is or two triangles across its diagonal from corner 0, where the
/// triangles are `input`'s, each of its quads counting as its two halves
/// across `q0–q2`, all of them used once; and, when `input` is a valid
/// half-edge mesh, a valid one too.
pub fn check_pairing(input: &IndexedMesh, paired: &IndexedMesh) -> Result<(), String> {
    let halves = |f: &[u32], out: &mut Vec<[u32; 3]>| match f.len() {
        3 => out.push([f[0], f[1], f[2]]),
        4 => out.extend([[f[0], f[1], f[2]], [f[2], f[3], f[0]]]),
        _ => {}
    };
    let rotations = |tris: Vec<[u32; 3]>| {
        let mut v: Vec<[u32; 3]> = tris
            .into_iter()
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        v.sort_unstable();
        v
    };
    if !paired.is_quad_only() {
        return Err("a face is not a quad".into());
    }
    // Bit for bit (a NaN coordinate is copied, not equal to itself).
    let bits = |m: &IndexedMesh| -> Vec<[u64; 3]> {
        m.positions
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect()
    };
    if bits(paired) != bits(input) {
        return Err("the positions differ".into());
    }
    if input.faces().any(|f| f.len() != 3 && f.len() != 4) {
        return Err("the input has a face of other than 3 or 4 corners".into());
    }
    let mut want = Vec::new();
    for f in input.faces() {
        halves(f, &mut want);
    }
    let mut got = Vec::new();
    for q in paired.faces() {
        halves(q, &mut got);
    }
    if rotations(got) != rotations(want) {
        return Err("the quads are not the input's triangles in pairs".into());
    }
    valid_if_input_is(input, paired)
}

/// `Ok` when `out` is a valid half-edge mesh or `input` is not one: a
/// conversion may not break a valid mesh (the tail of [`check_pairing`]
/// and [`crate::bridging::check_bridging`]).
pub(crate) fn valid_if_input_is(input: &IndexedMesh, out: &IndexedMesh) -> Result<(), String> {
    if crate::mesh::Mesh::from_indexed(input).is_err() {
        return Ok(());
    }
    crate::mesh::Mesh::from_indexed(out)
        .map(|_| ())
        .map_err(|e| format!("not a valid mesh (the input is): {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    fn check_pairing(input: &IndexedMesh, out: &IndexedMesh) {
        super::check_pairing(input, out).unwrap();
    }

    #[test]
    fn two_triangles_make_one_quad() {
        let m = IndexedMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            [[0u32, 1, 2], [0, 2, 3]],
        );
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!(out.face_count(), 1);
        assert_eq!(r.pairs, 1);
        assert_eq!(r.folded, 0);
        // The quad runs around the square once, counter-clockwise.
        assert_eq!(
            quad_quality(&out.positions, {
                let f = out.face(0);
                [f[0], f[1], f[2], f[3]]
            }),
            1.0
        );
        check_pairing(&m, &out);
    }

    #[test]
    fn a_lone_triangle_is_refused_by_name() {
        let m = IndexedMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], [[0u32, 1, 2]]);
        let e = pair_triangles(&m).unwrap_err();
        assert_eq!(
            e,
            PairingError::Unpaired {
                unpaired: 1,
                triangles: 1,
                first_face: 0
            }
        );
        assert!(e.to_string().contains("face 0"));
    }

    #[test]
    fn malformed_tables_are_refused_not_a_panic() {
        let mut m = IndexedMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], [[0u32, 1, 2]]);
        m.corner_normals = vec![0];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Malformed(_))
        ));
        m.corner_normals.clear();
        m.face_starts = vec![0, 4];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Malformed(_))
        ));
        m.face_starts = vec![0, 3];
        m.indices[2] = 7;
        assert_eq!(
            pair_triangles(&m).unwrap_err().to_string(),
            "malformed mesh: face 0 references vertex 7, but the mesh has 3 vertices"
        );
    }

    #[test]
    fn a_pentagon_is_refused() {
        let m = shapes::regular_polygon(5);
        assert_eq!(
            pair_triangles(&m).unwrap_err(),
            PairingError::FaceSize { face: 0, len: 5 }
        );
    }

    #[test]
    fn quads_stay_and_triangles_beside_them_pair() {
        // A strip: quad, then two triangles.
        let p = (0..6)
            .map(|i| DVec3::new((i / 2) as f64, (i % 2) as f64, 0.0))
            .collect();
        let m = IndexedMesh::from_faces(p, [&[0u32, 2, 3, 1][..], &[2, 4, 5], &[2, 5, 3]]);
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!(out.face(0), &[0, 2, 3, 1]);
        assert_eq!(r.pairs, 1);
        check_pairing(&m, &out);
    }

    #[test]
    fn triangulated_quad_shapes_pair_completely() {
        for (name, shape) in [
            ("sphere", shapes::quad_sphere(6, 1.0)),
            ("torus", shapes::torus(12, 8, 2.0, 0.6)),
            ("grid", shapes::grid(7, 5, 1.0, 1.0)),
            ("box", shapes::box_grid(3, DVec3::new(1.0, 2.0, 0.5))),
        ] {
            for seed in 0..4u64 {
                let tri = shapes::triangulated(&shape, seed);
                let (out, r) =
                    pair_triangles(&tri).unwrap_or_else(|e| panic!("{name}, seed {seed}: {e}"));
                assert_eq!(r.pairs, shape.face_count(), "{name}");
                check_pairing(&tri, &out);
            }
        }
    }

    /// Six points in the plane: a left tip at height `left`, the unit
    /// squares' corners `(1, 0) (1, 1) (2, 0) (2, 1)`, a right tip at
    /// height `right`.
    fn strip(left: f64, right: f64) -> Vec<DVec3> {
        [
            (0.0, left),
            (1.0, 0.0),
            (1.0, 1.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (3.0, right),
        ]
        .map(|(x, y)| DVec3::new(x, y, 0.0))
        .to_vec()
    }

    #[test]
    fn greedy_leftovers_are_paired_by_augmenting_paths() {
        // A strip of four triangles whose middle two make a square (the
        // best pair) and whose ends make convex but skewed quads with
        // their neighbours: greedy takes the square and strands the ends;
        // the path end – middle = middle – end flips to two pairs.
        let p = strip(0.3, 0.7);
        let m = IndexedMesh::from_faces(p, [[1u32, 2, 0], [1, 4, 2], [1, 3, 4], [4, 3, 5]]);
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!((r.pairs, r.greedy_pairs, r.folded), (2, 1, 0));
        check_pairing(&m, &out);
    }

    #[test]
    fn a_triangle_among_quads_pairs_through_them() {
        // Triangle, quad, triangle in a row: the triangles share no edge,
        // and the path T0 – quad – T1 re-pairs the quad's halves with them.
        let p = strip(0.5, 0.5);
        let m = IndexedMesh::from_faces(p, [&[0u32, 1, 2][..], &[1, 3, 4, 2], &[3, 5, 4]]);
        let (out, r) = pair_triangles(&m).unwrap();
        assert_eq!(out.face_count(), 2);
        assert_eq!(
            (r.triangles, r.pairs, r.repaired_quads, r.folded),
            (2, 2, 1, 0)
        );
        check_pairing(&m, &out);
        // A quad that no triangle needs stays as it is, corners and all.
        let (out, r) = pair_triangles(&shapes::grid(2, 2, 1.0, 1.0)).unwrap();
        assert_eq!(out.indices, shapes::grid(2, 2, 1.0, 1.0).indices);
        assert_eq!(r, PairingReport::default());
    }

    /// The size of a maximum matching of the graph on `n ≤ 16` vertices
    /// with edge list `edges`, by dynamic programming over vertex subsets.
    fn max_matching_brute(n: usize, edges: &[(u32, u32)]) -> usize {
        let mut best = vec![0usize; 1 << n];
        for set in 1usize..1 << n {
            // The lowest vertex of `set` unmatched, or matched to one of
            // its neighbours in `set`.
            let v = set.trailing_zeros() as usize;
            let rest = set & !(1 << v);
            let mut b = best[rest];
            for &(x, y) in edges {
                let (x, y) = (x as usize, y as usize);
                let w = if x == v {
                    y
                } else if y == v {
                    x
                } else {
                    continue;
                };
                if rest & (1 << w) != 0 {
                    b = b.max(1 + best[rest & !(1 << w)]);
                }
            }
            best[set] = b;
        }
        best[(1 << n) - 1]
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(400))]
        /// The searches end with a maximum matching (Berge: no augmenting
        /// path left), from any greedy start, on any small graph — odd
        /// cycles (blossoms) included — and every pair is an edge.
        #[test]
        fn the_searches_leave_a_maximum_matching(
            n in 2usize..13,
            edge_bits in proptest::collection::vec(proptest::prelude::any::<bool>(), 78),
            greedy in proptest::collection::vec(proptest::prelude::any::<u8>(), 78),
            plain_first in proptest::prelude::any::<bool>(),
        ) {
            let mut edges = Vec::new();
            let mut k = 0;
            for x in 0..n as u32 {
                for y in x + 1..n as u32 {
                    if edge_bits[k % 78] {
                        edges.push((x, y));
                    }
                    k += 1;
                }
            }
            let mut adj = vec![Vec::new(); n];
            for (i, &(x, y)) in edges.iter().enumerate() {
                adj[x as usize].push((y, i as u32));
                adj[y as usize].push((x, i as u32));
            }
            let mut mate = vec![u32::MAX; n];
            for (i, &(x, y)) in edges.iter().enumerate() {
                if greedy[i % 78] < 100 && mate[x as usize] == u32::MAX && mate[y as usize] == u32::MAX {
                    mate[x as usize] = y;
                    mate[y as usize] = x;
                }
            }
            let mut budget = usize::MAX;
            if plain_first {
                augment(&mut mate, &adj, &mut budget, |_| true);
            }
            blossom_augment(&mut mate, &adj, &mut budget, |_| true);
            let mut pairs = 0;
            for v in 0..n {
                let m = mate[v];
                if m != u32::MAX {
                    proptest::prop_assert_eq!(mate[m as usize], v as u32);
                    proptest::prop_assert!(edges.contains(&((v as u32).min(m), (v as u32).max(m))));
                    pairs += 1;
                }
            }
            proptest::prop_assert_eq!(pairs / 2, max_matching_brute(n, &edges));
        }
    }

    #[test]
    fn seams_and_groups_are_not_crossed() {
        // Two triangles of one square in two groups: no pair.
        let mut m = IndexedMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            [[0u32, 1, 2], [0, 2, 3]],
        );
        m.groups = vec![("a".into(), 0), ("b".into(), 1)];
        assert!(matches!(
            pair_triangles(&m),
            Err(PairingError::Unpaired { unpaired: 2, .. })
        ));
        // One group, but a texture seam along the diagonal: no pair.
        m.groups = vec![("a".into(), 0)];
        m.texcoords = vec![[0.0, 0.0]; 6];
        m.corner_texcoords = vec![0, 1, 2, 3, 4, 5];
        assert!(pair_triangles(&m).is_err());
        // Shared texture coordinates at the diagonal's ends: one quad that
        // keeps each corner's; flat shading (a normal per face) does not
        // keep the triangles apart.
        m.corner_texcoords = vec![0, 1, 2, 0, 2, 5];
        m.normals = vec![DVec3::Z, DVec3::Z];
        m.corner_normals = vec![0, 0, 0, 1, 1, 1];
        let (out, _) = pair_triangles(&m).unwrap();
        assert_eq!(out.groups, vec![("a".to_string(), 0)]);
        let f = out.face(0);
        for (k, &v) in f.iter().enumerate() {
            let want = [0, 1, 2, 5][v as usize];
            assert_eq!(out.corner_texcoords[k], want);
        }
    }
}
