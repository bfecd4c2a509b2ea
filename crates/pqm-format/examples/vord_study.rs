//! Study: bits per vertex of candidate codings of the vertex order.
use pqm_format::varint::put_s;
use pqm_format::{decode_all, Limits, Target};

fn z(b: &[u8]) -> usize {
    zstd::bulk::compress(b, 19).unwrap().len()
}

struct Adj {
    es: Vec<u32>,
    e: Vec<u32>,
    ds: Vec<u32>,
    d: Vec<u32>,
}

fn adj(n: usize, quads: &[[u32; 4]], sorted: bool) -> Adj {
    let mut e: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut d: Vec<Vec<u32>> = vec![Vec::new(); n];
    for q in quads {
        for k in 0..4 {
            let v = q[k] as usize;
            for w in [q[(k + 1) % 4], q[(k + 3) % 4]] {
                if !e[v].contains(&w) {
                    e[v].push(w);
                }
            }
        }
    }
    for q in quads {
        for k in 0..4 {
            let v = q[k] as usize;
            let w = q[(k + 2) % 4];
            if !e[v].contains(&w) && !d[v].contains(&w) {
                d[v].push(w);
            }
        }
    }
    if sorted {
        for l in e.iter_mut().chain(d.iter_mut()) {
            l.sort();
        }
    }
    let flat = |l: Vec<Vec<u32>>| {
        let mut s = vec![0u32];
        let mut f = Vec::new();
        for x in l {
            f.extend(x);
            s.push(f.len() as u32);
        }
        (s, f)
    };
    let (es, e) = flat(e);
    let (ds, d) = flat(d);
    Adj { es, e, ds, d }
}

#[derive(Clone, Copy, Debug)]
struct Cfg {
    k: usize,
    interleave: bool, // E(c1) D(c1) E(c2) ... vs E(c1..K) D(c1..K)
    sorted: bool,
    fallback: u8, // 0: delta to inv[j-1]+1 ; 1: delta to smallest unassigned
    lowbase: u8,  // 0 none, 1 first, 2 after 1-ring
    dd: usize,
    ring2: usize, // 2-ring of the last ring2 vertices (edge-edge)
}

fn code(inv: &[u32], quads: &[[u32; 4]], bv: usize, cfg: Cfg) -> (usize, usize, usize, Vec<usize>) {
    let n = inv.len();
    let a = adj(n, quads, cfg.sorted);
    let mut assigned = vec![false; n];
    let mut listed = vec![u32::MAX; n];
    let mut syms = Vec::with_capacity(n);
    let mut fb = Vec::new();
    let mut hist = vec![0usize; 256];
    let mut cand: Vec<u32> = Vec::new();
    let mut low = 0usize;
    let mut lowb = 0usize;
    let mut lastesc = 0i64;
    let mut escj: Vec<usize> = Vec::new();
    let mut fen = Fen::new(n);
    for j in 0..n {
        cand.clear();
        if cfg.lowbase == 1 && lowb < bv {
            listed[lowb] = j as u32;
            cand.push(lowb as u32);
        }
        let mut push = |w: u32, cand: &mut Vec<u32>| {
            if !assigned[w as usize] && listed[w as usize] != j as u32 && cand.len() < 255 {
                listed[w as usize] = j as u32;
                cand.push(w);
            }
        };
        if cfg.interleave {
            for k in 1..=cfg.k.min(j) {
                let c = inv[j - k] as usize;
                for &w in &a.e[a.es[c] as usize..a.es[c + 1] as usize] {
                    push(w, &mut cand);
                }
                for &w in &a.d[a.ds[c] as usize..a.ds[c + 1] as usize] {
                    push(w, &mut cand);
                }
            }
        } else {
            for k in 1..=cfg.k.min(j) {
                let c = inv[j - k] as usize;
                for &w in &a.e[a.es[c] as usize..a.es[c + 1] as usize] {
                    push(w, &mut cand);
                }
            }
            for k in 1..=cfg.k.min(j) {
                let c = inv[j - k] as usize;
                for &w in &a.d[a.ds[c] as usize..a.ds[c + 1] as usize] {
                    push(w, &mut cand);
                }
            }
        }
        if cfg.lowbase == 2 && lowb < bv && listed[lowb] != j as u32 {
            listed[lowb] = j as u32;
            cand.push(lowb as u32);
        }
        for k in 1..=cfg.ring2.min(j) {
            let c = inv[j - k] as usize;
            for &w in &a.e[a.es[c] as usize..a.es[c + 1] as usize] {
                let w = w as usize;
                for &x in &a.e[a.es[w] as usize..a.es[w + 1] as usize] {
                    if !assigned[x as usize] && listed[x as usize] != j as u32 && cand.len() < 255 {
                        listed[x as usize] = j as u32;
                        cand.push(x);
                    }
                }
            }
        }
        for k in 1..=cfg.dd.min(j) {
            let c = inv[j - k] as usize;
            for &w in &a.d[a.ds[c] as usize..a.ds[c + 1] as usize] {
                let w = w as usize;
                for &x in &a.d[a.ds[w] as usize..a.ds[w + 1] as usize] {
                    if !assigned[x as usize] && listed[x as usize] != j as u32 && cand.len() < 254 {
                        listed[x as usize] = j as u32;
                        cand.push(x);
                    }
                }
            }
        }
        let t = inv[j];
        if cfg.lowbase == 3 && lowb < bv && t as usize == lowb {
            syms.push(254);
            hist[254] += 1;
        } else {
            if cfg.lowbase == 3 {
                cand.retain(|&w| w as usize != lowb);
            }
            match cand.iter().position(|&w| w == t) {
                Some(i) => {
                    syms.push(i as u8);
                    hist[i] += 1;
                }
                None => {
                    syms.push(255);
                    escj.push(j);
                    hist[255] += 1;
                    match cfg.fallback {
                        0 => put_s(
                            &mut fb,
                            t as i64 - if j == 0 { 0 } else { inv[j - 1] as i64 + 1 },
                        ),
                        1 => put_s(&mut fb, t as i64 - low as i64),
                        2 => {
                            put_s(&mut fb, t as i64 - lastesc);
                        }
                        _ => {
                            // rank among unassigned, relative to rank of lastesc
                            let r = fen.prefix(t as usize) as i64;
                            let r0 = fen.prefix((lastesc as usize).min(n)) as i64;
                            put_s(&mut fb, r - r0);
                        }
                    }
                    lastesc = t as i64 + 1;
                }
            }
        }
        fen.add(t as usize, -1);
        assigned[t as usize] = true;
        while lowb < bv && assigned[lowb] {
            lowb += 1;
        }
        while low < n && assigned[low] {
            low += 1;
        }
    }
    let mut dec = [0usize; 10];
    for &j in &escj {
        dec[j * 10 / n] += 1;
    }
    eprintln!(
        "escapes by decile (% of decile): {:?}",
        dec.iter()
            .map(|&d| (1000 * d / (n / 10).max(1)) as f64 / 10.0)
            .collect::<Vec<_>>()
    );
    let mut all = syms.clone();
    all.extend_from_slice(&fb);
    (z(&all), z(&syms), z(&fb), hist)
}

