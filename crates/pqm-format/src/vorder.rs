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
//! hostile meshes (huge valences) cannot make it quadratic; both sides build
//! a list only as far as they need it (to the named vertex, or to the
//! symbol's entry; no list for an escape on the reader's side). The
//! constants were chosen by measuring the shared meshes (spec §8.2; `cargo
//! run --release -p pqm-format --example vertex_order`).

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
/// neighbours `D(v)` in spec order, in one compressed row `E(v) D(v)`: the
/// walk reads both lists of a recent vertex, which then are one run of
/// memory (one miss, not two).
struct Adjacency {
    /// `[start of E(v), start of D(v)]` per vertex, and the end; `D(v)`
    /// ends where `E(v + 1)` starts.
    at: Vec<[u32; 2]>,
    rows: Vec<u32>,
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
        // Exact bounds (what the decoder's memory estimate counts): at most
        // two edge neighbours and one diagonal one per corner, and the caps.
        let corners_n = at[n] as usize;
        let rows_max = (2 * corners_n).min(NBR_CAP * n) + corners_n.min(NBR_CAP * n);
        if rows_max > u32::MAX as usize {
            return Err(format!(
                "{corners_n} corners: too many for VNBR's 32-bit rows"
            ));
        }
        let mut a = Adjacency {
            at: Vec::with_capacity(n + 1),
            rows: Vec::with_capacity(rows_max),
        };
        for v in 0..n {
            let cs = &corners[at[v] as usize..at[v + 1] as usize];
            let corner = |c: u32, off: usize| quads[c as usize / 4][(c as usize % 4 + off) % 4];
            let e_start = a.rows.len();
            let mut ne = 0;
            for &c in cs {
                for w in [corner(c, 1), corner(c, 3)] {
                    if mark[w as usize] != v as u32 {
                        mark[w as usize] = v as u32;
                        if ne < NBR_CAP {
                            a.rows.push(w);
                            ne += 1;
                        }
                    }
                }
            }
            let d_start = a.rows.len();
            let mut nd = 0;
            for &c in cs {
                let w = corner(c, 2);
                if mark[w as usize] != v as u32 {
                    mark[w as usize] = v as u32;
                    if nd < NBR_CAP {
                        a.rows.push(w);
                        nd += 1;
                    }
                }
            }
            a.at.push([e_start as u32, d_start as u32]);
        }
        a.at.push([a.rows.len() as u32; 2]);
        Ok(a)
    }

    fn e(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.rows[self.at[v][0] as usize..self.at[v][1] as usize]
    }

    fn d(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.rows[self.at[v][1] as usize..self.at[v + 1][0] as usize]
    }

    /// `E(v)` then `D(v)`, one slice.
    fn ed(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.rows[self.at[v][0] as usize..self.at[v + 1][0] as usize]
    }
}

/// The unassigned vertices of `0..n`: one bit per vertex, and a Fenwick
/// tree of the counts per 64-bit word. Every step removes a vertex and an
/// escape asks a rank and a select: the tree has `n / 64` nodes, so it
/// stays in the first-level cache where a tree over the vertices (16 times
/// larger, spread over megabytes on large meshes) missed at each level.
struct Unassigned {
    /// Bit `v % 64` of word `v / 64`: `v` is unassigned.
    bits: Vec<u64>,
    /// Node `i` covers words `(i − lowbit(i), i]` (1-based).
    t: Vec<u32>,
    left: usize,
}

impl Unassigned {
    fn new(n: usize) -> Self {
        let words = n.div_ceil(64);
        let mut bits = vec![u64::MAX; words];
        if !n.is_multiple_of(64) {
            bits[words - 1] = (1u64 << (n % 64)) - 1;
        }
        // Linear Fenwick build: each node adds itself into its parent.
        let mut t = vec![0u32; words + 1];
        for i in 1..=words {
            t[i] += bits[i - 1].count_ones();
            let p = i + (i & i.wrapping_neg());
            if p <= words {
                t[p] += t[i];
            }
        }
        Unassigned { bits, t, left: n }
    }

    fn remove(&mut self, v: usize) {
        self.bits[v / 64] &= !(1u64 << (v % 64));
        let mut i = v / 64 + 1;
        while i < self.t.len() {
            self.t[i] -= 1;
            i += i & i.wrapping_neg();
        }
        self.left -= 1;
    }

    /// Unassigned vertices below `v` (`v ≤ n`).
    fn below(&self, v: usize) -> u64 {
        let w = v / 64;
        let (mut i, mut s) = (w, 0u64);
        while i > 0 {
            s += self.t[i] as u64;
            i -= i & i.wrapping_neg();
        }
        if let Some(&b) = self.bits.get(w) {
            s += (b & ((1u64 << (v % 64)) - 1)).count_ones() as u64;
        }
        s
    }

