//! Design study for issue 4 (≤ 30 bits/vertex): can the position
//! residuals' geometric context be used *under zstd*, with no arithmetic
//! coder? Each residual `r` is split Golomb-Rice style: `zigzag(r) >> k`
//! as a varint (a stream zstd models) and the `k` bits below it raw (a
//! packed bit stream), where `k` comes from something the decoder already
//! knows. Measures only; no format change (see the prototype below).
//!
//! `cargo run --release -p pqm-format --example rice_study -- FILE.pqm...`
//!
//! Per new vertex (records re-read as `midpoint_study` does): the version-4
//! stencil prediction (§7.6), and two local scales a decoder can compute
//! before it reads the residual: `spread` = the mean L1 distance of the
//! known edge neighbours to their mean, and `bend` = the L1 distance
//! between the parallelogram mean and the edge neighbours' mean (how far
//! the stencil's two parts disagree). Bits per new vertex, zstd-19 per
//! chunk of the file:
//!
//! * `today`: svarint residuals (what the file's `pos` stream holds);
//! * `rice spread − c`: `k = max(0, bucket(spread) − c)`;
//! * `rice adaptive`: `k` from running magnitude sums per context (axis ×
//!   spread bucket), as JPEG-LS does (`A`, `N`, halved at `N = 64`);
//! * `ideal`: an adaptive Elias-gamma model with the spread bucket as
//!   context (what an arithmetic coder would spend; the bound);
//! * `k=N`: a constant `k` (no context);
//! * `RULE bitlen(S/c) − C`: the rule a format would define — `S` the sum
//!   over the stencil's quads of `Σ_axis |n1 − n3|` (their *span*), `c`
//!   their count, `k = max(0, bitlen(⌊S / c⌋) − C)`, 0 without a quad;
//! * `PER-RECORD scale − C`: one `k` per record, from its first new
//!   vertex's `⌊S / c⌋` (the same for one-vertex records);
//! * `best offset per chunk`: the smallest of the `RULE` columns and `k = 0`
//!   in each chunk (what a per-chunk offset byte could reach);
//! * `BEND`: `k` from the stencil's own sums, `B = Σ_axis |nb − 2 op|`;
//! * bucketed variants: `rice bend − C` (the L1 gap between the
//!   parallelogram mean and the edge neighbours' mean), `span − C`,
//!   `spread+2bend − C`, `span+4bend − C` (their bucket minus `C`), and
//!   the adaptive `k` with the bend's bucket as a second context.
//!
//! Then the same splits of the `refs` and `conn` streams (they lose).
//!
//! ## Figures (session 18's bench files, format 4.0; 2026-12-06)
//!
//! Bits per new vertex, `pos` alone, zstd-19 per chunk:
//!
//! | file | today | `k = 3` | rule, `C = 6` | per record, `C = 6` | best `C` per chunk | ideal (axis × spread) |
//! |---|---|---|---|---|---|---|
//! | spot_quadrangulated | 30.59 | 28.26 | 27.58 | 27.72 | 27.52 | 28.12 |
//! | makehuman_base | 23.36 | 22.19 | 21.46 | 21.56 | 21.45 | 21.47 |
//! | loki | 22.80 | 21.78 | 21.15 | 21.32 | 21.14 | 21.05 |
//! | bunny (split) | 20.48 | 20.04 | 19.72 | 19.85 | 19.64 | 19.21 |
//! | fertility (split) | 24.83 | 23.19 | 22.87 | 23.01 | 22.86 | 22.70 |
//! | skull (split) | 20.02 | 19.54 | 19.09 | 19.23 | 19.06 | 18.81 |
//! | amo (split) | 17.16 | 17.32 | 17.10 | 17.18 | 16.86 | 16.50 |
//!
//! `C = 6` was the best of 3–10 on every mesh within 0.06 bits (amo:
//! `C = 7`, 16.89); `spread`
//! and `bend` did 0.1–0.5 bits worse than the span; a sum of two scales,
//! bucketed (`span+4bend`, `spread+2bend`), 0.1–0.3 better at its best
//! offset (loki 20.92, spot 27.43, makehuman 21.16, bunny 19.54): room for
//! a finer rule. On the quad meshes the
//! split gets within 0.1 bits of what the adaptive model would spend, with
//! no arithmetic decoder (the split triangle meshes stay 0.2–0.6 bits
//! short of it): the gain is the varint's low byte, which mixes
//! near-random low bits with zstd's symbols. `refs` and `conn` lose under any `k`.
//!
//! **Format 5.0 prototype** (branch `s21-rice`, not merged):
//! `C = 6` and the span rule in the spec (§7.6, a new §7.11, a sixth
//! stream `posbits` cut into a zstd block of its own), the Rust writer and
//! reader, the JavaScript reader, three 5.0 vectors. Whole files, the same
//! records, 4.0 → 5.0: spot 18,335 → 17,342 B (−5.4 %), makehuman 99,253 →
//! 95,893 (−3.4 %), loki 136,789 → 132,503 (−3.1 %), bunny 1,164,046 →
//! 1,153,401 (−0.9 %), fertility −2.8 %, skull −1.3 %, amo +0.2 %;
//! geometry bits per final vertex spot 43.98 → 41.27, makehuman 35.29 →
//! 33.88, loki 35.61 → 34.37, bunny 34.39 → 33.98. Decoding cost
//! (callgrind, one forward-only decode, the 4.0 decoder on the 4.0 file →
//! the prototype on the 5.0 file): loki 39.48 → 43.05 M instructions
//! (+9.0 %), makehuman 26.59 → 28.49 M (+7.1 %): the span summed over
//! every stencil quad (the edge split's ≈ 12 per record), the bit reads
//! and `k`; `decode_loop` (reused, medians over 8 names) loki 10.21 →
//! 9.58 M faces/s; the JavaScript decoder 5–8 % slower on loki and
//! makehuman. Not merged: 1–5 % smaller files for 7–9 % more decoding,
//! against issue 4's two targets, the nearer of which (10 M faces/s) it
//! would move away. A second variant with one `k` per record (the
//! `PER-RECORD` column, 85–90 % of the gain) still cost loki +7.6 %: most
//! of the cost is plumbing, which the same build paid on the 4.0 file too
//! (+4.3 %). The lead: a reader of its own for `pos` and its bits, `k`
//! once per record, and the 4.0 path measured first (`docs/figures-history.md`,
//! session 21).

