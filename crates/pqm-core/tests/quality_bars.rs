//! Quality bars of the coarsener on the real shared meshes (issue "qCoarsen
//! coarsener", section "Quality bars"). Each case coarsens a mesh from
//! `../shared/meshes` with the default options and checks what must always
//! hold — quad-only and valid, topology unchanged, every feature curve
//! alive, no quad inverted, worst valence no worse than allowed, every level
//! of the records replaying to the input — plus figures against thresholds.
//!
//! Where the target is not reached yet, the threshold here is the
//! figure the coarsener reaches today (a regression floor), written next to
//! the target: `floor (target)`. The achieved figures are printed.
//! The figures move by a few percent when the order of near-equal steps
//! changes (variants that should be equivalent measured 66–72 % ideal on
//! spot before the fold-over fix), so a floor sits a little below the
//! figure reached.

use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::metrics::{mesh_stats, valence};
use pqm_core::pairing::{check_pairing, pair_triangles};
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use pqm_core::{io, IndexedMesh, Mesh};
use std::path::PathBuf;

fn shared(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(name)
}

struct Bars {
    target: Target,
    /// Faces the coarsener must get to (at most).
    max_faces: usize,
    min_ideal: f64,
    min_sj_median: f64,
    max_hausdorff: f64,
}

enum Target {
    Faces(usize),
    Ratio(f64),
}

fn check(name: &str, bars: Bars) {
    check_made_quad(name, false, bars)
}

/// [`check`] of a non-quad input made quad-only by triangle pairing
/// (`paired`, `pqm encode`'s default since session 24) or by the split.
fn check_made_quad(name: &str, paired: bool, bars: Bars) {
    let path = shared(name);
    let mut input: IndexedMesh = io::read_mesh(&path).unwrap();
    if !input.is_quad_only() {
        input = if paired {
            let (out, _) = pair_triangles(&input).unwrap();
            check_pairing(&input, &out).unwrap();
            out
        } else {
            catmull_clark_split(&input, SplitMode::Linear).unwrap()
        };
    }
    let before = mesh_stats(&input, None);
    let input_worst = valence(&input).valence.iter().copied().max().unwrap_or(0) as usize;
    let mesh = Mesh::from_indexed(&input).unwrap();
    let opts = match bars.target {
        Target::Faces(n) => CoarsenOptions {
            target_faces: Some(n),
            ..Default::default()
        },
        Target::Ratio(r) => CoarsenOptions {
            target_ratio: Some(r),
            ..Default::default()
        },
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).unwrap();
    let curves = c.features().live_curves();
    let report = c.run(&mut |_| {});
    let m = c.mesh();
    m.validate().unwrap();
    assert!(
        m.faces().all(|f| m.face_degree(f) == 4),
        "{name}: not quad-only"
    );
    assert_eq!(
        c.features().live_curves(),
        curves,
        "{name}: a feature curve vanished"
    );
    let out = m.to_indexed().0;
    let after = mesh_stats(&out, Some(&input));
    let h = after.hausdorff.as_ref().unwrap();
    let out_worst = valence(&out).valence.iter().copied().max().unwrap_or(0) as usize;
    println!(
        "| {name} | {} | {} | {:.1}% → {:.1}% | {} | {:.3} / {:.3} | {:.4} | {:?} |",
        input.face_count(),
        out.face_count(),
        100.0 * before.valence.ideal_fraction,
        100.0 * after.valence.ideal_fraction,
        out_worst,
        after.scaled_jacobian.median,
        after.scaled_jacobian.worst,
        h.max,
        report.stop
    );
    println!(
        "  {name}: qv {} qe {} doublets {} chords {} (wide rescues {}); peak queue {} entries ({:.1} per input quad); rejections {:?}; of them defect-removing {:?}",
        report.qv_merges,
        report.qe_merges,
        report.doublets,
        c.chord_collapses(),
        report.wide_rescues,
        report.peak_queue,
        report.peak_queue as f64 / input.face_count() as f64,
        report.rejections,
        report.refused_fixes
    );
    if after.forced_irregular > 0 {
        // (the Euler-characteristic bound of metrics::topology: no quad mesh
        // of this topology and vertex count has a higher ideal fraction)
        println!(
            "  {name}: {} irregular vertices forced by the topology: ideal fraction at most {:.1}% at {} vertices",
            after.forced_irregular,
            100.0 * (1.0 - after.forced_irregular as f64 / after.vertices as f64),
            after.vertices
        );
    }
    assert!(after.valence.extraordinary >= after.forced_irregular);
    assert_eq!(
        (after.components, after.boundary_loops, after.genus),
        (before.components, before.boundary_loops, before.genus),
        "{name}: topology changed"
    );
    assert!(
        out.face_count() <= bars.max_faces,
        "{name}: stopped at {} faces",
        out.face_count()
    );
    assert!(
        out_worst <= input_worst.max(6),
        "{name}: worst valence {out_worst}"
    );
    // no inverted quad, unless the input had one (loki does: -0.30)
    assert!(
        after.scaled_jacobian.worst > 0.0
            || after.scaled_jacobian.worst >= before.scaled_jacobian.worst,
        "{name}: an inverted quad"
    );
    assert!(
        after.scaled_jacobian.median >= bars.min_sj_median,
        "{name}: SJ median"
    );
    assert!(
        after.valence.ideal_fraction >= bars.min_ideal,
        "{name}: ideal fraction"
    );
    assert!(h.max <= bars.max_hausdorff, "{name}: Hausdorff {}", h.max);
    // the records replay to the input at the finest level
    let pm = c.to_progressive();
    pm.validate().unwrap();
    assert_eq!(pm.level(pm.records.len()).face_count(), input.face_count());
}

