//! Design study for issue 4 (≤ 30 bits/vertex): how far is today's coding
//! (zigzag varints in five streams, zstd-19 per chunk) from what an entropy
//! coder could reach on the same symbols, and would another byte layout
//! under the same zstd help? Measures only; no format change.
//!
//! `cargo run --release -p pqm-format --example layout_study -- FILE.pqm...`
//!
//! It re-encodes each file's records with the default coding, chunk by chunk
//! along the file's own chunk table (cursors reset per chunk, as the writer
//! does), so `today` reproduces the file's chunk bytes. Per stream it then
//! prints, in bits per refined vertex (vertices appended by records):
//!
//! * `zstd alone`: the stream compressed by itself, chunk by chunk;
//! * `order-0 model`: each value split into a *token* (bit length of its
//!   zigzag / unsigned value) and the bits below the leading one (raw), the
//!   tokens priced at their empirical order-0 entropy per chunk (a static
//!   model that knows the chunk's histogram for free — what an ideal
//!   arithmetic coder without contexts gets, minus its table), raw bits at
//!   one bit each. (ops: the symbol bytes' order-0 entropy.)
//!
//! and whole-chunk layouts (all five streams in one zstd frame, as the
//! file): `today`, the position residuals in one stream per axis
//! (`pos/axis`), positions as token bytes + packed raw bits (`pos/tok+raw`,
//! Exp-Golomb style, zstd then Huffman-codes the tokens), the same for the
//! vertex-cursor deltas (`refs/tok+raw`).
//!
//! ## Figures (14-bit, format 3.1 files by `pqm encode`, default options; 2026-12-01)
//!
//! Bits per refined vertex; per stream zstd alone → order-0 model (the
//! slots stream is empty: 3.1 files hold no local or general records);
//! `Σ model` = the sum of the four models, against the file's real chunks;
//! then the layouts' change of the real chunk bytes:
//!
//! | file | ops | conn | refs | pos | chunks today | Σ model | pos/axis | pos/tok+raw | refs/tok+raw |
//! |---|---|---|---|---|---:|---:|---:|---:|---:|
//! | spot_quadrangulated | 2.37 → 1.98 | 5.55 → 6.27 | 6.60 → 5.62 | 31.83 → 29.19 | 47.37 | 43.06 | +0.74 | −0.17 | +0.28 |
//! | makehuman_base | 2.40 → 2.12 | 6.28 → 6.37 | 7.14 → 6.39 | 27.09 → 25.19 | 44.15 | 40.07 | −0.06 | +0.05 | +0.37 |
//! | loki | 2.17 → 1.91 | 5.52 → 6.44 | 6.98 → 6.18 | 24.55 → 22.89 | 40.64 | 37.42 | −0.19 | −0.18 | +0.19 |
//! | bunny (split) | 2.87 → 2.63 | 5.54 → 5.48 | 11.29 → 9.89 | 22.95 → 21.59 | 45.08 | 39.59 | −0.13 | −0.22 | −0.62 |
//!
//! Reading: an ideal order-0 coder over tokens and raw bits would save
//! 3.2–5.5 bits per refined vertex (7–12 %; conn's varints are better left
//! to zstd, whose matches beat the order-0 model there), and no byte layout
//! under zstd gains more than 0.6. Entropy coding alone cannot take a file
//! from 48–57 to 30 bits per final vertex: even under the model the records
//! cost 37–43 bits per refined vertex, of which the position residuals are
//! 21.6–29.2 (§7.6's predictions) and the anchor references 5.6–9.9. What
//! is left for issue 4 is better prediction (fewer bits of residual) and
//! cheaper anchors, not the coder. (`entropy_study`'s "−7.5 to −9.4 bits with
//! a range coder" compared its model against a per-stream *attribution* of
//! the chunk bytes, on 2.0 files whose local-form connectivity a context
//! model could still squeeze; format 3.0's edge-split form removed most of
//! that.)

use pqm_format::codec::{self, Coding, Cursors, QRecord, CONN, OPS, POS, REFS};
use pqm_format::varint::{put_s, Reader};

#[path = "common/models.rs"]
mod models;

/// MSB-first bit packer.
#[derive(Default)]
struct Bits {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl Bits {
    fn put(&mut self, v: u64, n: u32) {
        for i in (0..n).rev() {
            self.acc = self.acc << 1 | (v >> i & 1);
            self.n += 1;
            if self.n == 8 {
                self.out.push(self.acc as u8);
                self.acc = 0;
                self.n = 0;
            }
        }
    }
    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push((self.acc << (8 - self.n)) as u8);
        }
        self.out
    }
}

