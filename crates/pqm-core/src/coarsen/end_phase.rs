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
//! played out by the ordinary run, the end result is never less ideal
//! than the ordinary run's (the rollout argument: each choice is at least
//! as good as following the ordinary run from there).
//!
//! Only on the meshes that get chord phases ([`Coarsener::chords_wanted`]:
//! CAD-like block layouts under QEM placement) and with a face target.
//!
//! Invariants: the copies are thrown away; the step committed is checked
//! and logged as any other (the same `try_commit` / `commit_patch`), so
//! records replay as before; deterministic (the copies run the same
//! deterministic code, alternatives in a fixed order, ties by that order).

use super::{Coarsener, Entry};

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

impl Coarsener {
    /// Whether the next step is an end-phase step.
    pub(super) fn in_end_phase(&self, target: usize) -> bool {
        let faces = self.mesh.face_count();
        self.chords_on
            && !self.rollout
            && target > 0
            && faces > target
            && faces <= target + END_PHASE_MAX_FACES
            && faces as f64 <= END_PHASE_AT * target as f64
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
    /// left (the caller's ordinary handling of an empty queue applies).
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
        // back in the queue: the copies play the ordinary run, which
        // needs them (an entry a commit made stale is skipped as usual)
        for &e in &popped {
            self.queue.push(e);
        }
        let mut alts: Vec<Alt> = popped.iter().map(|&e| Alt::Step(e)).collect();
        alts.extend(
            self.chord_candidates(target)
                .into_iter()
                .map(|c| Alt::Chord(c.start, c.gain)),
        );
        // (reached the target, non-ideal vertices, vertices) of the best
        let mut best: Option<(usize, bool, usize, usize)> = None;
        for (i, &alt) in alts.iter().enumerate() {
            let mut copy = self.clone();
            copy.rollout = true;
            if !copy.apply_alt(alt) {
                if let Alt::Step(e) = alt {
                    // refused: as in the ordinary run, the entry is
                    // dropped and the refusal counted (the later copies
                    // start from there, as the ordinary run would)
                    self.queue
                        .retain(|x| !(x.cand == e.cand && x.stamps == e.stamps));
                    let ok = self.try_commit(e.cand);
                    debug_assert!(!ok, "refused on a copy, committed on the original");
                }
                continue;
            }
            while copy.steps(target, usize::MAX) {}
            let m = &copy.mesh;
            let reached = m.face_count() <= target;
            let verts = m.vertex_count();
            let defects = m
                .vertices()
                .filter(|&v| m.valence(v) != m.ideal_valence(v))
                .count();
            let better = match best {
                None => true,
                Some((_, r, d, n)) => {
                    (reached && !r)
                        || (reached == r
                            && (defects as u128) * (n as u128) < (d as u128) * (verts as u128))
                }
            };
            if better {
                best = Some((i, reached, defects, verts));
            }
        }
        let Some((i, ..)) = best else {
            return Some(false);
        };
        let ok = self.apply_alt(alts[i]);
        debug_assert!(ok, "an end-phase step committed on a copy is refused");
        Some(ok)
    }
}
