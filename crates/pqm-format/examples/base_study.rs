//! Design study for issue 4: what would a better coding of the base-mesh
//! section (spec §6) save? Measures only.
//!
//! `cargo run --release -p pqm-format --example base_study -- FILE.pqm...`
//!
//! Layouts, each compressed with zstd-19 as the writer does, same base mesh
//! (same vertex ids and face slots — the levels must stay id for id):
//! * `today`: §6 (corner deltas, then position deltas in id order);
//! * `mtf + par(id)`: corners as a symbol byte (0 = the smallest id not yet
//!   seen, 1..=32 = index in a move-to-front list of the last 32 vertices
//!   used, 255 = escape: an svarint delta from the previous corner in a
//!   second stream), positions in id order predicted by the mean of the
//!   parallelograms of the faces whose other three corners have smaller ids,
//!   else the mean of the smaller-id edge neighbours, else the previous code;
//! * `mtf + par(seen)`: the same corners, positions interleaved at each
//!   vertex's first appearance, predicted from that face's corners seen
//!   before (parallelogram when all three are, else their edge-neighbour
//!   mean, else the previous new vertex).
//!
//! ## Figures (format 3.1 files by `pqm encode`, default options; 2026-12-01)
//!
//! Bits per base vertex (per final vertex in brackets):
//!
//! | file (base vertices) | today | mtf + par(id) | mtf + par(seen) |
//! |---|---:|---:|---:|
//! | spot_quadrangulated (268) | 81.7 (7.47) | 78.0 (7.13) | 78.8 |
//! | loki (2,172) | 73.6 (5.81) | 69.0 (5.45) | 70.1 |
//! | makehuman_base (4,983) | 51.8 (13.48) | 49.5 (12.87) | 52.8 |
//! | bunny, split (1,415) | 93.7 (0.63) | 78.6 (0.53) | 80.2 |
//!
//! Only 3–7 % (bunny 16 %): of the `4 F` corners, 9–37 are the next unseen
//! id and 42–68 % escape the move-to-front list — the coarsener's base ids
//! are not in any traversal order of the base faces, so a single-rate coder
//! (connectivity ≈ 2–4 bits per vertex) needs the base renumbered, which
//! must happen in the coarsener (levels are id for id). Its positions,
//! 27–44 bits per base vertex under parallelogram prediction, are what the
//! base is made of once that is done: the base is too coarse for
//! prediction to help much. Renumbered, the base would save ≈ 2.5 bits
//! per final vertex (loki, spot), ≈ 5 on makehuman (a quarter of its
//! vertices are base vertices) and 0.2 on the bunny: left for a format
//! that also changes the records, as it needs the coarsener's base
//! numbering changed.

use pqm_format::varint::put_s;

#[path = "common/models.rs"]
mod models;

const MTF: usize = 32;

fn corners(quads: &[[u32; 4]], nv: usize) -> (Vec<u8>, Vec<u8>, Vec<u32>) {
    let mut sym = Vec::new();
    let mut esc = Vec::new();
    let mut seen = vec![false; nv];
    let mut next = 0usize;
    let mut mtf: Vec<u32> = Vec::new();
    let mut prev = 0i64;
    let mut order = Vec::new();
    let (mut n0, mut nm, mut ne) = (0, 0, 0);
    for q in quads {
        for &v in q {
            if !seen[v as usize] && v as usize == next {
                sym.push(0);
                n0 += 1;
            } else if let Some(i) = mtf.iter().position(|&u| u == v) {
                sym.push(1 + i as u8);
                nm += 1;
            } else {
                sym.push(255);
                put_s(&mut esc, v as i64 - prev);
                ne += 1;
            }
            if !seen[v as usize] {
                seen[v as usize] = true;
                order.push(v);
            }
            while next < nv && seen[next] {
                next += 1;
            }
            if let Some(i) = mtf.iter().position(|&u| u == v) {
                mtf.remove(i);
            }
            mtf.insert(0, v);
            mtf.truncate(MTF);
            prev = v as i64;
        }
    }
    println!("  corners: next unseen {n0}, move-to-front {nm}, escape {ne}");
    (sym, esc, order)
}

