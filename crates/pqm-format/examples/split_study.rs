//! How predictable the quad split's points are: a study for split inputs.
//!
//! `pqm encode` splits a triangle or mixed mesh into quads first (linear
//! points: an edge point at its edge's midpoint, a face point at its
//! face's centroid), and the file then codes every vertex of the split
//! mesh — on the bunny five of six are the split's points, each a linear
//! function of the input's own vertices. This study replays a file's
//! records and prices each new vertex's position three ways, by whether it
//! is one of the input's own vertices (input index below `N_ORIG`, from
//! the file's vertex order) or one of the split's:
//!
//! * `stencil`: the file's prediction (spec §7.6, version 4), as written;
//! * `mean`: the mean of the vertex's edge neighbours among the record's
//!   quads that are already decoded (exact for a face point whose edge
//!   points are there: the mean of a triangle's edge midpoints is its
//!   centroid);
//! * `pair`: the midpoint of the closest pair of those edge neighbours
//!   (exact for an edge point whose two endpoints are there), a choice
//!   the writer would have to name.
//!
//! For each: the share of vertices predicted within one grid step on
//! every axis, and the residuals' zstd-19 bytes as the file's `pos` stream
//! holds them (zigzag varints), one stream per class and predictor (`pair`
//! without naming the pair: a bound). `pair when within a step` is a mode a
//! decoder could follow: a selector byte per vertex (0: the stencil, else
//! the pair's number, from 1, among the pairs of decoded edge neighbours in
//! fan order), written when the closest pair is within one step, then the
//! residual against the predictor it names; selectors and residuals each
//! their own zstd stream. A measurement for a future prediction mode, not a
//! format: the file's bytes do not change.
//!
//! `cargo run --release -p pqm-format --example split_study -- FILE.pqm N_ORIG`
//! (`N_ORIG`: the input mesh's vertex count, e.g. 34,835 for the bunny).

#[path = "common/models.rs"]
mod models;

use pqm_format::codec::QRecord;
use pqm_format::varint::put_s;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(f), Some(n_orig)) = (args.first(), args.get(1).and_then(|n| n.parse().ok())) else {
        eprintln!("usage: split_study FILE.pqm N_ORIG");
        std::process::exit(2);
    };
    if let Err(e) = study(f, n_orig) {
        eprintln!("{f}: {e}");
        std::process::exit(1);
    }
}

/// Per class (0: the input's own vertices, 1: the split's points), per
/// predictor (stencil, mean, pair, best): residual varints, hits within a
/// step, vertices.
#[derive(Default)]
struct Tally {
    streams: [[Vec<u8>; 4]; 2],
    selectors: [Vec<u8>; 2],
    hits: [[usize; 3]; 2],
    count: [usize; 2],
}

fn study(f: &str, n_orig: u32) -> Result<(), String> {
    let models::Opened {
        dec,
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let order = dec
        .vertex_order()
        .map_err(|e| e.to_string())?
        .ok_or("the file has no vertex order")?
        .to_vec();
    let qmax = quant.qmax() as i64;
    let mut t = Tally::default();
    for rec in &pm.records {
        let r = QRecord::quantized(rec, &quant);
        let v0 = st.q.len() as u32;
        let mut code: Vec<[i64; 3]> = st.q.iter().map(|c| c.map(|x| x as i64)).collect();
        for &(v, c) in &r.moved {
            code[v as usize] = c.map(|x| x as i64);
        }
        code.extend(r.new_pos.iter().map(|c| c.map(|x| x as i64)));
        let quads: Vec<[u32; 4]> = r
            .appended
            .iter()
            .copied()
            .chain(r.rewritten.iter().map(|x| x.1))
            .collect();
        for i in 0..r.new_pos.len() {
            let x = v0 + i as u32;
            let xc = code[x as usize];
            let class = usize::from(order[x as usize] >= n_orig);
            // The file's stencil, and the edge neighbours in quad order.
            let sums = models::StencilSums::of(&code, &quads, x);
            let stencil = sums.predict(&code, x, v0, qmax);
            let e = &sums.edge;
            let mean_of = |vs: &[u32]| -> Option<[i64; 3]> {
                (!vs.is_empty()).then(|| {
                    [0, 1, 2].map(|a| {
                        (vs.iter().map(|&u| code[u as usize][a]).sum::<i64>() as f64
                            / vs.len() as f64)
                            .round() as i64
                    })
                })
            };
            let mean = mean_of(e).unwrap_or(stencil);
            let dist = |p: [i64; 3]| (0..3).map(|a| (xc[a] - p[a]).abs()).max().unwrap_or(0);
            // Every pair: the record's quads need not close the ring, so
            // which neighbours face each other is not known.
            let mut pair = stencil;
            let (mut best_d, mut best_i, mut idx) = (i64::MAX, 0usize, 0usize);
            for a in 0..e.len() {
                for b in a + 1..e.len() {
                    idx += 1;
                    if let Some(p) = mean_of(&[e[a], e[b]]) {
                        if dist(p) < best_d {
                            (best_d, pair, best_i) = (dist(p), p, idx);
                        }
                    }
                }
            }
            let preds = [stencil, mean, pair];
            let costs: Vec<(usize, Vec<u8>)> = preds
                .iter()
                .map(|p| {
                    let mut b = Vec::new();
                    for a in 0..3 {
                        put_s(&mut b, xc[a] - p[a]);
                    }
                    (b.len(), b)
                })
                .collect();
            for (j, p) in preds.iter().enumerate() {
                if dist(*p) <= 1 {
                    t.hits[class][j] += 1;
                }
                t.streams[class][j].extend_from_slice(&costs[j].1);
            }
            let (sel, j) = if best_d <= 1 {
                (best_i.min(255), 2)
            } else {
                (0, 0)
            };
            t.streams[class][3].extend_from_slice(&costs[j].1);
            t.selectors[class].push(sel as u8);
            t.count[class] += 1;
        }
        st.apply(&r);
    }
    println!(
        "## {f}: {} refined vertices ({} the input's own, {} the split's points)",
        t.count[0] + t.count[1],
        t.count[0],
        t.count[1]
    );
    println!("| vertices | predictor | within 1 step | bits per vertex (zstd-19) |");
    println!("|---|---|---:|---:|");
    for (c, name) in ["the input's own", "the split's points"].iter().enumerate() {
        let n = t.count[c].max(1) as f64;
        for (j, p) in [
            "stencil (the file's)",
            "mean of edge neighbours",
            "closest pair midpoint",
            "pair when within a step, + selector",
        ]
        .iter()
        .enumerate()
        {
            let bytes = models::zstd19(&[&t.streams[c][j]])
                + if j == 3 {
                    models::zstd19(&[&t.selectors[c]])
                } else {
                    0
                };
            let hit = if j < 3 {
                format!("{:.1} %", 100.0 * t.hits[c][j] as f64 / n)
            } else {
                "—".into()
            };
            println!("| {name} | {p} | {hit} | {:.2} |", 8.0 * bytes as f64 / n);
        }
    }
    Ok(())
}
