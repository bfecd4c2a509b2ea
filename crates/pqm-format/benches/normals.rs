//! Smooth normals that follow the level (`pqm_format::normals`): a client
//! moving between nearby levels frame after frame keeps its normals with
//! `SmoothNormals::apply` on each `Change`, against the peer measured in
//! the same run: every vertex's normal computed again at each new level
//! (`SmoothNormals::compute`). Two walks of 100 moves around three quarters
//! of the levels of a generated mesh of ~20k final quads whose records
//! move vertices: `small`, moves of up to ±0.1 % of the levels (what a
//! camera's frame-to-frame drift asks), and `large`, up to ±2 %. The level
//! moves are in every line (the decoder's share is `*_walk_only`).
//!
//! `cargo bench -p pqm-format --bench normals`

use criterion::{criterion_group, criterion_main, Criterion};
use pqm_core::progressive::testgen::{generate_with, BaseShape, GenOptions};
use pqm_format::normals::SmoothNormals;
use pqm_format::{write_to_vec, Decoder, EncodeOptions, Limits, Target};
use std::hint::black_box;

/// 100 levels around three quarters of `0..=last`, each move at most
/// `last / divisor` levels (deterministic).
fn walk(last: usize, divisor: u64) -> Vec<usize> {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut k = last * 3 / 4;
    (0..100)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let step = (x % (last as u64 / divisor + 1)) as usize;
            k = if x & 1 == 0 {
                k.saturating_sub(step)
            } else {
                (k + step).min(last)
            };
            k
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let pm = generate_with(&GenOptions {
        base: BaseShape::Box { n: 4 },
        ..GenOptions::new(11, 20_000)
    });
    let bytes = write_to_vec(&pm, &EncodeOptions::default())
        .expect("encode")
        .0;
    let mut dec = Decoder::new(Limits::default());
    dec.keep_undo_logs().expect("general decoder");
    dec.push(&bytes).expect("decode");
    let last = dec.deepest_level().expect("levels");
    eprintln!(
        "normals bench: {} final quads, {} levels, walks of 100 moves",
        pm.final_face_count(),
        last
    );
    let mut g = c.benchmark_group("normals");
    g.sample_size(10);
    for (name, walk) in [("small", walk(last, 1000)), ("large", walk(last, 50))] {
        g.bench_function(format!("{name}_walk_only"), |b| {
            b.iter(|| {
                for &k in &walk {
                    black_box(dec.set_level(Target::Level(k)).expect("level"));
                }
            })
        });
        g.bench_function(format!("{name}_walk_incremental_normals"), |b| {
            let mut n = SmoothNormals::default();
            n.apply(&dec, &dec.full_upload());
            b.iter(|| {
                for &k in &walk {
                    let change = dec.set_level(Target::Level(k)).expect("level");
                    black_box(n.apply(&dec, &change));
                }
            })
        });
        g.bench_function(format!("{name}_walk_recomputed_normals_peer"), |b| {
            b.iter(|| {
                for &k in &walk {
                    dec.set_level(Target::Level(k)).expect("level");
                    black_box(SmoothNormals::compute(&dec));
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
