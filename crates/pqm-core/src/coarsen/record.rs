//! Step logs and their conversion to canonical split records.
//!
//! While coarsening, every committed step (qvMerge, qeMerge, doublet removal,
//! smoothing) is logged in the coarsener's own ids (which never get reused,
//! so a log is unambiguous), packed into [`StepLogs`] as it is committed
//! (the logs are most of the coarsener's memory growth). [`to_progressive`]
//! then replays the logs in
//! reverse — coarse to fine — and assigns the canonical numbering of
//! [`crate::progressive`]: base faces and vertices in a traversal order (see
//! [`Base::of`]), each record's re-inserted vertices appended, each face kept
//! at its slot.

use crate::indexed::IndexedMesh;
use crate::mesh::{FaceId, Mesh, VertexId};
use crate::ops::{Applied, Patch};
use crate::progressive::{OpKind, ProgressiveMesh, SplitRecord};
use glam::DVec3;

/// One committed coarsening step, in the coarsener's ids.
///
/// The form a step is logged and read back in; the coarsener keeps every
/// step until [`to_progressive`] runs, so it stores them in [`StepLogs`]
/// (packed, no allocation per step), not as these.
#[derive(Clone, Debug, PartialEq)]
pub struct StepLog {
    /// The operator.
    pub op: OpKind,
    /// Faces the step removed or rewrote, with their vertex lists before it
    /// (a face of fewer than four vertices is padded with
    /// `VertexId(u32::MAX)`; a longer one keeps its first four, all a record
    /// can hold).
    pub faces_before: Vec<(FaceId, [VertexId; 4])>,
    /// Faces the step wrote (a step never creates a face id: every id here
    /// is also in `faces_before`).
    pub faces_after: Vec<FaceId>,
    /// Vertices the step deleted, with their positions before it.
    pub removed_vertices: Vec<(VertexId, DVec3)>,
    /// Vertices the step moved, with their positions before it.
    pub moved: Vec<(VertexId, DVec3)>,
}

/// The first four vertices of a face, padded with `VertexId(u32::MAX)`.
fn quad_of(vs: &[VertexId]) -> [VertexId; 4] {
    let mut q = [VertexId(NONE); 4];
    for (i, &v) in vs.iter().take(4).enumerate() {
        q[i] = v;
    }
    q
}

impl StepLog {
    /// The log of an applied patch: its removed faces with their old vertex
    /// lists, the ids of its inserted quads.
    pub fn of_patch(
        op: OpKind,
        patch: &Patch,
        applied: &Applied,
        removed_vertices: Vec<(VertexId, DVec3)>,
        moved: Vec<(VertexId, DVec3)>,
    ) -> StepLog {
        StepLog {
            op,
            faces_before: patch
                .remove
                .iter()
                .copied()
                .zip(applied.old_faces.iter().map(|vs| quad_of(vs)))
                .collect(),
            faces_after: applied
                .faces
                .iter()
                .take(patch.add.len())
                .copied()
                .collect(),
            removed_vertices,
            moved,
        }
    }
}

const NONE: u32 = u32::MAX;

/// Elements per chunk of a [`Chunked`] arena (a power of two, so a first
/// chunk grown by doubling stops exactly at it; tiny under unit tests so
/// that steps straddle chunks).
const CHUNK: usize = if cfg!(test) { 16 } else { 1 << 16 };

/// An append-only array stored in chunks of [`CHUNK`] elements.
///
/// Why not one `Vec`: growing a `Vec` by doubling holds the old and the new
/// buffer at once (up to 3x the contents) and leaves up to 2x slack; the
/// step logs are the biggest thing the coarsener keeps, so that slack would
/// be a large part of the peak. Chunks bound the slack to one chunk and never
/// copy. Every chunk but the last holds exactly `CHUNK` elements.
#[derive(Clone, Debug, Default)]
struct Chunked<T> {
    chunks: Vec<Vec<T>>,
    len: usize,
}

impl<T: Copy> Chunked<T> {
    fn push(&mut self, x: T) {
        match self.chunks.last_mut() {
            Some(c) if c.len() < CHUNK => c.push(x),
            _ => {
                // the first chunk grows by doubling (small inputs stay
                // small); later ones are allocated whole
                let mut c = if self.chunks.is_empty() {
                    Vec::new()
                } else {
                    Vec::with_capacity(CHUNK)
                };
                c.push(x);
                self.chunks.push(c);
            }
        }
        self.len += 1;
    }
    fn get(&self, i: usize) -> T {
        self.chunks[i / CHUNK][i % CHUNK]
    }
    /// Drops the elements from `len` on, freeing emptied chunks.
    fn truncate(&mut self, len: usize) {
        let keep = len.div_ceil(CHUNK);
        self.chunks.truncate(keep);
        if let Some(c) = self.chunks.last_mut() {
            c.truncate(len - (keep - 1) * CHUNK);
        }
        if self.chunks.len() < self.chunks.capacity() / 4 {
            self.chunks.shrink_to_fit();
        }
        self.len = len;
    }
}

/// An id in a narrow (3-byte) step is below this; `u32::MAX` (padding) is
/// stored as it.
const NARROW_NONE: u32 = 0xFF_FFFF;
/// Flag bits of a step's last byte (its low two bits are the op code).
const WIDE: u8 = 4;
const BIG_COUNTS: u8 = 8;

/// Every committed step's log, stored compactly as it is committed.
///
/// One chunked byte arena of ids and one of positions serve all steps (no
/// per-step allocation or `Vec` headers). A step's ids are: for each face
/// before it — rewritten faces first, then the ones it deleted (whose slots
/// refinement appends) — the face id and its four vertex ids; then the
/// removed vertices' ids; then the moved vertices' ids. Each id takes three
/// bytes (little-endian) when every id of the step is below 2^24 - 1 — the
/// usual case, meshes of up to 16 million elements — four otherwise. Then
/// come the counts (rewritten, appended, removed, moved: one byte each when
/// all are below 256, four otherwise) and a flag byte `op | WIDE |
/// BIG_COUNTS`; being last, they let the steps be read back from the end
/// (the order [`to_progressive`] needs) without an index. Positions: the
/// removed vertices', then the moved vertices' (before the step).
/// `faces_after` is not stored: it is exactly the rewritten faces.
#[derive(Clone, Debug, Default)]
pub struct StepLogs {
    ids: Chunked<u8>,
    positions: Chunked<DVec3>,
    steps: usize,
}

