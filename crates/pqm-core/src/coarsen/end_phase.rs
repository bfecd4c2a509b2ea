//! End phase: the last steps toward the face target chosen by rollouts.
//!
//! Near the target the paper's greedy order takes whatever step is still
//! legal, and on a block layout every local step there adds defects (see
//! `docs/paper-choices.md`, "Fandisk at 250 faces"): which step, and
//! whether a chord collapse (`coarsen::chord`) goes first, decides the
//! final defect count, but `E` only sees one step ahead. So once the face
//! count is within [`END_PHASE_AT`] of the target (and at most
//! [`END_PHASE_MAX_FACES`] above it), each step is chosen among a few
//! alternatives by playing the run out: the first [`END_PHASE_WIDTH`]
//! fresh candidates of the queue (in `E` order: the first one legal is
//! what the run would commit) and every chord collapse the chord phase
//! would accept (no defect added, target not passed), each committed on a
//! copy of the coarsener and coarsened from there to the target by the
//! ordinary run (chord and fix phases included, no end phase); the one
//! whose played-out result has the highest ideal-vertex fraction (one
//! that reaches the target before one that does not) is committed, ties
//! by that order. Since the ordinary run's own step is among them and is
//! played out by the ordinary run, a choice never plays out less ideal
//! than the ordinary run from there (a rollout); and since the refusal
//! tests also run on copies, the original is untouched until the chosen
//! step commits on it exactly as on its copy, so the run then goes on as
//! played out or better (fandisk → 250: 36 of 252 vertices non-ideal
//! predicted from 317 faces on and reached, 85.7 %, where the ordinary
//! run ends at 40, 84.1 %; see `docs/paper-choices.md`).
//!
//! Only on the meshes that get chord phases ([`Coarsener::chords_wanted`]:
//! CAD-like block layouts under QEM placement) and with a face target.
//!
//! Invariants: the copies are thrown away; the step committed is checked
//! and logged as any other (the same `try_commit` / `commit_patch`), so
//! records replay as before; deterministic (the copies run the same
//! deterministic code, alternatives in a fixed order, ties by that order).

use super::{Coarsener, Entry};
use rayon::prelude::*;

/// The end phase starts when the face count is at most this multiple of
/// the target.
pub const END_PHASE_AT: f64 = 1.3;

/// … and at most this many faces above it: each step plays out up to
/// `END_PHASE_WIDTH` + chords runs of up to this many faces, on copies of
/// the coarsener, so this bounds the phase's cost on large meshes.
pub const END_PHASE_MAX_FACES: usize = 100;

/// Queue candidates played out per step.
pub const END_PHASE_WIDTH: usize = 8;

/// One alternative of an end-phase step.
#[derive(Clone, Copy, Debug)]
enum Alt {
    Step(Entry),
    Chord((crate::mesh::FaceId, u8), i64),
}

/// Where a played-out alternative ends.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    reached: bool,
    defects: usize,
    vertices: usize,
}

impl Outcome {
    /// Reaching the target first, then the higher ideal-vertex fraction
    /// (compared exactly); a tie is not better.
    fn better_than(&self, o: &Outcome) -> bool {
        if self.reached != o.reached {
            return self.reached;
        }
        (self.defects as u128) * (o.vertices as u128)
            < (o.defects as u128) * (self.vertices as u128)
    }
}

impl Coarsener {
    /// Steps committed by the end phase so far (chord collapses among
    /// them are also counted by [`Coarsener::chord_collapses`]).
    pub fn end_phase_steps(&self) -> usize {
        self.end_steps
    }

    /// Turns the end phase off (or on again) — for tests and diagnosis,
    /// and for the copies that play alternatives out.
    #[doc(hidden)]
    pub fn set_end_phase(&mut self, on: bool) {
        self.end_phase = on;
    }

    /// The ordinary run from here to the target (or until nothing is
    /// legal), no final smoothing (it moves no valence): where it ends.
    fn play_out(&mut self, target: usize) -> Outcome {
        while self.steps(target, usize::MAX) {}
        let m = &self.mesh;
        Outcome {
            reached: m.face_count() <= target,
            defects: m
                .vertices()
                .filter(|&v| m.valence(v) != m.ideal_valence(v))
                .count(),
            vertices: m.vertex_count(),
        }
    }

    /// Whether the next step is an end-phase step.
    pub(super) fn in_end_phase(&self, target: usize) -> bool {
        let faces = self.mesh.face_count();
        self.chords_on
            && self.end_phase
            && target > 0
            && faces > target
            && faces <= target + END_PHASE_MAX_FACES
            && faces as f64 <= END_PHASE_AT * target as f64
    }