#[test]
fn spot_to_700() {
    check(
        "quad/spot_quadrangulated.obj",
        Bars {
            target: Target::Faces(700),
            max_faces: 700,
            min_ideal: 0.85, // (target 0.85; 86.6 % today, 85.4-86.6 % under reordered queues)
            min_sj_median: 0.85,
            max_hausdorff: 0.02,
        },
    );
}

#[test]
fn fandisk_with_sharp_features() {
    check(
        "quad/fandisk_quads.off",
        Bars {
            target: Target::Faces(250),
            // 250 reached since a run of three consecutive vertices of one
            // curve may merge (curves shortened: 246 → 145 feature edges)
            // and the fold-over reference stays on its side of a sharp
            // crease; before, the feature rules stopped it at 453 faces
            // (519 before the wide rescue, 488-509 before that)
            max_faces: 250,
            // (target 0.85; 85.7 % today at 250 faces, 36 non-ideal of
            // 252 vertices, with the end phase (`coarsen::end_phase`: from
            // 1.3x the target each step chosen by playing alternatives
            // out); 84.1 % (40) before it with the chord phases
            // (`coarsen::chord`: 13 closed quad strips collapsed whole,
            // 764 → 468 faces in the first phase with the input's 30
            // singular vertices kept), 83.9 % with a chord phase every
            // 0.95 or 0.85 of the faces, 80.7 % with one at the start
            // only; 75.8 % before them with the fix phases, 73.0 %
            // without. An end phase of 4 alternatives a step instead of 8
            // reaches 84.9 %, so this bar holds by one vertex)
            min_ideal: 0.85,
            min_sj_median: 0.85, // (0.953 today; 0.944 before the end phase, 0.870 before the chord phases)
            // (bar 0.02; 1.77 % today, 1.76 % before the end phase, 1.84 % before the chord phases — the test kept 1.7 % before, 1.58 %
            // at 453 faces; the last-phase limit for steps away from
            // features still matters: without it, 1.94 % at 453 faces)
            max_hausdorff: 0.02,
        },
    );
}

#[test]
fn loki_with_boundaries() {
    check(
        "quad/loki.obj",
        Bars {
            target: Target::Faces(2000),
            max_faces: 2000,
            // (target 0.85; 86.0 % today; 78.2 % before runs of three of
            // a curve's vertices (its boundary loops) could merge — see
            // fandisk — and the fix phases; with either alone 84.8-85.3 %,
            // and 83.0-85.1 % under reordered queues with the fix phases
            // and boundary-only runs)
            min_ideal: 0.85,
            min_sj_median: 0.85, // (target 0.85; 0.865 today, 0.793 before)
            max_hausdorff: 0.02,
        },
    );
}

#[test]
fn makehuman_many_components() {
    check(
        "quad/makehuman_base.obj",
        Bars {
            target: Target::Ratio(0.25),
            max_faces: 4622, // 25 %
            // (target 0.85 — out of reach: its 129 closed genus-0 pieces
            // (joint cubes and the like) force 8 irregular vertices each,
            // 1,032 (Σ(4 − valence) = 4χ on a closed quad mesh), so at 25 %
            // of the faces, 5,294 vertices, no quad mesh of this topology
            // is more than 80.5 % ideal; 72.6 % today)
            min_ideal: 0.72,
            min_sj_median: 0.85,
            max_hausdorff: 0.02,
        },
    );
}

#[test]
fn bunny_quad_split_to_5000() {
    check(
        "tri/bunny.off",
        Bars {
            target: Target::Faces(5000),
            max_faces: 5000,
            min_ideal: 0.82, // (the target for split inputs is 0.75; 83.1 % today)
            min_sj_median: 0.85,
            max_hausdorff: 0.02,
        },
    );
}

#[test]
fn bunny_paired_to_5000() {
    // The bunny's triangles joined in pairs (no new vertex): 34,833 quads.
    check_made_quad(
        "tri/bunny.off",
        true,
        Bars {
            target: Target::Faces(5000),
            max_faces: 5000,
            min_ideal: 0.84, // (0.85 for quad inputs; 86.1 % today)
            min_sj_median: 0.85,
            max_hausdorff: 0.02,
        },
    );
}