/// Reads fixed-width little-endian ids forward from a byte arena.
struct IdReader<'a> {
    bytes: &'a Chunked<u8>,
    at: usize,
    width: usize,
}

impl IdReader<'_> {
    fn next(&mut self) -> u32 {
        let mut x = 0u32;
        for k in 0..self.width {
            x |= u32::from(self.bytes.get(self.at + k)) << (8 * k);
        }
        self.at += self.width;
        if self.width == 3 && x == NARROW_NONE {
            NONE
        } else {
            x
        }
    }
}

impl StepLogs {
    /// No steps.
    pub fn new() -> StepLogs {
        StepLogs::default()
    }
    /// Number of steps logged.
    pub fn len(&self) -> usize {
        self.steps
    }
    /// Whether no step is logged.
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }
    /// Bytes held (ids, positions), for memory reports.
    pub fn heap_bytes(&self) -> usize {
        self.ids.chunks.iter().map(Vec::capacity).sum::<usize>()
            + self
                .positions
                .chunks
                .iter()
                .map(Vec::capacity)
                .sum::<usize>()
                * std::mem::size_of::<DVec3>()
    }

    /// Appends one step. `log.faces_after` must be a subset of
    /// `log.faces_before` (true of every step: a step never creates a face
    /// id); faces in `faces_after` only are ignored, as the records do.
    pub fn push(&mut self, log: &StepLog) {
        let all_ids = log
            .faces_before
            .iter()
            .flat_map(|(f, q)| std::iter::once(f.0).chain(q.iter().map(|v| v.0)))
            .chain(log.removed_vertices.iter().map(|r| r.0 .0))
            .chain(log.moved.iter().map(|m| m.0 .0));
        let wide = all_ids.filter(|&x| x != NONE).any(|x| x >= NARROW_NONE);
        let width = if wide { 4 } else { 3 };
        let ids = &mut self.ids;
        let mut put = |x: u32| {
            let x = if !wide && x == NONE { NARROW_NONE } else { x };
            for &b in &x.to_le_bytes()[..width] {
                ids.push(b);
            }
        };
        let rewritten = |f: &FaceId| log.faces_after.contains(f);
        let mut n_rewritten = 0u32;
        for pass_rewritten in [true, false] {
            for (f, q) in &log.faces_before {
                if rewritten(f) == pass_rewritten {
                    put(f.0);
                    for v in q {
                        put(v.0);
                    }
                    n_rewritten += u32::from(pass_rewritten);
                }
            }
        }
        for &(v, p) in &log.removed_vertices {
            put(v.0);
            self.positions.push(p);
        }
        for &(v, p) in &log.moved {
            put(v.0);
            self.positions.push(p);
        }
        let counts = [
            n_rewritten,
            log.faces_before.len() as u32 - n_rewritten,
            log.removed_vertices.len() as u32,
            log.moved.len() as u32,
        ];
        let big = counts.iter().any(|&c| c > 255);
        for c in counts {
            if big {
                for b in c.to_le_bytes() {
                    self.ids.push(b);
                }
            } else {
                self.ids.push(c as u8);
            }
        }
        let mut flags = log.op as u8;
        if wide {
            flags |= WIDE;
        }
        if big {
            flags |= BIG_COUNTS;
        }
        self.ids.push(flags);
        self.steps += 1;
    }

    /// Decodes the step whose data ends at `(ids_end, positions_end)`;
    /// returns it with where its data starts. In `faces_before` the
    /// rewritten faces come first.
    fn read_back(&self, ids_end: usize, positions_end: usize) -> (StepLog, usize, usize) {
        let flags = self.ids.get(ids_end - 1);
        let op = OpKind::from_code(flags & 3).unwrap_or(OpKind::Smooth);
        let count_width = if flags & BIG_COUNTS != 0 { 4 } else { 1 };
        let counts_start = ids_end - 1 - 4 * count_width;
        let mut counts = IdReader {
            bytes: &self.ids,
            at: counts_start,
            width: count_width,
        };
        let [n_rewritten, n_appended, n_removed, n_moved] = [(); 4].map(|_| counts.next() as usize);
        let width = if flags & WIDE != 0 { 4 } else { 3 };
        let n_faces = n_rewritten + n_appended;
        let ids_start = counts_start - (n_faces * 5 + n_removed + n_moved) * width;
        let positions_start = positions_end - n_removed - n_moved;
        let mut r = IdReader {
            bytes: &self.ids,
            at: ids_start,
            width,
        };
        let mut faces_before = Vec::with_capacity(n_faces);
        for _ in 0..n_faces {
            let f = FaceId(r.next());
            let q = [(); 4].map(|_| VertexId(r.next()));
            faces_before.push((f, q));
        }
        let faces_after = faces_before[..n_rewritten].iter().map(|e| e.0).collect();
        let mut p = positions_start;
        let mut vertices = |n: usize| -> Vec<(VertexId, DVec3)> {
            (0..n)
                .map(|_| {
                    let v = (VertexId(r.next()), self.positions.get(p));
                    p += 1;
                    v
                })
                .collect()
        };
        let removed_vertices = vertices(n_removed);
        let moved = vertices(n_moved);
        let log = StepLog {
            op,
            faces_before,
            faces_after,
            removed_vertices,
            moved,
        };
        (log, ids_start, positions_start)
    }

    /// The steps, last logged first.
    pub fn iter_rev(&self) -> impl Iterator<Item = StepLog> + '_ {
        let mut ends = (self.ids.len, self.positions.len);
        (0..self.steps).map(move |_| {
            let (log, i, p) = self.read_back(ends.0, ends.1);
            ends = (i, p);
            log
        })
    }

    /// Removes and returns the last step, freeing its storage (chunk by
    /// chunk).
    pub fn pop(&mut self) -> Option<StepLog> {
        if self.steps == 0 {
            return None;
        }
        let (log, i, p) = self.read_back(self.ids.len, self.positions.len);
        self.ids.truncate(i);
        self.positions.truncate(p);
        self.steps -= 1;
        Some(log)
    }
}

