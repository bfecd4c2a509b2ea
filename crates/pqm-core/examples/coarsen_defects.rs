//! Where the non-ideal vertices of a coarsened mesh are — a development aid
//! for the ideal-vertex share (issue 3's quality bar).
//!
//! `cargo run --release -p pqm-core --example coarsen_defects -- IN TARGET [RATIO]`
//!
//! Coarsens `IN` (Catmull-Clark split first when it is not quad-only) to
//! `TARGET` faces (or, when `TARGET` is 0, to `RATIO` of the input) with the
//! default options, like the quality bars, and prints for the input and the
//! output: the defects (vertices whose valence is not the metric's ideal) by
//! kind — interior valence 3, 5, 6+, boundary below / above its ideal — and
//! how they sit: interior 3–5 pairs joined by an edge, quads with two
//! valence-3 vertices on a diagonal and two valence-5 vertices on the other
//! (one qvMerge cancels all four), 3s whose quad has a 3 diagonally
//! opposite (a qvMerge makes a 4 of them), and quads with a 3 and a 5 on a
//! diagonal (what a qeMerge leaves at each end of its zipper in a regular
//! grid: the zipper's next qvMerge and doublet move the pair on).
use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::metrics::valence;
use pqm_core::{io, subdivide, IndexedMesh, Mesh};
use std::collections::BTreeMap;

fn breakdown(label: &str, im: &IndexedMesh) {
    let rep = valence(im);
    let mesh = Mesh::from_indexed(im).expect("mesh");
    let val = |v: pqm_core::mesh::VertexId| rep.valence[v.idx()] as i64;
    let ideal = |v: pqm_core::mesh::VertexId| rep.ideal[v.idx()] as i64;
    let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
    let mut n = 0usize;
    let mut defects = 0usize;
    for v in mesh.vertices() {
        n += 1;
        let (k, i) = (val(v), ideal(v));
        if k == i {
            continue;
        }
        defects += 1;
        let kind = if mesh.is_boundary_vertex(v) {
            format!("boundary ideal {i} valence {k}")
        } else if k >= 6 {
            "interior 6+".to_string()
        } else {
            format!("interior {k}")
        };
        *kinds.entry(kind).or_insert(0) += 1;
    }
    // pairs and cancellable quads among interior vertices
    let interior = |v| !mesh.is_boundary_vertex(v);
    let mut pairs35 = 0usize;
    let mut lone3 = 0usize;
    let mut lone5 = 0usize;
    for v in mesh.vertices() {
        if !interior(v) || !(val(v) == 3 || val(v) == 5) {
            continue;
        }
        let partner = if val(v) == 3 { 5 } else { 3 };
        let adj = mesh
            .vertex_ring(v)
            .any(|w| interior(w) && val(w) == partner);
        if val(v) == 3 && adj {
            pairs35 += mesh
                .vertex_ring(v)
                .filter(|&w| interior(w) && val(w) == 5)
                .count();
        }
        if !adj {
            if val(v) == 3 {
                lone3 += 1;
            } else {
                lone5 += 1;
            }
        }
    }
    let (mut q3535, mut q33, mut q35) = (0usize, 0usize, 0usize);
    for f in mesh.faces() {
        let Some(q) = mesh.quad_vertices(f) else {
            continue;
        };
        for d in 0..2 {
            let (a, b, c, e) = (q[d], q[d + 1], q[(d + 2) % 4], q[(d + 3) % 4]);
            if interior(a) && interior(c) && val(a).min(val(c)) == 3 && val(a).max(val(c)) == 5 {
                q35 += 1;
            }
            if [a, c].iter().all(|&x| interior(x) && val(x) == 3) {
                q33 += 1;
                if [b, e].iter().all(|&x| interior(x) && val(x) == 5) {
                    q3535 += 1;
                }
            }
        }
    }
    println!(
        "{label}: {} faces, {n} vertices, {defects} defects ({:.1}% ideal)",
        im.face_count(),
        100.0 * rep.stats.ideal_fraction
    );
    for (k, c) in &kinds {
        println!("    {k}: {c}");
    }
    println!(
        "    interior 3–5 edges {pairs35}; 3s without a 5 neighbour {lone3}, 5s without a 3 neighbour {lone5}; quads with 3s on a diagonal {q33} (of them 3-5-3-5: {q3535}); quads with a 3 and a 5 on a diagonal {q35}"
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = std::path::Path::new(&args[0]);
    let target: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(1000);
    let ratio: Option<f64> = args.get(2).and_then(|a| a.parse().ok());
    let mut im = io::read_mesh(path).expect("read");
    if !im.is_quad_only() {
        im = subdivide::catmull_clark_split(&im, subdivide::SplitMode::Linear).expect("split");
    }
    breakdown("input", &im);
    let mesh = Mesh::from_indexed(&im).expect("mesh");
    let opts = CoarsenOptions {
        target_faces: (target > 0).then_some(target),
        target_ratio: ratio,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let r = c.run(&mut |_| {});
    println!("  {r:?}");
    let out = c.mesh().to_indexed().0;
    breakdown("output", &out);
}