/// Token (bit length of `z`) and the bits below the leading one.
fn tok(z: u64) -> (u8, u64, u32) {
    let b = 64 - z.leading_zeros();
    let n = b.saturating_sub(1);
    (b as u8, z & ((1u64 << n) - 1), n)
}

/// Values of a varint stream, zigzag-decoded when `signed` (as zigzag
/// values: the token is taken of those).
fn values(s: &[u8]) -> Vec<u64> {
    let mut r = Reader::new(s, "x");
    let mut v = Vec::new();
    while r.remaining() > 0 {
        v.push(r.u().expect("varint"));
    }
    v
}

/// Order-0 entropy (bits) of `syms`.
fn entropy(syms: impl Iterator<Item = u8>) -> f64 {
    let mut hist = [0usize; 256];
    let mut n = 0usize;
    for s in syms {
        hist[s as usize] += 1;
        n += 1;
    }
    let n = n.max(1) as f64;
    hist.iter()
        .filter(|&&c| c > 0)
        .map(|&c| -(c as f64) * (c as f64 / n).log2())
        .sum()
}

/// Tokens (one byte each) and packed raw bits of `vals`.
fn tok_raw(vals: &[u64]) -> (Vec<u8>, Vec<u8>, f64) {
    let mut t = Vec::with_capacity(vals.len());
    let mut raw = Bits::default();
    let mut nraw = 0.0;
    for &z in vals {
        let (b, bits, n) = tok(z);
        t.push(b);
        raw.put(bits, n);
        nraw += n as f64;
    }
    (t, raw.finish(), nraw)
}

fn main() {
    models::study_files("layout_study", study);
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

    let layouts = ["today", "pos/axis", "pos/tok+raw", "refs/tok+raw"];
    let mut tot = [0usize; 4];
    // per stream (ops, conn, refs, pos): zstd alone, order-0 bound (bits)
    let streams = [(OPS, "ops"), (CONN, "conn"), (REFS, "refs"), (POS, "pos")];
    let mut alone = [0usize; 4];
    let mut bound = [0f64; 4];
    let mut file_chunks = 0usize;
    let mut k = 0usize;
    for c in dec.chunks() {
        file_chunks += c.compressed_len as usize;
        let mut s: [Vec<u8>; 5] = Default::default();
        let mut cur = Cursors::default();
        for _ in 0..c.record_count {
            let r = QRecord::quantized(&pm.records[k], &quant);
            codec::encode_record(&st, &r, &mut cur, &mut s, coding);
            st.apply(&r);
            k += 1;
        }
        let p: [&[u8]; 5] = [&s[0], &s[1], &s[2], &s[3], &s[4]];
        tot[0] += models::zstd19(&p);
        for (i, &(t, _)) in streams.iter().enumerate() {
            alone[i] += models::zstd19(&[p[t]]);
            bound[i] += if t == OPS {
                entropy(s[t].iter().copied())
            } else {
                let (tk, _, nraw) = tok_raw(&values(&s[t]));
                entropy(tk.into_iter()) + nraw
            };
        }
        let pos = values(&s[POS]);
        let mut ax: [Vec<u8>; 3] = Default::default();
        for (i, &z) in pos.iter().enumerate() {
            put_s(&mut ax[i % 3], pqm_format::varint::unzigzag(z));
        }
        tot[1] += models::zstd19(&[p[0], p[1], p[2], p[3], &ax[0], &ax[1], &ax[2]]);
        let (t, raw, _) = tok_raw(&pos);
        tot[2] += models::zstd19(&[p[0], p[1], p[2], p[3], &t, &raw]);
        let (rt, rraw, _) = tok_raw(&values(&s[REFS]));
        tot[3] += models::zstd19(&[p[0], p[1], &rt, &rraw, p[3], p[4]]);
    }
    let b = |x: f64| x * 8.0 / refined;
    println!(
        "{f}: {k} records, {refined:.0} refined vertices; the file's chunks {:.2} bits/refined vertex",
        b(file_chunks as f64)
    );
    for (i, &(_, name)) in streams.iter().enumerate() {
        println!(
            "  {name:5} zstd alone {:6.2}, order-0 model {:6.2}",
            b(alone[i] as f64),
            bound[i] / refined
        );
    }
    for (n, t) in layouts.iter().zip(&tot) {
        println!(
            "  {n:14} {:6.2} ({:+.2})",
            b(*t as f64),
            b(*t as f64 - tot[0] as f64)
        );
    }
    Ok(())
}