use pqm_format::codec::QRecord;
use pqm_format::varint::{put_u, zigzag};

#[path = "common/models.rs"]
mod models;

/// Packed raw bits, LSB first.
#[derive(Default)]
struct Bits {
    n: usize,
}

impl Bits {
    fn bytes(&self) -> usize {
        self.n.div_ceil(8)
    }
}

/// A Rice-split stream: high parts as varints, low parts as raw bits.
#[derive(Default)]
struct Rice {
    hi: Vec<u8>,
    lo: Bits,
    total: usize,
    /// Bytes per chunk.
    chunks: Vec<usize>,
}

impl Rice {
    fn put(&mut self, r: i64, k: u32) {
        let u = zigzag(r);
        put_u(&mut self.hi, u >> k);
        self.lo.n += k as usize;
    }
    fn flush(&mut self) {
        if !self.hi.is_empty() || self.lo.n > 0 {
            let b = models::zstd19(&[&self.hi]) + self.lo.bytes();
            self.total += b;
            self.chunks.push(b);
        }
        self.hi.clear();
        self.lo = Bits::default();
    }
}

/// JPEG-LS-style running magnitude per context.
#[derive(Clone, Copy)]
struct Run {
    a: u64,
    n: u64,
}

impl Run {
    fn k(&self) -> u32 {
        let mut k = 0;
        while (self.n << k) < self.a && k < 24 {
            k += 1;
        }
        k
    }
    fn add(&mut self, u: u64) {
        self.a += u;
        self.n += 1;
        if self.n >= 64 {
            self.a >>= 1;
            self.n >>= 1;
        }
    }
}

const CS: [u32; 6] = [3, 4, 5, 6, 7, 8];

fn main() {
    models::study_files("rice_study", study);
    models::study_files("rice_study", study_streams);
}