    /// The unassigned vertex with `r` unassigned vertices below it
    /// (`r < left`).
    fn select(&self, mut r: u64) -> usize {
        let words = self.t.len() - 1;
        // The word holding it: the last whose predecessors hold ≤ r.
        let mut pos = 0;
        let mut step = if words == 0 {
            0
        } else {
            1 << (usize::BITS - 1 - words.leading_zeros())
        };
        while step > 0 {
            if pos + step <= words && (self.t[pos + step] as u64) <= r {
                pos += step;
                r -= self.t[pos] as u64;
            }
            step >>= 1;
        }
        // Bit `r` (0-based) among the word's set bits, by halves.
        let mut x = self.bits.get(pos).copied().unwrap_or(0);
        let mut at = 0;
        for half in [32u32, 16, 8, 4, 2, 1] {
            let c = (x & ((1u64 << half) - 1)).count_ones() as u64;
            if r >= c {
                r -= c;
                x >>= half;
                at += half as usize;
            }
        }
        64 * pos + at
    }
}

/// Per vertex: [`ASSIGNED`], or the last step whose list holds it (`j + 1`;
/// 0: none yet). One array, so a candidate costs one memory access.
const ASSIGNED: u32 = u32::MAX;

/// The state both sides keep while walking the input order.
struct Walk {
    adj: Adjacency,
    base: usize,
    mark: Vec<u32>,
    list: Vec<u32>,
    /// Canonical vertex of each input vertex so far.
    inv: Vec<u32>,
    /// Smallest unassigned base vertex (`base` when none is left).
    low_base: usize,
    free: Unassigned,
    /// Rank reference: one past the last escaped vertex (0 before any).
    after_escape: usize,
}

/// How far [`Walk::candidates`] builds the list: both sides need only its
/// first entries — up to the named vertex, or to entry `i` — and the whole
/// list only for an escape (to prove the vertex is not in it).
enum Until {
    Vertex(u32),
    Len(usize),
}

impl Walk {
    fn new(n: usize, quads: &[[u32; 4]], base: usize) -> Result<Walk, String> {
        Ok(Walk {
            adj: Adjacency::new(n, quads)?,
            base: base.min(n),
            mark: vec![0; n],
            list: Vec::with_capacity(MAX_LIST),
            inv: Vec::with_capacity(n),
            low_base: 0,
            free: Unassigned::new(n),
            after_escape: 0,
        })
    }

    fn low(&self) -> Option<u32> {
        (self.low_base < self.base).then_some(self.low_base as u32)
    }

    /// Builds the candidate list of the next input vertex (spec §8.2), in
    /// order, stopping early as `until` allows.
    fn candidates(&mut self, until: Until) {
        let j = self.inv.len();
        let stamp = j as u32 + 1;
        self.list.clear();
        let low = self.low();
        let Walk {
            adj,
            mark,
            list,
            inv,
            ..
        } = self;
        // Adds `x` if it qualifies; true when the list is as long as needed.
        let mut add = |x: u32| {
            let m = &mut mark[x as usize];
            if *m != ASSIGNED && *m != stamp && Some(x) != low {
                *m = stamp;
                list.push(x);
                let done = match until {
                    Until::Vertex(t) => x == t,
                    Until::Len(l) => list.len() >= l,
                };
                return done || list.len() >= MAX_LIST;
            }
            false
        };
        let recent = |k: usize| inv[j - k];
        'build: {
            for k in 1..=RECENT.min(j) {
                let h = recent(k);
                for &w in adj.ed(h) {
                    if add(w) {
                        break 'build;
                    }
                }
            }
            for k in 1..=RECENT_EE.min(j) {
                for &w in adj.e(recent(k)) {
                    for &x in adj.e(w) {
                        if add(x) {
                            break 'build;
                        }
                    }
                }
            }
            for k in 1..=RECENT.min(j) {
                for &w in adj.d(recent(k)) {
                    for &x in adj.d(w) {
                        if add(x) {
                            break 'build;
                        }
                    }
                }
            }
        }
    }

    fn assign(&mut self, t: u32) {
        self.mark[t as usize] = ASSIGNED;
        self.free.remove(t as usize);
        self.inv.push(t);
        while self.low_base < self.base && self.mark[self.low_base] == ASSIGNED {
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
        w.code(t, &mut symbols, &mut ranks);
    }
    symbols.extend_from_slice(&ranks);
    Ok(symbols)
}

