//! Design study for issue 4: are a record's new vertices often the exact
//! mean of two (or all) of their known edge neighbours — as the edge points
//! and face points of a linear split are — so that a per-vertex choice of
//! predictor could code them in a few bits? Measures only.
//!
//! `cargo run --release -p pqm-format --example midpoint_study -- FILE.pqm...`
//!
//! For each new vertex `x` of each record (in id order, as §7.6 predicts):
//! `E` = its edge neighbours in the record's quads that are already known
//! (existing vertices and earlier new ones). Predictors: `today` (§7.6's
//! multi-parallelogram, else the known corners' mean), `mean` (of `E`), and
//! `pair` (the best of the rounded means of two entries of `E`, an oracle
//! that would cost the pair's index). Bits are priced with an
//! Elias-gamma-like `2 ⌊log2(|r| + 1)⌋ + 1` per axis (a rough, monotone
//! stand-in: only the comparison matters), the oracle choice adding
//! `log2(2 + pairs)` bits. Then real sizes: each predictor's residuals as
//! svarints, zstd-19 per chunk of the file (the pos stream alone): `today`,
//! `edge mean`, `best-of` (the cheapest predictor per vertex, its index in
//! a selection byte stream), `snap` (the pair mean or edge mean nearest to
//! today's prediction — no signalling) and half way between snap and today.
//!
//! ## Figures (format 3.1 files, default options; 2026-12-01)
//!
//! | file (new vertices) | within ±1: today / edge mean / some pair | zstd bits per new vertex: today / edge mean / best-of / snap |
//! |---|---|---|
//! | loki (25,342) | 3.8 / 3.0 / 21.9 % | 24.62 / 23.46 / 22.61 / 23.19 |
//! | bunny, split (207,585) | 8.9 / 18.3 / 39.7 % (qvMerge inverses 63.5 %) | 23.03 / 20.05 / 20.06 / 20.43 |
//! | spot_quadrangulated (2,662) | — | 31.88 / 31.21 / 31.09 / 31.33 |
//!
//! Many new vertices do sit at the mean of two known neighbours (the edge
//! points of the bunny's linear split above all), but naming the pair costs
//! what it saves under zstd; the plain edge-neighbour mean gets most of it:
//! 0.7–3.0 bits per new vertex (3–13 % of the positions, ≈ 1–6 % of a
//! file). Worth taking in a future major version together with other
//! changes, not alone.
//!
//! ## Session 17: blends and stencils (session 16's files, 3.2; 2026-12-06)
//!
//! zstd-19 per chunk, bits per new vertex, of residuals against: `today`;
//! the blend `w · today + (1 − w) · edge mean` (`blend w`, the edge mean
//! over all known edge neighbours, distinct); the per-quad stencil
//! `(a (n1 + n3) − b o) / (d c)` over §7.6's qualifying quads only (`(1, 0,
//! 2)` = their edge mean, `(5, 2, 8)` = w = 1/4, the version-4 rule); and
//! adaptive Elias-gamma costs of the blend-1/4 residuals with the local
//! scale (the mean L1 distance of the edge neighbours to their mean, its
//! bucket) as context:
//!
//! | file | today | edge mean | blend 1/4 | stencil (1,0,2) | stencil (5,2,8) | adaptive, scale context |
//! |---|---|---|---|---|---|---|
//! | spot_quadrangulated | 30.86 | 30.48 | 30.25 | 30.79 | 30.55 | 27.84 |
//! | makehuman_base | 23.86 | 23.12 | 22.99 | 23.55 | 23.30 | 21.16 |
//! | loki | 23.59 | 22.51 | 22.43 | 23.03 | 22.79 | 20.74 |
//! | bunny (split) | 22.48 | 19.57 | 20.39 | 19.76 | 20.48 | 19.17 |
//!
//! The stencil is what a decoder's existing parallelogram loops compute
//! with other weights, so format 4.0 took it (§7.6 version 4); the blend
//! over distinct edge neighbours would save 0.2–0.4 more but needs their
//! deduplication in every fast path.