/// Builds the progressive mesh from the coarsest mesh and the logs.
/// `errors[s]` is the error bound after `s` steps (`logs.len() + 1`
/// entries).
pub fn to_progressive(coarsest: &Mesh, logs: &StepLogs, errors: &[f64]) -> ProgressiveMesh {
    build(
        Base::of(coarsest),
        logs.len(),
        logs.iter_rev(),
        errors,
        None,
    )
    .0
}

/// [`to_progressive`] of a run in rounds ([`super::CoarsenOptions::round_fraction`]):
/// the steps of each round are put in ascending order of their anchors
/// (see [`Rounds`]). Also returns, per record, its round and its step's
/// sort key (for tests and studies).
pub fn to_progressive_in_rounds(
    coarsest: &Mesh,
    logs: &StepLogs,
    errors: &[f64],
    rounds: &Rounds,
) -> (ProgressiveMesh, Vec<(u32, u32)>) {
    build(
        Base::of(coarsest),
        logs.len(),
        logs.iter_rev(),
        errors,
        Some(rounds),
    )
}

/// [`to_progressive`] that consumes the logs and frees them as their records
/// are built, so the logs and the records are not both held in full (the
/// same result). `base` is [`Base::of`] the coarsest mesh: taking it first
/// lets the caller free the mesh before the records are built.
/// With `rounds` (a run in rounds), the steps of each round are sorted as in
/// [`to_progressive_in_rounds`].
pub fn into_progressive(
    base: Base,
    mut logs: StepLogs,
    errors: &[f64],
    rounds: Option<&Rounds>,
) -> ProgressiveMesh {
    let n = logs.len();
    build(
        base,
        n,
        std::iter::from_fn(move || logs.pop()),
        errors,
        rounds,
    )
    .0
}

/// Step and round boundaries of a run in rounds of independent steps
/// ([`super::CoarsenOptions::round_fraction`]), in commit order.
///
/// A *step* is the logs one commit pushed (the operator, then the doublet
/// removals it triggered); a *round* is a run of steps none of which
/// removes or rewrites a face an earlier step of the round wrote, so their
/// refinement records commute. Each step carries two *key vertices* (coarsener ids)
/// that exist from the round's coarse end on: its sort key is the smaller
/// canonical id of the two — for a qvMerge twice the surviving vertex (the
/// split form's anchor, spec §7.5), for a qeMerge the two endpoints of the
/// shared edge (the edge-split form's `A`, `D`, §7.10), for a lone doublet
/// removal two corners of the face it rewrote.
#[derive(Clone, Debug, Default)]
pub struct Rounds {
    steps: Vec<StepMark>,
    /// Reorder the records in windows of this fraction of the face count
    /// at each window's coarse end ([`super::CoarsenOptions::reorder_window`]);
    /// the round grouping is then not used.
    window: Option<f64>,
}

#[derive(Clone, Copy, Debug)]
struct StepMark {
    logs: u32,
    key: [u32; 2],
    round: u32,
    /// The step's own error bound (its largest drift over the bbox
    /// diagonal), which bounds what it adds to any level that has it
    /// collapsed.
    own_error: f64,
}

impl Rounds {
    /// Appends a step of `logs` logs in round `round` (rounds numbered in
    /// commit order; consecutive steps with the same number form a round)
    /// with its own error bound `own_error` (fraction of the bbox
    /// diagonal).
    pub fn push(&mut self, logs: usize, key: [VertexId; 2], round: u32, own_error: f64) {
        self.steps.push(StepMark {
            logs: logs as u32,
            key: key.map(|v| v.0),
            round,
            own_error,
        });
    }
    /// Number of steps.
    pub fn len(&self) -> usize {
        self.steps.len()
    }
    /// Reorder the records in windows of `f ×` the face count (see
    /// [`super::CoarsenOptions::reorder_window`]); `None` or `f <= 0`: no
    /// windows.
    pub fn set_window(&mut self, f: Option<f64>) {
        self.window = f.filter(|&f| f > 0.0);
    }
    /// Whether no step is marked.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
    /// Number of rounds.
    pub fn round_count(&self) -> usize {
        let changes = self.steps.windows(2).filter(|w| w[0].round != w[1].round);
        changes.count() + usize::from(!self.steps.is_empty())
    }
    /// Logs covered by the marked steps.
    pub fn log_count(&self) -> usize {
        self.steps.iter().map(|s| s.logs as usize).sum()
    }
}

/// What the records are built from besides the logs: the coarsest mesh in
/// canonical numbering and the maps from the coarsener's ids to it.
#[derive(Clone, Debug)]
pub struct Base {
    /// Coarsener vertex id → canonical id (`u32::MAX`: not yet placed).
    cv: Vec<u32>,
    /// Coarsener face id → canonical slot (`u32::MAX`: not yet placed).
    cf: Vec<u32>,
    base: IndexedMesh,
    vertex_order: Vec<u32>,
}

