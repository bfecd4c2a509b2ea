//! Design study for issue 4 (≤ 30 bits/vertex): where could the next halving
//! of `.pqm` bits come from? No format or encoder change — this example only
//! measures.
//!
//! `cargo run --release -p pqm-format --example entropy_study -- FILE.pqm...`
//!
//! For each file it decodes the records (public API), re-encodes them one by
//! one with [`codec::encode_record`] (default [`codec::Coding`], one cursor
//! run over the whole file — the real encoder resets the cursors at every
//! chunk, a negligible difference) and parses every record's five streams
//! back into named fields. It then prints, on the same records:
//!
//! 1. **Today's bits** (zstd-19 per chunk of zigzag varints, from the
//!    encoder's report, as `examples/streams.rs`) against the **ideal cost
//!    under simple adaptive models** — what a range coder would reach within
//!    ~1–3 %: every field has its own adaptive order-0 frequency table
//!    (Krichevsky–Trofimov estimate, counts start empty, so learning cost is
//!    included). Small integers are coded directly (alphabet 0..31, larger
//!    values escape to the next scheme); counts, deltas and residuals use an
//!    Elias-gamma *bucket* (bit length of |v|+1, adaptive) + a sign bit (when
//!    ≠ 0) + raw low bits. Position residuals are priced with several
//!    contexts for the bucket: none; the previous coordinate's bucket; the
//!    record form × moved/new × axis; the level fraction (tenths of the
//!    record sequence); and all three combined (`pos.ctx-all`, the one used in
//!    the totals). All figures are bits per refined vertex (vertices
//!    appended by records).
//! 2. **Anchors if records were reordered**: consecutive records are grouped
//!    greedily (file order) into batches whose touched vertex sets (anchor,
//!    old and new corners of rewritten faces, appended faces' corners, moved
//!    vertices) are disjoint; inside a batch the anchors are sorted and coded
//!    as gaps (Elias-gamma ideal, and adaptive gamma buckets), the first one
//!    of a batch as its absolute id. Also `log2 C(V, k)` per batch, the cost of
//!    naming an unordered set of k anchors among V vertices. This estimates
//!    what a batched coarsener (each batch an independent set, decoded in id
//!    order) would pay; it ignores that reordering records renumbers the
//!    vertices they append. Then, on the file's own order, anchors named
//!    in a list of the vertices the last records touched (each record puts
//!    its anchor, new vertices and its quads' corners at the front; 64
//!    entries): an adaptive hit flag, then the entry's index or today's
//!    delta. Session 20: loki 10.31 → 9.28 bits per anchor (5.49 → 4.95
//!    per refined vertex; 65 % misses, 15 % the previous record's anchor),
//!    spot 8.81 → 8.27 — about half a bit per vertex, too little for a
//!    format change.
//! 3. **Position prediction alternatives** for the new vertex of every
//!    record, each priced by the same adaptive model (context: previous
//!    coordinate's bucket, one model per predictor): today's §7.6 prediction
//!    (the residual in the file), the mean of the vertex's known edge
//!    neighbours in the record's quads, the mean of all parallelograms
//!    `a + b − d` with known corners, and their average ("butterfly-like").
//!
//! ## Figures (14-bit positions; files by `pqm encode` of main at 4a27f4a; 2026-11-22)
//!
//! Record streams, bits per refined vertex, today (zstd) → ideal adaptive:
//!
//! | file | ops | conn | refs | slots | pos | records |
//! |---|---|---|---|---|---|---|
//! | loki | 2.27 → 2.63 | 27.33 → 22.94 | 7.09 → 5.82 | 3.15 → 2.69 | 26.10 → 22.71 | 65.95 → 56.79 |
//! | makehuman_base | 2.67 → 2.98 | 25.84 → 20.72 | 7.51 → 6.23 | 2.82 → 2.38 | 28.51 → 25.30 | 67.35 → 57.62 |
//! | spot_quadrangulated | 2.36 → 2.70 | 26.38 → 22.90 | 6.31 → 5.19 | 3.09 → 2.69 | 33.34 → 29.26 | 71.48 → 62.74 |
//! | bunny (tri) | 2.96 → 4.98 | 14.84 → 11.10 | 12.22 → 9.98 | 1.37 → 1.10 | 24.72 → 21.51 | 56.10 → 48.68 |
//!
//! (ops: zstd beats order-0, order-1 and order-2 symbol models, by 0.3 —
//! 1.6; keep the symbols in zstd or find a better context. "Today" per
//! stream is the encoder's attribution — each stream compressed alone, the
//! chunk's real size shared in proportion — not an exact split.) Per record, ideal, loki:
//! qvMerge 5.0 ops + 3.3 conn + 11.2 anchor + 24.5 pos bits; qeMerge (4 new
//! vertices) 2.1 + **134.8 conn** + 10.6 + **16.7 slots** + 86.0 pos; the
//! local-form corner codes alone are 17.1 bits/refined vertex (13.9 with a
//! context of form × corner position × previous code), masks 4.5.
//!
//! Whole file per final vertex: the optional `VORD` section is 11.9 (loki),
//! 7.5 (makehuman), 10.8 (spot), 19.0 (bunny); the base mesh costs 74, 50,
//! 82, 93 bits per *base* vertex (5.4, 12.6, 7.3, 0.5 per final vertex).
//!
//! Anchors (loki): today 11.4 bits/anchor (ideal adaptive); greedy batches
//! of consecutive records are tiny (1.24 records, worse: 14.0); layering by
//! dependency depth gives 575 batches of 22.9 anchors: 10.8 bits/anchor with
//! adaptive gamma gaps, 9.2 as the `log2 C(V, k)` set bound (bunny: 12.5 →
//! 10.0 / 7.5 with 187 anchors per batch).
//!
//! New-vertex positions (loki, bits/new vertex, same model): today 22.7,
//! edge mean 22.1, parallelograms 22.8, blend 22.2; bunny 21.3 / 18.9 /
//! 21.3 / 19.8. A neighbourhood-scale context and a modelled mantissa bit
//! gain < 0.15 on the quad meshes (and lose up to 1.2 on spot: context
//! dilution), 0.6–0.8 on bunny.
//!
//! Ranked (bits per *final* vertex, loki / makehuman / spot / bunny; file
//! today 78.7 / 70.8 / 83.8 / 75.5): drop `VORD` (an encoder option) −11.9 /
//! −7.5 / −10.8 / −19.0; range coder with adaptive models on conn, refs,
//! slots, pos −8.8 / −7.5 / −8.3 / −9.4; a qeMerge edge-split form
//! (operators.md's inverse: half-edge + 4 wing indices + 2 fan sides, ≈ 22
//! bits instead of ≈ 162 per record — an *estimate*, not measured; it also
//! makes the corner-code context moot, which alone gives −3.0 / −1.2 / −1.7 /
//! −1.1) −20.9 / −14.9 / −20.2 / −9.2; single-rate base mesh at ≈ 25 bits
//! per base vertex (estimate) −3.6 / −6.3 / −5.0 / −0.4; edge-mean
//! prediction −0.6 / −0.4 / −0.4 / −2.4; batched anchors −0.3 / −0.3 /
//! −0.4 / −2.0. All together ≈ 33 / 34 / 39 / 33 bits per final vertex.