/// The other streams (`refs`, `conn`), re-encoded chunk by chunk as
/// `layout_study` does: zstd-19 of the varints against Rice splits with a
/// constant `k` and with JPEG-LS's running `k` (one context per stream).
fn study_streams(f: &str) -> Result<(), String> {
    use pqm_format::codec::{self, Coding, Cursors, CONN, REFS};
    let models::Opened {
        dec,
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let refined = (pm.final_vertex_count() - pm.base.positions.len()).max(1) as f64;
    let mut k = 0usize;
    let names = [(REFS, "refs"), (CONN, "conn")];
    let mut base = [0usize; 2];
    let mut cons: Vec<[usize; 2]> = vec![[0; 2]; 6];
    let mut adap = [0usize; 2];
    for c in dec.chunks() {
        let mut s: [Vec<u8>; 5] = Default::default();
        let mut cur = Cursors::default();
        for _ in 0..c.record_count {
            let r = QRecord::quantized(&pm.records[k], &quant);
            codec::encode_record(&st, &r, &mut cur, &mut s, Coding::default());
            st.apply(&r);
            k += 1;
        }
        for (i, &(t, _)) in names.iter().enumerate() {
            base[i] += models::zstd19(&[&s[t]]);
            let mut rd = pqm_format::varint::Reader::new(&s[t], "x");
            let mut vals = Vec::new();
            while rd.remaining() > 0 {
                vals.push(rd.u().expect("varint"));
            }
            for (kk, row) in cons.iter_mut().enumerate() {
                let mut r = Rice::default();
                for &v in &vals {
                    put_u(&mut r.hi, v >> kk);
                    r.lo.n += kk;
                }
                r.flush();
                row[i] += r.total;
            }
            let mut r = Rice::default();
            let mut run = Run { a: 4, n: 1 };
            for &v in &vals {
                let kk = run.k();
                put_u(&mut r.hi, v >> kk);
                r.lo.n += kk as usize;
                run.add(v);
            }
            r.flush();
            adap[i] += r.total;
        }
    }
    let b = |x: usize| x as f64 * 8.0 / refined;
    for (i, &(_, name)) in names.iter().enumerate() {
        print!("{f} {name}: zstd {:.2}", b(base[i]));
        for (kk, row) in cons.iter().enumerate() {
            print!(", k={kk} {:.2}", b(row[i]));
        }
        println!(", running k {:.2} (bits per refined vertex)", b(adap[i]));
    }
    Ok(())
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened {
        dec,
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let ends = models::chunk_ends(&dec);
    let mut today = Vec::new();
    let mut z_today = 0usize;
    let mut fixed: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut fixed_b: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut constant: Vec<Rice> = (0..8).map(|_| Rice::default()).collect();
    let mut mixed: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut spanned: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut exact: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut per_record: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut exact_b: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut no_quad = 0usize;
    let mut spanned2: Vec<Rice> = CS.iter().map(|_| Rice::default()).collect();
    let mut adaptive = Rice::default();
    let mut adaptive_s = Rice::default();
    let mut runs = vec![Run { a: 4, n: 1 }; 3 * 32];
    let mut runs_s = vec![Run { a: 4, n: 1 }; 3 * 32 * 4];
    let mut ideal = models::Gamma::default();
    let mut ideal_plain = models::Gamma::default();
    let (mut c_ideal, mut c_plain) = (0f64, 0f64);
    let mut n = 0usize;
    let mut hist = [0usize; 32];
    // Every split ends its chunk here: at each chunk end and after the
    // last record (one list, so that no split is left out of either).
    macro_rules! flush_all {
        () => {
            fixed
                .iter_mut()
                .chain(fixed_b.iter_mut())
                .chain(constant.iter_mut())
                .chain(mixed.iter_mut())
                .chain(spanned.iter_mut())
                .chain(exact.iter_mut())
                .chain(per_record.iter_mut())
                .chain(exact_b.iter_mut())
                .chain(spanned2.iter_mut())
                .for_each(Rice::flush);
            adaptive.flush();
            adaptive_s.flush();
        };
    }
    for (ri, rec) in pm.records.iter().enumerate() {
        if ends.contains(&ri) {
            z_today += models::zstd19(&[&today]);
            today.clear();
            flush_all!();
            // Chunks stay independent: the running sums start again.
            runs.fill(Run { a: 4, n: 1 });
            runs_s.fill(Run { a: 4, n: 1 });
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
        let qmax = quant.qmax() as i64;
        // One scale per record: the first new vertex's stencil span.
        let mut rec_scale: Option<i64> = None;
        for (i, c) in r.new_pos.iter().enumerate() {
            let x = v0 + i as u32;
            let xc = c.map(|t| t as i64);
            let known = |u: u32| u < x;
            let (mut nb, mut op, mut cnt) = ([0i64; 3], [0i64; 3], 0i64);
            let mut span = 0i64;
            let mut e: Vec<u32> = Vec::new();
            let mut first: Option<[u32; 3]> = None;
            for q in &quads {
                let Some(k) = q.iter().position(|&u| u == x) else {
                    continue;
                };
                let (n1, o, n3) = (q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]);
                first.get_or_insert([n1, o, n3]);
                if known(n1) && known(o) && known(n3) {
                    for t in 0..3 {
                        nb[t] += code[n1 as usize][t] + code[n3 as usize][t];
                        op[t] += code[o as usize][t];
                        span += (code[n1 as usize][t] - code[n3 as usize][t]).abs();
                    }
                    cnt += 1;
                }
                for u in [n1, n3] {
                    if known(u) && !e.contains(&u) {
                        e.push(u);
                    }
                }
            }
            // §7.6: the stencil, else version 1's rule on the first quad.
            let pred: [i64; 3] = if cnt > 0 {
                [0, 1, 2].map(|t| ((5 * nb[t] - 2 * op[t]).div_euclid(8 * cnt)).clamp(0, qmax))
            } else if let Some([n1, o, n3]) = first {
                let ks: Vec<u32> = [n1, o, n3].into_iter().filter(|&u| known(u)).collect();
                if ks.is_empty() {
                    if x > v0 {
                        code[(x - 1) as usize]
                    } else {
                        [qmax / 2 + 1; 3]
                    }
                } else {
                    [0, 1, 2].map(|t| {
                        ks.iter().map(|&u| code[u as usize][t]).sum::<i64>() / ks.len() as i64
                    })
                }
            } else if x > v0 {
                code[(x - 1) as usize]
            } else {
                [qmax / 2 + 1; 3]
            };
            // Scales the decoder knows before the residual.
            let spread = if e.is_empty() {
                0
            } else {
                let m: [i64; 3] = [0, 1, 2]
                    .map(|t| e.iter().map(|&u| code[u as usize][t]).sum::<i64>() / e.len() as i64);
                e.iter()
                    .map(|&u| {
                        (0..3)
                            .map(|t| (code[u as usize][t] - m[t]).abs())
                            .sum::<i64>()
                    })
                    .sum::<i64>()
                    / e.len() as i64
            };
            let bend = if cnt > 0 {
                (0..3)
                    .map(|t| ((nb[t] - op[t]) - nb[t] / 2).abs() / cnt)
                    .sum::<i64>()
            } else {
                spread
            };
            if rec_scale.is_none() && cnt > 0 {
                rec_scale = Some(span / cnt);
            }
            // `bitlen(v) − c`, 0 without a stencil quad.
            let rule = |v: i64, c: u32| {
                if cnt > 0 {
                    (64 - (v as u64).leading_zeros()).saturating_sub(c)
                } else {
                    0
                }
            };
            // Bend as a format could define it, from the stencil's own
            // sums: B = Σ_axis |nb − 2 op|.
            let bsum: i64 = (0..3).map(|a| (nb[a] - 2 * op[a]).abs()).sum();
            let sb = models::bucket(spread as u64).min(31);
            let bb = models::bucket(bend as u64).min(31);
            hist[sb] += 1;
            if cnt == 0 {
                no_quad += 1;
            }
            for t in 0..3 {
                let res = xc[t] - pred[t];
                pqm_format::varint::put_s(&mut today, res);
                for (j, &cc) in CS.iter().enumerate() {
                    fixed[j].put(res, (sb as u32).saturating_sub(cc));
                    fixed_b[j].put(res, (bb as u32).saturating_sub(cc));
                }
                for (k, c) in constant.iter_mut().enumerate() {
                    c.put(res, k as u32);
                }
                let mb = models::bucket((spread + 2 * bend) as u64) as u32;
                let sp = if cnt > 0 { span / cnt } else { spread };
                // The rule as a format would define it: k = bitlen(⌊S / c⌋) − C, 0 without a quad.
                for (j, &cc) in CS.iter().enumerate() {
                    exact[j].put(res, rule(span / cnt.max(1), cc));
                    let rs = rec_scale.unwrap_or(0) as u64;
                    per_record[j].put(res, (64 - rs.leading_zeros()).saturating_sub(cc));
                    exact_b[j].put(res, rule(bsum / cnt.max(1), cc - 1));
                }
                for (j, &cc) in CS.iter().enumerate() {
                    spanned[j].put(res, (models::bucket(sp as u64) as u32).saturating_sub(cc));
                    spanned2[j].put(
                        res,
                        (models::bucket((sp + 4 * bend) as u64) as u32).saturating_sub(cc),
                    );
                }
                for (j, &cc) in CS.iter().enumerate() {
                    mixed[j].put(res, mb.saturating_sub(cc));
                }
                let ctx = t * 32 + sb;
                let k = runs[ctx].k();
                adaptive.put(res, k);
                runs[ctx].add(zigzag(res));
                let ctx_s = ctx * 4 + (bb.min(15) / 4);
                let k = runs_s[ctx_s].k();
                adaptive_s.put(res, k);
                runs_s[ctx_s].add(zigzag(res));
                c_ideal += ideal.cost_signed_m((t as u64) << 6 | sb as u64, res);
                c_plain += ideal_plain.cost_signed_m(t as u64, res);
            }
            n += 1;
            code.push(xc);
        }
        st.apply(&r);
    }
    z_today += models::zstd19(&[&today]);
    flush_all!();
    let per = |b: usize| b as f64 * 8.0 / n.max(1) as f64;
    println!("## {f}: {n} new vertices, bits per new vertex");
    println!("today (svarint, zstd-19 per chunk): {:.2}", per(z_today));
    for (j, &cc) in CS.iter().enumerate() {
        println!(
            "rice spread − {cc}: {:.2}   rice bend − {cc}: {:.2}",
            per(fixed[j].total),
            per(fixed_b[j].total)
        );
    }
    for (k, c) in constant.iter().enumerate() {
        print!("k={k}: {:.2}  ", per(c.total));
    }
    println!();
    for (j, &cc) in CS.iter().enumerate() {
        print!("spread+2bend − {cc}: {:.2}  ", per(mixed[j].total));
    }
    println!();
    for (j, &cc) in CS.iter().enumerate() {
        print!("span − {cc}: {:.2}  ", per(spanned[j].total));
    }
    println!();
    for (j, &cc) in CS.iter().enumerate() {
        print!("RULE bitlen(S/c) − {cc}: {:.2}  ", per(exact[j].total));
    }
    println!("  ({no_quad} new vertices without a stencil quad)");
    // The best offset per chunk (k = 0 included: `today`'s chunk sizes are
    // the k = 0 column of `constant`).
    let n_chunks = exact[0].chunks.len();
    let mut best = 0usize;
    for c in 0..n_chunks {
        let mut m = constant[0].chunks[c];
        for e in &exact {
            m = m.min(e.chunks[c]);
        }
        best += m;
    }
    for (j, &cc) in CS.iter().enumerate() {
        print!("PER-RECORD scale − {cc}: {:.2}  ", per(per_record[j].total));
    }
    println!();
    println!(
        "best offset per chunk (3–8 or k = 0): {:.2} over {n_chunks} chunks",
        per(best)
    );
    for (j, &cc) in CS.iter().enumerate() {
        print!(
            "BEND bitlen(B/c) − {}: {:.2}  ",
            cc - 1,
            per(exact_b[j].total)
        );
    }
    println!();
    for (j, &cc) in CS.iter().enumerate() {
        print!("span+4bend − {cc}: {:.2}  ", per(spanned2[j].total));
    }
    println!();
    println!(
        "rice adaptive (axis × spread): {:.2}; (axis × spread × bend): {:.2}",
        per(adaptive.total),
        per(adaptive_s.total)
    );
    println!(
        "ideal adaptive gamma: no context {:.2}, axis × spread {:.2}",
        c_plain / n.max(1) as f64,
        c_ideal / n.max(1) as f64
    );
    println!("spread buckets: {:?}", &hist[..20]);
    Ok(())
}
