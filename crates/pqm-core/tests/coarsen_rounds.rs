//! Coarsening in rounds of independent steps (`CoarsenOptions::round_fraction`):
//! the records still replay to the input, each round's records come in
//! ascending order of their anchors, and the result is deterministic.

use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm_core::progressive::{OpKind, ProgressiveMesh};
use pqm_core::{shapes, IndexedMesh, Mesh};

fn coarsener(src: &IndexedMesh, target: usize, rounds: Option<f64>) -> Coarsener {
    let mesh = Mesh::from_indexed(src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        placement: Placement::Subset,
        round_fraction: rounds,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    c.run(&mut |_| {});
    c
}

fn torus() -> IndexedMesh {
    shapes::noisy(&shapes::bumpy_torus(48, 20, 2.0, 0.6, 0.4, 11), 0.004, 2)
}

/// A mesh with a boundary (and so feature curves).
fn sheet() -> IndexedMesh {
    let g = shapes::height_grid(30, 30, |x, y| 0.1 * (5.0 * x).sin() * (3.0 * y).cos());
    shapes::noisy(&g, 0.003, 8)
}

/// The full level is the input (same positions, same faces with the same
/// corner order, in input ids), and every level in between is a valid
/// mesh whose vertices sit at input positions.
fn assert_replays(pm: &ProgressiveMesh, src: &IndexedMesh) {
    pm.validate().expect("valid progressive mesh");
    let n = pm.records.len();
    for k in (0..n).step_by(5).chain([n]) {
        let level = pm.level(k);
        Mesh::from_indexed(&level)
            .unwrap_or_else(|e| panic!("level {k} of {n} is not a valid mesh: {e}"));
        for (id, p) in level.positions.iter().enumerate() {
            assert_eq!(*p, src.positions[pm.vertex_order[id] as usize], "level {k}");
        }
    }
    let fine = pm.level(n);
    let mut got: Vec<Vec<u32>> = fine
        .faces()
        .map(|f| f.iter().map(|&v| pm.vertex_order[v as usize]).collect())
        .collect();
    let mut want: Vec<Vec<u32>> = src.faces().map(|f| f.to_vec()).collect();
    got.sort();
    want.sort();
    assert_eq!(got, want);
    assert!(
        pm.level_error.windows(2).all(|w| w[0] >= w[1]),
        "the error bound never grows with the level"
    );
}

#[test]
fn rounds_replay_to_the_input() {
    for (src, target) in [(torus(), 150), (sheet(), 80)] {
        for r in [0.05, 0.2, 1.0] {
            let c = coarsener(&src, target, Some(r));
            assert!(c.in_rounds());
            let (rounds, steps, _) = c.round_stats().expect("in rounds");
            assert!(
                steps > 100 && rounds * 3 < steps,
                "rounds hold several steps: {rounds} rounds of {steps} steps"
            );
            let borrowed = c.to_progressive();
            assert!(borrowed.records.len() > 100);
            assert_replays(&borrowed, &src);
            let consumed = c.into_progressive();
            assert!(consumed == borrowed, "into_progressive = to_progressive");
        }
    }
}

#[test]
fn rounds_are_deterministic() {
    let src = torus();
    let a = coarsener(&src, 150, Some(0.1)).into_progressive();
    let b = coarsener(&src, 150, Some(0.1)).into_progressive();
    assert!(a == b);
}

#[test]
fn rounds_only_apply_to_subset_placement() {
    let src = torus();
    let run = |rounds| {
        let mesh = Mesh::from_indexed(&src).expect("valid quad mesh");
        let opts = CoarsenOptions {
            target_faces: Some(300),
            round_fraction: rounds,
            ..Default::default()
        };
        let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
        c.run(&mut |_| {});
        assert!(!c.in_rounds());
        c.into_progressive()
    };
    assert!(run(Some(0.1)) == run(None));
}

/// The vertex a record's compact form anchors on, as the key promises:
/// a qvMerge's inverse keeps the survivor, the corner of the appended quad
/// opposite the new vertex; a qeMerge's inverse names the endpoints of the
/// edge, the two old vertices in three of its four appended quads.
fn anchors(pm: &ProgressiveMesh) -> Vec<Option<Vec<u32>>> {
    let mut v = pm.base.positions.len() as u32;
    let mut out = Vec::new();
    for r in &pm.records {
        let v0 = v;
        v += r.new_vertices.len() as u32;
        out.push(match r.op {
            OpKind::QvMerge if r.appended_faces.len() == 1 && r.new_vertices.len() == 1 => {
                let q = r.appended_faces[0];
                q.iter()
                    .position(|&x| x == v0)
                    .map(|k| vec![q[(k + 2) % 4]])
            }
            OpKind::QeMerge => {
                let mut ends: Vec<u32> = Vec::new();
                for q in &r.appended_faces {
                    for &x in q {
                        if x < v0
                            && !ends.contains(&x)
                            && r.appended_faces.iter().filter(|q| q.contains(&x)).count() >= 3
                        {
                            ends.push(x);
                        }
                    }
                }
                (ends.len() == 2).then_some(ends)
            }
            _ => None,
        });
    }
    out
}

#[test]
fn anchors_ascend_within_each_round() {
    for (src, target) in [(torus(), 150), (sheet(), 80)] {
        let c = coarsener(&src, target, Some(0.1));
        let (pm, keys) = c.to_progressive_with_keys();
        assert_eq!(keys.len(), pm.records.len());
        let anchors = anchors(&pm);
        let mut checked = 0;
        for (k, a) in anchors.iter().enumerate() {
            if let Some(a) = a {
                // the key is the anchor (qvMerge) or the smaller endpoint
                assert_eq!(
                    keys[k].1,
                    *a.iter().min().unwrap(),
                    "record {k} ({:?})",
                    pm.records[k].op
                );
                checked += 1;
            }
        }
        assert!(checked * 2 > pm.records.len(), "{checked} anchors checked");
        // non-decreasing within a round; a round is a run of equal numbers
        let mut longest = 0;
        let mut run = 1;
        for k in 1..keys.len() {
            if keys[k].0 == keys[k - 1].0 {
                assert!(
                    keys[k].1 >= keys[k - 1].1,
                    "records {} and {k}: keys {:?} then {:?}",
                    k - 1,
                    keys[k - 1],
                    keys[k]
                );
                run += 1;
                longest = longest.max(run);
            } else {
                run = 1;
            }
        }
        assert!(longest >= 10, "some round holds many records: {longest}");
    }
}

/// [`coarsener`] with the records reordered in windows
/// (`CoarsenOptions::reorder_window`).
fn coarsener_in_windows(
    src: &IndexedMesh,
    target: usize,
    rounds: Option<f64>,
    window: Option<f64>,
) -> Coarsener {
    let mesh = Mesh::from_indexed(src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        placement: Placement::Subset,
        round_fraction: rounds,
        reorder_window: window,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    c.run(&mut |_| {});
    c
}

/// Windows reorder the records only: the same base and the same number of
/// records as without them, the records still replay to the input, and
/// the consuming build is the borrowing one.
#[test]
fn windows_replay_to_the_input() {
    for (src, target) in [(torus(), 150), (sheet(), 80)] {
        for rounds in [None, Some(0.05)] {
            let plain = coarsener_in_windows(&src, target, rounds, None).into_progressive();
            for w in [0.02, 0.1, 1.0] {
                let c = coarsener_in_windows(&src, target, rounds, Some(w));
                let borrowed = c.to_progressive();
                assert!(borrowed.base == plain.base, "window {w}: same base");
                assert_eq!(borrowed.records.len(), plain.records.len());
                assert!(borrowed.records != plain.records, "window {w}: reordered");
                assert_replays(&borrowed, &src);
                let consumed = c.into_progressive();
                assert!(consumed == borrowed, "into_progressive = to_progressive");
            }
        }
    }
}

/// In windows, each step's key is its anchor and the keys ascend within
/// each sweep; with windows large enough, sweeps hold many records.
#[test]
fn anchors_ascend_within_each_sweep() {
    for (src, target) in [(torus(), 150), (sheet(), 80)] {
        for rounds in [None, Some(0.05)] {
            let c = coarsener_in_windows(&src, target, rounds, Some(0.2));
            let (pm, keys) = c.to_progressive_with_keys();
            assert_eq!(keys.len(), pm.records.len());
            for (k, a) in anchors(&pm).iter().enumerate() {
                if let Some(a) = a {
                    assert_eq!(keys[k].1, *a.iter().min().unwrap(), "record {k}");
                }
            }
            let mut longest = 0;
            let mut run = 1;
            for k in 1..keys.len() {
                assert!(keys[k].0 >= keys[k - 1].0, "sweeps are numbered in order");
                if keys[k].0 == keys[k - 1].0 {
                    assert!(keys[k].1 >= keys[k - 1].1, "records {} and {k}", k - 1);
                    run += 1;
                    longest = longest.max(run);
                } else {
                    run = 1;
                }
            }
            assert!(longest >= 10, "some sweep holds many records: {longest}");
        }
    }
}

/// A level inside a round or a window gets the bound of the block's fine
/// end raised by the own bounds of the steps it has collapsed (no longer
/// the coarse end's for all of them): the bound still never grows with the
/// level and still holds the level's sampled Hausdorff distance to the
/// input, and it now falls inside rounds, not only between them.
#[test]
fn levels_inside_blocks_are_bounded_by_their_collapsed_steps() {
    use pqm_core::metrics::hausdorff::{hausdorff, HausdorffOptions};
    for (src, target) in [(torus(), 150), (sheet(), 80)] {
        for (rounds, window) in [
            (Some(0.05), None),
            (Some(0.005), Some(0.05)),
            (None, Some(0.1)),
        ] {
            let c = coarsener_in_windows(&src, target, rounds, window);
            let (pm, keys) = c.to_progressive_with_keys();
            let e = &pm.level_error;
            assert!(e.windows(2).all(|w| w[0] >= w[1]), "non-increasing");
            let n = pm.records.len();
            for k in (0..=n).step_by((n / 40).max(1)) {
                let h = hausdorff(&pm.level(k), &src, &HausdorffOptions::default());
                assert!(
                    h.symmetric.max <= e[k] + 1e-12,
                    "{rounds:?}/{window:?} level {k}: Hausdorff {} above the bound {}",
                    h.symmetric.max,
                    e[k]
                );
            }
            if window.is_none() {
                // a round holds records a..b (file order); the coarse-end
                // rule gave every level a..b its level a's bound
                let below = (1..n).any(|k| {
                    let a = (0..k)
                        .rev()
                        .take_while(|&j| keys[j].0 == keys[k - 1].0)
                        .last();
                    keys[k].0 == keys[k - 1].0 && a.is_some_and(|a| e[k] < e[a])
                });
                assert!(
                    below,
                    "{rounds:?}: no level inside a round below its coarse end"
                );
            }
        }
    }
}
