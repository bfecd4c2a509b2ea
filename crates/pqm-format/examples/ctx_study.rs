//! Design study for issue 4 (≤ 30 bits/vertex): what adaptive context
//! models would spend on the position residuals, the vertex references and
//! the op symbols, against zstd's bytes for the same streams. Measures
//! only; no format change.
//!
//! `cargo run --release -p pqm-format --example ctx_study -- FILE.pqm...`
//!
//! Each stream's values, chunk by chunk (re-encoded as `layout_study`
//! does), priced by the ideal code length of adaptive models
//! (`common/models.rs`): `pos` as an adaptive Elias-gamma bucket plus raw
//! bits (`gamma+`: the first bit under the leading one modelled too) under
//! five contexts — none, the axis, the axis and the previous coordinate's
//! bucket in the same vertex, that and the previous vertex's largest
//! bucket, the axis and one of those; `refs` without and with the previous
//! reference's bucket as context; `ops` order-0 and order-1. `reset`
//! starts every chunk with fresh models (chunks stay independent),
//! `carried` keeps them across chunks.
//!
//! ## Figures (session 16's bench files, format 3.2; 2026-12-06)
//!
//! Bits per refined vertex, zstd alone → best adaptive model:
//!
//! | file | pos | refs | ops |
//! |---|---|---|---|
//! | spot_quadrangulated | 30.80 → 28.29 (reset, no context) | 5.35 → 4.82 | 1.74 → 1.71 |
//! | makehuman_base | 23.83 → 22.24 (carried, axis + previous coordinate) | 5.66 → 5.29 | 1.84 → 1.71 |
//! | loki | 23.54 → 21.67 (carried, axis + previous coordinate) | 5.73 → 5.25 | 1.68 → 1.53 |
//! | bunny (split) | 22.39 → 20.79 (carried, axis + previous coordinate) | 6.86 → 6.19 | 1.96 → 1.59 |
//!
//! About 2.2–3.2 bits per refined vertex in all, for an adaptive
//! arithmetic decoder (per symbol, slower than zstd's table-driven
//! decoding, against issue 4's decode speed): not taken. Geometric
//! contexts help more (`midpoint_study`: the local scale as context).

#![allow(clippy::needless_range_loop)] // per-context loops over parallel arrays read best indexed

use pqm_format::codec::{self, Coding, Cursors, QRecord, CONN, OPS, POS, REFS};
use pqm_format::varint::{unzigzag, Reader};

#[path = "common/models.rs"]
mod models;
use models::{bucket, Freq, Gamma};

fn values(s: &[u8]) -> Vec<u64> {
    let mut r = Reader::new(s, "x");
    let mut v = Vec::new();
    while r.remaining() > 0 {
        v.push(r.u().expect("varint"));
    }
    v
}

fn main() {
    models::study_files("ctx_study", study);
}

struct Models {
    pos: Vec<Gamma>,
    pos_m: Vec<Gamma>,
    refs: Vec<Gamma>,
    ops: Vec<std::collections::HashMap<u64, Freq>>,
}

const NPOS: usize = 5;
const NREF: usize = 2;
const NOPS: usize = 2;

