//! Coarsens a mesh file and prints the quality figures — a development aid
//! (the `pqm coarsen` command is the user-facing tool).
//!
//! `cargo run --release -p pqm-core --example coarsen_file -- IN TARGET_FACES [OUT]`
//!
//! `PQM_SMOOTHING=none|local|global` picks the smoothing,
//! `PQM_GLOBAL_ITERS=N` the iterations of the final global smoothing
//! (default: the coarsener's). On loki → 2,000: 1 → 78.2 % ideal, SJ median
//! 0.793; 5 → 0.807; 20 → 0.792, same ideal fraction and Hausdorff.
use pqm_core::coarsen::{CoarsenOptions, Coarsener, Smoothing};
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
    let smoothing = match std::env::var("PQM_SMOOTHING").as_deref() {
        Ok("local") => Smoothing::Local,
        Ok("none") => Smoothing::None,
        _ => Smoothing::Global,
    };
    let opts = CoarsenOptions {
        target_faces: Some(target),
        smoothing,
        global_smoothing_iterations: std::env::var("PQM_GLOBAL_ITERS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    let r = c.run(&mut |_| {});
    let dt = t.elapsed();
    let m = c.mesh();
    m.validate().expect("valid");
    let out = m.to_indexed().0;
    let stats = pqm_core::metrics::mesh_stats(&out, Some(&im));
    let h = stats.hausdorff.as_ref().map_or(f64::NAN, |h| h.max);
    println!(
        "{}: {} -> {} faces in {:.2?}; ideal {:.1}%, worst valence {}, SJ median {:.3} worst {:.3}; hausdorff max {:.4}; genus {} loops {} comps {}",
        path.display(),
        im.face_count(),
        m.face_count(),
        dt,
        100.0 * stats.valence.ideal_fraction,
        stats.valence.worst,
        stats.scaled_jacobian.median,
        stats.scaled_jacobian.worst,
        h,
        stats.genus,
        stats.boundary_loops,
        stats.components,
    );
    println!("  {r:?}");
    if let Some(path) = args.get(2) {
        io::write_mesh(std::path::Path::new(path), &out).expect("write");
    }
}
