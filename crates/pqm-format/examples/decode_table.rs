//! Rust decode throughput of `.pqm` files beside a single-rate peer decoded
//! in the same run, as a Markdown table (`scripts/decode-table.sh` runs it
//! on the bench files).
//!
//! `cargo run --release -p pqm-format --example decode_table -- FILE.pqm... [--runs N] [--rounds R]`
//!
//! Per file, the whole file pushed at once and refined to the finest level
//! (zstd, CRCs, base and records: what `decode_loop` times), in six ways,
//! each in processes of its own (`--mode`), the ways alternated over
//! `--rounds` rounds:
//!
//! * `cold`: a new [`Decoder`] per decode, after
//!   [`pqm_format::release_recycled`] — every decode's arrays are new
//!   memory, faulted in page by page, as in a process that decodes one
//!   file;
//! * `new`: a new [`Decoder`] per decode — it takes over the allocations
//!   the previous one left when dropped, as in a client that makes a
//!   decoder per asset;
//! * `reused`: one decoder, [`Decoder::reset`] between decodes — the arrays
//!   keep their pages, as in a client that keeps its decoder;
//!
//! each as the general decoder and as [`Decoder::forward_only`].
//!
//! The peer is what gltfpack ships for a static mesh: the finest level's
//! triangles (each quad as the two that `pqm decode`'s glTF export writes,
//! split along its shorter diagonal; until session 22, the two the
//! decoder draws, which made the peer's size follow the file's corner
//! order: the canonical bunny's 976 KB against 743 KB for the same quads
//! as the input's corners start, 851 KB split the shorter way) and 14-bit codes
//! (`[u16; 4]` per vertex), reordered by meshoptimizer for the vertex
//! cache and vertex fetch, coded with its index and vertex codecs
//! (`meshopt` crate, the C++ library's own) and then zstd-19 (gltfpack's
//! output is meant to be compressed once more, by the server's gzip or
//! Brotli or a zstd layer). Its decode: both zstd frames, then both
//! meshoptimizer decoders, into new buffers each run (as `fresh`). A
//! single-rate codec has no levels to keep and no topology to update, so
//! it is the ceiling, not a like-for-like: the ratio says how far a
//! progressive decoder is from simply unpacking the final mesh.
//!
//! Figures are M faces/s (quads; the peer's triangles / 2): per mode the
//! median over the rounds of each process's median of `--runs` decodes
//! (default 15 after one untimed one; 3 rounds), and the best decode.
//!
//! A second table gives memory: the peak resident set (`VmHWM`, Linux) of a
//! process that reads one file and decodes it once to the finest level
//! (general, forward-only), of one that reads the peer's compressed mesh
//! (written to a temporary file) and decodes it once, and of one that only
//! reads the `.pqm` file (the baseline: the executable and the input).

use pqm_format::{decode_all, quad_triangles, Decoder, Limits, Target};
use std::hint::black_box;
use std::time::Instant;

/// The whole file into `d` (reset first), refined to the finest level;
/// returns its quad count.
fn decode_into(d: &mut Decoder, bytes: &[u8]) -> usize {
    d.reset(Limits::none());
    d.push(bytes).expect("decode");
    assert!(d.status().finished, "the file ends early");
    d.set_level(Target::Level(usize::MAX))
        .expect("finest level");
    d.quads().len()
}

/// File `f` (its `bytes`) decoded whole, at its finest level; exits with
/// the error if it does not decode.
fn finest_level(f: &str, bytes: &[u8]) -> Decoder {
    let mut d = decode_all(bytes, Limits::none()).unwrap_or_else(|e| {
        eprintln!("{f}: {e}");
        std::process::exit(1)
    });
    d.set_level(Target::Level(usize::MAX))
        .expect("finest level");
    d
}

/// The peer's two compressed buffers and counts.
struct Peer {
    index_z: Vec<u8>,
    vertex_z: Vec<u8>,
    index_count: usize,
    vertex_count: usize,
    bytes: usize,
}

