//! Development aid: why the defects left near a vertex stay. For every
//! candidate of the faces around a vertex it reports the step's score, the
//! defects it would remove (as `V` counts them) and the verdict a commit
//! would reach now — tried on a copy, so the coarsener is unchanged.
//! Used by the `coarsen_refusals` example; not part of the coarsening.

use super::{fix_phase, Cand, Coarsener, SCRATCH};
use crate::mesh::VertexId;

/// One candidate near a vertex and what became of it.
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct Probe {
    /// `qv(face,diagonal)` or `qe(face,edge)`.
    pub cand: String,
    /// `E`, `None` when the candidate cannot be scored (`verdict` says why).
    pub cost: Option<f64>,
    /// Defects removed as scored (before minus after).
    pub gain: i64,
    /// `committed`, or the reason the commit was refused.
    pub verdict: String,
}

impl Coarsener {
    /// Every candidate of the faces around `v` (both qvMerge diagonals,
    /// the qeMerge across each interior edge), scored and tried under the
    /// current phase on a copy of the coarsener.
    #[doc(hidden)]
    pub fn probe_around(&self, v: VertexId) -> Vec<Probe> {
        let mut out = Vec::new();
        let faces: Vec<_> = self.mesh.vertex_faces(v).collect();
        for f in faces {
            let mut cands = vec![Cand::Qv(f, 0), Cand::Qv(f, 1)];
            for (i, h) in self.mesh.face_halfedges(f).enumerate() {
                if self.mesh.face(self.mesh.twin(h)).is_some() {
                    cands.push(Cand::Qe(f, i as u8, 0));
                }
            }
            for c in cands {
                let (cost, gain) = SCRATCH.with(|s| {
                    let s = &mut s.borrow_mut();
                    let cost = self.score_with(c, s, false);
                    (cost, fix_phase::gain_of(s.v_counts))
                });
                let name = match c {
                    Cand::Qv(f, d) => format!("qv({},{d})", f.0),
                    Cand::Qe(f, i, _) => format!("qe({},{i})", f.0),
                };
                let verdict = match cost {
                    None => match self.build(c) {
                        Err(e) => format!("unscored: {}", super::reject_name(&e)),
                        Ok(_) => "unscored: valence cap or degenerate".to_string(),
                    },
                    Some(_) => {
                        let mut copy = self.clone();
                        let before = copy.report.rejections.clone();
                        if copy.try_commit(c) {
                            "committed".to_string()
                        } else {
                            copy.report
                                .rejections
                                .iter()
                                .find(|(k, n)| before.get(*k) != Some(n))
                                .map_or("refused".to_string(), |(k, _)| k.clone())
                        }
                    }
                };
                out.push(Probe {
                    cand: name,
                    cost,
                    gain: if cost.is_some() { gain } else { 0 },
                    verdict,
                });
            }
        }
        out
    }
}

/// The state after one committed step of [`Coarsener::run_traced`].
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct TraceRow {
    pub faces: usize,
    /// Non-ideal vertices off the curves, on curves, at feature corners.
    pub defects: [usize; 3],
    pub feature_edges: usize,
    /// `qv` or `qe`.
    pub op: &'static str,
    pub cap: usize,
    pub fix_only: bool,
    pub limit_deviation: bool,
}

impl Coarsener {
    /// The counts so far (the report [`Coarsener::run`] returns).
    #[doc(hidden)]
    pub fn report_so_far(&self) -> &super::CoarsenReport {
        &self.report
    }

    /// Defects by kind: off the curves, on curves, at feature corners.
    #[doc(hidden)]
    pub fn defects_by_kind(&self) -> [usize; 3] {
        let m = &self.mesh;
        let mut out = [0; 3];
        for v in m.vertices() {
            if m.valence(v) != m.ideal_valence(v) {
                let k = if self.features.is_corner(v) {
                    2
                } else {
                    self.features.is_feature(v) as usize
                };
                out[k] += 1;
            }
        }
        out
    }

    /// [`Coarsener::run`] without the final smoothing, one committed step
    /// at a time, with the state after each.
    #[doc(hidden)]
    pub fn run_traced(&mut self) -> Vec<TraceRow> {
        self.begin();
        let target = self.target_faces();
        let mut rows = Vec::new();
        loop {
            let qv = self.report.qv_merges;
            let more = self.steps(target, 1);
            if self.report.qv_merges + self.report.qe_merges > rows.len() {
                rows.push(TraceRow {
                    faces: self.mesh.face_count(),
                    defects: self.defects_by_kind(),
                    feature_edges: self.features.edge_count(),
                    op: if self.report.qv_merges > qv {
                        "qv"
                    } else {
                        "qe"
                    },
                    cap: self.cap,
                    fix_only: self.fix_only,
                    limit_deviation: self.limit_deviation,
                });
            }
            if !more {
                break;
            }
        }
        rows
    }
}

#[cfg(test)]
mod tests {
    use super::super::{CoarsenOptions, Smoothing};
    use super::*;
    use crate::{shapes, Mesh};

    fn coarsener() -> Coarsener {
        let src = shapes::noisy(&shapes::torus(24, 12, 1.0, 0.35), 0.01, 3);
        let opts = CoarsenOptions {
            target_faces: Some(120),
            smoothing: Smoothing::None,
            ..Default::default()
        };
        Coarsener::with_defaults(Mesh::from_indexed(&src).unwrap(), 180.0, &[], opts).unwrap()
    }

    /// The traced run is the run: the same steps, the same mesh (so what
    /// the trace shows is what `run` does), one row per committed step.
    #[test]
    fn traced_run_matches_run() {
        let mut a = coarsener();
        let report = a.run(&mut |_| {});
        let mut b = coarsener();
        let rows = b.run_traced();
        assert_eq!(a.mesh().to_indexed().0, b.mesh().to_indexed().0);
        assert!(rows.len() > 20, "{} steps", rows.len());
        assert_eq!(rows.len(), report.qv_merges + report.qe_merges);
        assert_eq!(rows.last().map(|r| r.faces), Some(a.mesh().face_count()));
        assert_eq!(b.report_so_far().rejections, report.rejections);
    }

    /// Probing tries commits on a copy: the coarsener is unchanged, and on
    /// a mesh that can still be coarsened some candidate would commit.
    #[test]
    fn probe_leaves_the_coarsener_unchanged() {
        let mut c = coarsener();
        c.rescore_all();
        let before = c.mesh().to_indexed().0;
        let vs: Vec<VertexId> = c.mesh().vertices().step_by(37).collect();
        let probes: Vec<Probe> = vs.iter().flat_map(|&v| c.probe_around(v)).collect();
        assert!(
            probes.iter().any(|p| p.verdict == "committed"),
            "{probes:?}"
        );
        assert_eq!(c.mesh().to_indexed().0, before);
        assert_eq!(c.report_so_far().qv_merges + c.report_so_far().qe_merges, 0);
    }
}
