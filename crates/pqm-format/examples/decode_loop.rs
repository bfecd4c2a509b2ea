//! Decodes one `.pqm` file `N` times (push decoder to the finest level, as
//! `decode_speed` does) and prints the best time: a steady loop to run
//! under `perf record -e cpu-clock` or `perf stat -r 5`, whose CPU time
//! (`task-clock`) is steadier than wall time on a shared machine.
//!
//! Also prints a checksum (FNV-1a) of the finest level's quads and position
//! codes, so that an A/B pair of builds can be checked to decode the same
//! mesh.
//!
//! The figure depends on the heap layout, which the executable's name moves
//! (`std::env::args` allocates it): one build measured makehuman
//! forward-only 2.38 ms under one name and 2.72 ms under another of other
//! length, reproducibly. Compare builds under several name lengths (copies
//! named `z`, `zz`, … alternated; `docs/figures-history.md`, session 12).
//!
//! With `forward` after `N` the decoder is [`Decoder::forward_only`] (no
//! undo data: one-way decoding). With `order` the timed part also asks for
//! the vertex order ([`Decoder::vertex_order`], which decodes the `VORD` /
//! `VNBR` section on first use): what an exporter pays, and what every
//! decode paid when the section was read on arrival.
//!
//! With `reuse` one decoder decodes every time, [`Decoder::reset`] between
//! decodes: its arrays keep their pages, as in a client that decodes file
//! after file. Without it each decode has a new decoder, which takes over
//! the allocations the previous one left when dropped. With `cold` the
//! process frees those first ([`pqm_format::release_recycled`], outside the
//! timed part), so that every decode's arrays are new memory, faulted in
//! page by page, as in a process that decodes one file.
//!
//! `cargo run --release -p pqm-format --example decode_loop -- FILE.pqm [N] [forward] [order] [reuse|cold]`

use pqm_format::{DecodeError, Decoder, Limits, Target};

/// The whole file, pushed at once, into `d` (reset first).
fn decode_whole(d: &mut Decoder, bytes: &[u8]) -> Result<(), DecodeError> {
    d.reset(Limits::none());
    d.push(bytes)?;
    if !d.status().finished {
        return Err(DecodeError::Parameter("the file ends early".into()));
    }
    Ok(())
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(f) = args.next() else {
        eprintln!("usage: decode_loop FILE.pqm [N] [forward] [order] [reuse|cold]");
        std::process::exit(2);
    };
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20);
    let rest: Vec<String> = args.collect();
    let forward = rest.iter().any(|a| a == "forward");
    let order = rest.iter().any(|a| a == "order");
    let reuse = rest.iter().any(|a| a == "reuse");
    let cold = rest.iter().any(|a| a == "cold") && !reuse;
    let new_decoder = || {
        if forward {
            Decoder::forward_only(Limits::none())
        } else {
            Decoder::new(Limits::none())
        }
    };
    let mut kept = new_decoder();
    let bytes = match std::fs::read(&f) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{f}: {e}");
            std::process::exit(1);
        }
    };
    let mut best = f64::MAX;
    let mut faces = 0;
    let mut sum = 0xcbf2_9ce4_8422_2325u64;
    for _ in 0..n.max(1) {
        if cold {
            pqm_format::release_recycled();
        }
        let t = std::time::Instant::now();
        let mut fresh;
        let d = if reuse {
            &mut kept
        } else {
            fresh = new_decoder();
            &mut fresh
        };
        if let Err(e) = decode_whole(d, &bytes) {
            eprintln!("{f}: {e}");
            std::process::exit(1);
        }
        if let Err(e) = d.set_level(Target::Level(usize::MAX)) {
            eprintln!("{f}: {e}");
            std::process::exit(1);
        }
        if order {
            if let Err(e) = d.vertex_order() {
                eprintln!("{f}: {e}");
                std::process::exit(1);
            }
        }
        faces = d.quads().len();
        best = best.min(t.elapsed().as_secs_f64());
        // Outside the timed part.
        sum = 0xcbf2_9ce4_8422_2325u64;
        let words = d
            .quads()
            .iter()
            .flatten()
            .chain(d.position_codes().iter().flatten());
        for &w in words {
            sum = (sum ^ w as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    println!(
        "{f}{}{}{}: best of {n}: {:.2} ms, {:.2} M faces/s, checksum {sum:016x}",
        if forward { " (forward-only)" } else { "" },
        if reuse {
            " (reused decoder)"
        } else if cold {
            " (cold decoder)"
        } else {
            ""
        },
        if order { " (+ vertex order)" } else { "" },
        best * 1e3,
        faces as f64 / best / 1e6
    );
}