fn main() {
    models::study_files("base_study", study);
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened { dec, pm, state, .. } = models::open(f)?;
    let qmax = state.qmax;
    let q: Vec<[i64; 3]> = state.q.iter().map(|c| c.map(|x| x as i64)).collect();
    let quads = state.quads;
    let nv = q.len();
    let today = dec.header().map_or(0, |h| h.base_compressed_len as usize);
    println!(
        "{f}: base {nv} vertices, {} quads, {} final vertices",
        quads.len(),
        pm.final_vertex_count()
    );
    let per = |b: usize| {
        (
            b as f64 * 8.0 / nv as f64,
            b as f64 * 8.0 / pm.final_vertex_count() as f64,
        )
    };
    let (a, b) = per(today);
    println!(
        "  today            {today:7} B = {a:6.1} bits/base vertex = {b:5.2} bits/final vertex"
    );

    let (sym, esc, order) = corners(&quads, nv);
    // vertex -> faces
    let mut vf: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for (i, qd) in quads.iter().enumerate() {
        for &v in qd {
            vf[v as usize].push(i);
        }
    }
    // positions in id order
    let mut pos = Vec::new();
    let mut prevc = [0i64; 3];
    for v in 0..nv {
        let mut sum = [0i64; 3];
        let mut c = 0;
        let mut nsum = [0i64; 3];
        let mut nc = 0;
        for &fi in &vf[v] {
            let qd = quads[fi];
            let k = qd.iter().position(|&u| u as usize == v).unwrap();
            let (n1, o, n3) = (qd[(k + 1) % 4], qd[(k + 2) % 4], qd[(k + 3) % 4]);
            if (n1 as usize) < v && (o as usize) < v && (n3 as usize) < v {
                for t in 0..3 {
                    sum[t] += q[n1 as usize][t] + q[n3 as usize][t] - q[o as usize][t];
                }
                c += 1;
            }
            for n in [n1, n3] {
                if (n as usize) < v {
                    for t in 0..3 {
                        nsum[t] += q[n as usize][t];
                    }
                    nc += 1;
                }
            }
        }
        let pred = if c > 0 {
            sum.map(|s| s.div_euclid(c))
        } else if nc > 0 {
            nsum.map(|s| s.div_euclid(nc))
        } else {
            prevc
        };
        for t in 0..3 {
            put_s(&mut pos, q[v][t] - pred[t]);
        }
        prevc = q[v];
    }
    // today's corners (deltas) with today's and with par(id) positions
    let mut tc = Vec::new();
    let mut prev = 0i64;
    for qd in &quads {
        for &v in qd {
            put_s(&mut tc, v as i64 - prev);
            prev = v as i64;
        }
    }
    let mut tp = Vec::new();
    let mut pc = [0i64; 3];
    for c in &q {
        for t in 0..3 {
            put_s(&mut tp, c[t] - pc[t]);
        }
        pc = *c;
    }
    let zc = models::zstd19(&[&tc]);
    let zt = models::zstd19(&[&tc, &tp]);
    let zp = models::zstd19(&[&tc, &pos]);
    println!(
        "  today re-made    {zt:7} B: corners alone {:.1}, +pos {:.1} bits/base vertex; with par(id) pos {:.1} (= {:.2} bits/final vertex)",
        zc as f64 * 8.0 / nv as f64,
        (zt - zc) as f64 * 8.0 / nv as f64,
        (zp - zc) as f64 * 8.0 / nv as f64,
        per(zp).1
    );
    let (gc, gp) = traversal_study(&q, &quads, qmax);
    println!(
        "  traversal (4.0)  conn {:.1} + pos {:.1} bits/base vertex = {:.2} bits/final vertex",
        gc as f64 * 8.0 / nv as f64,
        gp as f64 * 8.0 / nv as f64,
        per(gc + gp).1,
    );
    let s1 = models::zstd19(&[&sym, &esc, &pos]);
    let (a, b) = per(s1);
    let c1 = models::zstd19(&[&sym, &esc]);
    println!(
        "  mtf + par(id)    {s1:7} B = {a:6.1} bits/base vertex = {b:5.2} bits/final vertex (conn {:.1}, pos {:.1} bits/base vertex)",
        c1 as f64 * 8.0 / nv as f64,
        (s1 - c1) as f64 * 8.0 / nv as f64
    );

    // positions at first appearance
    let mut known = vec![false; nv];
    let mut pos2 = Vec::new();
    let mut prevc = [0i64; 3];
    for qd in &quads {
        for k in 0..4 {
            let v = qd[k] as usize;
            if known[v] {
                continue;
            }
            let (n1, o, n3) = (
                qd[(k + 1) % 4] as usize,
                qd[(k + 2) % 4] as usize,
                qd[(k + 3) % 4] as usize,
            );
            let pred = if known[n1] && known[o] && known[n3] {
                [0, 1, 2].map(|t| q[n1][t] + q[n3][t] - q[o][t])
            } else {
                let mut s = [0i64; 3];
                let mut c = 0;
                for n in [n1, n3, o] {
                    if known[n] {
                        for t in 0..3 {
                            s[t] += q[n][t];
                        }
                        c += 1;
                    }
                }
                if c > 0 {
                    s.map(|x| x.div_euclid(c))
                } else {
                    prevc
                }
            };
            for t in 0..3 {
                put_s(&mut pos2, q[v][t] - pred[t]);
            }
            known[v] = true;
            prevc = q[v];
        }
    }
    let _ = order;
    let s2 = models::zstd19(&[&sym, &esc, &pos2]);
    let (a, b) = per(s2);
    println!(
        "  mtf + par(seen)  {s2:7} B = {a:6.1} bits/base vertex = {b:5.2} bits/final vertex (pos {:.1})",
        (s2 - c1) as f64 * 8.0 / nv as f64
    );
    Ok(())
}

/// The traversal layout of spec §6.1 (format 4.0) for this base, after
/// renumbering it in the walk's order (`walk_order`) when it is not (the
/// bases of 3.x files): zstd-19 bytes of its connectivity streams and of
/// its positions.
fn traversal_study(q: &[[i64; 3]], quads: &[[u32; 4]], qmax: u32) -> (usize, usize) {
    let refs: Vec<&[u32]> = quads.iter().map(|f| &f[..]).collect();
    let (faces, vertices) = pqm_core::progressive::walk_order(&refs, q.len());
    let mut id = vec![0u32; q.len()];
    for (new, &old) in vertices.iter().enumerate() {
        id[old as usize] = new as u32;
    }
    let codes: Vec<[u32; 3]> = vertices
        .iter()
        .map(|&o| q[o as usize].map(|x| x as u32))
        .collect();
    let quads: Vec<[u32; 4]> = faces
        .iter()
        .map(|&f| quads[f as usize].map(|v| id[v as usize]))
        .collect();
    let p = pqm_format::base::encode_traversal(&codes, &quads, qmax).expect("walk-ordered");
    let pos_at = *p.cuts.last().expect("four parts");
    (
        models::zstd19(&[&p.payload[..pos_at]]),
        models::zstd19(&[&p.payload[pos_at..]]),
    )
}
