//! The coarsener on procedural meshes: validity after every level, topology
//! kept, targets honoured, records replay to the input.

mod common;
use common::{grid, quad_sphere, torus};
use pqm_core::coarsen::{CoarsenOptions, Coarsener, Smoothing, StopReason};
use pqm_core::{IndexedMesh, Mesh};

fn run(src: &IndexedMesh, opts: CoarsenOptions) -> (Coarsener, pqm_core::coarsen::CoarsenReport) {
    let mesh = Mesh::from_indexed(src).unwrap();
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let r = c.run(&mut |_| {});
    (c, r)
}

fn canon_faces(pos: &[glam::DVec3], faces: &[[u32; 4]]) -> Vec<Vec<[i64; 3]>> {
    let key = |p: glam::DVec3| [(p.x * 1e9) as i64, (p.y * 1e9) as i64, (p.z * 1e9) as i64];
    let mut out: Vec<Vec<[i64; 3]>> = faces
        .iter()
        .map(|f| {
            let ks: Vec<[i64; 3]> = f.iter().map(|&v| key(pos[v as usize])).collect();
            let m = (0..4).min_by_key(|&i| ks[i]).unwrap();
            (0..4).map(|i| ks[(m + i) % 4]).collect()
        })
        .collect();
    out.sort();
    out
}

#[test]
fn torus_coarsens_validly_and_replays() {
    let src = torus(40, 24);
    let (c, r) = run(
        &src,
        CoarsenOptions {
            target_faces: Some(200),
            ..Default::default()
        },
    );
    let m = c.mesh();
    m.validate().unwrap();
    assert!(m.faces().all(|f| m.face_degree(f) == 4));
    assert_eq!(m.genus(), 1);
    assert!(
        m.face_count() <= 200 || r.stop == Some(StopReason::NothingLegal),
        "{r:?}"
    );
    println!("{r:?} faces {}", m.face_count());
    let pm = c.to_progressive();
    // finest level = input (as geometry + connectivity)
    let (pos, faces) = pm.level_quads(pm.records.len());
    let mut src_faces: Vec<[u32; 4]> = src.faces().map(|f| [f[0], f[1], f[2], f[3]]).collect();
    let src_canon = canon_faces(&src.positions, &src_faces);
    assert_eq!(canon_faces(&pos, &faces), src_canon);
    src_faces.clear();
    // level errors never increase toward the finest level
    assert!(pm.level_error.windows(2).all(|w| w[0] >= w[1]));
}

#[test]
fn sphere_and_grid_keep_topology() {
    for (src, genus, loops) in [(quad_sphere(12), 0, 0), (grid(20, 14), 0, 1)] {
        let (c, r) = run(
            &src,
            CoarsenOptions {
                target_ratio: Some(0.25),
                ..Default::default()
            },
        );
        let m = c.mesh();
        m.validate().unwrap();
        assert_eq!(m.genus(), genus);
        assert_eq!(m.boundary_loops().len(), loops);
        assert_eq!(m.components().1, 1);
        println!("{r:?} {} -> {}", src.face_count(), m.face_count());
    }
}

#[test]
fn local_smoothing_and_determinism() {
    let src = torus(30, 20);
    let opts = CoarsenOptions {
        target_faces: Some(150),
        smoothing: Smoothing::Local,
        ..Default::default()
    };
    let (a, _) = run(&src, opts.clone());
    let (b, _) = run(&src, opts);
    assert_eq!(a.to_progressive(), b.to_progressive());
    a.mesh().validate().unwrap();
}

/// Stale entries are pruned: the heap never holds more than about twice the
/// live bound (two qvMerge + two qeMerge entries per face), where skipping
/// them only at pop time let it grow with the number of steps (18 entries
/// per input quad on spot). The records stay valid (every record moves a
/// vertex at most once, also when the shape rescue relaxes a merge target).
#[test]
fn queue_stays_bounded_and_records_validate() {
    for src in [torus(40, 24), grid(30, 24)] {
        let n = src.face_count();
        let (c, r) = run(
            &src,
            CoarsenOptions {
                target_ratio: Some(0.2),
                ..Default::default()
            },
        );
        // prune threshold 2·(4F + 64) plus one commit's worth of pushes
        assert!(
            r.peak_queue <= 8 * n + 1000,
            "{} entries for {n} faces",
            r.peak_queue
        );
        assert!(r.qv_merges + r.qe_merges > 0);
        c.to_progressive().validate().unwrap();
    }
}