impl Base {
    /// The base of `coarsest`, numbered in a traversal order: faces
    /// breadth-first, vertices by first appearance along them (the private
    /// `traversal_order` states it exactly), so the base section's deltas
    /// are small.
    pub fn of(coarsest: &Mesh) -> Base {
        let (faces, vertices) = traversal_order(coarsest);
        let mut cv = vec![NONE; coarsest.vertex_capacity()];
        let mut cf = vec![NONE; coarsest.face_capacity()];
        let mut base = IndexedMesh::new();
        let mut vertex_order = Vec::with_capacity(vertices.len());
        for v in vertices {
            cv[v.idx()] = base.positions.len() as u32;
            vertex_order.push(v.0);
            base.positions.push(coarsest.position(v));
        }
        let mut buf = Vec::with_capacity(4);
        for f in faces {
            cf[f.idx()] = base.face_count() as u32;
            buf.clear();
            buf.extend(coarsest.face_vertices(f).map(|v| cv[v.idx()]));
            base.push_face(&buf);
        }
        Base {
            cv,
            cf,
            base,
            vertex_order,
        }
    }
}

/// The order the base's faces and vertices are numbered in: the walk of
/// the `.pqm` base section's traversal layout (spec §6.1), so that a writer
/// can code the base in a few bits per face.
///
/// Invariant: faces are in breadth-first order across edges — start at the
/// lowest-id face not yet reached (a *component start*); visiting a face
/// `f`, for each corner `k` in order, with `a = f[k]`, `b = f[k + 1]`, the
/// face holding the half-edge `b → a` (the one across that edge) is queued
/// if it is not yet; repeat per connected component. Vertices are numbered
/// by first appearance in the walk: a component start's corners in order;
/// a face queued across `(a, b)`, with `b` at its corner `r`, its corners
/// `r + 2` then `r + 3` (`a` and `b` are already numbered). Live vertices
/// in no face (there should be none) come last, in id order.
///
/// Why: the base section (spec §6.1) codes each face queued across an edge
/// as a rotation and its two far corners, each mostly "new" (the next id)
/// or the vertex that closes the fan, which only works when ids and slots
/// follow this walk (the coarsener's own ids follow no order).
/// Deterministic: the only orders used are face ids, corner order and the
/// queue's.
fn traversal_order(m: &Mesh) -> (Vec<FaceId>, Vec<VertexId>) {
    let ids: Vec<FaceId> = m.faces().collect();
    let corners: Vec<Vec<u32>> = ids
        .iter()
        .map(|&f| m.face_vertices(f).map(|v| v.0).collect())
        .collect();
    let refs: Vec<&[u32]> = corners.iter().map(|c| &c[..]).collect();
    let (faces, vertices) = crate::progressive::walk_order(&refs, m.vertex_capacity());
    let live: Vec<bool> = {
        let mut l = vec![false; m.vertex_capacity()];
        for v in m.vertices() {
            l[v.idx()] = true;
        }
        l
    };
    (
        faces.into_iter().map(|i| ids[i as usize]).collect(),
        // `walk_order` lists every id up to the capacity; dead ones are not
        // vertices of the mesh
        vertices
            .into_iter()
            .filter(|&v| live[v as usize])
            .map(VertexId)
            .collect(),
    )
}

/// The numbering state of [`build`]: coarsener ids → canonical ones.
struct Numbering {
    cv: Vec<u32>,
    cf: Vec<u32>,
    vertex_order: Vec<u32>,
    n_faces: u32,
}

/// Replays `n` logs given last-logged first (coarse → fine). With `rounds`
/// (covering every log), the steps of each round are sorted by their keys
/// (stable: equal keys keep the coarse-to-fine order) before their records
/// are built, each step's records kept together and in order, and every
/// level inside a round gets the bound [`block_errors`] gives;
/// with a window set ([`Rounds::set_window`]), the steps are reordered in
/// windows instead ([`build_windows`]). Returns, per record, its round (or
/// sweep) and its step's key (none without rounds or windows).
fn build(
    start: Base,
    n: usize,
    coarse_to_fine: impl Iterator<Item = StepLog>,
    errors: &[f64],
    rounds: Option<&Rounds>,
) -> (ProgressiveMesh, Vec<(u32, u32)>) {
    let Base {
        cv,
        cf,
        base,
        vertex_order,
    } = start;
    let mut num = Numbering {
        n_faces: base.face_count() as u32,
        cv,
        cf,
        vertex_order,
    };
    let mut records = Vec::with_capacity(n);
    let mut keys = Vec::new();
    let rounds = rounds.filter(|r| r.log_count() == n);
    let mut errors = std::borrow::Cow::Borrowed(errors);
    match rounds {
        None => {
            for log in coarse_to_fine {
                records.push(record_of(log, &mut num));
            }
        }
        Some(r) if r.window.is_some() => {
            keys.reserve(n);
            build_windows(
                r,
                n,
                coarse_to_fine,
                &mut errors,
                &mut records,
                &mut keys,
                &mut num,
            );
        }
        Some(r) => {
            keys.reserve(n);
            let mut logs = coarse_to_fine;
            // rounds last first; each round's steps in commit order
            let mut end = r.steps.len();
            let mut log_end = n;
            while end > 0 {
                let round = r.steps[end - 1].round;
                let mut begin = end - 1;
                while begin > 0 && r.steps[begin - 1].round == round {
                    begin -= 1;
                }
                let marks = &r.steps[begin..end];
                // the round's steps coarse to fine (last committed first),
                // each with its logs coarse to fine
                let mut steps: Vec<(u32, f64, Vec<StepLog>)> = marks
                    .iter()
                    .rev()
                    .map(|m| {
                        let ls: Vec<StepLog> = logs.by_ref().take(m.logs as usize).collect();
                        (m.key_in(&num.cv), m.own_error, ls)
                    })
                    .collect();
                steps.sort_by_key(|s| s.0);
                let mut own = Vec::with_capacity(steps.len());
                for (key, e, ls) in steps {
                    for log in ls {
                        records.push(record_of(log, &mut num));
                        keys.push((round, key));
                        own.push(e);
                    }
                }
                let log_begin = block_errors(&mut errors, &own, log_end);
                end = begin;
                log_end = log_begin;
            }
        }
    }
    let level_error = (0..=n)
        .map(|k| errors.get(n - k).copied().unwrap_or(0.0))
        .collect();
    let pm = ProgressiveMesh {
        base,
        records,
        vertex_order: num.vertex_order,
        level_error,
    };
    (pm, keys)
}

