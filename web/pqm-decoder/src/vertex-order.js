/**
 * The `VNBR` vertex-order section (spec §8.2, version 3.1): the input order
 * coded against the finest level's adjacency. Written from the spec text.
 *
 * For each input vertex j a symbol names its canonical vertex: an index in
 * a candidate list built from the canonical vertices of the last input
 * vertices (their edge / diagonal neighbours and 2-rings), 254 for the
 * smallest unassigned base vertex, or 255 followed by a rank among the
 * unassigned vertices. A list is built only as far as its symbol needs (an
 * escape needs none). Every byte is hostile: errors are thrown as plain
 * strings that the caller wraps with the section.
 */

import { Reader } from './reader.js';

const MAX_LIST = 254;
const SYM_BASE = 254;
const SYM_ESCAPE = 255;
const NBR_CAP = 12;

/**
 * E(v) and D(v) of every vertex (spec §8.2), in one compressed row
 * `E(v) D(v)` per vertex (a recent vertex's two lists are one run of
 * memory): E(v) is rows[eAt[v] .. dAt[v]], D(v) is rows[dAt[v] .. eAt[v + 1]].
 * @param {number} n vertex count
 * @param {Uint32Array} quads 4 ids per slot
 * @param {number} nf slot count
 */
function adjacency(n, quads, nf) {
  const at = new Uint32Array(n + 1);
  for (let i = 0; i < 4 * nf; i++) {
    const v = quads[i];
    if (v >= n) throw `quad vertex ${v} out of range (${n} vertices)`;
    at[v + 1]++;
  }
  for (let i = 0; i < n; i++) at[i + 1] += at[i];
  // corners of each vertex in slot order (a counting sort keeps it)
  const fill = at.slice();
  const corners = new Uint32Array(at[n]);
  for (let i = 0; i < 4 * nf; i++) corners[fill[quads[i]]++] = i;
  const mark = new Int32Array(n).fill(-1);
  const eAt = new Uint32Array(n + 1);
  const dAt = new Uint32Array(n + 1);
  // E(v) has at most min(2 × corners, 12) entries, D(v) min(corners, 12)
  const rows = new Uint32Array(Math.min(2 * at[n], NBR_CAP * n) + Math.min(at[n], NBR_CAP * n));
  let nr = 0;
  for (let v = 0; v < n; v++) {
    const e0 = nr;
    eAt[v] = e0;
    for (let c = at[v]; c < at[v + 1]; c++) {
      const s = corners[c] & ~3;
      const k = corners[c] & 3;
      const w1 = quads[s + ((k + 1) & 3)];
      if (mark[w1] !== v) {
        mark[w1] = v;
        if (nr - e0 < NBR_CAP) rows[nr++] = w1;
      }
      const w3 = quads[s + ((k + 3) & 3)];
      if (mark[w3] !== v) {
        mark[w3] = v;
        if (nr - e0 < NBR_CAP) rows[nr++] = w3;
      }
    }
    const d0 = nr;
    dAt[v] = d0;
    for (let c = at[v]; c < at[v + 1]; c++) {
      const s = corners[c] & ~3;
      const w = quads[s + (((corners[c] & 3) + 2) & 3)];
      if (mark[w] !== v) {
        mark[w] = v;
        if (nr - d0 < NBR_CAP) rows[nr++] = w;
      }
    }
  }
  eAt[n] = nr;
  dAt[n] = nr;
  return { eAt, dAt, rows };
}

/** Set bits of a 32-bit word. */
function popcount(x) {
  x -= (x >>> 1) & 0x55555555;
  x = (x & 0x33333333) + ((x >>> 2) & 0x33333333);
  return Math.imul((x + (x >>> 4)) & 0x0f0f0f0f, 0x01010101) >>> 24;
}

/**
 * Decodes a `VNBR` payload into the permutation (canonical id → input index).
 * @param {Uint8Array} payload the decompressed section
 * @param {number} n final vertex count
 * @param {Uint32Array} quads the finest level's quads, 4 ids per slot
 * @param {number} nf the finest level's slot count
 * @param {number} base base vertex count
 * @returns {Uint32Array}
 */