/// The wide rescue — a step that adds no defect and fails the shape guard
/// relaxes the free vertices of every face around it — moves vertices
/// beyond the step's patch. Those moves must be part of the step's record
/// and checked like the rest: the records replay to the input exactly, and
/// no level between whole steps (about every eighth checked) has an
/// inverted quad or breaks a mesh invariant.
#[test]
fn wide_rescue_moves_are_recorded_and_keep_levels_sound() {
    use pqm_core::progressive::OpKind;
    use pqm_core::{io, ops};
    // (the procedural shapes here coarsen without needing it)
    let spot = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes/quad/spot_quadrangulated.obj");
    let src = io::read_mesh(&spot).unwrap();
    let worst_in = src
        .faces()
        .map(|f| ops::quad_scaled_jacobian([0, 1, 2, 3].map(|i| src.positions[f[i] as usize])))
        .fold(f64::INFINITY, f64::min);
    assert!(worst_in > 0.0, "the input has no inverted quad");
    let (c, r) = run(
        &src,
        CoarsenOptions {
            target_faces: Some(120),
            ..Default::default()
        },
    );
    assert!(
        r.wide_rescues > 0,
        "the case exercises the wide rescue: {r:?}"
    );
    c.mesh().validate().unwrap();
    let pm = c.to_progressive();
    pm.validate().unwrap();
    let n = pm.records.len();
    let (pos, faces) = pm.level_quads(n);
    let src_faces: Vec<[u32; 4]> = src.faces().map(|f| [f[0], f[1], f[2], f[3]]).collect();
    assert_eq!(
        canon_faces(&pos, &faces),
        canon_faces(&src.positions, &src_faces)
    );
    // levels between whole steps (a step's doublet re-insertions come
    // before its operator's record: in between, its quads may fold)
    let whole: Vec<usize> = (0..=n)
        .filter(|&k| k == 0 || pm.records[k - 1].op != OpKind::Doublet)
        .collect();
    for &k in whole.iter().step_by((whole.len() / 8).max(1)) {
        let (pos, faces) = pm.level_quads(k);
        for q in &faces {
            let sj = ops::quad_scaled_jacobian(q.map(|v| pos[v as usize]));
            assert!(sj > 0.0, "level {k}: a quad is inverted ({sj})");
        }
        Mesh::from_indexed(&pm.level(k))
            .and_then(|m| m.validate())
            .unwrap_or_else(|e| panic!("level {k}: {e}"));
    }
}

/// A boundary loop gets shorter too: a run of three consecutive loop
/// vertices may merge (docs/paper-choices.md, "Consecutive feature
/// vertices"). Before, rule 1 let at most two feature vertices merge and a
/// coarsened grid kept every boundary vertex (loki kept all 328). The loop
/// survives, the grid's corners are not cut, the mesh stays quad-only and
/// valid, and the records replay to the input, under both placements.
#[test]
fn boundary_loops_are_shortened() {
    let src = grid(12, 10);
    let boundary = |m: &Mesh| m.vertices().filter(|&v| m.is_boundary_vertex(v)).count();
    // the grid's four corners: its vertices of valence 2
    let corners = |m: &Mesh| -> Vec<glam::DVec3> {
        m.vertices()
            .filter(|&v| m.valence(v) == 2)
            .map(|v| m.position(v))
            .collect()
    };
    let input_corners = corners(&Mesh::from_indexed(&src).unwrap());
    assert_eq!(input_corners.len(), 4);
    for placement in [
        pqm_core::coarsen::Placement::Qem,
        pqm_core::coarsen::Placement::Subset,
    ] {
        let mesh = Mesh::from_indexed(&src).unwrap();
        let before = boundary(&mesh);
        let opts = CoarsenOptions {
            target_faces: Some(30),
            placement,
            ..Default::default()
        };
        let mut c = Coarsener::with_defaults(mesh, 180.0, &[], opts).expect("features");
        let curves = c.features().live_curves();
        c.run(&mut |_| {});
        let m = c.mesh();
        m.validate().unwrap();
        assert!(m.faces().all(|f| m.face_degree(f) == 4));
        assert_eq!(c.features().live_curves(), curves);
        let after = boundary(m);
        assert!(
            after < before,
            "{placement:?}: boundary {before} -> {after} vertices"
        );
        for p in &input_corners {
            assert!(
                m.vertices().any(|v| m.position(v) == *p),
                "{placement:?}: the grid's corner {p} was cut"
            );
        }
        let pm = c.to_progressive();
        pm.validate().unwrap();
        assert_eq!(pm.level(pm.records.len()).face_count(), src.face_count());
    }
}