/// The peer of `dec`'s current level: its quads split as `pqm decode`'s
/// glTF export splits them (along the shorter diagonal,
/// [`pqm_core::io::quad_split_diagonal`]: what gltfpack would be given).
fn peer_encode(dec: &Decoder) -> Peer {
    let (quads, codes) = (dec.quads(), dec.position_codes());
    let p = dec.positions_f64();
    let indices: Vec<u32> = quads
        .iter()
        .flat_map(|&q| {
            let (mut t, r) = (q, pqm_core::io::quad_split_diagonal(&p, q));
            t.rotate_left(r);
            quad_triangles(t)
        })
        .collect();
    let vertices: Vec<[u16; 4]> = codes
        .iter()
        .map(|c| [c[0] as u16, c[1] as u16, c[2] as u16, 0])
        .collect();
    let mut indices = meshopt::optimize_vertex_cache(&indices, vertices.len());
    let vertices = meshopt::optimize_vertex_fetch(&mut indices, &vertices);
    let index_raw = meshopt::encode_index_buffer(&indices, vertices.len()).expect("index codec");
    let vertex_raw = meshopt::encode_vertex_buffer(&vertices).expect("vertex codec");
    let index_z = zstd::bulk::compress(&index_raw, 19).expect("zstd");
    let vertex_z = zstd::bulk::compress(&vertex_raw, 19).expect("zstd");
    Peer {
        bytes: index_z.len() + vertex_z.len(),
        index_z,
        vertex_z,
        index_count: quads.len() * 6,
        vertex_count: vertices.len(),
    }
}

/// One decode of the peer; returns its triangle count.
fn peer_decode(p: &Peer) -> usize {
    let index_raw = zstd::bulk::decompress(&p.index_z, 64 << 20).expect("zstd");
    let vertex_raw = zstd::bulk::decompress(&p.vertex_z, 64 << 20).expect("zstd");
    let idx: Vec<u32> = meshopt::decode_index_buffer(&index_raw, p.index_count).expect("index");
    let v: Vec<[u16; 4]> =
        meshopt::decode_vertex_buffer(&vertex_raw, p.vertex_count).expect("vertex");
    black_box(&v);
    idx.len() / 3
}

/// The peer's compressed mesh as a file: four little-endian `u64` (index
/// count, vertex count, the two frames' lengths), then the two frames.
fn peer_to_bytes(p: &Peer) -> Vec<u8> {
    let mut out = Vec::new();
    for n in [
        p.index_count,
        p.vertex_count,
        p.index_z.len(),
        p.vertex_z.len(),
    ] {
        out.extend_from_slice(&(n as u64).to_le_bytes());
    }
    out.extend_from_slice(&p.index_z);
    out.extend_from_slice(&p.vertex_z);
    out
}

fn peer_from_bytes(b: &[u8]) -> Peer {
    let n = |i: usize| u64::from_le_bytes(b[8 * i..8 * i + 8].try_into().unwrap()) as usize;
    let (ic, vc, il) = (n(0), n(1), n(2));
    let (index_z, vertex_z) = b[32..].split_at(il);
    Peer {
        bytes: index_z.len() + vertex_z.len(),
        index_z: index_z.to_vec(),
        vertex_z: vertex_z.to_vec(),
        index_count: ic,
        vertex_count: vc,
    }
}

