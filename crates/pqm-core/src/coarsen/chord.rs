//! Chord collapse: a whole closed quad strip (a dual loop) removed at once.
//!
//! A *chord* is the sequence of quads met by walking from a quad across an
//! edge, out through the opposite edge, into the next quad, and so on until
//! the walk is back at its first quad. Its *rungs* are the edges it
//! crosses: rung `i` is `(a_i, b_i)`, the entering half-edge of quad `i`
//! (`a_i → b_i`), so every `a_i` lies on one side of the strip and every
//! `b_i` on the other. Collapsing the chord merges each `b_i` with its
//! `a_i` and deletes the strip's quads: the two sides are zipped together.
//! Counts for `n` quads: V−n, E−2n, F−n; the Euler characteristic and the
//! quad-only property are kept, and the valence of each merged vertex is
//! `val(a_i) + val(b_i) − 4`: a block-structured mesh keeps its singular
//! vertices (a 3 across from a 5 cancel), where the paper's local steps
//! move and create them (see `docs/paper-choices.md`, "Fandisk at 250
//! faces").
//!
//! **Why one record, not a sequence of qvMerges.** The only operators that
//! delete a strip quad and keep the rest are qvMerge (and doublet removal,
//! which dissolves a vertex instead of merging it): a qvMerge of a strip
//! quad merges one of its *diagonals*, `(a_i, b_{i+1})` or `(a_{i+1},
//! b_i)`, and once one quad of the strip has merged a diagonal the next
//! quad's other diagonal would merge three vertices — so any qvMerge
//! sequence over the strip pairs every `a_i` with `b_{i±1}`, a collapse with
//! one side shifted by a quad. Where the chord crosses a feature curve (on
//! CAD meshes nearly every chord does: the curve is then one of the
//! rungs) the shift puts a curve vertex's two curve edges into one quad, a
//! straight corner, which the shape guard refuses; stopped short of the
//! curve instead, each end adds a 3 and a 5. The collapse is therefore one
//! patch — "remove the strip, merge these pairs, rewrite the faces around
//! them" — logged as one step with the qvMerge record kind, of which it is
//! the `n`-vertex generalization (a qvMerge is one quad removed and one
//! pair merged, recorded as vertex list rewrites plus the re-inserted
//! vertex). The records are generic replacements (re-inserted vertices,
//! rewritten slots, appended quads), so the `.pqm` format and its decoders
//! read them unchanged (the encoder codes them in the general form).
//!
//! Invariants (checked before commit, on the patch, by
//! [`Coarsener::commit_patch`], as for every step): quad-only, manifold,
//! four distinct dual chords per quad, no fold-over or inverted quad,
//! feature curves kept (each merged pair passes the rule-1 group check;
//! curves neither split nor lost after the whole collapse), valence cap,
//! surface deviation and error bound; otherwise the mesh is put back
//! exactly.

use super::{Coarsener, GroupConstraint, Placement, ALPHA, V_FLOOR};
use crate::mesh::{FaceId, HalfedgeId, Mesh, VertexId};
use crate::ops::{Patch, Reject};
use crate::progressive::OpKind;

/// Longest chord traced (quads): a longer one is skipped (its collapse
/// would be a large change of the surface anyway, and tracing every chord
/// of a big mesh must stay linear).
pub const MAX_CHORD_QUADS: usize = 4000;

/// The chord phase runs only on meshes at least this ideal at its start:
/// block-structured (CAD-like) quad meshes, whose chords run between the
/// singular vertices, so that collapsing a chord keeps the layout. On a
/// mesh from a remesher or a Catmull-Clark split the chords wander across
/// the whole surface and a collapse is a global change.
pub const CHORD_MIN_IDEAL: f64 = 0.95;

/// The chord phases run only where at least this fraction of the
/// interior edges are on sharp feature curves: fandisk 16.1 %; the noisy
/// bumpy torus of the tests and `coarsen_identity` 10.3 % (its "creases"
/// are noise; at 5 % it got chord phases and reached 304 instead of 387
/// faces toward 150 — not evaluated, so left out), suzanne 12.2 % (95 %
/// ideal: out by the other test), spot 0.2 %, loki 0.4 %.
pub const CHORD_MIN_CREASE: f64 = 0.15;

/// A chord phase runs at the start and then each time the face count has
/// fallen to this fraction of its count after the last one: local steps
/// change which strips are legal (fandisk: 0.95 and 0.85 measured 83.9 %,
/// 0.9 84.1 %, only at the start 80.7 %). Not in the end phase
/// (`coarsen::end_phase`), where each chord collapse the phase would
/// accept is one of the alternatives of every step.
pub const CHORD_PHASE_EVERY: f64 = 0.9;