    /// A copy that plays the ordinary run, without the step logs (they
    /// only grow, and the copy is thrown away: so it costs the current
    /// mesh, not the whole history).
    fn copy_for_rollout(&mut self) -> Coarsener {
        let logs = std::mem::take(&mut self.logs);
        let errors = std::mem::take(&mut self.errors);
        let mut copy = self.clone();
        self.logs = logs;
        self.errors = errors;
        copy.end_phase = false;
        copy
    }

    fn apply_alt(&mut self, alt: Alt) -> bool {
        match alt {
            Alt::Step(e) => self.try_commit(e.cand),
            Alt::Chord(start, gain) => self.commit_chord(start, gain),
        }
    }

    /// One end-phase step: `Some(true)` when a step was committed,
    /// `Some(false)` when the candidates taken from the queue were all
    /// refused (call again), `None` when the queue has no fresh candidate
    /// left (the caller's ordinary handling of an empty queue applies) or
    /// none of the alternatives committed on its copy (the ordinary pop).
    pub(super) fn end_phase_step(&mut self, target: usize) -> Option<bool> {
        let mut popped: Vec<Entry> = Vec::new();
        while popped.len() < END_PHASE_WIDTH {
            let Some(e) = self.queue.pop() else {
                break;
            };
            if self.fresh(&e) {
                popped.push(e);
            }
        }
        if popped.is_empty() {
            return None;
        }
        // which of them would commit now, each tried on a copy: a refused
        // one is dropped, as the ordinary run drops it, and its refusal
        // counted; the original is not touched (an undo may renumber
        // half-edges, and the step chosen below must commit on the
        // original exactly as it did on its copy). A legal one's copy,
        // its step committed, is kept to be played out below.
        let mut legal: Vec<Entry> = Vec::with_capacity(popped.len());
        let mut stepped: Vec<Coarsener> = Vec::with_capacity(popped.len());
        for &e in &popped {
            let mut copy = self.copy_for_rollout();
            if copy.apply_alt(Alt::Step(e)) {
                legal.push(e);
                stepped.push(copy);
            } else {
                self.report.rejections = copy.report.rejections;
                self.report.refused_fixes = copy.report.refused_fixes;
            }
        }
        // the legal ones back in the queue, the original's and each kept
        // copy's: the play-outs run the ordinary run, which needs them (an
        // entry a commit made stale is skipped as usual; the queue's order
        // is total, so when an entry was pushed does not matter)
        for &e in &legal {
            self.queue.push(e);
            for copy in &mut stepped {
                copy.queue.push(e);
            }
        }
        let mut alts: Vec<Alt> = legal.iter().map(|&e| Alt::Step(e)).collect();
        alts.extend(
            self.chord_candidates(target)
                .into_iter()
                .map(|c| Alt::Chord(c.start, c.gain)),
        );
        if let [Alt::Step(e)] = alts[..] {
            // nothing to choose between (and it commits: tested above) —
            // no copy to play out
            let ok = self.apply_alt(Alt::Step(e));
            self.end_steps += ok as usize;
            return ok.then_some(true);
        }
        // each played out on its own copy (in parallel: the copies share
        // nothing, and the choice below reads the results in order); the
        // queue steps' copies have their step committed already, a chord's
        // legality is not known before
        let mut copies: Vec<(Coarsener, bool)> = stepped.into_iter().map(|c| (c, true)).collect();
        copies.extend(
            alts[legal.len()..]
                .iter()
                .map(|_| (self.copy_for_rollout(), false)),
        );
        let outcomes: Vec<Option<Outcome>> = copies
            .into_par_iter()
            .zip(alts.par_iter())
            .map(|((mut copy, done), &alt)| {
                (done || copy.apply_alt(alt)).then(|| copy.play_out(target))
            })
            .collect();
        let mut best: Option<(usize, Outcome)> = None;
        for (i, o) in outcomes.into_iter().enumerate() {
            let Some(o) = o else {
                continue;
            };
            if best.as_ref().is_none_or(|(_, b)| o.better_than(b)) {
                best = Some((i, o));
            }
        }
        let Some((i, ..)) = best else {
            // none committed: all taken from the queue were refused (and
            // dropped: call again); or — not expected, the legal ones were
            // tested on the same mesh — the queue's entries commit no
            // more, and the ordinary pop takes over (it drops what it
            // refuses), so the loop always moves on
            return if legal.is_empty() { Some(false) } else { None };
        };
        let ok = self.apply_alt(alts[i]);
        debug_assert!(ok, "an end-phase step committed on a copy is refused");
        self.end_steps += ok as usize;
        // (were it refused, the same choice would come again: the
        // ordinary pop takes over instead)
        ok.then_some(true)
    }
}
