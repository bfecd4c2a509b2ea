//! The `VNBR` vertex-order section (spec §8.2): the input order coded
//! against the finest level's adjacency.
//!
//! Input orders are locally coherent (an input vertex is usually a
//! neighbour, or a neighbour's neighbour, of one of the last few), while
//! canonical ids are not, so `VORD`'s deltas barely compress. `VNBR` walks
//! the input order instead and names the canonical vertex of input vertex
//! `j` by its index in a candidate list built from the canonical vertices of
//! the last few input vertices, with two more symbols: the smallest
//! unassigned base vertex (base vertices keep the input's relative order,
//! spec §8.2) and an escape followed by a rank among the unassigned
//! vertices. Every step is linear in the list sizes, which are capped, so
//! hostile meshes (huge valences) cannot make it quadratic.

use crate::varint::{put_s, Reader};

/// Candidates per list (symbols `0..MAX_LIST`).
pub const MAX_LIST: usize = 254;
/// Symbol: the smallest unassigned base vertex.
pub const SYM_BASE: u8 = 254;
/// Symbol: escape, a rank follows in the rank stream.
pub const SYM_ESCAPE: u8 = 255;
/// Edge and diagonal neighbours kept per vertex (the first ones, spec order).
pub const NBR_CAP: usize = 12;
/// Recent input vertices whose 1-ring and diagonal 2-ring are listed.
const RECENT: usize = 4;
/// Recent input vertices whose edge 2-ring is listed.
const RECENT_EE: usize = 8;

/// Per vertex: its first [`NBR_CAP`] edge neighbours `E(v)` and diagonal
/// neighbours `D(v)` in spec order (compressed rows).
struct Adjacency {
    e_at: Vec<u32>,
    e: Vec<u32>,
    d_at: Vec<u32>,
    d: Vec<u32>,
}

impl Adjacency {
    /// `E(v)`, `D(v)` of every vertex of `quads` over `n` vertices (spec
    /// §8.2): scan `v`'s corners by slot, corner 0..4; the corner's next
    /// then previous vertex are edge neighbours, the opposite one a
    /// diagonal neighbour unless it is an edge neighbour.
    fn new(n: usize, quads: &[[u32; 4]]) -> Result<Adjacency, String> {
        let mut at = vec![0u32; n + 1];
        for q in quads {
            for &v in q {
                let c = at
                    .get_mut(v as usize + 1)
                    .filter(|_| (v as usize) < n)
                    .ok_or_else(|| format!("quad vertex {v} out of range ({n} vertices)"))?;
                *c += 1;
            }
        }
        for i in 0..n {
            at[i + 1] += at[i];
        }
        // Corners per vertex, in slot order (a counting sort keeps it).
        let mut fill = at.clone();
        let mut corners = vec![0u32; at[n] as usize];
        for (s, q) in quads.iter().enumerate() {
            for (k, &v) in q.iter().enumerate() {
                corners[fill[v as usize] as usize] = (4 * s + k) as u32;
                fill[v as usize] += 1;
            }
        }
        let mut mark = vec![u32::MAX; n];
        let mut a = Adjacency {
            e_at: Vec::with_capacity(n + 1),
            e: Vec::new(),
            d_at: Vec::with_capacity(n + 1),
            d: Vec::new(),
        };
        a.e_at.push(0);
        a.d_at.push(0);
        for v in 0..n {
            let cs = &corners[at[v] as usize..at[v + 1] as usize];
            let corner = |c: u32, off: usize| quads[c as usize / 4][(c as usize % 4 + off) % 4];
            let (mut ne, mut nd) = (0, 0);
            for &c in cs {
                for w in [corner(c, 1), corner(c, 3)] {
                    if mark[w as usize] != v as u32 {
                        mark[w as usize] = v as u32;
                        if ne < NBR_CAP {
                            a.e.push(w);
                            ne += 1;
                        }
                    }
                }
            }
            for &c in cs {
                let w = corner(c, 2);
                if mark[w as usize] != v as u32 {
                    mark[w as usize] = v as u32;
                    if nd < NBR_CAP {
                        a.d.push(w);
                        nd += 1;
                    }
                }
            }
            a.e_at.push(a.e.len() as u32);
            a.d_at.push(a.d.len() as u32);
        }
        Ok(a)
    }