impl Walk {
    /// Codes canonical vertex `t` as the next input vertex (the writer's
    /// unique choice of symbol, spec §8.2) and assigns it.
    fn code(&mut self, t: u32, symbols: &mut Vec<u8>, ranks: &mut Vec<u8>) {
        if self.low() == Some(t) {
            symbols.push(SYM_BASE);
            self.assign(t);
            return;
        }
        self.candidates(Until::Vertex(t));
        if self.list.last() == Some(&t) {
            symbols.push((self.list.len() - 1) as u8);
        } else {
            symbols.push(SYM_ESCAPE);
            let r = self.free.below(t as usize) as i64;
            let r0 = self.free.below(self.after_escape) as i64;
            put_s(ranks, r - r0);
            self.after_escape = t as usize + 1;
        }
        self.assign(t);
    }
}

/// `order` (canonical id → input index, a permutation of `0..n`) with the
/// input indices from `keep` on given out anew, in the order that `VNBR`
/// codes in the fewest bits: each next one is the first entry of the
/// candidate list, else the smallest unassigned base vertex, else the
/// first unassigned vertex past the last escape — so their symbols are
/// nearly all 0. Indices below `keep` stay as they are.
///
/// For inputs whose vertices past `keep` are the writer's own, with no
/// meaning to the user: the edge and face points of the quad split that
/// `pqm encode` makes of a triangle or mixed mesh (the input's own
/// vertices keep their indices, spec §8). Their input order otherwise costs
/// most of the section (the bunny: 10 bits per vertex in all).
pub fn free_tail(
    order: &[u32],
    quads: &[[u32; 4]],
    base: usize,
    keep: usize,
) -> Result<Vec<u32>, String> {
    let n = order.len();
    if keep >= n {
        return Ok(order.to_vec());
    }
    let mut inv = vec![u32::MAX; keep];
    for (c, &i) in order.iter().enumerate() {
        if i as usize >= n {
            return Err(format!("vertex order entry {c} = {i} out of range"));
        }
        if let Some(s) = inv.get_mut(i as usize) {
            if *s != u32::MAX {
                return Err(format!("vertex order entry {c} = {i} repeated"));
            }
            *s = c as u32;
        }
    }
    let mut w = Walk::new(n, quads, base)?;
    // The symbols are thrown away: only the walk's state matters.
    let (mut symbols, mut ranks) = (Vec::with_capacity(n), Vec::new());
    for &t in &inv {
        if t == u32::MAX {
            return Err("vertex order is not a permutation".into());
        }
        w.code(t, &mut symbols, &mut ranks);
    }
    let mut out = order.to_vec();
    for j in keep..n {
        w.candidates(Until::Len(1));
        let t = match (w.list.first(), w.low()) {
            (Some(&x), _) | (None, Some(x)) => x,
            (None, None) => {
                let left = w.free.left as u64;
                let r0 = w.free.below(w.after_escape);
                w.free.select(r0.min(left - 1)) as u32
            }
        };
        out[t as usize] = j as u32;
        w.code(t, &mut symbols, &mut ranks);
    }
    Ok(out)
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
        let t = match s {
            SYM_BASE => w
                .low()
                .ok_or_else(|| format!("VNBR symbol {j}: no base vertex is left"))?,
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
                let t = w.free.select(r as u64) as u32;
                // Naming `low` by an escape is refused (symbol 254 does
                // it); a vertex the list holds is not looked for: that
                // would cost a whole list per escape, which is most of the
                // time on incoherent inputs (spec §8.2).
                if w.low() == Some(t) {
                    return Err(format!(
                        "VNBR symbol {j}: escape names base vertex {t}, which symbol 254 names"
                    ));
                }
                w.after_escape = t as usize + 1;
                t
            }
            i => {
                w.candidates(Until::Len(i as usize + 1));
                *w.list.get(i as usize).ok_or_else(|| {
                    format!(
                        "VNBR symbol {j} = {i} but the list has {} candidates",
                        w.list.len()
                    )
                })?
            }
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
        // One word, several words, a multiple of 64, removals at word ends.
        for n in [1usize, 37, 64, 200, 1000] {
            let mut u = Unassigned::new(n);
            let gone: Vec<usize> = (0..n)
                .filter(|v| v % 7 == 0 || v % 64 == 63 || (v * 31) % 11 == 3)
                .collect();
            for &v in &gone {
                u.remove(v);
            }
            let free: Vec<usize> = (0..n).filter(|v| !gone.contains(v)).collect();
            for v in 0..=n {
                let want = free.iter().filter(|&&f| f < v).count() as u64;
                assert_eq!(u.below(v), want, "n {n}, below {v}");
            }
            for (r, &v) in free.iter().enumerate() {
                assert_eq!(u.select(r as u64), v, "n {n}, rank {r}");
            }
            assert_eq!(u.left, free.len());
        }
    }
}