impl StepMark {
    /// The step's sort key: the smaller canonical id of its two key
    /// vertices (`NONE` for one not numbered yet).
    fn key_in(&self, cv: &[u32]) -> u32 {
        let c = |v: u32| cv.get(v as usize).copied().unwrap_or(NONE);
        c(self.key[0]).min(c(self.key[1]))
    }
}

/// The error bounds of the levels strictly inside a block of records (a
/// round or a window) whose logs, in commit order, end at `log_end`;
/// `own[i]` is the own error bound of the step of the block's `i`-th
/// record in file order (coarse to fine). Returns where the block's logs
/// begin.
///
/// A level inside the block has the block's fine end refined and a suffix
/// of its records (in file order) still collapsed: the steps of that
/// suffix, applied to the fine end, give the level's mesh (the block's
/// records commute that way: a round's steps are independent, a window's
/// order keeps every step after those it depends on). So its bound is the
/// fine end's, `errors[log_begin]`, raised by the own bounds of the
/// collapsed steps — a drift is a running maximum of displacements, and a
/// step's own drift counts whatever came before it, collapsed or not.
/// It never exceeds the coarse end's bound, which every level inside
/// used to get.
fn block_errors(errors: &mut std::borrow::Cow<'_, [f64]>, own: &[f64], log_end: usize) -> usize {
    let n = own.len();
    let log_begin = log_end - n;
    if log_end < errors.len() && n > 1 {
        let fine = errors[log_begin];
        let coarse = errors[log_end];
        let e = errors.to_mut();
        // `c` logs of the block committed = its last `c` records collapsed
        let mut worst = fine;
        for c in 1..n {
            worst = worst.max(own[n - c]);
            e[log_begin + c] = worst.min(coarse);
        }
    }
    log_begin
}

/// The steps in windows ([`super::CoarsenOptions::reorder_window`]):
/// windows cut coarse to fine from the coarse end, each of `f ×` the face
/// count at its coarse end (at least one step); each window in sweeps
/// ([`sweep_window`]). Levels strictly inside a window get the bound
/// [`block_errors`] gives. `keys` gets, per record, its sweep (numbered
/// over the whole run) and its step's key.
fn build_windows(
    r: &Rounds,
    n: usize,
    mut logs: impl Iterator<Item = StepLog>,
    errors: &mut std::borrow::Cow<'_, [f64]>,
    records: &mut Vec<SplitRecord>,
    keys: &mut Vec<(u32, u32)>,
    num: &mut Numbering,
) {
    let f = r.window.unwrap_or(1.0);
    let mut end = r.steps.len();
    let mut log_end = n;
    let mut sweeps = 0u32;
    while end > 0 {
        let w = ((f * num.n_faces as f64).ceil() as usize).max(1);
        let begin = end.saturating_sub(w);
        let marks = &r.steps[begin..end];
        let mut own = Vec::new();
        sweeps += sweep_window(marks, &mut logs, records, keys, &mut own, num, sweeps);
        let log_begin = block_errors(errors, &own, log_end);
        end = begin;
        log_end = log_begin;
    }
}

/// One window of steps (`marks`, in commit order) in *sweeps*. Two steps
/// conflict when their face-id sets (the `faces_before` ids of their logs)
/// intersect; steps that do not conflict commute (see [`Rounds`]). A step
/// is *ready* once every coarser step of the window it conflicts with has
/// its records built; the next step is the ready one of the smallest key at
/// or above the last one's, or, when there is none, the ready one of the
/// smallest key (a new sweep). A step's key is taken when it becomes ready:
/// its key vertices exist by then (one created inside the window was
/// created by a conflicting coarser step). Each step's logs stay together
/// and in order. Returns the number of sweeps; `keys` gets
/// `(first_sweep + sweep, key)` per record.
///
/// Why sweeps and not layers (each step one layer after the latest
/// conflicting one, each layer sorted): the sequential coarsener's steps
/// form long conflict chains (loki, 1000-step windows: 30–130 layers), and
/// every layer restarts the ascent; a sweep takes a step as soon as its
/// dependencies are in, so a window needs about half as many (15–67), and
/// files were 0.4–1 % smaller (session 16, docs/s16-window-experiment.md).
fn sweep_window(
    marks: &[StepMark],
    logs: &mut impl Iterator<Item = StepLog>,
    records: &mut Vec<SplitRecord>,
    keys: &mut Vec<(u32, u32)>,
    own: &mut Vec<f64>,
    num: &mut Numbering,
    first_sweep: u32,
) -> u32 {
    use std::collections::{BTreeSet, HashMap};
    // coarse to fine (last committed first)
    let mut steps: Vec<(&StepMark, Vec<StepLog>)> = marks
        .iter()
        .rev()
        .map(|m| (m, logs.by_ref().take(m.logs as usize).collect()))
        .collect();
    let n = steps.len();
    // the dependencies: per face, the latest step touching it (steps
    // touching one face form a chain, so the latest one suffices)
    let mut last: HashMap<u32, usize> = HashMap::new();
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut indeg = vec![0u32; n];
    let mut preds: Vec<usize> = Vec::new();
    for (i, (_, ls)) in steps.iter().enumerate() {
        preds.clear();
        for l in ls {
            for (f, _) in &l.faces_before {
                if let Some(j) = last.insert(f.0, i) {
                    if j != i {
                        preds.push(j);
                    }
                }
            }
        }
        preds.sort_unstable();
        preds.dedup();
        indeg[i] = preds.len() as u32;
        for &j in &preds {
            succ[j].push(i);
        }
    }
    let mut ready: BTreeSet<(u32, usize)> = (0..n)
        .filter(|&i| indeg[i] == 0)
        .map(|i| (steps[i].0.key_in(&num.cv), i))
        .collect();
    let (mut cursor, mut sweeps) = (0u32, 0u32);
    while let Some(&(k, i)) = ready
        .range((cursor, 0)..)
        .next()
        .or_else(|| ready.iter().next())
    {
        if sweeps == 0 || k < cursor {
            sweeps += 1;
        }
        ready.remove(&(k, i));
        cursor = k;
        for log in std::mem::take(&mut steps[i].1) {
            records.push(record_of(log, num));
            keys.push((first_sweep + sweeps - 1, k));
            own.push(steps[i].0.own_error);
        }
        for &j in &succ[i] {
            indeg[j] -= 1;
            if indeg[j] == 0 {
                ready.insert((steps[j].0.key_in(&num.cv), j));
            }
        }
    }
    sweeps
}

