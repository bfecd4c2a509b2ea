//! Decode throughput on a generated progressive mesh of ~100k final quads:
//! push the whole file (CRC + zstd + record decoding), then refine to the
//! finest level (also with a forward-only decoder, which keeps no undo
//! log, and with one decoder reset between iterations, whose arrays keep
//! their pages); and moving between levels with the undo log.
//! Throughput is reported in faces reconstructed per second.
//! `subset_torus`: the same push-and-refine on what `pqm encode` writes
//! (format 2.0, `Placement::Subset`: split, face-split and local-form
//! records), from a noisy bumpy torus of 12 800 quads coarsened to 1 % by
//! pqm-core's coarsener — built here, in ~1 s, not read from a file.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pqm_core::coarsen::{CoarsenOptions, Coarsener, Placement, Smoothing};
use pqm_core::progressive::testgen::{generate_with, BaseShape, GenOptions};
use pqm_core::{shapes, Mesh};
use pqm_format::{decode_all, write_to_vec, Decoder, EncodeOptions, Limits, Target};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let pm = generate_with(&GenOptions {
        base: BaseShape::Box { n: 4 },
        smooth_prob: 0.0,
        ..GenOptions::new(7, 100_000)
    });
    let (bytes, report) = write_to_vec(&pm, &EncodeOptions::default()).expect("encode");
    let faces = pm.final_face_count() as u64;
    eprintln!(
        "bench mesh: {} final quads, {} records, {} bytes ({:.1} bits/refined vertex)",
        faces,
        pm.records.len(),
        bytes.len(),
        report.bits_per_vertex.total
    );
    let mut g = c.benchmark_group("decode");
    g.sample_size(10);
    g.throughput(Throughput::Elements(faces));
    g.bench_function("push_all_and_refine_100k", |b| {
        b.iter(|| {
            let mut d = Decoder::new(Limits::default());
            d.push(black_box(&bytes)).expect("decode");
            d.set_level(Target::Level(usize::MAX)).expect("refine");
            black_box(d.quads().len())
        })
    });
    g.bench_function("push_all_and_refine_100k_forward_only", |b| {
        b.iter(|| {
            let mut d = Decoder::forward_only(Limits::default());
            d.push(black_box(&bytes)).expect("decode");
            d.set_level(Target::Level(usize::MAX)).expect("refine");
            black_box(d.quads().len())
        })
    });
    // One decoder for every iteration, reset between files: its arrays
    // keep their pages (a client decoding asset after asset).
    let mut kept = Decoder::new(Limits::default());
    g.bench_function("push_all_and_refine_100k_reused_decoder", |b| {
        b.iter(|| {
            kept.reset(Limits::default());
            kept.push(black_box(&bytes)).expect("decode");
            kept.set_level(Target::Level(usize::MAX)).expect("refine");
            black_box(kept.quads().len())
        })
    });
    g.bench_function("push_in_1500_byte_packets", |b| {
        b.iter(|| {
            let mut d = Decoder::new(Limits::default());
            for p in bytes.chunks(1500) {
                d.push(black_box(p)).expect("decode");
            }
            black_box(d.deepest_level())
        })
    });
    let mut dec = decode_all(&bytes, Limits::default()).expect("decode");
    g.bench_function("coarsen_and_refine_full_range", |b| {
        b.iter(|| {
            dec.set_level(Target::Level(0)).expect("coarsen");
            dec.set_level(Target::Level(usize::MAX)).expect("refine");
            black_box(dec.quads().len())
        })
    });
    // What `pqm encode` writes: subset placement, format 2.0 defaults.
    let src = shapes::noisy(&shapes::bumpy_torus(160, 80, 2.0, 0.6, 0.4, 7), 0.004, 3);
    let mesh = Mesh::from_indexed(&src).expect("valid quad mesh");
    let opts = CoarsenOptions {
        target_faces: Some(src.face_count() / 100),
        placement: Placement::Subset,
        smoothing: Smoothing::None,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    c.run(&mut |_| {});
    let pm = c.into_progressive();
    let (sub, _) = write_to_vec(&pm, &EncodeOptions::default()).expect("encode");
    let sub_faces = pm.final_face_count() as u64;
    eprintln!(
        "subset torus: {} final quads, {} records, {} bytes",
        sub_faces,
        pm.records.len(),
        sub.len()
    );
    g.throughput(Throughput::Elements(sub_faces));
    g.bench_function("push_all_and_refine_subset_torus", |b| {
        b.iter(|| {
            let mut d = Decoder::new(Limits::default());
            d.push(black_box(&sub)).expect("decode");
            d.set_level(Target::Level(usize::MAX)).expect("refine");
            black_box(d.quads().len())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