use pqm_format::codec::{self, Coding, Cursors, MeshState, QRecord, CONN, OPS, POS, REFS, SLOTS};
use pqm_format::varint::Reader;
use pqm_format::{write_to_vec, EncodeOptions};
use std::collections::{BTreeMap, HashMap, HashSet};

const OP_NAMES: [&str; 4] = ["qvMerge", "qeMerge", "doublet", "smooth"];
/// Residual models of part 3.
const MODELS: [&str; 3] = [
    "ctx prev bucket",
    "ctx prev bucket + neighbourhood scale",
    "ctx prev + scale, 1 modelled mantissa bit",
];
const PREDICTORS: [&str; 4] = [
    "today §7.6",
    "edge mean",
    "parallelograms",
    "½ mean + ½ par",
];
const FORM_NAMES: [&str; 4] = ["general", "split", "local", "face-split"];

#[path = "common/models.rs"]
mod models;
use models::{bucket, Freq, Gamma, Small};

/// Entries of part 2b's list of recently touched vertices.
const RECENT: usize = 64;

/// Ideal Elias-gamma length of `v ≥ 0` (coded as v + 1).
fn gamma_len(v: u64) -> f64 {
    (2 * bucket(v) - 1) as f64
}

/// log2 of the binomial coefficient C(n, k).
fn log2_binom(n: u64, k: u64) -> f64 {
    let mut s = 0.0;
    for i in 0..k {
        s += ((n - i) as f64).log2() - ((i + 1) as f64).log2();
    }
    s
}

