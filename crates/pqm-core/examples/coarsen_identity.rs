//! Result-identity check for coarsener performance work: coarsens a fixed
//! set of meshes and prints one hash per case over everything the coarsener
//! decides — the report, the progressive mesh (base, every record, vertex
//! order, level errors; floats hashed through their exact `Debug` text) and
//! the coarsest mesh. A speed-up must leave every line unchanged.
//! The report's `peak_queue` is left out of the hash (printed beside it):
//! it measures the queue's memory, which the pruning schedule changes by
//! design while the result must not.
//! `PQM_PRUNE_SLACK=x` sets [`Coarsener::set_prune_slack`] (0 = prune
//! after every commit): every hash must stay the same.
//!
//! `cargo run --release -p pqm-core --example coarsen_identity [-- CASE…]`
//! Cases: `spot` (spot_quadrangulated → 700), `spot-local` (same, local
//! smoothing), `fandisk` (fandisk_quads, sharp features → 200), `torus` (a
//! generated noisy bumpy torus → 150), `suzanne` (split once, open → 300),
//! `loki` (open, 27k quads → 2,000), `bunny` (tri/bunny.off split, ≈209k
//! quads → 2,000; slow). No argument: every case but `bunny`.
use pqm_core::coarsen::{CoarsenOptions, Coarsener, Smoothing};
use pqm_core::{io, shapes, subdivide, IndexedMesh, Mesh};
use std::fmt::Write as _;
use std::hash::Hasher;
use std::path::Path;
use std::time::Instant;

/// Feeds formatted text straight into a hasher (no big string in memory).
struct HashWriter(std::collections::hash_map::DefaultHasher);
impl std::fmt::Write for HashWriter {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.0.write(s.as_bytes());
        Ok(())
    }
}

fn shared(rel: &str) -> IndexedMesh {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel);
    io::read_mesh(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn run(name: &str, mut im: IndexedMesh, target: usize, smoothing: Smoothing) {
    if !im.is_quad_only() {
        im = subdivide::catmull_clark_split(&im, subdivide::SplitMode::Linear).expect("split");
    }
    let t = Instant::now();
    let mesh = Mesh::from_indexed(&im).expect("mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        smoothing,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    if let Some(slack) = std::env::var("PQM_PRUNE_SLACK")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        c.set_prune_slack(slack);
    }
    let mut report = c.run(&mut |_| {});
    let peak_queue = std::mem::take(&mut report.peak_queue);
    let coarsest = c.mesh().to_indexed().0;
    // `PQM_TO_PROGRESSIVE=1`: the borrowing variant (must hash the same)
    let pm = if std::env::var_os("PQM_TO_PROGRESSIVE").is_some() {
        c.to_progressive()
    } else {
        c.into_progressive()
    };
    let dt = t.elapsed().as_secs_f64();
    let mut h = HashWriter(Default::default());
    write!(h, "{report:?}|{pm:?}|{coarsest:?}").expect("hash");
    println!(
        "{name:<11} {:>7} -> {:>5} faces, {:>6} records, hash {:016x}  ({dt:.2} s, queue peak {peak_queue})",
        im.face_count(),
        coarsest.face_count(),
        pm.records.len(),
        h.0.finish()
    );
}

fn main() {
    let mut cases: Vec<String> = std::env::args().skip(1).collect();
    if cases.is_empty() {
        cases = ["spot", "spot-local", "fandisk", "torus", "suzanne", "loki"]
            .map(String::from)
            .to_vec();
    }
    for case in &cases {
        match case.as_str() {
            "spot" => run(
                case,
                shared("quad/spot_quadrangulated.obj"),
                700,
                Smoothing::Global,
            ),
            "spot-local" => run(
                case,
                shared("quad/spot_quadrangulated.obj"),
                700,
                Smoothing::Local,
            ),
            "fandisk" => run(
                case,
                shared("quad/fandisk_quads.off"),
                200,
                Smoothing::Global,
            ),
            "torus" => run(
                case,
                shapes::noisy(&shapes::bumpy_torus(64, 24, 2.0, 0.6, 0.4, 7), 0.004, 3),
                150,
                Smoothing::Global,
            ),
            "suzanne" => run(case, shared("quad/suzanne.obj"), 300, Smoothing::Global),
            "loki" => run(case, shared("quad/loki.obj"), 2000, Smoothing::Global),
            "bunny" => run(case, shared("tri/bunny.off"), 2000, Smoothing::Global),
            other => eprintln!("unknown case {other}"),
        }
    }
}
