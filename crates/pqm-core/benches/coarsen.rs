//! Coarsener speed and memory against meshoptimizer, measured in one run.
//!
//! `cargo bench -p pqm-core --bench coarsen` coarsens the quad split of the
//! Stanford bunny (`shared/meshes/tri/bunny.off`, ≈ 208k quads) to 2,000
//! quads and, in the same run, simplifies its triangulation (≈ 416k
//! triangles) to 4,000 triangles with `meshopt_simplify`, then prints a
//! table: times, their ratio, collapses per second and the coarsener's peak
//! heap per input quad (a counting allocator). Under `cargo test` the same
//! code runs on a small procedural mesh, as a smoke test.
//! `PQM_BENCH_MESH=path PQM_BENCH_TARGET=n` picks another input;
//! `PQM_BENCH_TRACE=1` prints the live heap and the peak so far (bytes per
//! input quad) as the face count drops, to see where the peak is.

use pqm_core::coarsen::{CoarsenOptions, Coarsener};
use pqm_core::subdivide::{catmull_clark_split, SplitMode};
use pqm_core::{io, shapes, IndexedMesh, Mesh};
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

struct Counting;
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static OVERALL: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            let now = CURRENT.fetch_add(l.size(), Ordering::Relaxed) + l.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) };
        CURRENT.fetch_sub(l.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn main() {
    let bench = std::env::args().any(|a| a == "--bench");
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes/tri/bunny.off");
    let (name, input, target): (String, IndexedMesh, usize) = match std::env::var("PQM_BENCH_MESH")
    {
        Ok(p) => {
            let t = std::env::var("PQM_BENCH_TARGET")
                .ok()
                .and_then(|t| t.parse().ok())
                .unwrap_or(2000);
            (
                p.clone(),
                io::read_mesh(Path::new(&p)).expect("read mesh"),
                t,
            )
        }
        Err(_) if bench && shared.exists() => (
            "bunny.off".into(),
            io::read_mesh(&shared).expect("read bunny"),
            2000,
        ),
        Err(_) => ("quad sphere 24".into(), shapes::quad_sphere(24, 1.0), 300),
    };
    let quads = if input.is_quad_only() {
        input.clone()
    } else {
        catmull_clark_split(&input, SplitMode::Linear).expect("split")
    };
    let n_quads = quads.face_count();

    // --- pqm: coarsen the quads
    let base = CURRENT.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let t = Instant::now();
    let mesh = Mesh::from_indexed(&quads).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(target),
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    // (peak during the phase, live at its end), to see what holds the
    // peak; each phase restarts the peak from what is live
    let phase = || {
        let now = CURRENT.load(Ordering::Relaxed);
        let peak = PEAK.swap(now, Ordering::Relaxed);
        OVERALL.fetch_max(peak, Ordering::Relaxed);
        (peak - base, now - base)
    };
    let after_setup = phase();
    let trace = std::env::var_os("PQM_BENCH_TRACE").is_some();
    let mut next_trace = n_quads;
    let report = c.run(&mut |faces| {
        if trace && faces <= next_trace {
            next_trace = faces.saturating_sub(n_quads / 20);
            let per = |b: usize| b.saturating_sub(base) as f64 / n_quads as f64;
            eprintln!(
                "trace: {faces} faces, live {:.0}, peak so far {:.0} B/quad",
                per(CURRENT.load(Ordering::Relaxed)),
                per(PEAK.load(Ordering::Relaxed))
            );
        }
    });
    let after_run = phase();
    let (queue_peak, entry_bytes) = c.queue_peak();
    let reached = c.mesh().face_count();
    let log_bytes = c.logs().heap_bytes();
    let pm = c.into_progressive();
    let after_records = phase();
    let t_pqm = t.elapsed().as_secs_f64();
    let peak = OVERALL.load(Ordering::Relaxed) - base;
    let steps = pm.records.len();

    // --- meshopt: simplify the triangulation (two triangles per quad)
    let mut tris: Vec<u32> = Vec::with_capacity(n_quads * 6);
    for f in quads.faces() {
        tris.extend_from_slice(&[f[0], f[1], f[2], f[0], f[2], f[3]]);
    }
    let verts: Vec<[f32; 3]> = quads
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let bytes: &[u8] =
        unsafe { std::slice::from_raw_parts(verts.as_ptr().cast::<u8>(), verts.len() * 12) };
    let adapter = meshopt::VertexDataAdapter::new(bytes, 12, 0).expect("adapter");
    let t = Instant::now();
    let out = meshopt::simplify(
        &tris,
        &adapter,
        2 * target * 3,
        1.0,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    let t_mo = t.elapsed().as_secs_f64();

    println!("coarsen benchmark on {name} ({n_quads} quads)");
    println!("| tool | input | output | time (s) | steps/s |");
    println!("|---|---|---|---|---|");
    println!(
        "| pqm coarsen | {n_quads} quads | {reached} quads | {t_pqm:.3} | {:.0} |",
        steps as f64 / t_pqm
    );
    println!(
        "| meshopt_simplify | {} tris | {} tris | {t_mo:.3} | {:.0} |",
        tris.len() / 3,
        out.len() / 3,
        (tris.len() / 3 - out.len() / 3) as f64 / 2.0 / t_mo
    );
    println!("ratio pqm / meshopt: {:.1}x", t_pqm / t_mo);
    println!(
        "peak heap during coarsening: {:.0} bytes per input quad",
        peak as f64 / n_quads as f64
    );
    let per = |b: usize| b as f64 / n_quads as f64;
    println!(
        "bytes per input quad, (peak in phase, live after): setup ({:.0}, {:.0}), coarsening ({:.0}, {:.0}), records ({:.0}, {:.0})",
        per(after_setup.0),
        per(after_setup.1),
        per(after_run.0),
        per(after_run.1),
        per(after_records.0),
        per(after_records.1)
    );
    println!(
        "priority queue peak: {queue_peak} entries x {entry_bytes} bytes = {:.0} bytes per input quad (Vec capacity up to 2x that)",
        (queue_peak * entry_bytes) as f64 / n_quads as f64
    );
    println!(
        "step logs (compact, held until the records are built): {:.0} bytes per input quad",
        per(log_bytes)
    );
    println!(
        "stop: {:?}, {} qv, {} qe, {} doublets",
        report.stop, report.qv_merges, report.qe_merges, report.doublets
    );
    assert!(reached < n_quads, "the coarsener made no progress");
}