#![allow(clippy::needless_range_loop)] // per-axis loops over three arrays read best indexed

use pqm_format::codec::QRecord;
use pqm_format::varint::put_s;

#[path = "common/models.rs"]
mod models;

fn gbits(r: i64) -> f64 {
    let a = r.unsigned_abs() + 1;
    (2 * (63 - a.leading_zeros()) + 1) as f64
}

fn cost(x: [i64; 3], p: [i64; 3]) -> (f64, i64) {
    let mut b = 0.0;
    let mut m = 0;
    for t in 0..3 {
        b += gbits(x[t] - p[t]);
        m = m.max((x[t] - p[t]).abs());
    }
    (b, m)
}

fn main() {
    models::study_files("midpoint_study", study);
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened {
        dec,
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let (mut n, mut b_today, mut b_mean, mut b_oracle) = (0usize, 0.0, 0.0, 0.0);
    let (mut exact_pair, mut exact_mean, mut exact_today) = (0usize, 0usize, 0usize);
    let mut ops = [[0usize; 2]; 4];
    // chunk-wise streams: today's residuals; selection bytes + chosen residuals
    let ends = models::chunk_ends(&dec);
    let (mut z_today, mut z_sel, mut z_mean) = (0usize, 0usize, 0usize);
    let (mut z_snap, mut z_blend) = (0usize, 0usize);
    const WS: [i64; 5] = [1, 2, 3, 5, 6];
    let mut z_w = [0usize; 5];
    let mut s_w: [Vec<u8>; 5] = Default::default();
    // per-quad stencils (a (n1 + n3) - b o) / (d c) over §7.6's quads
    const ST: [(i64, i64, i64); 5] = [(1, 0, 2), (9, 2, 16), (5, 2, 8), (11, 6, 16), (1, 1, 1)];
    let mut z_st = [0usize; 5];
    let mut s_st: [Vec<u8>; 5] = Default::default();
    let mut g_plain = models::Gamma::default();
    let mut g_scale = models::Gamma::default();
    let mut g_scale2 = models::Gamma::default();
    let (mut c_plain, mut c_scale, mut c_scale2) = (0f64, 0f64, 0f64);
    let (mut s_snap, mut s_blend) = (Vec::new(), Vec::new());
    let (mut s_today, mut s_sel, mut s_res, mut s_mean) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (ri, rec) in pm.records.iter().enumerate() {
        if ends.contains(&ri) {
            z_today += models::zstd19(&[&s_today]);
            z_sel += models::zstd19(&[&s_sel, &s_res]);
            z_mean += models::zstd19(&[&s_mean]);
            z_snap += models::zstd19(&[&s_snap]);
            z_blend += models::zstd19(&[&s_blend]);
            for i in 0..5 {
                z_w[i] += models::zstd19(&[&s_w[i]]);
                s_w[i].clear();
                z_st[i] += models::zstd19(&[&s_st[i]]);
                s_st[i].clear();
            }
            s_snap.clear();
            s_blend.clear();
            s_today.clear();
            s_sel.clear();
            s_res.clear();
            s_mean.clear();
        }
        let r = QRecord::quantized(rec, &quant);
        let v0 = st.q.len() as u32;
        let mut code: Vec<[i64; 3]> = st.q.iter().map(|c| c.map(|x| x as i64)).collect();
        for &(v, c) in &r.moved {
            code[v as usize] = c.map(|x| x as i64);
        }
        let quads: Vec<[u32; 4]> = r
            .appended
            .iter()
            .copied()
            .chain(r.rewritten.iter().map(|x| x.1))
            .collect();
        for (i, c) in r.new_pos.iter().enumerate() {
            let x = v0 + i as u32;
            let xc = c.map(|t| t as i64);
            let known = |u: u32| u < x;
            let mut par = [0i64; 3];
            let mut stp = [[0i64; 3]; 5];
            let mut npar = 0;
            let mut e: Vec<u32> = Vec::new();
            let mut kn: Vec<u32> = Vec::new();
            for q in &quads {
                let Some(k) = q.iter().position(|&u| u == x) else {
                    continue;
                };
                let (n1, o, n3) = (q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]);
                if known(n1) && known(o) && known(n3) {
                    for t in 0..3 {
                        par[t] += code[n1 as usize][t] + code[n3 as usize][t] - code[o as usize][t];
                        for (i, &(a, b, _)) in ST.iter().enumerate() {
                            stp[i][t] += a * (code[n1 as usize][t] + code[n3 as usize][t])
                                - b * code[o as usize][t];
                        }
                    }
                    npar += 1;
                }
                for u in [n1, n3] {
                    if known(u) && !e.contains(&u) {
                        e.push(u);
                    }
                }
                for u in [n1, o, n3] {
                    if known(u) && !kn.contains(&u) {
                        kn.push(u);
                    }
                }
            }
            let mean_of = |s: &[u32]| -> Option<[i64; 3]> {
                if s.is_empty() {
                    return None;
                }
                let mut m = [0i64; 3];
                for &u in s {
                    for t in 0..3 {
                        m[t] += code[u as usize][t];
                    }
                }
                Some(m.map(|v| v.div_euclid(s.len() as i64)))
            };
            let today = if npar > 0 {
                par.map(|v| v.div_euclid(npar))
            } else {
                mean_of(&kn).unwrap_or(code[(x - 1) as usize])
            };
            let (bt, mt) = cost(xc, today);
            let (bm, mm) = mean_of(&e).map_or((bt, mt), |p| cost(xc, p));
            let mut best = (bt.min(bm), mt.min(mm));
            let mut choice = (bt, 0u8, today);
            if let Some(p) = mean_of(&e) {
                if bm < choice.0 {
                    choice = (bm, 1, p);
                }
            }
            let mut prev_b = 0u64;
            for t in 0..3 {
                put_s(&mut s_today, xc[t] - today[t]);
                put_s(&mut s_mean, xc[t] - mean_of(&e).unwrap_or(today)[t]);
                let em = mean_of(&e).unwrap_or(today)[t];
                for (i, &(_, _, d)) in ST.iter().enumerate() {
                    let p = if npar > 0 {
                        stp[i][t].div_euclid(d * npar)
                    } else {
                        today[t]
                    };
                    put_s(&mut s_st[i], xc[t] - p);
                }
                let pb = (2 * today[t] + 6 * em).div_euclid(8);
                let pb = if npar > 0 { pb } else { today[t] };
                let mut sc = 0i64;
                for &u in &e {
                    sc += (0..3)
                        .map(|a| (code[u as usize][a] - mean_of(&e).unwrap_or(today)[a]).abs())
                        .sum::<i64>();
                }
                let sc = if e.is_empty() { 0 } else { sc / e.len() as i64 };
                let sb = models::bucket(sc as u64) as u64;
                let r = xc[t] - pb;
                c_plain += g_plain.cost_signed_m(t as u64, r);
                c_scale += g_scale.cost_signed_m((t as u64) << 6 | sb, r);
                c_scale2 += g_scale2.cost_signed_m((t as u64) << 12 | sb << 6 | prev_b.min(15), r);
                prev_b = if t == 2 {
                    0
                } else {
                    models::bucket(r.unsigned_abs()) as u64
                };
                for i in 0..5 {
                    let p = (WS[i] * today[t] + (8 - WS[i]) * em).div_euclid(8);
                    put_s(&mut s_w[i], xc[t] - if npar > 0 { p } else { today[t] });
                }
            }
            // snap: the pair mean (or edge mean) nearest to `today`
            {
                let mut snap = today;
                let mut dbest = i64::MAX;
                let mut cands: Vec<[i64; 3]> = Vec::new();
                if let Some(p) = mean_of(&e) {
                    cands.push(p);
                }
                for a in 0..e.len() {
                    for b in a + 1..e.len() {
                        cands.push([0, 1, 2].map(|t| {
                            (code[e[a] as usize][t] + code[e[b] as usize][t]).div_euclid(2)
                        }));
                    }
                }
                for p in cands {
                    let d: i64 = (0..3).map(|t| (p[t] - today[t]).abs()).sum();
                    if d < dbest {
                        dbest = d;
                        snap = p;
                    }
                }
                for t in 0..3 {
                    put_s(&mut s_snap, xc[t] - snap[t]);
                    put_s(&mut s_blend, xc[t] - (snap[t] + today[t]).div_euclid(2));
                }
            }
            let mut pairs = 0;
            for a in 0..e.len() {
                for b in a + 1..e.len() {
                    pairs += 1;
                    let p = [0, 1, 2]
                        .map(|t| (code[e[a] as usize][t] + code[e[b] as usize][t]).div_euclid(2));
                    let (bp, mp) = cost(xc, p);
                    if bp < choice.0 && pairs < 250 {
                        choice = (bp, 1 + pairs as u8, p);
                    }
                    if mp <= 1 {
                        best.1 = best.1.min(mp);
                    }
                    if bp < best.0 {
                        best.0 = bp;
                    }
                    best.1 = best.1.min(mp);
                }
            }
            s_sel.push(choice.1);
            for t in 0..3 {
                put_s(&mut s_res, xc[t] - choice.2[t]);
            }
            n += 1;
            b_today += bt;
            b_mean += bm;
            b_oracle += best.0 + (2.0 + pairs as f64).log2();
            exact_today += (mt <= 1) as usize;
            exact_mean += (mm <= 1) as usize;
            exact_pair += (best.1 <= 1) as usize;
            ops[r.op as usize][0] += 1;
            ops[r.op as usize][1] += (best.1 <= 1) as usize;
            code.push(xc);
        }
        st.apply(&r);
    }
    z_today += models::zstd19(&[&s_today]);
    z_sel += models::zstd19(&[&s_sel, &s_res]);
    z_mean += models::zstd19(&[&s_mean]);
    z_snap += models::zstd19(&[&s_snap]);
    z_blend += models::zstd19(&[&s_blend]);
    let nf = n.max(1) as f64;
    println!(
        "  adaptive gamma, blend 2/8: plain {:.2}, scale ctx {:.2}, scale+prev axis {:.2}",
        c_plain / nf,
        c_scale / nf,
        c_scale2 / nf
    );
    for i in 0..5 {
        z_st[i] += models::zstd19(&[&s_st[i]]);
        println!("  stencil {:?}: {:.2}", ST[i], z_st[i] as f64 * 8.0 / nf);
        z_w[i] += models::zstd19(&[&s_w[i]]);
        println!("  blend {}/8 today: {:.2}", WS[i], z_w[i] as f64 * 8.0 / nf);
    }
    println!(
        "  zstd-19: snap to the pair mean nearest today's prediction {:.2}, half way there {:.2}",
        z_snap as f64 * 8.0 / nf,
        z_blend as f64 * 8.0 / nf
    );
    println!(
        "  zstd-19 per chunk, bits per new vertex: today {:.2}, edge mean {:.2}, best-of with a selection byte {:.2}",
        z_today as f64 * 8.0 / nf,
        z_mean as f64 * 8.0 / nf,
        z_sel as f64 * 8.0 / nf
    );
    println!("{f}: {n} new vertices");
    println!(
        "  within ±1 per axis: today {:.1} %, edge mean {:.1} %, some pair or mean {:.1} %",
        100.0 * exact_today as f64 / nf,
        100.0 * exact_mean as f64 / nf,
        100.0 * exact_pair as f64 / nf
    );
    println!(
        "  gamma bits per new vertex: today {:.1}, edge mean {:.1}, oracle best-of with choice cost {:.1}",
        b_today / nf,
        b_mean / nf,
        b_oracle / nf
    );
    for (o, name) in ["qvMerge", "qeMerge", "doublet", "smooth"]
        .iter()
        .enumerate()
    {
        if ops[o][0] > 0 {
            println!(
                "  {name}: {} new vertices, {:.1} % within ±1 by some pair or mean",
                ops[o][0],
                100.0 * ops[o][1] as f64 / ops[o][0] as f64
            );
        }
    }
    Ok(())
}
