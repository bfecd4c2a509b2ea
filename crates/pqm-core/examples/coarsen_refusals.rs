//! Why the defects of a coarsened mesh stay — a development aid for the
//! ideal-vertex share (issue 3's quality bar), written for fandisk.
//!
//! `cargo run --release -p pqm-core --example coarsen_refusals -- IN TARGET`
//!
//! Coarsens `IN` to `TARGET` faces with the default options but no global
//! smoothing (so the mesh is the one the last step left), then prints
//! 1. the defect count (vertices whose valence is not their ideal) along
//!    the run, from the records' levels;
//! 2. the output's defects by kind: the number of sharp edges at the
//!    vertex (dihedral ≥ 60° on the output itself) and the valence;
//! 3. for each defect off the curves, every candidate of its faces that
//!    would remove defects, with its score and the verdict a commit would
//!    reach now (`Coarsener::probe_around`), and a tally of those verdicts.
use pqm_core::coarsen::{CoarsenOptions, Coarsener, Smoothing};
use pqm_core::{io, Mesh};
use std::collections::BTreeMap;

fn defects(m: &Mesh) -> usize {
    m.vertices()
        .filter(|&v| m.valence(v) != m.ideal_valence(v))
        .count()
}

fn sharp_edges(m: &Mesh, v: pqm_core::VertexId) -> usize {
    m.vertex_ring(v)
        .filter(|&u| {
            let Some(h) = m.find_halfedge(v, u) else {
                return false;
            };
            match (m.face(h), m.face(m.twin(h))) {
                (Some(f), Some(g)) => m.face_normal(f).dot(m.face_normal(g)) < 0.5,
                _ => true,
            }
        })
        .count()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = std::path::Path::new(&args[0]);
    let target: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(250);
    let verbose = args.iter().any(|a| a == "-v");
    let im = io::read_mesh(path).expect("read");
    let mesh = Mesh::from_indexed(&im).expect("mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        smoothing: Smoothing::None,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let before = c.defects_by_kind();
    let trace = c.run_traced();
    println!("input defects (off curves, on curves, corners): {before:?}");
    let rep = c.report_so_far();
    println!("refused at commit: {:?}", rep.rejections);
    println!("of them removing defects: {:?}", rep.refused_fixes);
    // defects added or removed per kind of step: (curve shortened?, op, phase)
    let mut by: BTreeMap<(bool, &str, String), (usize, [i64; 3])> = BTreeMap::new();
    let mut prev = (before, c.features().edge_count());
    for t in &trace {
        let phase = format!(
            "{}{}{}",
            if t.fix_only { "fix " } else { "" },
            if t.cap < 6 { "cap5" } else { "cap6" },
            if t.limit_deviation { "" } else { " last" }
        );
        let e = by
            .entry((t.feature_edges < prev.1, t.op, phase))
            .or_insert((0, [0; 3]));
        e.0 += 1;
        for k in 0..3 {
            e.1[k] += t.defects[k] as i64 - prev.0[k] as i64;
        }
        prev = (t.defects, t.feature_edges);
    }
    println!("(curve shortened, op, phase): steps, defect change (off curves, on curves, corners)");
    for (k, v) in &by {
        println!("  {k:?}: {v:?}");
    }
    let mut lastp = (0, false, true);
    for t in &trace {
        if (t.cap, t.fix_only, t.limit_deviation) != lastp {
            lastp = (t.cap, t.fix_only, t.limit_deviation);
            println!(
                "  phase {lastp:?} from {} faces, defects {:?}",
                t.faces, t.defects
            );
        }
    }
    let mut lastf = usize::MAX;
    for t in &trace {
        if t.faces / 10 != lastf / 10 {
            println!(
                "  at {} faces: {:?}, {} feature edges",
                t.faces, t.defects, t.feature_edges
            );
            lastf = t.faces;
        }
    }
    // 1. along the run
    let pm = c.to_progressive();
    let mut last_faces = usize::MAX;
    println!("defects along the run (coarse to fine): faces vertices defects");
    for k in 0..pm.level_count() {
        let m = Mesh::from_indexed(&pm.level(k)).expect("level");
        let f = m.face_count();
        if f / 25 != last_faces / 25 || k + 1 == pm.level_count() {
            println!("  {f:5} {:5} {:4}", m.vertex_count(), defects(&m));
            last_faces = f;
        }
    }
    // 2. kinds
    let m = c.mesh();
    let mut kinds: BTreeMap<(usize, usize), (usize, usize)> = BTreeMap::new();
    for v in m.vertices() {
        let e = kinds.entry((sharp_edges(m, v), m.valence(v))).or_default();
        e.0 += 1;
        if m.valence(v) != m.ideal_valence(v) {
            e.1 += 1;
        }
    }
    println!(
        "output: {} faces, {} vertices, {} defects; (sharp edges, valence): vertices, defects",
        m.face_count(),
        m.vertex_count(),
        defects(m)
    );
    for ((s, val), (n, d)) in &kinds {
        println!("  ({s}, {val}): {n} {d}");
    }
    // 2b. curve vertices (feature degree 2): edges off the curve on each side
    let mut split: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for v in m.vertices() {
        if !c.features().is_feature(v) || c.features().is_corner(v) {
            continue;
        }
        let ring: Vec<_> = m.vertex_ring(v).collect();
        let fe: Vec<usize> = (0..ring.len())
            .filter(|&i| c.features().is_feature_edge(v, ring[i]))
            .collect();
        if fe.len() != 2 {
            continue;
        }
        let a = fe[1] - fe[0] - 1;
        let b = ring.len() - 2 - a;
        *split.entry((a.min(b), a.max(b))).or_insert(0) += 1;
    }
    println!("curve vertices by edges off the curve on each side (fewer, more): {split:?}");
    // 3. refusals near the smooth-region defects
    let mut tally: BTreeMap<String, usize> = BTreeMap::new();
    let mut without = 0;
    let feats = c.features();
    for v in m.vertices() {
        if m.valence(v) == m.ideal_valence(v) || feats.is_feature(v) {
            continue;
        }
        let near_feature = m.vertex_ring(v).filter(|&u| feats.is_feature(u)).count();
        let probes: Vec<_> = c
            .probe_around(v)
            .into_iter()
            .filter(|p| p.gain > 0 || p.cost.is_none())
            .collect();
        let fixing: Vec<_> = probes.iter().filter(|p| p.gain > 0).collect();
        if fixing.is_empty() {
            without += 1;
        }
        println!(
            "v{} valence {} ({near_feature} of its neighbours on a curve; ring valences {:?}): {} defect-removing candidates",
            v.0,
            m.valence(v),
            m.vertex_ring(v).map(|u| (m.valence(u), feats.is_feature(u))).collect::<Vec<_>>(),
            fixing.len()
        );
        for p in &probes {
            if p.gain > 0 || verbose {
                println!(
                    "    {} gain {} cost {:?}: {}",
                    p.cand, p.gain, p.cost, p.verdict
                );
            }
            if p.gain > 0 {
                *tally.entry(p.verdict.clone()).or_insert(0) += 1;
            }
        }
    }
    println!("smooth-region defects without a defect-removing candidate: {without}");
    println!("verdicts of the defect-removing candidates near them: {tally:?}");
}