/// The closed chord through `h0` (the entering half-edge of its first
/// quad): every quad's entering half-edge, in order. `Err(path)` when the
/// walk meets the boundary or a non-quad, revisits a quad (a chord that
/// crosses itself), or exceeds `max_len`: `path` holds the entering
/// half-edges walked so far (so the caller can mark them as seen).
pub fn trace(m: &Mesh, h0: HalfedgeId, max_len: usize) -> Result<Vec<HalfedgeId>, Vec<HalfedgeId>> {
    let mut path: Vec<HalfedgeId> = Vec::new();
    let mut h = h0;
    loop {
        let Some(q) = m.face(h) else {
            return Err(path);
        };
        if m.face_degree(q) != 4 || path.len() >= max_len {
            return Err(path);
        }
        path.push(h);
        // out through the opposite edge, into the quad across it
        let t = m.twin(m.next(m.next(h)));
        if m.face(t).is_none() {
            return Err(path);
        }
        h = t;
        if h == h0 {
            break;
        }
    }
    Ok(path)
}

/// The quads a chord collapse deletes, in face-id order (a quad met twice
/// once).
fn strip_of(m: &Mesh, enter: &[HalfedgeId]) -> Vec<FaceId> {
    let mut quads: Vec<FaceId> = enter.iter().filter_map(|&h| m.face(h)).collect();
    quads.sort_unstable();
    quads.dedup();
    quads
}

/// A chord collapse to try: its first quad and the corner of its
/// entering half-edge, and the defects it removes.
#[derive(Clone, Copy, Debug)]
pub(super) struct ChordCand {
    pub start: (FaceId, u8),
    pub gain: i64,
}

/// A scored chord collapse.
struct Scored {
    cost: f64,
    gain: i64,
    /// Smallest face id of the strip (ties).
    key: u32,
    /// The chord's first quad and the corner of its entering half-edge.
    start: (FaceId, u8),
}

impl Coarsener {
    /// Every closed, simple chord of the mesh, each once, in the order of
    /// the smallest face id met (quads in face-id order, direction 0 — the
    /// quad's half-edges 0 and 2 — first).
    pub(super) fn chords(&self) -> Vec<Vec<HalfedgeId>> {
        let m = &self.mesh;
        let mut seen = vec![0u8; m.face_capacity()];
        let mut out = Vec::new();
        for f in m.faces() {
            if m.face_degree(f) != 4 {
                continue;
            }
            for d in 0..2u8 {
                if seen[f.idx()] & (1 << d) != 0 {
                    continue;
                }
                let Some(h0) = m.face_halfedges(f).nth(d as usize) else {
                    continue;
                };
                let (path, closed) = match trace(m, h0, MAX_CHORD_QUADS) {
                    Ok(p) => (p, true),
                    Err(p) => (p, false),
                };
                for &h in &path {
                    if let Some(q) = m.face(h) {
                        if let Some(i) = m.face_halfedges(q).position(|x| x == h) {
                            seen[q.idx()] |= 1 << (i % 2);
                        }
                    }
                }
                if closed {
                    out.push(path);
                }
            }
        }
        out
    }

    /// The collapse of the chord entered by `enter` as one patch: each
    /// rung's pair merged (into the feature vertex rule 1 pins, else the
    /// smaller id) at its QEM position under the pair's feature constraint,
    /// the strip's quads deleted, every other face of a merged-away vertex
    /// rewritten. `Err` when a pair breaks feature rule 1, two rungs share
    /// a vertex, or a rewritten face would lose a corner.
    pub(super) fn chord_patch(&self, enter: &[HalfedgeId]) -> Result<Patch, Reject> {
        let m = &self.mesh;
        let mut patch = Patch::default();
        // merge classes: the rungs' pairs, joined where the chord crosses
        // itself (a quad met twice has all four edges as rungs: its four
        // corners become one vertex)
        let mut classes: Vec<Vec<VertexId>> = Vec::new();
        for &h in enter {
            let (a, b) = (m.from_vertex(h), m.to_vertex(h));
            let ia = classes.iter().position(|c| c.contains(&a));
            let ib = classes.iter().position(|c| c.contains(&b));
            match (ia, ib) {
                (None, None) => classes.push(vec![a, b]),
                (Some(i), None) => classes[i].push(b),
                (None, Some(j)) => classes[j].push(a),
                (Some(i), Some(j)) if i != j => {
                    let cj = classes.swap_remove(j);
                    let i = if i == classes.len() { j } else { i };
                    classes[i].extend(cj);
                }
                _ => {}
            }
        }
        for class in &mut classes {
            class.sort_unstable();
            if class.len() > 4 {
                return Err(Reject::NotApplicable("more than four vertices would merge"));
            }
            let con = self.features.check_group(m, class)?;
            let keep = match con {
                GroupConstraint::Pinned(v) => v,
                _ => class[0],
            };
            for &g in class.iter() {
                if g != keep {
                    patch.merged.push((g, keep));
                }
            }
            patch.moved.push((keep, self.place(class, con)));
        }
        let strip = strip_of(m, enter);
        let mut rewritten: Vec<FaceId> = Vec::new();
        for &(g, _) in &patch.merged {
            for f in m.vertex_faces(g) {
                if !strip.contains(&f) && !rewritten.contains(&f) {
                    rewritten.push(f);
                }
            }
        }
        rewritten.sort_unstable();
        let mut buf = Vec::with_capacity(8);
        for &f in &rewritten {
            crate::ops::map_face(m, f, &patch.merged, &mut buf);
            let mut d = buf.clone();
            d.sort_unstable();
            d.dedup();
            if buf.len() != 4 || d.len() != 4 {
                return Err(Reject::NotApplicable(
                    "a face around the chord loses a corner",
                ));
            }
            patch.add.push([buf[0], buf[1], buf[2], buf[3]]);
        }
        patch.remove = rewritten;
        patch.remove.extend_from_slice(&strip);
        Ok(patch)
    }