    fn e(&self, v: u32) -> &[u32] {
        &self.e[self.e_at[v as usize] as usize..self.e_at[v as usize + 1] as usize]
    }

    fn d(&self, v: u32) -> &[u32] {
        &self.d[self.d_at[v as usize] as usize..self.d_at[v as usize + 1] as usize]
    }
}

/// Counts of unassigned vertices (a Fenwick tree over `0..n`).
struct Unassigned {
    t: Vec<u32>,
    left: usize,
}

impl Unassigned {
    fn new(n: usize) -> Self {
        // Every vertex starts unassigned: node i covers (i − lowbit(i), i].
        let t = (0..=n).map(|i| (i & i.wrapping_neg()) as u32).collect();
        Unassigned { t, left: n }
    }

    fn remove(&mut self, v: usize) {
        let mut i = v + 1;
        while i < self.t.len() {
            self.t[i] -= 1;
            i += i & i.wrapping_neg();
        }
        self.left -= 1;
    }

    /// Unassigned vertices below `v`.
    fn below(&self, v: usize) -> u64 {
        let (mut i, mut s) = (v, 0u64);
        while i > 0 {
            s += self.t[i] as u64;
            i -= i & i.wrapping_neg();
        }
        s
    }

    /// The unassigned vertex with `r` unassigned vertices below it
    /// (`r < left`).
    fn select(&self, mut r: u64) -> usize {
        let n = self.t.len() - 1;
        let mut pos = 0;
        let mut step = if n == 0 {
            0
        } else {
            1 << (usize::BITS - 1 - n.leading_zeros())
        };
        while step > 0 {
            if pos + step <= n && (self.t[pos + step] as u64) <= r {
                pos += step;
                r -= self.t[pos] as u64;
            }
            step >>= 1;
        }
        pos
    }
}

/// The state both sides keep while walking the input order.
struct Walk {
    adj: Adjacency,
    base: usize,
    assigned: Vec<bool>,
    /// `listed[v] == j + 1`: `v` is in step `j`'s list.
    listed: Vec<u32>,
    list: Vec<u32>,
    /// Canonical vertex of each input vertex so far.
    inv: Vec<u32>,
    /// Smallest unassigned base vertex (`base` when none is left).
    low_base: usize,
    free: Unassigned,
    /// Rank reference: one past the last escaped vertex (0 before any).
    after_escape: usize,
}

impl Walk {
    fn new(n: usize, quads: &[[u32; 4]], base: usize) -> Result<Walk, String> {
        Ok(Walk {
            adj: Adjacency::new(n, quads)?,
            base: base.min(n),
            assigned: vec![false; n],
            listed: vec![0; n],
            list: Vec::with_capacity(MAX_LIST),
            inv: Vec::with_capacity(n),
            low_base: 0,
            free: Unassigned::new(n),
            after_escape: 0,
        })
    }

    /// Builds the candidate list of the next input vertex (spec §8.2).
    fn candidates(&mut self) {
        let j = self.inv.len();
        let stamp = j as u32 + 1;
        self.list.clear();
        let low_base = (self.low_base < self.base).then_some(self.low_base as u32);
        let Walk {
            adj,
            assigned,
            listed,
            list,
            inv,
            ..
        } = self;
        let mut add = |x: u32| {
            if list.len() < MAX_LIST
                && !assigned[x as usize]
                && listed[x as usize] != stamp
                && Some(x) != low_base
            {
                listed[x as usize] = stamp;
                list.push(x);
            }
        };
        let recent = |k: usize| inv[j - k];
        for k in 1..=RECENT.min(j) {
            let h = recent(k);
            adj.e(h).iter().chain(adj.d(h)).for_each(|&w| add(w));
        }
        for k in 1..=RECENT_EE.min(j) {
            for &w in adj.e(recent(k)) {
                adj.e(w).iter().for_each(|&x| add(x));
            }
        }
        for k in 1..=RECENT.min(j) {
            for &w in adj.d(recent(k)) {
                adj.d(w).iter().for_each(|&x| add(x));
            }
        }
    }

