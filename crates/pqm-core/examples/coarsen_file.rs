//! Coarsens a mesh file and prints the quality figures — a development aid
//! (the `pqm coarsen` command is the user-facing tool).
//!
//! `cargo run --release -p pqm-core --example coarsen_file -- IN TARGET_FACES [OUT]`
use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::ops::quad_scaled_jacobian;
use pqm_core::{io, subdivide, Mesh};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = std::path::Path::new(&args[0]);
    let target: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(1000);
    let mut im = io::read_mesh(path).expect("read");
    if !im.is_quad_only() {
        im = subdivide::catmull_clark_split(&im, subdivide::SplitMode::Linear).expect("split");
    }
    let t = Instant::now();
    let mesh = Mesh::from_indexed(&im).expect("mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let r = c.run(&mut |_| {});
    let dt = t.elapsed();
    let m = c.mesh();
    m.validate().expect("valid");
    let mut sj: Vec<f64> = m
        .faces()
        .filter_map(|f| m.quad_vertices(f))
        .map(|q| quad_scaled_jacobian(q.map(|v| m.position(v))))
        .collect();
    sj.sort_by(f64::total_cmp);
    let ideal = m
        .vertices()
        .filter(|&v| m.valence(v) == m.ideal_valence(v))
        .count();
    let worst = m.vertices().map(|v| m.valence(v)).max().unwrap_or(0);
    println!(
        "{}: {} -> {} faces in {:.2?}; ideal {:.1}%, worst valence {}, SJ median {:.3} worst {:.3}; genus {} loops {} comps {}; {:?}",
        path.display(),
        im.face_count(),
        m.face_count(),
        dt,
        100.0 * ideal as f64 / m.vertex_count() as f64,
        worst,
        sj[sj.len() / 2],
        sj[0],
        m.genus(),
        m.boundary_loops().len(),
        m.components().1,
        r
    );
    if let Some(out) = args.get(2) {
        io::write_mesh(std::path::Path::new(out), &m.to_indexed().0).expect("write");
    }
}