    /// The paper's `E` of a chord collapse and the defects it removes:
    /// `V` over the merging vertices, before and after (a merged vertex's
    /// valence after counted from its faces outside the strip), `D` the
    /// importance-weighted distance each vertex moves, averaged, over the
    /// bbox diagonal; `A` is left out (factor 1: the strip's dual chords
    /// and the edges it leaves run the same way, so the alignment barely
    /// changes).
    fn chord_cost(&self, patch: &Patch, enter: &[HalfedgeId]) -> (f64, i64) {
        let m = &self.mesh;
        let strip: Vec<FaceId> = enter.iter().filter_map(|&h| m.face(h)).collect();
        let (mut ideal_b, mut count_b, mut ideal_a, mut dsum) = (0usize, 0usize, 0usize, 0.0f64);
        let mut buf = Vec::with_capacity(8);
        for &(keep, p) in &patch.moved {
            let mut nbrs: Vec<VertexId> = Vec::new();
            let mut boundary = false;
            let members = std::iter::once(keep)
                .chain(patch.merged.iter().filter(|g| g.1 == keep).map(|g| g.0));
            for v in members {
                count_b += 1;
                ideal_b += (m.valence(v) == m.ideal_valence(v)) as usize;
                boundary |= m.is_boundary_vertex(v);
                let imp = self.attrs.importance.get(v.idx()).copied().unwrap_or(1.0);
                dsum += imp * (m.position(v) - p).length();
                for f in m.vertex_faces(v) {
                    if strip.contains(&f) {
                        continue;
                    }
                    crate::ops::map_face(m, f, &patch.merged, &mut buf);
                    if let Some(i) = buf.iter().position(|&x| x == keep) {
                        let k = buf.len();
                        for w in [buf[(i + 1) % k], buf[(i + k - 1) % k]] {
                            if !nbrs.contains(&w) {
                                nbrs.push(w);
                            }
                        }
                    }
                }
            }
            let ideal = if boundary { 3 } else { 4 };
            ideal_a += (nbrs.len() == ideal) as usize;
        }
        let n = patch.moved.len();
        let vb = ideal_b as f64 / count_b.max(1) as f64;
        let va = (ideal_a as f64 / n.max(1) as f64).max(V_FLOOR);
        let d = dsum / count_b.max(1) as f64 / self.diag;
        let cost = (vb / va + ALPHA).powi(2) * (d + ALPHA).powi(2);
        let gain = (count_b - ideal_b) as i64 - (n - ideal_a) as i64;
        (cost, gain)
    }

    /// Runs a chord phase when the face count has fallen to the next
    /// trigger ([`CHORD_PHASE_EVERY`]; the first call always runs one).
    pub(super) fn maybe_chord_phase(&mut self, target: usize) {
        if !self.chords_on || self.mesh.face_count() > self.chord_next {
            return;
        }
        self.chord_phase(target);
        self.chord_next = (CHORD_PHASE_EVERY * self.mesh.face_count() as f64) as usize;
    }

    /// Whether this mesh gets chord phases (decided on the input): at
    /// least [`CHORD_MIN_IDEAL`] of its vertices ideal and at least
    /// [`CHORD_MIN_CREASE`] of its interior edges on sharp feature curves —
    /// a CAD-like block layout — under [`Placement::Qem`].
    pub(super) fn chords_wanted(&self) -> bool {
        let m = &self.mesh;
        let n = m.vertex_count().max(1);
        let ideal = m
            .vertices()
            .filter(|&v| m.valence(v) == m.ideal_valence(v))
            .count();
        let (mut interior, mut crease) = (0usize, 0usize);
        for h in m.halfedges() {
            let t = m.twin(h);
            if h.0 > t.0 || m.is_boundary_edge(h) {
                continue;
            }
            interior += 1;
            crease += self
                .features
                .is_feature_edge(m.from_vertex(h), m.to_vertex(h)) as usize;
        }
        // (a collapse places its merged vertices by QEM: never under
        // `Placement::Subset`, whose levels keep input positions)
        self.opts.placement == Placement::Qem
            && ideal as f64 / n as f64 >= CHORD_MIN_IDEAL
            && crease as f64 >= CHORD_MIN_CREASE * interior.max(1) as f64
    }

