//! Read throughput of the mesh readers (bytes of input per second), and the
//! cost of `check` on a large quad mesh.
//!
//! * `io_read/obj/loki` — `read_obj_bytes` on `shared/meshes/quad/loki.obj`
//!   (2.6 MB, v/vt quads);
//! * `io_read/ply-binary/bunny` — `read_ply_bytes` on a binary little-endian PLY
//!   written from `shared/meshes/tri/bunny.off` into a temporary directory;
//! * `io_read/off-ascii/bunny`, `io_read/off-binary/amo` — the OFF readers;
//! * `io_check/amo-quads` — `check` on 540,660 quads made by splitting each
//!   triangle of `large/amo.off` into three quads (centroid + edge midpoints).
//!
//! The files are read into memory first, so only parsing is measured.
//! Targets: OBJ and PLY at least 100 MB/s; `check` on 500k faces well under 1 s.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pqm_core::io;
use pqm_core::IndexedMesh;
use std::collections::HashMap;
use std::hint::black_box;
use std::path::PathBuf;

type Reader = fn(&[u8]) -> Result<IndexedMesh, io::MeshIoError>;

fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/meshes")
        .join(rel)
}

fn bench_read(c: &mut Criterion) {
    let loki = std::fs::read(shared("quad/loki.obj")).expect("loki.obj");
    let bunny_off = std::fs::read(shared("tri/bunny.off")).expect("bunny.off");
    let amo = std::fs::read(shared("large/amo.off")).expect("amo.off");
    let dir = tempfile::tempdir().expect("temp dir");
    let ply_path = dir.path().join("bunny.ply");
    let bunny = io::read_off_bytes(&bunny_off).expect("bunny.off parses");
    io::write_mesh(&ply_path, &bunny).expect("write bunny.ply");
    let bunny_ply = std::fs::read(&ply_path).expect("read bunny.ply");

    let mut g = c.benchmark_group("io_read");
    g.sample_size(20);
    let cases: [(&str, &[u8], Reader); 4] = [
        ("obj/loki", &loki, io::read_obj_bytes),
        ("ply-binary/bunny", &bunny_ply, io::read_ply_bytes),
        ("off-ascii/bunny", &bunny_off, io::read_off_bytes),
        ("off-binary/amo", &amo, io::read_off_bytes),
    ];
    for (name, data, read) in cases {
        g.throughput(Throughput::Bytes(data.len() as u64));
        g.bench_function(name, |b| b.iter(|| read(black_box(data)).expect("parses")));
    }
    g.finish();
}

/// Splits every triangle into three quads (centroid and shared edge midpoints).
fn tri_to_quads(m: &IndexedMesh) -> IndexedMesh {
    let mut out = IndexedMesh {
        positions: m.positions.clone(),
        ..IndexedMesh::new()
    };
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut midpoint = |out: &mut IndexedMesh, a: u32, b: u32| {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let p = (out.positions[a as usize] + out.positions[b as usize]) * 0.5;
            out.positions.push(p);
            out.positions.len() as u32 - 1
        })
    };
    for f in 0..m.face_count() {
        let t = m.face(f);
        let (a, b, c) = (t[0], t[1], t[2]);
        let center =
            (m.positions[a as usize] + m.positions[b as usize] + m.positions[c as usize]) / 3.0;
        out.positions.push(center);
        let mc = out.positions.len() as u32 - 1;
        let (ab, bc, ca) = (
            midpoint(&mut out, a, b),
            midpoint(&mut out, b, c),
            midpoint(&mut out, c, a),
        );
        out.push_face(&[a, ab, mc, ca]);
        out.push_face(&[b, bc, mc, ab]);
        out.push_face(&[c, ca, mc, bc]);
    }
    out
}

fn bench_check(c: &mut Criterion) {
    let amo = io::read_mesh(&shared("large/amo.off")).expect("amo.off");
    let quads = tri_to_quads(&amo);
    io::check(&quads).expect("subdivided amo is valid");
    let mut g = c.benchmark_group("io_check");
    g.sample_size(10);
    g.throughput(Throughput::Elements(quads.face_count() as u64));
    g.bench_function("amo-quads", |b| b.iter(|| io::check(black_box(&quads))));
    g.finish();
}

criterion_group!(benches, bench_read, bench_check);
criterion_main!(benches);