impl Models {
    fn new() -> Self {
        Models {
            pos: (0..NPOS).map(|_| Gamma::default()).collect(),
            pos_m: (0..NPOS).map(|_| Gamma::default()).collect(),
            refs: (0..NREF).map(|_| Gamma::default()).collect(),
            ops: (0..NOPS).map(|_| Default::default()).collect(),
        }
    }
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened {
        dec,
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let coding = Coding::default();
    let refined = (pm.final_vertex_count() - pm.base.positions.len()).max(1) as f64;
    let mut zst = [0usize; 4];
    // [reset per chunk, carried]
    let mut pos = [[0f64; NPOS]; 2];
    let mut pos_m = [[0f64; NPOS]; 2];
    let mut refs = [[0f64; NREF]; 2];
    let mut ops = [[0f64; NOPS]; 2];
    let mut carried = Models::new();
    let mut k = 0usize;
    let streams = [OPS, CONN, REFS, POS];
    for c in dec.chunks() {
        let mut s: [Vec<u8>; 5] = Default::default();
        let mut cur = Cursors::default();
        for _ in 0..c.record_count {
            let r = QRecord::quantized(&pm.records[k], &quant);
            codec::encode_record(&st, &r, &mut cur, &mut s, coding);
            st.apply(&r);
            k += 1;
        }
        for (i, &t) in streams.iter().enumerate() {
            zst[i] += models::zstd19(&[&s[t]]);
        }
        let mut reset = Models::new();
        for (mi, m) in [&mut reset, &mut carried].into_iter().enumerate() {
            // positions
            let pv: Vec<i64> = values(&s[POS]).into_iter().map(unzigzag).collect();
            let mut prev_max = 0usize;
            for (j, t) in pv.chunks(3).enumerate() {
                let _ = j;
                let mut bx = [0usize; 3];
                for a in 0..t.len() {
                    let v = t[a];
                    let within = match a {
                        0 => prev_max,
                        1 => bx[0],
                        _ => bx[0].max(bx[1]),
                    }
                    .min(15) as u64;
                    let ctxs: [u64; NPOS] = [
                        0,
                        a as u64,
                        (a as u64) << 4 | within,
                        (a as u64) << 8 | within << 4 | (prev_max.min(15) as u64),
                        (a as u64) << 4
                            | if a == 0 {
                                prev_max.min(15) as u64
                            } else {
                                bx[0].min(15) as u64
                            },
                    ];
                    for (ci, &cx) in ctxs.iter().enumerate() {
                        pos[mi][ci] += m.pos[ci].cost_signed(cx, v);
                        pos_m[mi][ci] += m.pos_m[ci].cost_signed_m(cx, v);
                    }
                    bx[a] = bucket(v.unsigned_abs());
                }
                prev_max = bx.iter().copied().max().unwrap_or(0);
            }
            // refs
            let rv: Vec<i64> = values(&s[REFS]).into_iter().map(unzigzag).collect();
            let mut pb = 0u64;
            for &v in &rv {
                refs[mi][0] += m.refs[0].cost_signed_m(0, v);
                refs[mi][1] += m.refs[1].cost_signed_m(pb.min(20), v);
                pb = bucket(v.unsigned_abs()) as u64;
            }
            let mut po = 0u64;
            for &o in &s[OPS] {
                for ci in 0..NOPS {
                    let cx = if ci == 0 { 0 } else { po };
                    ops[mi][ci] += m.ops[ci]
                        .entry(cx)
                        .or_insert_with(|| Freq::new(256))
                        .cost(o as usize);
                }
                po = o as u64;
            }
        }
    }
    let b = |x: f64| x / refined;
    println!("{f}: {k} records, {refined:.0} refined vertices (bits per refined vertex)");
    println!(
        "  zstd alone: ops {:.2} conn {:.2} refs {:.2} pos {:.2}",
        b(zst[0] as f64 * 8.0),
        b(zst[1] as f64 * 8.0),
        b(zst[2] as f64 * 8.0),
        b(zst[3] as f64 * 8.0)
    );
    for (mi, name) in ["reset", "carried"].iter().enumerate() {
        println!(
            "  {name:7} pos gamma  {}",
            pos[mi]
                .iter()
                .map(|&x| format!("{:.2}", b(x)))
                .collect::<Vec<_>>()
                .join(" ")
        );
        println!(
            "  {name:7} pos gamma+ {}",
            pos_m[mi]
                .iter()
                .map(|&x| format!("{:.2}", b(x)))
                .collect::<Vec<_>>()
                .join(" ")
        );
        println!(
            "  {name:7} refs {}   ops {}",
            refs[mi]
                .iter()
                .map(|&x| format!("{:.2}", b(x)))
                .collect::<Vec<_>>()
                .join(" "),
            ops[mi]
                .iter()
                .map(|&x| format!("{:.2}", b(x)))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    Ok(())
}