    /// The chord phase: while the face target allows, commit the cheapest
    /// (by `E`) chord collapse that adds no defect, every chord traced and
    /// scored again after each commit; stops when none commits (the
    /// guards of [`Coarsener::commit_patch`] — surface deviation and shape
    /// above all — decide how far it goes). Only where
    /// [`Coarsener::chords_wanted`] said so. Returns the collapses made.
    pub(super) fn chord_phase(&mut self, target: usize) -> usize {
        if target == 0 || !self.chords_on {
            return 0;
        }
        let mut done = 0;
        loop {
            let mut committed = false;
            for s in self.chord_candidates(target) {
                if self.commit_chord(s.start, s.gain) {
                    done += 1;
                    committed = true;
                    break;
                }
            }
            if !committed {
                return done;
            }
        }
    }
}

impl Coarsener {
    /// Every closed chord whose collapse adds no defect and leaves at
    /// least `target` faces, scored by the paper's `E` (cheapest first,
    /// ties by the strip's smallest face id): `(start, gain)` with `start`
    /// the chord's first quad and the corner of its entering half-edge.
    pub(super) fn chord_candidates(&self, target: usize) -> Vec<ChordCand> {
        let faces = self.mesh.face_count();
        let mut scored: Vec<Scored> = Vec::new();
        for enter in self.chords() {
            let strip = strip_of(&self.mesh, &enter);
            if faces < target + strip.len() {
                continue;
            }
            let Ok(patch) = self.chord_patch(&enter) else {
                continue;
            };
            let (cost, gain) = self.chord_cost(&patch, &enter);
            if gain < 0 {
                continue;
            }
            let m = &self.mesh;
            let Some(f0) = m.face(enter[0]) else {
                continue;
            };
            let Some(i0) = m.face_halfedges(f0).position(|x| x == enter[0]) else {
                continue;
            };
            let key = strip.first().map_or(u32::MAX, |f| f.0);
            scored.push(Scored {
                cost,
                gain,
                key,
                start: (f0, i0 as u8),
            });
        }
        scored.sort_by(|x, y| x.cost.total_cmp(&y.cost).then(x.key.cmp(&y.key)));
        scored
            .into_iter()
            .map(|s| ChordCand {
                start: s.start,
                gain: s.gain,
            })
            .collect()
    }

    /// Collapses the chord entered at `start` (first quad, corner) under
    /// every check of a step; `false` (mesh unchanged) when refused.
    pub(super) fn commit_chord(&mut self, start: (FaceId, u8), gain: i64) -> bool {
        // traced again from its first quad and corner: a refused
        // collapse's undo may have renumbered half-edges (see `Cand`),
        // never faces or their corners
        let m = &self.mesh;
        if !m.is_face_alive(start.0) {
            return false;
        }
        let Some(h0) = m.face_halfedges(start.0).nth(start.1 as usize) else {
            return false;
        };
        let Ok(enter) = trace(m, h0, MAX_CHORD_QUADS) else {
            return false;
        };
        let Ok(patch) = self.chord_patch(&enter) else {
            return false;
        };
        let ok = self.commit_patch(OpKind::QvMerge, patch, gain);
        self.chords_done += ok as usize;
        ok
    }
}

impl Coarsener {
    /// Chord collapses committed so far (each logged as one step; not
    /// counted in [`super::CoarsenReport::qv_merges`]).
    pub fn chord_collapses(&self) -> usize {
        self.chords_done
    }

    /// Collapses the chord through the `corner`-th half-edge of face `f`
    /// (its entering edge), under every check of a coarsening step — for
    /// tests and diagnosis. `false` (mesh unchanged) when the chord is not
    /// closed and simple enough or the collapse is refused.
    #[doc(hidden)]
    pub fn collapse_chord(&mut self, f: FaceId, corner: u8) -> bool {
        let m = &self.mesh;
        if !m.is_face_alive(f) {
            return false;
        }
        let Some(h0) = m.face_halfedges(f).nth(corner as usize) else {
            return false;
        };
        let Ok(enter) = trace(m, h0, MAX_CHORD_QUADS) else {
            return false;
        };
        let Ok(patch) = self.chord_patch(&enter) else {
            return false;
        };
        let (_, gain) = self.chord_cost(&patch, &enter);
        let ok = self.commit_patch(OpKind::QvMerge, patch, gain);
        self.chords_done += ok as usize;
        ok
    }
}