/// The record of one log, numbering what it re-inserts.
fn record_of(log: StepLog, num: &mut Numbering) -> SplitRecord {
    let Numbering {
        cv,
        cf,
        vertex_order,
        n_faces,
    } = num;
    let mut rec = SplitRecord {
        op: log.op,
        new_vertices: Vec::new(),
        moved: Vec::new(),
        rewritten: Vec::new(),
        appended_faces: Vec::new(),
    };
    let mut removed = log.removed_vertices;
    removed.sort_by_key(|r| r.0);
    for (v, p) in removed {
        cv[v.idx()] = vertex_order.len() as u32;
        vertex_order.push(v.0);
        rec.new_vertices.push(p);
    }
    let mut moved: Vec<(u32, DVec3)> = log
        .moved
        .iter()
        .map(|&(v, before)| (cv[v.idx()], before))
        .collect();
    moved.sort_by_key(|m| m.0);
    rec.moved = moved;
    let quad = |vs: &[VertexId; 4], cv: &[u32]| -> [u32; 4] {
        vs.map(|v| if v.0 == NONE { NONE } else { cv[v.idx()] })
    };
    let mut appended: Vec<(FaceId, [u32; 4])> = Vec::new();
    for (f, vs) in &log.faces_before {
        let q = quad(vs, cv);
        if log.faces_after.contains(f) {
            rec.rewritten.push((cf[f.idx()], q));
        } else {
            appended.push((*f, q));
        }
    }
    rec.rewritten.sort_by_key(|r| r.0);
    appended.sort_by_key(|a| a.0);
    if log.op == OpKind::QeMerge {
        let v0 = (vertex_order.len() - rec.new_vertices.len()) as u32;
        if let Some((u, order)) = qe_canonical_order(&appended, v0, rec.new_vertices.len()) {
            relabel_qe(&mut rec, &mut appended, vertex_order, cv, v0, u, order);
        }
    }
    for (f, q) in appended {
        cf[f.idx()] = *n_faces;
        *n_faces += 1;
        rec.appended_faces.push(q);
    }
    rec
}

/// The canonical order of a qeMerge record's new vertices and appended
/// quads (the `.pqm` edge-split form's, spec §7.10, which then needs no
/// permutation): with `X0 < X1` the endpoints (the old vertices in three of
/// the four appended quads), the quad with the edge `X1 → X0` read from
/// `X0` is `(X0, u2(X0), u1(X1), X1)` and the one with `X0 → X1` is
/// `(X0, X1, u2(X1), u1(X0))`; new vertices in the order `u1(X0), u2(X0),
/// u1(X1), u2(X1)`, appended quads in the order those two, then the other
/// quad at `X0`, then the one at `X1`. Returns the current ids of the four
/// new vertices in canonical order and the appended indices in canonical
/// order; `None` when the record does not have this shape (it keeps the
/// coarsener's order). Defined by the smaller endpoint id, so it does not
/// depend on which endpoint a file names.
fn qe_canonical_order(
    appended: &[(FaceId, [u32; 4])],
    v0: u32,
    n_new: usize,
) -> Option<([u32; 4], [usize; 4])> {
    if appended.len() != 4 || n_new != 4 {
        return None;
    }
    let mut ends = Vec::with_capacity(2);
    for (_, q) in appended {
        for &v in q {
            if v < v0
                && !ends.contains(&v)
                && appended.iter().filter(|a| a.1.contains(&v)).count() >= 3
            {
                ends.push(v);
            }
        }
    }
    if ends.len() != 2 {
        return None;
    }
    let (x0, x1) = (ends[0].min(ends[1]), ends[0].max(ends[1]));
    let has_edge = |q: &[u32; 4], a: u32, b: u32| (0..4).any(|k| q[k] == a && q[(k + 1) % 4] == b);
    let from_x0 = |q: [u32; 4]| -> Option<[u32; 4]> {
        let k = q.iter().position(|&v| v == x0)?;
        Some([q[k], q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]])
    };
    let c0 = appended.iter().position(|a| has_edge(&a.1, x1, x0))?;
    let c1 = appended.iter().position(|a| has_edge(&a.1, x0, x1))?;
    let rest = |x: u32| (0..4).find(|&i| i != c0 && i != c1 && appended[i].1.contains(&x));
    let (t0, t1) = (rest(x0)?, rest(x1)?);
    let [_, a, b, _] = from_x0(appended[c0].1)?;
    let [_, _, c, d] = from_x0(appended[c1].1)?;
    let u = [d, a, b, c];
    let order = [c0, c1, t0, t1];
    let distinct = |x: &[u32; 4]| (0..4).all(|i| (0..i).all(|j| x[i] != x[j]));
    let is_new = |v: u32| v >= v0 && v < v0 + 4;
    (u.iter().all(|&v| is_new(v)) && distinct(&u) && distinct(&order.map(|i| i as u32)))
        .then_some((u, order))
}

