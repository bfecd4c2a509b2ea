//! Fix phases: now and then, every step that removes defects, whatever
//! its `E`.
//!
//! `E` orders steps by `V`, `D` and `A` together, so a step that cancels a
//! 3–5 pair but moves a vertex far (large `D`) or across the field (`A`)
//! waits behind cheap defect-neutral steps — and those change its
//! neighbourhood until it is gone. A defect-removing candidate legal now is
//! rare (a few dozen at a time on loki), but what it removes stays removed.
//!
//! So when the face count first drops to each of [`FIX_PHASES_AT`] times the
//! face target, the queue is rebuilt with only the candidates that remove
//! defects (non-ideal vertices among those the step changes, as `V` counts
//! them: [`gain_of`] > 0), still ordered by `E`; those are popped and
//! committed under the usual checks, with the faces around each commit
//! re-scored under the same filter, until none is left; then every face is
//! scored again and coarsening goes on. Nothing else changes: the same
//! operators, guards and limits — but for [`super::FIX_DEVIATION_FACTOR`],
//! which does not apply in a fix phase (with it, the far steps a fix phase
//! reaches took fertility's remesh to a coarse Hausdorff distance of 1.11
//! %, its test's bar 1 %; without it loki 84.7 → 84.8 %); no fix phase
//! without a face target.
//!
//! Figures (loki → 2,000 faces, with boundary-only runs of three — since
//! replaced by the general rule of `FeatureState::check_run`; four orders, each
//! cost scaled by a fixed pseudo-random factor in `[1, 1.05)` per
//! candidate): ideal fraction 82.5 % mean (81.4–83.3) → 84.1 % (83.0–85.1);
//! the default order 82.3 → 84.8 %. Trigger sets measured: fix phases also
//! at 3× and 2× (loki 84.0 % mean, spot 85.2 %); at 1.3 … 1.01 (seven, loki
//! 83.6 %); a fix phase filtering for at least two defects removed (84.0
//! %); defect-removing steps first at all times instead (every `E` scaled
//! by 10⁻⁹ per defect removed: 83.0 %). With the general run rule, without
//! → with fix phases: loki 85.3 → 86.0 %, fandisk (250 faces) 73.0 → 75.8
//! %, makehuman 72.0 → 72.6 %, bunny 82.5 → 83.1 %.
//!
//! Invariant: a fix phase only filters and reorders candidates; each step
//! is checked and logged as any other, so records, determinism (the queue
//! is rebuilt from the faces in id order) and the checks are unchanged.

use super::Coarsener;

/// Multiples of the face target at which a fix phase starts (each once,
/// the first time the face count is at or below it).
pub const FIX_PHASES_AT: [f64; 4] = [1.5, 1.2, 1.1, 1.03];

/// Defects a scored candidate removes, from `V`'s terms `(ideal before,
/// counted before, ideal after, counted after)`: non-ideal vertices before
/// minus after.
pub(super) fn gain_of(v_counts: (usize, usize, usize, usize)) -> i64 {
    let (ideal_b, count_b, ideal_a, count_a) = v_counts;
    (count_b as i64 - ideal_b as i64) - (count_a as i64 - ideal_a as i64)
}

impl Coarsener {
    /// Starts the next fix phase if the face count has reached its trigger
    /// (`target` > 0): the queue is rebuilt with defect-removing candidates
    /// only.
    pub(super) fn start_fix_phase(&mut self, target: usize) {
        if self.fix_only || target == 0 {
            return;
        }
        // (in the end phase the chord collapses are among each step's
        // alternatives instead)
        if !self.in_end_phase(target) {
            self.maybe_chord_phase(target);
        }
        let faces = self.mesh.face_count() as f64;
        let mut due = false;
        while let Some(&at) = FIX_PHASES_AT.get(self.fix_phases) {
            if faces > at * target as f64 {
                break;
            }
            // (several triggers passed at once start one phase)
            self.fix_phases += 1;
            due = true;
        }
        if due {
            self.fix_only = true;
            self.rescore_all();
        }
    }

    /// Ends a fix phase whose queue ran empty: every face is scored again.
    /// `false` when no fix phase was running.
    pub(super) fn end_fix_phase(&mut self) -> bool {
        if !self.fix_only {
            return false;
        }
        self.fix_only = false;
        self.rescore_all();
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_counts_non_ideal_vertices() {
        // 2 of 5 ideal before (3 defects), 2 of 3 after (1 defect)
        assert_eq!(gain_of((2, 5, 2, 3)), 2);
        assert_eq!(gain_of((4, 4, 2, 4)), -2);
        assert_eq!(gain_of((0, 0, 0, 0)), 0);
    }
}
