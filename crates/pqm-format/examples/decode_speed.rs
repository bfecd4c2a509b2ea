//! Decode throughput on real `.pqm` files, and where the time goes: for each
//! file, the best of `REPS` runs of (a) the whole push decoder to the finest
//! level (`decode_all` + refine), (b) zstd alone on every section it
//! decompresses (the peer: what no record coding can beat), and (c) moving
//! from level 0 to the finest and back with the undo log. Prints a table in
//! million faces reconstructed per second (final faces / time).
//!
//! `cargo run --release -p pqm-format --example decode_speed -- FILE.pqm...`

use pqm_format::{decode_all, Limits, Target};
use std::time::{Duration, Instant};

const REPS: usize = 5;

fn best(mut f: impl FnMut()) -> Duration {
    (0..REPS)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed()
        })
        .min()
        .unwrap_or_default()
}

fn main() {
    println!("| file | final faces | records | decode (ms) | of it zstd (ms) | M faces/s | records only M faces/s | level 0 ↔ finest (ms) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for f in std::env::args().skip(1) {
        let Ok(bytes) = std::fs::read(&f) else {
            eprintln!("{f}: cannot read");
            continue;
        };
        let Ok(mut dec) = decode_all(&bytes, Limits::none()) else {
            eprintln!("{f}: does not decode");
            continue;
        };
        let Some(h) = dec.header().cloned() else {
            continue;
        };
        let faces = h.final_face_count as f64;
        let t_all = best(|| {
            let mut d = decode_all(&bytes, Limits::none()).expect("decodes");
            d.set_level(Target::Level(usize::MAX)).expect("refine");
            std::hint::black_box(d.quads().len());
        });
        // zstd alone: the base section and every chunk, as the decoder does.
        let table_end = h.header_len as usize + dec.chunks().len() * h.chunk_entry_len as usize + 4;
        let mut frames: Vec<(&[u8], usize)> = vec![(
            &bytes[table_end..table_end + h.base_compressed_len as usize],
            h.base_uncompressed_len as usize,
        )];
        for c in dec.chunks() {
            let o = c.offset as usize;
            frames.push((
                &bytes[o..o + c.compressed_len as usize],
                c.uncompressed_len as usize,
            ));
        }
        let t_zstd = best(|| {
            let mut z = zstd::bulk::Decompressor::new().expect("zstd");
            for &(fr, n) in &frames {
                std::hint::black_box(z.decompress(fr, n).expect("frame").len());
            }
        });
        let t_nav = best(|| {
            dec.set_level(Target::Level(0)).expect("coarsen");
            dec.set_level(Target::Level(usize::MAX)).expect("refine");
        });
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        println!(
            "| {} | {} | {} | {:.1} | {:.1} | {:.2} | {:.2} | {:.1} |",
            std::path::Path::new(&f)
                .file_name()
                .map_or(f.clone(), |n| n.to_string_lossy().into_owned()),
            h.final_face_count,
            h.record_count,
            ms(t_all),
            ms(t_zstd),
            faces / t_all.as_secs_f64() / 1e6,
            faces / (t_all.saturating_sub(t_zstd)).as_secs_f64().max(1e-9) / 1e6,
            ms(t_nav)
        );
    }
}
