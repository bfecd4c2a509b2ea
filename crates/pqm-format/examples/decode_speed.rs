//! Decode throughput on real `.pqm` files, and where the time goes: for each
//! file, the best of `REPS` runs of (a) the whole push decoder to the finest
//! level (`decode_all` + refine), (b) zstd alone on every section it
//! decompresses (the peer: what no record coding can beat), and (c) moving
//! from level 0 to the finest and back with the undo log — the first time
//! (the general decoder then decodes the chunks again for its undo log) and
//! the best of the next; and (d) the same
//! records re-encoded without the local form (version 1.0's coding), decoded
//! in the same run, as the peer for the ratio. Prints a table in million
//! faces reconstructed per second (final faces / time).
//!
//! `cargo run --release -p pqm-format --example decode_speed -- FILE.pqm...`

use pqm_format::{decode_all, write_to_vec, EncodeOptions, Limits, Target};
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
    println!("| file | final faces | records | decode (ms) | of it zstd (ms) | M faces/s | records only M faces/s | first level 0 ↔ finest (ms) | level 0 ↔ finest (ms) | 1.0 coding decode (ms) | time ratio |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
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
        let full = |b: &[u8]| {
            best(|| {
                let mut d = decode_all(b, Limits::none()).expect("decodes");
                d.set_level(Target::Level(usize::MAX)).expect("refine");
                std::hint::black_box(d.quads().len());
            })
        };
        let t_all = full(&bytes);
        let peer = dec.to_progressive_mesh().and_then(|pm| {
            let opts = EncodeOptions {
                bits: h.quant_bits,
                local_form: false,
                ..EncodeOptions::default()
            };
            write_to_vec(&pm, &opts).ok().map(|x| x.0)
        });
        let t_peer = peer.as_deref().map(full);
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
        // From the finest level (where `decode_all` + refine leaves a
        // client) down and back.
        dec.set_level(Target::Level(usize::MAX)).expect("refine");
        let t = Instant::now();
        dec.set_level(Target::Level(0)).expect("coarsen");
        dec.set_level(Target::Level(usize::MAX)).expect("refine");
        let t_first = t.elapsed();
        let t_nav = best(|| {
            dec.set_level(Target::Level(0)).expect("coarsen");
            dec.set_level(Target::Level(usize::MAX)).expect("refine");
        });
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let (peer_ms, ratio) = t_peer.map_or(("-".into(), "-".into()), |t| {
            (format!("{:.1}", ms(t)), format!("{:.2}", ms(t_all) / ms(t)))
        });
        println!(
            "| {} | {} | {} | {:.1} | {:.1} | {:.2} | {:.2} | {:.1} | {:.1} | {} | {} |",
            std::path::Path::new(&f)
                .file_name()
                .map_or(f.clone(), |n| n.to_string_lossy().into_owned()),
            h.final_face_count,
            h.record_count,
            ms(t_all),
            ms(t_zstd),
            faces / t_all.as_secs_f64() / 1e6,
            faces / (t_all.saturating_sub(t_zstd)).as_secs_f64().max(1e-9) / 1e6,
            ms(t_first),
            ms(t_nav),
            peer_ms,
            ratio
        );
    }
}