/// This process's peak resident set in MB (`VmHWM`; `None` off Linux).
fn peak_rss_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Memory worker: reads `file` and, by `what`, decodes it once (`general`,
/// `forward`; a `.pqm`), decodes it as the peer's file once (`peer`) or
/// only holds it (`none`); prints its peak resident set in MB.
fn memory_worker(what: &str, file: &str) {
    let bytes = std::fs::read(file).unwrap_or_else(|e| {
        eprintln!("{file}: {e}");
        std::process::exit(1)
    });
    match what {
        "general" => {
            black_box(decode_into(&mut Decoder::new(Limits::none()), &bytes));
        }
        "forward" => {
            black_box(decode_into(
                &mut Decoder::forward_only(Limits::none()),
                &bytes,
            ));
        }
        "peer" => {
            black_box(peer_decode(&peer_from_bytes(&bytes)));
        }
        _ => {
            black_box(&bytes);
        }
    }
    match peak_rss_mb() {
        Some(mb) => println!("{mb}"),
        None => println!("nan"),
    }
}

/// The memory table (see the module docs): one process per file and way.
fn memory_table(exe: &std::path::Path, files: &[String]) {
    let run = |what: &str, file: &str| -> f64 {
        let out = std::process::Command::new(exe)
            .args(["--memory-worker", what, file])
            .output()
            .expect("run the worker");
        if !out.status.success() {
            eprint!("{}", String::from_utf8_lossy(&out.stderr));
            std::process::exit(1);
        }
        String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse()
            .unwrap_or(f64::NAN)
    };
    println!();
    println!("| file | quads | baseline (file read) | pqm general | pqm forward-only | peer (meshopt + zstd) | pqm forward-only / peer, above the baseline |");
    println!("|---|---|---|---|---|---|---|");
    for f in files {
        let bytes = std::fs::read(f).unwrap_or_else(|e| {
            eprintln!("{f}: {e}");
            std::process::exit(1)
        });
        let finest = finest_level(f, &bytes);
        let peer = peer_encode(&finest);
        let peer_file =
            std::env::temp_dir().join(format!("pqm-decode-table-{}.peer", std::process::id()));
        std::fs::write(&peer_file, peer_to_bytes(&peer)).expect("write the peer's file");
        let (base, general, forward) = (run("none", f), run("general", f), run("forward", f));
        let peer_mb = run("peer", &peer_file.to_string_lossy());
        let peer_base = run("none", &peer_file.to_string_lossy());
        let _ = std::fs::remove_file(&peer_file);
        let name = std::path::Path::new(f)
            .file_stem()
            .map_or(f.clone(), |s| s.to_string_lossy().into_owned());
        println!(
            "| {name} | {} | {base:.1} | {general:.1} | {forward:.1} | {peer_mb:.1} | {:.2}× |",
            finest.quads().len(),
            (forward - base) / (peer_mb - peer_base),
        );
    }
    println!();
    println!("Peak resident set (VmHWM) in MB of a process decoding the file once to its finest level; the baseline process only reads the .pqm file, and the ratio subtracts each side's own baseline (the peer's: reading its file).");
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}

fn best(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MAX, f64::min)
}

/// The ways to decode, as `--mode` names them.
const MODES: [&str; 7] = [
    "cold-general",
    "cold-forward",
    "new-general",
    "new-forward",
    "reused-general",
    "reused-forward",
    "peer",
];

/// Where `--mode` `name` is in [`MODES`] (and in each row's timings).
fn mode_index(name: &str) -> usize {
    MODES.iter().position(|m| *m == name).expect("a mode")
}

/// Worker: decodes every file `runs` times in `mode` (after one untimed
/// decode) and prints `file \t faces \t mode \t median s \t best s \t pqm
/// bytes \t peer bytes` per file.
fn worker(files: &[String], mode: &str, runs: usize) {
    let forward = mode.ends_with("forward");
    let (reuse, cold) = (mode.starts_with("reused"), mode.starts_with("cold"));
    let new = || {
        if forward {
            Decoder::forward_only(Limits::none())
        } else {
            Decoder::new(Limits::none())
        }
    };
    for f in files {
        let bytes = std::fs::read(f).unwrap_or_else(|e| {
            eprintln!("{f}: {e}");
            std::process::exit(1)
        });
        // The peer is built only in its own mode's process: its buffers
        // would leave the heap in another state than a decoder's (glibc
        // keeps or returns freed blocks by their sizes), and the cold
        // decoders' page faults with it.
        let (faces, peer) = {
            let finest = finest_level(f, &bytes);
            let peer = (mode == "peer").then(|| peer_encode(&finest));
            (finest.quads().len(), peer)
        };
        let mut kept = new();
        let mut times = Vec::with_capacity(runs);
        for round in 0..=runs {
            if cold {
                // What the last decoder left is freed, outside the timing.
                pqm_format::release_recycled();
            }
            let t = Instant::now();
            let n = match &peer {
                Some(p) => peer_decode(p) / 2,
                None if reuse => decode_into(&mut kept, &bytes),
                None => decode_into(&mut new(), &bytes),
            };
            let dt = t.elapsed().as_secs_f64();
            assert_eq!(n, faces, "{mode}");
            if round > 0 {
                times.push(dt);
            }
        }
        println!(
            "{f}\t{faces}\t{mode}\t{}\t{}\t{}\t{}",
            median(&times),
            best(&times),
            bytes.len(),
            peer.map_or(0, |p| p.bytes)
        );
    }
}