/// Gives the new vertices `u` (current ids, canonical order) the ids
/// `v0, v0 + 1, …` and puts the appended quads in `order`, everywhere the
/// record and the numbering refer to them.
fn relabel_qe(
    rec: &mut SplitRecord,
    appended: &mut [(FaceId, [u32; 4])],
    vertex_order: &mut [u32],
    cv: &mut [u32],
    v0: u32,
    u: [u32; 4],
    order: [usize; 4],
) {
    // new id of current new vertex v0 + i
    let mut to = [0u32; 4];
    for (k, &v) in u.iter().enumerate() {
        to[(v - v0) as usize] = v0 + k as u32;
    }
    let map = |q: &mut [u32; 4]| {
        for c in q.iter_mut() {
            if *c >= v0 && *c < v0 + 4 {
                *c = to[(*c - v0) as usize];
            }
        }
    };
    rec.rewritten.iter_mut().for_each(|r| map(&mut r.1));
    appended.iter_mut().for_each(|a| map(&mut a.1));
    let old_pos: Vec<DVec3> = rec.new_vertices.clone();
    let tail = v0 as usize..v0 as usize + 4;
    let old_vo: Vec<u32> = vertex_order[tail.clone()].to_vec();
    for i in 0..4 {
        let k = (to[i] - v0) as usize;
        rec.new_vertices[k] = old_pos[i];
        vertex_order[v0 as usize + k] = old_vo[i];
        cv[old_vo[i] as usize] = to[i];
    }
    let old_app = appended.to_vec();
    for (k, &i) in order.iter().enumerate() {
        appended[k] = old_app[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A log in the form [`StepLogs`] gives back: rewritten faces first,
    /// `faces_after` exactly those.
    fn normalized(log: &StepLog) -> StepLog {
        let (mut kept, gone): (Vec<(FaceId, [VertexId; 4])>, Vec<_>) = log
            .faces_before
            .iter()
            .copied()
            .partition(|(f, _)| log.faces_after.contains(f));
        let faces_after = kept.iter().map(|e| e.0).collect();
        kept.extend(gone);
        StepLog {
            faces_before: kept,
            faces_after,
            ..log.clone()
        }
    }

    fn id(wide: bool) -> BoxedStrategy<u32> {
        // narrow ids, the padding value, and (in wide steps) ids that need
        // four bytes, including the narrow padding code itself
        if wide {
            prop_oneof![0..64u32, Just(NONE), Just(NARROW_NONE), any::<u32>()].boxed()
        } else {
            prop_oneof![0..64u32, Just(NONE), 0..NARROW_NONE].boxed()
        }
    }

    fn log() -> impl Strategy<Value = StepLog> {
        (any::<bool>(), 0..4u8, 0..300usize, 0..3usize).prop_flat_map(
            |(wide, op, n_moved, n_faces)| {
                let pos = (-1e3..1e3f64, -1e3..1e3f64, -1e3..1e3f64)
                    .prop_map(|(x, y, z)| DVec3::new(x, y, z));
                (
                    Just(op),
                    proptest::collection::vec(
                        (
                            id(wide),
                            [id(wide), id(wide), id(wide), id(wide)],
                            any::<bool>(),
                        ),
                        n_faces..n_faces * 4 + 1,
                    ),
                    proptest::collection::vec((id(wide), pos.clone()), 0..3),
                    proptest::collection::vec((id(wide), pos), n_moved..=n_moved),
                )
                    .prop_map(|(op, faces, removed, moved)| StepLog {
                        op: OpKind::from_code(op).unwrap_or(OpKind::Smooth),
                        faces_after: faces.iter().filter(|e| e.2).map(|e| FaceId(e.0)).collect(),
                        faces_before: faces
                            .iter()
                            .map(|e| (FaceId(e.0), e.1.map(VertexId)))
                            .collect(),
                        removed_vertices: removed
                            .into_iter()
                            .map(|(v, p)| (VertexId(v), p))
                            .collect(),
                        moved: moved.into_iter().map(|(v, p)| (VertexId(v), p)).collect(),
                    })
            },
        )
    }

    /// `src` coarsened to `faces` quads as `pqm encode` does (subset
    /// placement, default rules).
    fn coarsened(src: &IndexedMesh, faces: usize) -> ProgressiveMesh {
        use crate::coarsen::{CoarsenOptions, Coarsener, Placement};
        let opts = CoarsenOptions {
            target_faces: Some(faces),
            placement: Placement::Subset,
            ..Default::default()
        };
        let mesh = Mesh::from_indexed(src).unwrap();
        let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
        c.run(&mut |_| {});
        c.into_progressive()
    }

    /// Every qeMerge record of a real coarsening comes out in the canonical
    /// order (recomputing it from the record finds the identity), and the
    /// progressive mesh still replays to the input.
    #[test]
    fn qe_merge_records_are_in_canonical_order() {
        let src = crate::shapes::bumpy_torus(40, 24, 3.0, 1.0, 0.05, 7);
        let pm = coarsened(&src, 150);
        pm.validate().unwrap();
        let mut v = pm.base.positions.len() as u32;
        let (mut qe, mut checked) = (0, 0);
        for r in &pm.records {
            if r.op == OpKind::QeMerge {
                qe += 1;
                let app: Vec<(FaceId, [u32; 4])> =
                    r.appended_faces.iter().map(|&q| (FaceId(0), q)).collect();
                // (A record of another shape keeps the coarsener's order.)
                if let Some((u, order)) = qe_canonical_order(&app, v, r.new_vertices.len()) {
                    assert_eq!(u, [v, v + 1, v + 2, v + 3]);
                    assert_eq!(order, [0, 1, 2, 3]);
                    checked += 1;
                }
            }
            v += r.new_vertices.len() as u32;
        }
        // On a closed surface nearly every qeMerge has the shape.
        assert!(checked > 20 && checked * 10 >= qe * 9, "{checked} of {qe}");
        assert_is_input(&pm.level(pm.records.len()), &pm.vertex_order, &src);
    }

    /// `mesh`, its vertices mapped to input ids by `order`, is `src`: the
    /// same positions and the same faces with the same corner order (face
    /// order aside).
    fn assert_is_input(mesh: &IndexedMesh, order: &[u32], src: &IndexedMesh) {
        assert_eq!(order.len(), mesh.positions.len());
        for (canon, &orig) in order.iter().enumerate() {
            assert_eq!(mesh.positions[canon], src.positions[orig as usize]);
        }
        let mut got: Vec<Vec<u32>> = mesh
            .faces()
            .map(|f| f.iter().map(|&v| order[v as usize]).collect())
            .collect();
        let mut want: Vec<Vec<u32>> = src.faces().map(|f| f.to_vec()).collect();
        got.sort();
        want.sort();
        assert_eq!(got, want);
    }

    /// Checks that `base` is numbered as [`traversal_order`] documents:
    /// vertex ids first appear along the faces as `0, 1, 2, …` (and every
    /// vertex is in a face); components are contiguous; each face after
    /// the first of its component shares a vertex with an earlier face, and
    /// (breadth-first) the earliest such face — the one that queued it —
    /// never moves back along the order, nor, among the faces one face
    /// queued, does the corner of it that queued them. Returns the number
    /// of components.
    fn assert_traversal_order(base: &IndexedMesh) -> usize {
        // The walk of `traversal_order`, written again over the indexed
        // faces: it must visit faces `0, 1, …` and number vertices `0, 1, …`.
        let faces: Vec<&[u32]> = base.faces().collect();
        let mut across = std::collections::HashMap::new();
        for (i, f) in faces.iter().enumerate() {
            for k in 0..f.len() {
                across.insert((f[k], f[(k + 1) % f.len()]), i);
            }
        }
        let mut queued = vec![false; faces.len()];
        let mut order: Vec<usize> = Vec::new();
        let mut next = 0u32;
        let mut seen = vec![false; base.vertex_count()];
        let mut number = |v: u32| {
            if !seen[v as usize] {
                assert_eq!(v, next, "vertex {v} is first seen where {next} is due");
                seen[v as usize] = true;
                next += 1;
            }
        };
        let (mut head, mut components) = (0, 0);
        for start in 0..faces.len() {
            if queued[start] {
                continue;
            }
            components += 1;
            queued[start] = true;
            order.push(start);
            faces[start].iter().for_each(|&v| number(v));
            while head < order.len() {
                let f = faces[order[head]];
                head += 1;
                for k in 0..f.len() {
                    let (a, b) = (f[k], f[(k + 1) % f.len()]);
                    if let Some(&g) = across.get(&(b, a)) {
                        if !queued[g] {
                            queued[g] = true;
                            order.push(g);
                            let gv = faces[g];
                            let r = gv.iter().position(|&v| v == b).unwrap();
                            for t in 2..gv.len() {
                                number(gv[(r + t) % gv.len()]);
                            }
                        }
                    }
                }
            }
        }
        assert!(
            order.iter().enumerate().all(|(i, &f)| i == f),
            "faces are not in the walk's order"
        );
        assert_eq!(next as usize, base.vertex_count(), "a vertex in no face");
        components
    }

    /// The base of a real coarsening (two components, one with a boundary)
    /// is in the documented traversal order, and the records still replay
    /// it to the input, id for id through `vertex_order`.
    #[test]
    fn base_is_numbered_in_traversal_order() {
        let torus = crate::shapes::bumpy_torus(40, 24, 3.0, 1.0, 0.05, 7);
        let mut grid = crate::shapes::noisy(&crate::shapes::grid(24, 16, 3.0, 2.0), 0.01, 3);
        for p in &mut grid.positions {
            p.x += 10.0;
        }
        let src = crate::shapes::concat(&[torus, grid]);
        let pm = coarsened(&src, 200);
        pm.validate().unwrap();
        assert!(!pm.records.is_empty());
        assert_eq!(assert_traversal_order(&pm.base), 2);
        assert_is_input(&pm.level(pm.records.len()), &pm.vertex_order, &src);
    }

    /// On an uncoarsened mesh whose ids follow no order (a procedural
    /// mesh's faces and vertices shuffled), [`Base::of`] numbers it in the
    /// traversal order and `vertex_order` maps each base vertex back to its
    /// input position.
    #[test]
    fn base_of_shuffled_mesh_is_in_traversal_order() {
        let src = crate::shapes::two_components();
        // a fixed permutation of vertices and faces (multiplicative, so
        // neighbours in the input are far apart in the ids)
        let nv = src.vertex_count() as u64;
        let perm_v: Vec<u32> = (0..nv).map(|i| ((i * 37 + 11) % nv) as u32).collect();
        let faces: Vec<&[u32]> = src.faces().collect();
        let nf = faces.len() as u64;
        let mut shuffled = IndexedMesh::new();
        shuffled.positions = vec![DVec3::ZERO; nv as usize];
        for (i, &j) in perm_v.iter().enumerate() {
            shuffled.positions[j as usize] = src.positions[i];
        }
        for k in 0..nf {
            let f = faces[((k * 29 + 5) % nf) as usize];
            let q: Vec<u32> = f.iter().map(|&v| perm_v[v as usize]).collect();
            shuffled.push_face(&q);
        }
        let base = Base::of(&Mesh::from_indexed(&shuffled).unwrap());
        assert_eq!(assert_traversal_order(&base.base), 2);
        assert_eq!(base.base.face_count(), shuffled.face_count());
        assert_is_input(&base.base, &base.vertex_order, &shuffled);
    }

    proptest! {
        /// Every step comes back, last first, both borrowed and popped, and
        /// popping everything frees every chunk.
        #[test]
        fn step_logs_round_trip(logs in proptest::collection::vec(log(), 0..40)) {
            let mut store = StepLogs::new();
            for l in &logs {
                store.push(l);
            }
            prop_assert_eq!(store.len(), logs.len());
            let want: Vec<StepLog> = logs.iter().rev().map(normalized).collect();
            let borrowed: Vec<StepLog> = store.iter_rev().collect();
            prop_assert_eq!(&borrowed, &want);
            let popped: Vec<StepLog> = std::iter::from_fn(|| store.pop()).collect();
            prop_assert_eq!(&popped, &want);
            prop_assert_eq!(store.heap_bytes(), 0);
        }
    }
}