export function decodeVnbr(payload, n, quads, nf, base) {
  if (payload.length < n) throw `VNBR payload has ${payload.length} bytes, fewer than its ${n} symbols`;
  const { eAt, dAt, rows } = adjacency(n, quads, nf);
  base = Math.min(base, n);
  const ranks = new Reader(payload, n, payload.length, 'VNBR ranks');
  // mark[v]: ASSIGNED, or the last step j + 1 whose list holds v (0: none)
  const ASSIGNED = 0xffffffff;
  const mark = new Uint32Array(n);
  const list = new Uint32Array(MAX_LIST);
  const inv = new Uint32Array(n);
  const order = new Uint32Array(n);
  // The unassigned vertices: one bit each (bit v & 31 of word v >> 5), and
  // a Fenwick tree of the counts per word (node i covers words
  // (i − lowbit(i), i]): n / 32 nodes stay in the first-level cache, where
  // a tree over the vertices missed at every level on large meshes.
  const words = (n + 31) >>> 5;
  const bits = new Int32Array(words).fill(-1);
  if (n & 31) bits[words - 1] = (1 << (n & 31)) - 1;
  const fen = new Uint32Array(words + 1);
  for (let i = 1; i <= words; i++) {
    fen[i] += popcount(bits[i - 1]);
    const p = i + (i & -i);
    if (p <= words) fen[p] += fen[i];
  }
  let left = n;
  let top = 1;
  while (top * 2 <= words) top *= 2;
  let low = 0; // smallest unassigned base vertex (base when none is left)
  let after = 0; // rank reference p: one past the last escaped vertex
  let len = 0;
  let stamp = 0;
  let lowV = -1;
  let need = 0;
  // Appends x if it qualifies; true once the list has `need` entries.
  const add = (x) => {
    const m = mark[x];
    if (m !== ASSIGNED && m !== stamp && x !== lowV) {
      mark[x] = stamp;
      list[len++] = x;
      return len >= need;
    }
    return false;
  };
  // The candidate list of input vertex j (spec §8.2), built only as far as
  // entry need − 1: a symbol s needs no more (an escape needs no list).
  const build = (j) => {
    len = 0;
    const r1 = Math.min(4, j);
    for (let k = 1; k <= r1; k++) {
      const h = inv[j - k];
      // E(h) then D(h): one run
      for (let i = eAt[h]; i < eAt[h + 1]; i++) if (add(rows[i])) return;
    }
    const r2 = Math.min(8, j);
    for (let k = 1; k <= r2; k++) {
      const h = inv[j - k];
      for (let i = eAt[h]; i < dAt[h]; i++) {
        const w = rows[i];
        for (let m = eAt[w]; m < dAt[w]; m++) if (add(rows[m])) return;
      }
    }
    for (let k = 1; k <= r1; k++) {
      const h = inv[j - k];
      for (let i = dAt[h]; i < eAt[h + 1]; i++) {
        const w = rows[i];
        for (let m = dAt[w]; m < eAt[w + 1]; m++) if (add(rows[m])) return;
      }
    }
  };
  for (let j = 0; j < n; j++) {
    stamp = j + 1;
    lowV = low < base ? low : -1;
    const s = payload[j];
    let t;
    if (s === SYM_BASE) {
      if (lowV < 0) throw `VNBR symbol ${j}: no base vertex is left`;
      t = lowV;
    } else if (s === SYM_ESCAPE) {
      const dr = ranks.s();
      // R(after): whole words below it, then its word's low bits
      const aw = after >>> 5;
      let r0 = 0;
      for (let i = aw; i > 0; i -= i & -i) r0 += fen[i];
      if (aw < words && (after & 31) !== 0) r0 += popcount(bits[aw] & ((1 << (after & 31)) - 1));
      const r = r0 + dr;
      if (!(r >= 0 && r < left)) throw `VNBR symbol ${j}: rank ${r0} + ${dr} outside 0..${left}`;
      // the unassigned vertex with r unassigned vertices below it: its word
      // (the last whose predecessors hold ≤ r), then the bit, by halves
      let pos = 0;
      let rem = r;
      for (let step = words === 0 ? 0 : top; step > 0; step >>= 1) {
        if (pos + step <= words && fen[pos + step] <= rem) {
          pos += step;
          rem -= fen[pos];
        }
      }
      let x = bits[pos];
      let b = 0;
      for (let half = 16; half > 0; half >>= 1) {
        const c = popcount(x & ((1 << half) - 1));
        if (rem >= c) {
          rem -= c;
          x >>>= half;
          b += half;
        }
      }
      t = 32 * pos + b;
      // naming low by an escape is refused (symbol 254 does it); a vertex
      // the list holds is not looked for (spec §8.2)
      if (t === lowV) throw `VNBR symbol ${j}: escape names base vertex ${t}, which symbol 254 names`;
      after = t + 1;
    } else {
      need = s + 1;
      build(j);
      if (s >= len) throw `VNBR symbol ${j} = ${s} but the list has ${len} candidates`;
      t = list[s];
    }
    order[t] = j;
    inv[j] = t;
    mark[t] = ASSIGNED;
    bits[t >>> 5] &= ~(1 << (t & 31));
    for (let i = (t >>> 5) + 1; i <= words; i += i & -i) fen[i]--;
    left--;
    while (low < base && mark[low] === ASSIGNED) low++;
  }
  if (ranks.remaining() !== 0) throw `${ranks.remaining()} unused bytes in VNBR`;
  return order;
}