/// All models and accumulators of one file.
#[derive(Default)]
struct Study {
    small: HashMap<&'static str, Small>,
    gamma: HashMap<&'static str, Gamma>,
    /// Ideal bits per (stream, field).
    field: BTreeMap<(usize, &'static str), f64>,
    /// Ideal bits per op kind and stream.
    per_op: [[f64; 5]; 4],
    /// Bits of the current record per stream.
    rec: [f64; 5],
    /// Previous symbol byte and the op/form bits of the one before it
    /// (contexts of the order-1 / order-2 symbol models).
    prev_sym: u8,
    prev2: u64,
}

impl Study {
    fn small(&mut self, stream: usize, name: &'static str, ctx: u64, v: u64) {
        let b = self.small.entry(name).or_default().cost(ctx, v);
        self.add(stream, name, b);
    }
    fn signed(&mut self, stream: usize, name: &'static str, ctx: u64, v: i64) {
        let b = self.gamma.entry(name).or_default().cost_signed(ctx, v);
        self.add(stream, name, b);
    }
    fn add(&mut self, stream: usize, name: &'static str, b: f64) {
        *self.field.entry((stream, name)).or_default() += b;
        self.rec[stream] += b;
    }
    /// A field priced only for the field table (alternative models).
    fn side(&mut self, stream: usize, name: &'static str, ctx: u64, v: i64) {
        let b = self.gamma.entry(name).or_default().cost_signed(ctx, v);
        *self.field.entry((stream, name)).or_default() += b;
    }
}

/// Everything one record's streams say, by field.
struct Parsed {
    form: u8,
    anchor: Option<u32>,
    /// Position residuals of moved vertices, then of new vertices.
    moved_res: Vec<[i64; 3]>,
    new_res: Vec<[i64; 3]>,
}

fn parse(
    s: &[Vec<u8>; 5],
    st: &MeshState,
    cur_before: u32,
    r: &QRecord,
    level: f64,
    y: &mut Study,
) -> Result<Parsed, String> {
    let mut rd = [0, 1, 2, 3, 4].map(|t| Reader::new(&s[t], codec::STREAM_NAMES[t]));
    let sym = rd[OPS].byte()?;
    let form = (sym >> 2) & 3;
    let opf = (sym & 3) as u64 | (form as u64) << 2;
    y.small(OPS, "symbol", 0, sym as u64);
    // Order-1 alternative (previous symbol's op and form), table only.
    {
        let b = y
            .small
            .entry("symbol|prev")
            .or_default()
            .cost((y.prev_sym & 15) as u64, sym as u64);
        *y.field.entry((OPS, "symbol|prev (alt)")).or_default() += b;
        let b = y
            .small
            .entry("symbol|prev2")
            .or_default()
            .cost(y.prev2 << 8 | (y.prev_sym & 15) as u64, sym as u64);
        *y.field.entry((OPS, "symbol|prev 2 (alt)")).or_default() += b;
    }
    y.prev2 = (y.prev_sym & 15) as u64;
    y.prev_sym = sym;
    let mut anchor = None;
    let mut n_moved = 0usize;
    let n_new = r.new_pos.len();
    match form {
        1 | 3 => {
            let d = rd[REFS].s()?;
            let m = (cur_before as i64 + d) as u32;
            anchor = Some(m);
            y.signed(REFS, "anchor delta", form as u64, d);
            if form == 1 {
                let l = st.star(m)?.link.len() as u64;
                let i = rd[CONN].u()?;
                let e = rd[CONN].u()?;
                y.small(CONN, "split i", l.min(16), i);
                y.small(CONN, "split e", l.min(16), e);
                if sym & 0x40 != 0 {
                    n_moved = 1;
                }
            } else {
                let x = rd[CONN].u()?;
                y.small(CONN, "face-split x", 0, x);
            }
        }
        _ => {
            let local = form == 2;
            if local {
                let d = rd[REFS].s()?;
                anchor = Some((cur_before as i64 + d) as u32);
                y.signed(REFS, "anchor delta", 2, d);
            }
            let c = [0, 1, 2, 3].map(|_| rd[CONN].u());
            let [nn, nm, nr, na] = [c[0].clone()?, c[1].clone()?, c[2].clone()?, c[3].clone()?];
            y.small(CONN, "count new", opf, nn);
            y.small(CONN, "count moved", opf, nm);
            y.small(CONN, "count rewritten", opf, nr);
            y.small(CONN, "count appended", opf, na);
            n_moved = nm as usize;
            if local {
                for t in 0..nr {
                    let v = rd[SLOTS].u()?;
                    y.small(
                        SLOTS,
                        if t == 0 {
                            "local rw first"
                        } else {
                            "local rw gap"
                        },
                        0,
                        v,
                    );
                }
                for t in 0..nm {
                    let v = rd[SLOTS].u()?;
                    y.small(
                        SLOTS,
                        if t == 0 {
                            "local moved first"
                        } else {
                            "local moved gap"
                        },
                        0,
                        v,
                    );
                }
            } else {
                for _ in 0..nm {
                    let d = rd[REFS].s()?;
                    y.signed(REFS, "general moved ref", 0, d);
                }
                for t in 0..nr {
                    if t == 0 {
                        let d = rd[SLOTS].s()?;
                        y.signed(SLOTS, "general slot first", 0, d);
                    } else {
                        let g = rd[SLOTS].u()?;
                        y.small(SLOTS, "general slot gap", 0, g);
                    }
                }
            }
            let mut last_code = 0u64;
            let mut corner =
                |y: &mut Study, rd: &mut [Reader; 5], slot: u64| -> Result<(), String> {
                    let x = rd[CONN].u()?;
                    y.small(CONN, "corner code", form as u64, x);
                    // Alternative: context = form, corner position, previous code.
                    let b = y
                        .small
                        .entry("corner|ctx")
                        .or_default()
                        .cost((form as u64) << 12 | slot << 8 | last_code.min(31), x);
                    *y.field
                        .entry((CONN, "corner code|form,pos,prev (alt)"))
                        .or_default() += b;
                    last_code = x;
                    if x == 0 {
                        if local {
                            let i = rd[SLOTS].u()?;
                            y.small(SLOTS, "local corner index", 0, i);
                        } else {
                            let d = rd[REFS].s()?;
                            y.signed(REFS, "general corner ref", 0, d);
                        }
                    }
                    Ok(())
                };
            for _ in 0..nr {
                let mask = rd[CONN].u()?;
                y.small(CONN, "mask", form as u64, mask);
                for c in 0..4 {
                    if mask & (1 << c) != 0 {
                        corner(y, &mut rd, c)?;
                    }
                }
            }
            for c in 0..4 * na {
                corner(y, &mut rd, 4 + c % 4)?;
            }
        }
    }
    let mut res = Vec::with_capacity(n_moved + n_new);
    for _ in 0..n_moved + n_new {
        let mut p = [0i64; 3];
        for x in p.iter_mut() {
            *x = rd[POS].s()?;
        }
        res.push(p);
    }
    for (t, &remain) in rd
        .iter()
        .map(|r| r.remaining())
        .collect::<Vec<_>>()
        .iter()
        .enumerate()
    {
        if remain != 0 {
            return Err(format!(
                "stream {} has {remain} bytes left after parsing a record",
                codec::STREAM_NAMES[t]
            ));
        }
    }
    let dec = (level * 10.0).min(9.0) as u64;
    for (k, p) in res.iter().enumerate() {
        let is_new = (k >= n_moved) as u64;
        let kind = (form as u64) << 1 | is_new;
        let mut prev = 99u64;
        for (a, &v) in p.iter().enumerate() {
            y.side(POS, "pos ctx-none (alt)", 0, v);
            y.side(POS, "pos ctx-form (alt)", kind << 2 | a as u64, v);
            y.side(POS, "pos ctx-level (alt)", dec, v);
            y.side(POS, "pos ctx-all (alt)", prev << 8 | kind << 4 | dec, v);
            let name = if is_new == 1 {
                "pos new, ctx-prev"
            } else {
                "pos moved, ctx-prev"
            };
            y.signed(POS, name, prev, v);
            prev = bucket(v.unsigned_abs()) as u64;
        }
    }
    let moved_res = res[..n_moved].to_vec();
    let new_res = res[n_moved..].to_vec();
    Ok(Parsed {
        form,
        anchor,
        moved_res,
        new_res,
    })
}

/// Alternative predictions for new vertex `v` of `r` (level `st` before it;
/// `known(u)` gives the position of a vertex the decoder has before `v`):
/// (mean of edge neighbours, mean of parallelograms).
fn alt_predictions(
    r: &QRecord,
    v: u32,
    known: &dyn Fn(u32) -> Option<[i64; 3]>,
) -> (Option<[f64; 3]>, Option<[f64; 3]>, f64) {
    let quads = r
        .rewritten
        .iter()
        .map(|x| x.1)
        .chain(r.appended.iter().copied());
    let mut nb: Vec<u32> = Vec::new();
    let (mut par, mut np) = ([0f64; 3], 0usize);
    for q in quads {
        let Some(k) = q.iter().position(|&x| x == v) else {
            continue;
        };
        let (a, b, d) = (q[(k + 1) % 4], q[(k + 3) % 4], q[(k + 2) % 4]);
        for u in [a, b] {
            if known(u).is_some() && !nb.contains(&u) {
                nb.push(u);
            }
        }
        if let (Some(pa), Some(pb), Some(pd)) = (known(a), known(b), known(d)) {
            for t in 0..3 {
                par[t] += (pa[t] + pb[t] - pd[t]) as f64;
            }
            np += 1;
        }
    }
    let mean = (!nb.is_empty()).then(|| {
        let mut m = [0f64; 3];
        for &u in &nb {
            let p = known(u).unwrap_or_default();
            for t in 0..3 {
                m[t] += p[t] as f64 / nb.len() as f64;
            }
        }
        m
    });
    let par = (np > 0).then(|| par.map(|x| x / np as f64));
    // Scale of the neighbourhood: mean L∞ distance of the known edge
    // neighbours from their mean (grid steps) — a context for residual size.
    let scale = mean.map_or(0.0, |m| {
        nb.iter()
            .map(|&u| {
                let p = known(u).unwrap_or_default();
                (0..3)
                    .map(|t| (p[t] as f64 - m[t]).abs())
                    .fold(0.0, f64::max)
            })
            .sum::<f64>()
            / nb.len() as f64
    });
    (mean, par, scale)
}

/// Prices the anchors of each batch as ascending gaps: (Elias-gamma ideal,
/// adaptive gamma buckets, Σ log2 C(V, k)), `V` = vertices before the batch.
fn price_batches(batches: &[Vec<u32>], v0s: &[u32]) -> (f64, f64, f64) {
    let (mut gam, mut enumer) = (0.0, 0.0);
    let mut adaptive = Gamma::default();
    let mut adaptive_bits = 0.0;
    for (b, &v0) in batches.iter().zip(v0s) {
        if b.is_empty() {
            continue;
        }
        let mut a = b.clone();
        a.sort_unstable();
        let mut prev: Option<u32> = None;
        for &m in &a {
            let g = match prev {
                None => m as u64,
                Some(p) => (m - p - 1) as u64,
            };
            gam += gamma_len(g);
            adaptive_bits += adaptive.cost(prev.is_none() as u64, g);
            prev = Some(m);
        }
        enumer += log2_binom(v0 as u64, a.len() as u64);
    }
    (gam, adaptive_bits, enumer)
}

fn main() {
    models::study_files("entropy_study", study);
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened {
        size,
        dec,
        pm,
        quant,
        state: mut st,
    } = models::open(f)?;
    let bits = dec.header().map_or(14, |h| h.quant_bits);
    let opts = EncodeOptions {
        bits,
        version_major: 2,
        ..EncodeOptions::default()
    };
    let (out, rep) = write_to_vec(&pm, &opts).map_err(|e| e.to_string())?;
    let n = rep.refined_vertices.max(1) as f64;

    // The 2.0 coding this study measured (it parses forms 0-3 only; format
    // 3.0's edge-split form is what it led to).
    let coding = Coding {
        major: 2,
        edge_split: false,
        ..Coding::default()
    };
    let mut cur = Cursors::default();
    let mut y = Study::default();
    let nrec = pm.records.len();
    let mut forms = [0usize; 4];

    // Part 2 state.
    let mut batches: Vec<Vec<u32>> = vec![Vec::new()];
    let mut batch_set: HashSet<u32> = HashSet::new();
    let mut batch_v0: Vec<u32> = vec![st.q.len() as u32];
    let mut anchor_today = Gamma::default();
    // Layering: each record goes one layer after the last record that
    // touched any of its vertices (the fewest batches that keep every
    // dependency in order).
    let mut last_layer: HashMap<u32, usize> = HashMap::new();
    let mut layers: Vec<Vec<u32>> = Vec::new();
    let mut layer_v0: Vec<u32> = Vec::new();
    let mut anchor_today_bits = 0.0;
    // Part 2b: the anchor named in a list of the vertices the last records
    // touched, most recent first (see the module docs).
    let mut recent: Vec<u32> = Vec::new();
    let (mut recent_mode, mut recent_idx) = (Freq::new(2), Freq::new(RECENT));
    let mut recent_miss = Gamma::default();
    let mut recent_bits = 0.0;
    let mut recent_hits = [0usize; 4];

    // Part 3: (name, class) → bits; class 0 split, 1 face split, 2 local/general.
    // (predictor, model, class) → model / bits.
    let mut pred_models: HashMap<(usize, usize, usize), Gamma> = HashMap::new();
    let mut pred_bits: BTreeMap<(usize, usize, usize), f64> = BTreeMap::new();
    let mut pred_count = [0usize; 3];

    for (k, rec) in pm.records.iter().enumerate() {
        let r = QRecord::quantized(rec, &quant);
        let mut s: [Vec<u8>; 5] = Default::default();
        let cur_before = cur.vref;
        codec::encode_record(&st, &r, &mut cur, &mut s, coding);
        y.rec = [0.0; 5];
        let p = parse(&s, &st, cur_before, &r, k as f64 / nrec as f64, &mut y)
            .map_err(|e| format!("record {k}: {e}"))?;
        forms[p.form as usize] += 1;
        for t in 0..5 {
            y.per_op[r.op as usize][t] += y.rec[t];
        }
        let _ = &p.moved_res;

        // Part 2: touched set and greedy batches.
        let v0 = st.q.len() as u32;
        let mut touched: Vec<u32> = Vec::new();
        touched.extend(p.anchor);
        for &(sl, q) in &r.rewritten {
            touched.extend(st.quads[sl as usize]);
            touched.extend(q);
        }
        for q in &r.appended {
            touched.extend(q);
        }
        touched.extend(r.moved.iter().map(|m| m.0));
        if touched.iter().any(|v| batch_set.contains(v)) {
            batches.push(Vec::new());
            batch_v0.push(v0);
            batch_set.clear();
        }
        let layer = touched
            .iter()
            .filter_map(|v| last_layer.get(v))
            .max()
            .map_or(0, |&l| l + 1);
        for &v in &touched {
            last_layer.insert(v, layer);
        }
        if let Some(m) = p.anchor {
            if layers.len() <= layer {
                layers.resize(layer + 1, Vec::new());
                layer_v0.resize(layer + 1, v0);
            }
            layers[layer].push(m);
            layer_v0[layer] = layer_v0[layer].min(v0);
        }
        batch_set.extend(touched);
        if let Some(m) = p.anchor {
            if let Some(b) = batches.last_mut() {
                b.push(m);
            }
            anchor_today_bits += anchor_today.cost_signed(0, m as i64 - cur_before as i64);
            match recent.iter().position(|&u| u == m) {
                Some(i) => {
                    recent_bits += recent_mode.cost(1) + recent_idx.cost(i);
                    recent_hits[match i {
                        0 => 0,
                        1..=3 => 1,
                        _ => 2,
                    }] += 1;
                }
                None => {
                    recent_bits += recent_mode.cost(0)
                        + recent_miss.cost_signed(0, m as i64 - cur_before as i64);
                    recent_hits[3] += 1;
                }
            }
        }
        {
            // The record's vertices to the front: anchor, new vertices,
            // appended then rewritten quads' corners.
            let mut fresh: Vec<u32> = Vec::new();
            let n_new = r.new_pos.len() as u32;
            let verts = p
                .anchor
                .into_iter()
                .chain(v0..v0 + n_new)
                .chain(r.appended.iter().flatten().copied())
                .chain(r.rewritten.iter().flat_map(|(_, q)| q.iter().copied()));
            for u in verts {
                if !fresh.contains(&u) {
                    fresh.push(u);
                }
            }
            recent.retain(|u| !fresh.contains(u));
            fresh.extend_from_slice(&recent);
            fresh.truncate(RECENT);
            recent = fresh;
        }

        // Part 3: alternative predictions of the new vertices.
        let class = match p.form {
            1 => 0,
            3 => 1,
            _ => 2,
        };
        for (t, &res) in p.new_res.iter().enumerate() {
            let v = v0 + t as u32;
            let known = |u: u32| -> Option<[i64; 3]> {
                if u < v0 {
                    let q = r
                        .moved
                        .iter()
                        .find(|m| m.0 == u)
                        .map_or(st.q[u as usize], |m| m.1);
                    Some(q.map(|x| x as i64))
                } else if u < v {
                    Some(r.new_pos[(u - v0) as usize].map(|x| x as i64))
                } else {
                    None
                }
            };
            let actual = r.new_pos[t].map(|x| x as i64);
            let today_pred = [0, 1, 2].map(|a| actual[a] - res[a]);
            let (mean, par, scale) = alt_predictions(&r, v, &known);
            let sc = bucket(scale as u64) as u64;
            let tp = today_pred.map(|x| x as f64);
            let mean = mean.unwrap_or(tp);
            let par = par.unwrap_or(tp);
            let blend = [0, 1, 2].map(|a| 0.5 * (mean[a] + par[a]));
            let preds: [(&str, [f64; 3]); 4] = [
                ("today §7.6", tp),
                ("edge mean", mean),
                ("parallelograms", par),
                ("½ mean + ½ par", blend),
            ];
            pred_count[class] += 1;
            for (pi, (_, pr)) in preds.iter().enumerate() {
                for (mi, _) in MODELS.iter().enumerate() {
                    let g = pred_models.entry((pi, mi, class)).or_default();
                    let mut prev = 99u64;
                    let mut b = 0.0;
                    for a in 0..3 {
                        let rr = actual[a] - pr[a].round() as i64;
                        b += match mi {
                            0 => g.cost_signed(prev, rr),
                            1 => g.cost_signed(prev << 8 | sc, rr),
                            _ => g.cost_signed_m(prev << 8 | sc, rr),
                        };
                        prev = bucket(rr.unsigned_abs()) as u64;
                    }
                    *pred_bits.entry((pi, mi, class)).or_default() += b;
                }
            }
        }
        st.apply(&r);
    }

    // ---- Output ----
    println!(
        "## {f}: {} bytes ({} re-encoded); {} records (forms g/s/l/f {}/{}/{}/{}), {} refined vertices; file {:.1} bits/final vertex",
        size,
        out.len(),
        nrec,
        forms[0],
        forms[1],
        forms[2],
        forms[3],
        rep.refined_vertices,
        rep.file_bits_per_vertex
    );
    println!("\n### 1. today (varint + zstd 19) vs ideal adaptive, bits/refined vertex\n");
    println!("| stream | today | ideal | saving |");
    println!("|---|---:|---:|---:|");
    let (mut tt, mut ti) = (0.0, 0.0);
    for t in 0..5 {
        let today = 8.0 * rep.stream_bytes[t] / n;
        let ideal: f64 = y.per_op.iter().map(|o| o[t]).sum::<f64>() / n;
        tt += today;
        ti += ideal;
        println!(
            "| {} | {today:.2} | {ideal:.2} | {:.2} |",
            codec::STREAM_NAMES[t],
            today - ideal
        );
    }
    println!("| all records | {tt:.2} | {ti:.2} | {:.2} |", tt - ti);
    // Whole-file budget per *final* vertex (what issue 4 counts).
    let nfinal = (st.q.len() as f64).max(1.0);
    let per_final = |bytes: u64| 8.0 * bytes as f64 / nfinal;
    println!(
        "\nwhole file per final vertex ({} vertices): header+table {:.2}, base mesh {:.2} ({} base vertices, {:.1} bits each), optional sections (VORD) {:.2}, records {:.2} (ideal adaptive: {:.2}); total {:.2}",
        st.q.len(),
        per_final(rep.header_bytes + rep.table_bytes),
        per_final(rep.base_bytes),
        pm.base.positions.len(),
        8.0 * rep.base_bytes as f64 / pm.base.positions.len().max(1) as f64,
        per_final(rep.section_bytes),
        per_final(rep.chunk_bytes),
        ti * n / nfinal,
        per_final(rep.total_bytes)
    );
    println!("\n| op | records | avg new | today | ideal (ops/conn/refs/slots/pos) | ideal | ideal bits/record (ops/conn/refs/slots/pos) |");
    println!("|---|---:|---:|---:|---|---:|---|");
    for (o, s) in rep.per_op.iter().enumerate() {
        if s.records == 0 {
            continue;
        }
        let today: f64 = s.bytes.iter().sum::<f64>() * 8.0 / n;
        let i = y.per_op[o].map(|b| b / n);
        let k = s.records as f64;
        let pr = y.per_op[o].map(|b| b / k);
        println!(
            "| {} | {} | {:.2} | {today:.2} | {:.2} / {:.2} / {:.2} / {:.2} / {:.2} | {:.2} | {:.1} / {:.1} / {:.1} / {:.1} / {:.1} |",
            OP_NAMES[o],
            s.records,
            s.new as f64 / k,
            i[0],
            i[1],
            i[2],
            i[3],
            i[4],
            i.iter().sum::<f64>(),
            pr[0],
            pr[1],
            pr[2],
            pr[3],
            pr[4]
        );
    }
    println!("\n| stream | field (ideal adaptive; `(alt)` = alternative model, not in totals) | bits/refined vertex |");
    println!("|---|---|---:|");
    for (&(t, name), &b) in &y.field {
        println!("| {} | {name} | {:.2} |", codec::STREAM_NAMES[t], b / n);
    }

    // Part 2.
    println!("\n### 2. anchors if records were reordered into independent batches\n");
    let anchors: usize = batches.iter().map(|b| b.len()).sum();
    let na = anchors.max(1) as f64;
    println!(
        "today: {anchors} anchors, signed delta vs cursor, ideal adaptive gamma: {:.2} bits/refined vertex ({:.2} bits/anchor)\n",
        anchor_today_bits / n,
        anchor_today_bits / na
    );
    println!("| batching | batches | mean anchors/batch | sorted gaps, Elias-gamma | sorted gaps, adaptive gamma | log2 C(V, k) set bound |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (name, bs, v0s) in [
        ("greedy, consecutive records", &batches, &batch_v0),
        ("layered (dependency depth)", &layers, &layer_v0),
    ] {
        let nb = bs.iter().filter(|b| !b.is_empty()).count();
        let (gam, adaptive_bits, enumer) = price_batches(bs, v0s);
        println!(
            "| {name} | {nb} | {:.2} | {:.2} ({:.1}) | {:.2} ({:.1}) | {:.2} ({:.1}) |",
            anchors as f64 / nb.max(1) as f64,
            gam / n,
            gam / na,
            adaptive_bits / n,
            adaptive_bits / na,
            enumer / n,
            enumer / na
        );
    }
    println!("(bits/refined vertex, bits/anchor in brackets)");
    let hits: usize = recent_hits.iter().sum();
    let pct = |k: usize| 100.0 * recent_hits[k] as f64 / hits.max(1) as f64;
    println!(
        "\nanchors named in a list of the last records' vertices ({RECENT} entries, most recent first; a hit/miss flag, then the index or today's delta, each adaptive): {:.2} bits/refined vertex ({:.2} bits/anchor) against {:.2} ({:.2}); entry 0 {:.1} %, entries 1–3 {:.1} %, 4–{} {:.1} %, misses {:.1} %",
        recent_bits / n,
        recent_bits / na,
        anchor_today_bits / n,
        anchor_today_bits / na,
        pct(0),
        pct(1),
        RECENT - 1,
        pct(2),
        pct(3),
    );

    // Part 3.
    println!("\n### 3. new-vertex positions, ideal adaptive bits/refined vertex by predictor and residual model\n");
    println!(
        "| predictor | residual model | split ({}) | face split ({}) | local/general ({}) | all | bits/predicted vertex |",
        pred_count[0], pred_count[1], pred_count[2]
    );
    println!("|---|---|---:|---:|---:|---:|---:|");
    let nv = pred_count.iter().sum::<usize>().max(1) as f64;
    for (pi, pname) in PREDICTORS.iter().enumerate() {
        for (mi, mname) in MODELS.iter().enumerate() {
            let b = [0, 1, 2].map(|c| pred_bits.get(&(pi, mi, c)).copied().unwrap_or(0.0));
            let all: f64 = b.iter().sum();
            println!(
                "| {pname} | {mname} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} |",
                b[0] / n,
                b[1] / n,
                b[2] / n,
                all / n,
                all / nv
            );
        }
    }
    let _ = FORM_NAMES;
    println!();
    Ok(())
}