    fn assign(&mut self, t: u32) {
        self.assigned[t as usize] = true;
        self.free.remove(t as usize);
        self.inv.push(t);
        while self.low_base < self.base && self.assigned[self.low_base] {
            self.low_base += 1;
        }
    }
}

/// The `VNBR` payload of `order` (canonical id → input index, a permutation
/// of `0..n`) over the finest level's `quads` with `base` base vertices.
pub fn encode(order: &[u32], quads: &[[u32; 4]], base: usize) -> Result<Vec<u8>, String> {
    let n = order.len();
    let mut inv = vec![u32::MAX; n];
    for (c, &i) in order.iter().enumerate() {
        match inv.get_mut(i as usize) {
            Some(s) if *s == u32::MAX => *s = c as u32,
            _ => {
                return Err(format!(
                    "vertex order entry {c} = {i} out of range or repeated"
                ))
            }
        }
    }
    let mut w = Walk::new(n, quads, base)?;
    let mut symbols = Vec::with_capacity(n);
    let mut ranks = Vec::new();
    for &t in &inv {
        w.candidates();
        if w.low_base < w.base && t as usize == w.low_base {
            symbols.push(SYM_BASE);
        } else if let Some(i) = w.list.iter().position(|&x| x == t) {
            symbols.push(i as u8);
        } else {
            symbols.push(SYM_ESCAPE);
            let r = w.free.below(t as usize) as i64;
            let r0 = w.free.below(w.after_escape) as i64;
            put_s(&mut ranks, r - r0);
            w.after_escape = t as usize + 1;
        }
        w.assign(t);
    }
    symbols.extend_from_slice(&ranks);
    Ok(symbols)
}

/// Decodes a `VNBR` payload into the permutation (canonical id → input
/// index) for `n` vertices; every byte is checked (spec §8.2's reject rules).
pub fn decode(
    payload: &[u8],
    n: usize,
    quads: &[[u32; 4]],
    base: usize,
) -> Result<Vec<u32>, String> {
    if payload.len() < n {
        return Err(format!(
            "VNBR payload has {} bytes, fewer than its {n} symbols",
            payload.len()
        ));
    }
    let (symbols, rest) = payload.split_at(n);
    let mut ranks = Reader::new(rest, "VNBR ranks");
    let mut w = Walk::new(n, quads, base)?;
    let mut order = vec![0u32; n];
    for (j, &s) in symbols.iter().enumerate() {
        w.candidates();
        let t = match s {
            SYM_BASE if w.low_base < w.base => w.low_base as u32,
            SYM_BASE => return Err(format!("VNBR symbol {j}: no base vertex is left")),
            SYM_ESCAPE => {
                let d = ranks.s()?;
                let r0 = w.free.below(w.after_escape) as i64;
                let r = r0
                    .checked_add(d)
                    .filter(|r| (0..w.free.left as i64).contains(r));
                let Some(r) = r else {
                    return Err(format!(
                        "VNBR symbol {j}: rank {r0} + {d} outside 0..{}",
                        w.free.left
                    ));
                };
                let t = w.free.select(r as u64);
                let stamp = j as u32 + 1;
                if w.listed[t] == stamp || (w.low_base < w.base && t == w.low_base) {
                    return Err(format!(
                        "VNBR symbol {j}: escape names vertex {t}, which has a symbol"
                    ));
                }
                w.after_escape = t + 1;
                t as u32
            }
            i => *w.list.get(i as usize).ok_or_else(|| {
                format!(
                    "VNBR symbol {j} = {i} but the list has {} candidates",
                    w.list.len()
                )
            })?,
        };
        order[t as usize] = j as u32;
        w.assign(t);
    }
    if ranks.remaining() != 0 {
        return Err(format!("{} unused bytes in VNBR", ranks.remaining()));
    }
    Ok(order)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn select_inverts_below() {
        let mut u = Unassigned::new(37);
        for v in [0, 5, 6, 20, 36] {
            u.remove(v);
        }
        let free: Vec<usize> = (0..37).filter(|v| ![0, 5, 6, 20, 36].contains(v)).collect();
        for (r, &v) in free.iter().enumerate() {
            assert_eq!(u.below(v), r as u64);
            assert_eq!(u.select(r as u64), v);
        }
        assert_eq!(u.left, free.len());
    }
}
