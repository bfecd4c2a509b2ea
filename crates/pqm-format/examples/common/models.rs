//! Ideal adaptive code lengths shared by the coding studies
//! (`entropy_study`, `qe_split_study`): what a range coder with these
//! adaptive models would spend, within ~1–3 %, and their `main`. Included
//! with `#[path]`.
#![allow(dead_code)]

use std::collections::HashMap;

/// Adaptive frequency table over `0..n` (KT estimator: each symbol starts
/// at ½). `cost` returns the ideal code length in bits and then counts it.
#[derive(Clone)]
pub struct Freq {
    c: Vec<f64>,
    total: f64,
}

impl Freq {
    pub fn new(n: usize) -> Self {
        Freq {
            c: vec![0.5; n],
            total: 0.5 * n as f64,
        }
    }
    pub fn cost(&mut self, s: usize) -> f64 {
        let b = -(self.c[s] / self.total).log2();
        self.c[s] += 1.0;
        self.total += 1.0;
        b
    }
}

/// Bit length of `v + 1` (1 for 0): the Elias-gamma bucket.
pub fn bucket(v: u64) -> usize {
    (64 - (v + 1).leading_zeros()) as usize
}

/// Magnitudes: adaptive bucket per context + raw low bits.
#[derive(Default)]
pub struct Gamma {
    ctx: HashMap<u64, Freq>,
}

impl Gamma {
    pub fn cost(&mut self, ctx: u64, v: u64) -> f64 {
        let b = bucket(v);
        self.ctx.entry(ctx).or_insert_with(|| Freq::new(65)).cost(b) + (b - 1) as f64
    }
    pub fn cost_signed(&mut self, ctx: u64, v: i64) -> f64 {
        self.cost(ctx, v.unsigned_abs()) + if v != 0 { 1.0 } else { 0.0 }
    }
    /// [`Gamma::cost_signed`] with the first bit below the leading one
    /// modelled adaptively (context: `ctx` and the bucket) — residuals are
    /// roughly Laplacian, so values low in their bucket are more likely.
    pub fn cost_signed_m(&mut self, ctx: u64, v: i64) -> f64 {
        let a = v.unsigned_abs();
        let b = bucket(a);
        let mut bits = self.ctx.entry(ctx).or_insert_with(|| Freq::new(65)).cost(b);
        if b >= 2 {
            let bit = (((a + 1) >> (b - 2)) & 1) as usize;
            bits += self
                .ctx
                .entry(1 << 63 | ctx << 8 | 0x80 | b as u64)
                .or_insert_with(|| Freq::new(2))
                .cost(bit);
            bits += (b - 2) as f64;
        }
        bits + if v != 0 { 1.0 } else { 0.0 }
    }
}

/// Small integers: direct adaptive symbol below `DIRECT`, else escape + gamma.
pub const DIRECT: usize = 32;
#[derive(Default)]
pub struct Small {
    ctx: HashMap<u64, Freq>,
    esc: Gamma,
}

impl Small {
    pub fn cost(&mut self, ctx: u64, v: u64) -> f64 {
        let f = self.ctx.entry(ctx).or_insert_with(|| Freq::new(DIRECT + 1));
        if (v as usize) < DIRECT {
            f.cost(v as usize)
        } else {
            f.cost(DIRECT) + self.esc.cost(ctx, v - DIRECT as u64)
        }
    }
}

/// The studies' `main`: runs `study` on every file named on the command
/// line; exit code 2 without files, 1 when one failed (named on stderr).
pub fn study_files(name: &str, study: fn(&str) -> Result<(), String>) {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        eprintln!("usage: {name} FILE.pqm...");
        std::process::exit(2);
    }
    let mut failed = false;
    for f in files {
        if let Err(e) = study(&f) {
            eprintln!("{f}: {e}");
            failed = true;
        }
    }
    if failed {
        std::process::exit(1);
    }
}

/// A `.pqm` file opened for a study: the decoder (header, chunk table),
/// its records as a progressive mesh, the file's quantizer and the base
/// level as the codec's state (records are re-encoded against it).
pub struct Opened {
    /// The file's length in bytes.
    pub size: usize,
    pub dec: pqm_format::Decoder,
    pub pm: pqm_core::ProgressiveMesh,
    pub quant: pqm_format::Quantizer,
    pub state: pqm_format::codec::MeshState,
}

/// Decodes `f` whole (no limits) into an [`Opened`].
pub fn open(f: &str) -> Result<Opened, String> {
    let bytes = std::fs::read(f).map_err(|e| e.to_string())?;
    let dec =
        pqm_format::decode_all(&bytes, pqm_format::Limits::none()).map_err(|e| e.to_string())?;
    let pm = dec.to_progressive_mesh().ok_or("nothing decoded")?;
    let quant = dec.quantizer().ok_or("no quantizer")?;
    let base_q: Vec<[u32; 3]> = pm
        .base
        .positions
        .iter()
        .map(|p| quant.quantize(*p))
        .collect();
    let base_quads: Vec<[u32; 4]> = pm.base.faces().map(|f| [f[0], f[1], f[2], f[3]]).collect();
    let state = pqm_format::codec::MeshState::new(quant.qmax(), base_q, base_quads);
    Ok(Opened {
        size: bytes.len(),
        dec,
        pm,
        quant,
        state,
    })
}

/// The record index at which each chunk of `dec`'s file ends (the count
/// of records up to and including it), in chunk order.
pub fn chunk_ends(dec: &pqm_format::Decoder) -> Vec<usize> {
    dec.chunks()
        .iter()
        .scan(0usize, |a, c| {
            *a += c.record_count as usize;
            Some(*a)
        })
        .collect()
}

/// Bytes of `parts` as one chunk payload would hold them (each a varint
/// length, then its bytes) after zstd-19, the writer's default level.
pub fn zstd19(parts: &[&[u8]]) -> usize {
    let mut payload = Vec::new();
    for p in parts {
        pqm_format::varint::put_u(&mut payload, p.len() as u64);
        payload.extend_from_slice(p);
    }
    zstd::bulk::compress(&payload, 19).map_or(usize::MAX, |c| c.len())
}