fn main() {
    let mut files = Vec::new();
    let (mut runs, mut rounds, mut mode) = (15usize, 3usize, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut num = |d: usize| args.next().and_then(|s| s.parse().ok()).unwrap_or(d).max(1);
        match a.as_str() {
            "--runs" => runs = num(runs),
            "--rounds" => rounds = num(rounds),
            "--mode" => mode = args.next(),
            "--memory-worker" => {
                let (what, file) = (
                    args.next().unwrap_or_default(),
                    args.next().unwrap_or_default(),
                );
                memory_worker(&what, &file);
                return;
            }
            _ => files.push(a),
        }
    }
    if files.is_empty() {
        eprintln!("usage: decode_table FILE.pqm... [--runs N] [--rounds R] [--mode MODE]");
        std::process::exit(2);
    }
    if let Some(m) = mode {
        if !MODES.contains(&m.as_str()) {
            eprintln!("--mode: one of {}", MODES.join(", "));
            std::process::exit(2);
        }
        worker(&files, &m, runs);
        return;
    }
    // Each mode in processes of its own (a new decoder's cost depends on
    // what the process's heap holds, and a reused decoder holds it), the
    // modes alternated over `rounds` rounds.
    let exe = std::env::current_exe().expect("own path");
    // per file: faces, pqm bytes, peer bytes, per mode (medians, bests)
    type Row = (usize, usize, usize, Vec<(Vec<f64>, Vec<f64>)>);
    let mut rows: Vec<Row> = files
        .iter()
        .map(|_| (0, 0, 0, vec![(Vec::new(), Vec::new()); MODES.len()]))
        .collect();
    for _ in 0..rounds {
        for (mi, m) in MODES.iter().enumerate() {
            let out = std::process::Command::new(&exe)
                .args(&files)
                .args(["--runs", &runs.to_string(), "--mode", m])
                .output()
                .expect("run the worker");
            if !out.status.success() {
                eprint!("{}", String::from_utf8_lossy(&out.stderr));
                std::process::exit(1);
            }
            let text = String::from_utf8_lossy(&out.stdout);
            for (row, line) in rows.iter_mut().zip(text.lines()) {
                let c: Vec<&str> = line.split('\t').collect();
                let num = |i: usize| c[i].parse::<f64>().expect("worker output");
                (row.0, row.1) = (num(1) as usize, num(5) as usize);
                if *m == "peer" {
                    row.2 = num(6) as usize;
                }
                row.3[mi].0.push(num(3));
                row.3[mi].1.push(num(4));
            }
        }
    }
    println!(
        "| file | quads | cold general | cold forward | new general | new forward | reused general | reused forward | meshopt + zstd (same run) | pqm reused forward / peer | bytes pqm / peer |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (f, (faces, pqm_bytes, peer_bytes, per)) in files.iter().zip(&rows) {
        let rate = |t: f64| *faces as f64 / t / 1e6;
        let cells: Vec<String> = per
            .iter()
            .map(|(med, bst)| format!("{:.2} (best {:.2})", rate(median(med)), rate(best(bst))))
            .collect();
        let name = std::path::Path::new(f)
            .file_stem()
            .map_or(f.clone(), |s| s.to_string_lossy().into_owned());
        println!(
            "| {name} | {faces} | {} | {:.2}× | {:.2}× |",
            cells.join(" | "),
            median(&per[mode_index("peer")].0) / median(&per[mode_index("reused-forward")].0),
            *pqm_bytes as f64 / *peer_bytes as f64,
        );
    }
    println!();
    println!(
        "M faces/s (quads; the peer's triangles / 2): median over {rounds} processes per mode of each one's median of {runs} decodes (best: the fastest decode), modes alternated."
    );
    memory_table(&exe, &files);
}