struct Fen {
    t: Vec<i64>,
}
impl Fen {
    fn new(n: usize) -> Self {
        let mut f = Fen { t: vec![0; n + 1] };
        for i in 0..n {
            f.add(i, 1);
        }
        f
    }
    fn add(&mut self, i: usize, d: i64) {
        let mut i = i + 1;
        while i < self.t.len() {
            self.t[i] += d;
            i += i & i.wrapping_neg();
        }
    }
    /// count of unassigned < i
    fn prefix(&self, i: usize) -> i64 {
        let mut i = i;
        let mut s = 0;
        while i > 0 {
            s += self.t[i];
            i -= i & i.wrapping_neg();
        }
        s
    }
}

fn main() {
    for f in std::env::args().skip(1) {
        let bytes = std::fs::read(&f).unwrap();
        let mut dec = decode_all(&bytes, Limits::none()).unwrap();
        dec.set_level(Target::Level(usize::MAX)).unwrap();
        let order = dec.vertex_order().unwrap().to_vec();
        let quads = dec.quads().to_vec();
        let n = order.len();
        let mut inv = vec![0u32; n];
        for (i, &o) in order.iter().enumerate() {
            inv[o as usize] = i as u32;
        }
        let mut vord = Vec::new();
        let mut prev = 0i64;
        for &o in &order {
            put_s(&mut vord, o as i64 - prev);
            prev = o as i64;
        }
        let bv = dec.header().unwrap().base_vertex_count as usize;
        let mono = order[..bv].windows(2).all(|w| w[0] < w[1]);
        println!("base {bv} monotone {mono}");
        let bits = |b: usize| 8.0 * b as f64 / n as f64;
        println!("## {f}: n={n} VORD {:.2} b/v", bits(z(&vord)));
        let c0 = Cfg {
            k: 4,
            interleave: true,
            sorted: false,
            fallback: 3,
            lowbase: 3,
            ring2: 8,
            dd: 0,
        };
        for cfg in [
            c0,
            Cfg { dd: 1, ..c0 },
            Cfg { dd: 2, ..c0 },
            Cfg { dd: 4, ..c0 },
        ] {
            let (all, s, fbb, h) = code(&inv, &quads, bv, cfg);
            println!(
                "{cfg:?}: total {:.2} (syms {:.2} fb {:.2}) esc {:.1}% h0..4 {:?}",
                bits(all),
                bits(s),
                bits(fbb),
                100.0 * h[255] as f64 / n as f64,
                &h[..5]
                    .iter()
                    .map(|&x| (100.0 * x as f64 / n as f64).round())
                    .collect::<Vec<_>>()
            );
        }
    }
}
