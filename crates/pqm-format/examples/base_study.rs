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
    let (gc, gp, gs) = gate_study(&q, &quads);
    println!(
        "  gate coding      conn {:.1} + pos {:.1} bits/base vertex = {:.2} bits/final vertex; corners new/cand/escape {:?}, components {}",
        gc as f64 * 8.0 / nv as f64,
        gp as f64 * 8.0 / nv as f64,
        per(gc + gp).1,
        &gs[..3],
        gs[3]
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

/// Prototype of a traversal coding of the base connectivity: faces
/// re-ordered breadth-first across edges, vertices by first appearance;
/// each face after a component's first is attached to an open edge of
/// its parent and codes its rotation and its two far corners (new, the
/// vertex closing the fan at that end, or an escape). Returns the zstd
/// bytes of (connectivity, stencil-predicted positions).
pub fn gate_study(q: &[[i64; 3]], quads: &[[u32; 4]]) -> (usize, usize, [usize; 4]) {
    use std::collections::HashMap;
    let nf = quads.len();
    let mut dir: HashMap<(u32, u32), usize> = HashMap::new();
    for (i, f) in quads.iter().enumerate() {
        for k in 0..4 {
            dir.insert((f[k], f[(k + 1) % 4]), i);
        }
    }
    // edge BFS
    let mut queued = vec![false; nf];
    let mut order = Vec::with_capacity(nf);
    let mut head = 0;
    for s in 0..nf {
        if queued[s] {
            continue;
        }
        queued[s] = true;
        order.push(s);
        while head < order.len() {
            let f = quads[order[head]];
            head += 1;
            for k in 0..4 {
                if let Some(&g) = dir.get(&(f[(k + 1) % 4], f[k])) {
                    if !queued[g] {
                        queued[g] = true;
                        order.push(g);
                    }
                }
            }
        }
    }
    // renumber: first appearance in coding order (a component's first
    // face: its corners in order; a face attached at its parent's edge:
    // the far corner after the shared edge, then the other)
    let nv = q.len();
    let mut id = vec![u32::MAX; nv];
    let mut next = 0u32;
    let mut faces: Vec<[u32; 4]> = Vec::with_capacity(nf);
    {
        let mut placed = vec![false; nf];
        let mut hq = 0usize;
        let mut num = |v: u32, id: &mut Vec<u32>| {
            if id[v as usize] == u32::MAX {
                id[v as usize] = next;
                next += 1;
            }
        };
        let mut pos_in_order = vec![0usize; nf];
        for (i, &fi) in order.iter().enumerate() {
            pos_in_order[fi] = i;
        }
        // replay the BFS with the coding order of corners
        for (i, &fi) in order.iter().enumerate() {
            let _ = i;
            if placed[fi] {
                continue;
            }
            placed[fi] = true;
            for &v in &quads[fi] {
                num(v, &mut id);
            }
            let mut qd = vec![fi];
            while hq < qd.len() {
                let f = quads[qd[hq]];
                hq += 1;
                for k in 0..4 {
                    if let Some(&g) = dir.get(&(f[(k + 1) % 4], f[k])) {
                        if !placed[g] {
                            placed[g] = true;
                            let gq = quads[g];
                            let r = (0..4).find(|&r| gq[r] == f[(k + 1) % 4]).unwrap();
                            num(gq[(r + 2) % 4], &mut id);
                            num(gq[(r + 3) % 4], &mut id);
                            qd.push(g);
                        }
                    }
                }
            }
            hq = 0;
        }
        for &fi in &order {
            faces.push(quads[fi].map(|v| id[v as usize]));
        }
    }
    let mut pos_of = vec![[0i64; 3]; nv];
    for v in 0..nv {
        if id[v] != u32::MAX {
            pos_of[id[v] as usize] = q[v];
        }
    }
    // simulate the decoder
    let mut flags = Vec::new();
    let mut rots = Vec::new();
    let mut syms = Vec::new();
    let mut esc = Vec::new();
    let mut stats = [0usize; 4];
    let mut known: HashMap<(u32, u32), usize> = HashMap::new();
    // open half-edges per vertex: incoming (w -> a) and outgoing (b -> z)
    let mut seen_v = 0u32;
    let mut n = 0usize;
    let mut h = 0usize;
    let mut dec: Vec<[u32; 4]> = Vec::new();
    let open_in = |known: &HashMap<(u32, u32), usize>, a: u32| -> Vec<u32> {
        let mut c: Vec<(usize, u32)> = known
            .iter()
            .filter(|(&(w, t), _)| t == a && !known.contains_key(&(a, w)))
            .map(|(&(w, _), &f)| (f, w))
            .collect();
        c.sort();
        c.into_iter().map(|x| x.1).collect()
    };
    let open_out = |known: &HashMap<(u32, u32), usize>, b: u32| -> Vec<u32> {
        let mut c: Vec<(usize, u32)> = known
            .iter()
            .filter(|(&(s, z), _)| s == b && !known.contains_key(&(z, b)))
            .map(|(&(_, z), &f)| (f, z))
            .collect();
        c.sort();
        c.into_iter().map(|x| x.1).collect()
    };
    let mut code_corner = |v: u32, cands: &[u32], seen_v: &mut u32, syms: &mut Vec<u8>, esc: &mut Vec<u8>, stats: &mut [usize; 4]| {
        if v == *seen_v {
            syms.push(0);
            *seen_v += 1;
            stats[0] += 1;
        } else if let Some(i) = cands.iter().position(|&c| c == v) {
            syms.push(1 + i.min(200) as u8);
            stats[1] += 1;
        } else {
            syms.push(255);
            put_s(esc, (*seen_v as i64) - 1 - v as i64);
            stats[2] += 1;
        }
    };
    while n < nf {
        if h == n {
            // component start
            let f = faces[n];
            for &v in &f {
                code_corner(v, &[], &mut seen_v, &mut syms, &mut esc, &mut stats);
            }
            for k in 0..4 {
                known.insert((f[k], f[(k + 1) % 4]), n);
            }
            dec.push(f);
            n += 1;
            stats[3] += 1;
            continue;
        }
        let f = dec[h];
        h += 1;
        for k in 0..4 {
            let (a, b) = (f[k], f[(k + 1) % 4]);
            if known.contains_key(&(b, a)) {
                continue;
            }
            // is the next face the one across (a, b)?
            let g = faces.get(n).copied();
            let across = g.and_then(|g| (0..4).find(|&r| g[r] == b && g[(r + 1) % 4] == a));
            match across {
                Some(r) => {
                    flags.push(1);
                    let g = g.unwrap();
                    rots.push(r as u8);
                    let x = g[(r + 2) % 4];
                    let y = g[(r + 3) % 4];
                    let cx = open_in(&known, a);
                    code_corner(x, &cx, &mut seen_v, &mut syms, &mut esc, &mut stats);
                    let cy = open_out(&known, b);
                    code_corner(y, &cy, &mut seen_v, &mut syms, &mut esc, &mut stats);
                    for t in 0..4 {
                        known.insert((g[t], g[(t + 1) % 4]), n);
                    }
                    dec.push(g);
                    n += 1;
                }
                None => flags.push(0),
            }
        }
    }
    assert_eq!(dec, faces);
    let conn = models::zstd19(&[&flags, &rots, &syms, &esc]);
    // positions: stencil over quads with smaller-id corners
    let mut vf: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for (i, qd) in faces.iter().enumerate() {
        for &v in qd {
            vf[v as usize].push(i);
        }
    }
    let mut pos = Vec::new();
    let mut prevc = [0i64; 3];
    for v in 0..nv {
        let mut sum = [0i64; 3];
        let mut c = 0;
        let mut nsum = [0i64; 3];
        let mut nc = 0;
        for &fi in &vf[v] {
            let qd = faces[fi];
            let k = qd.iter().position(|&u| u as usize == v).unwrap();
            let (n1, o, n3) = (qd[(k + 1) % 4] as usize, qd[(k + 2) % 4] as usize, qd[(k + 3) % 4] as usize);
            if n1 < v && o < v && n3 < v {
                for t in 0..3 {
                    sum[t] += 5 * (pos_of[n1][t] + pos_of[n3][t]) - 2 * pos_of[o][t];
                }
                c += 1;
            }
            for nn in [n1, n3] {
                if nn < v {
                    for t in 0..3 {
                        nsum[t] += pos_of[nn][t];
                    }
                    nc += 1;
                }
            }
        }
        let pred = if c > 0 {
            sum.map(|s| s.div_euclid(8 * c))
        } else if nc > 0 {
            nsum.map(|s| s.div_euclid(nc))
        } else {
            prevc
        };
        for t in 0..3 {
            put_s(&mut pos, pos_of[v][t] - pred[t]);
        }
        prevc = pos_of[v];
    }
    let _ = (&rots, &flags);
    (conn, models::zstd19(&[&pos]), stats)
}
