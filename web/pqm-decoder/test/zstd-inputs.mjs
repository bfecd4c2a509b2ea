// Deterministic inputs of the zstd decoder test (zstd.test.mjs) and of the
// script that compressed them into test/data/zstd/ with the zstd command
// line tool (tools/make-zstd-fixtures.mjs): each kind exercises other parts
// of a frame — raw and RLE blocks, 1- and 4-stream Huffman literals,
// treeless literals and repeated FSE tables across blocks, long and
// overlapping matches, repeat offsets, several blocks per frame.

/** xorshift32: the same bytes on every run. */
function rng(seed) {
  let x = seed >>> 0 || 1;
  return () => {
    x ^= x << 13;
    x >>>= 0;
    x ^= x >>> 17;
    x ^= x << 5;
    x >>>= 0;
    return x;
  };
}

/** name → bytes. */
export function zstdInputs() {
  const out = {};
  const r = rng(12345);
  // uniformly random: raw blocks (incompressible)
  out.random = Uint8Array.from({ length: 5000 }, () => r() & 255);
  // one repeated byte: RLE blocks or one long overlapping match
  out.runs = new Uint8Array(200000).fill(7);
  // skewed bytes (Huffman literals), few matches: like a .pqm payload
  out.skewed = Uint8Array.from({ length: 40000 }, () => {
    const x = r();
    return (x & 7) === 0 ? x >>> 24 : (x >>> 8) & 15;
  });
  // varint-like stream of small signed deltas
  const v = [];
  while (v.length < 30000) {
    const d = ((r() % 2000) - 1000) * ((r() & 3) === 0 ? 50 : 1);
    let u = d < 0 ? -2 * d - 1 : 2 * d;
    while (u >= 128) {
      v.push((u & 127) | 128);
      u = Math.floor(u / 128);
    }
    v.push(u);
  }
  out.varints = Uint8Array.from(v);
  // text-like: words from a small vocabulary (many matches, repeat offsets)
  const words = ['quad', 'vertex', 'split', 'edge', 'face', 'level', 'chunk', 'frontier', 'zstd', 'record', ' ', '\n'];
  const t = [];
  while (t.length < 140000) for (const ch of words[r() % words.length]) t.push(ch.charCodeAt(0));
  out.text = Uint8Array.from(t);
  // long repeats of random blocks at varied distances (long offsets and matches)
  const base = Uint8Array.from({ length: 4000 }, () => r() & 255);
  const m = [];
  while (m.length < 300000) {
    const at = r() % 3000;
    const len = 20 + (r() % 900);
    for (let k = 0; k < len; k++) m.push(base[(at + k) % 4000]);
    if ((r() & 3) === 0) for (let k = 0; k < 30; k++) m.push(r() & 255);
  }
  out.repeats = Uint8Array.from(m);
  // tiny and empty frames
  out.tiny = Uint8Array.of(1, 2, 3, 1, 2, 3, 1, 2, 3, 4);
  out.empty = new Uint8Array(0);
  return out;
}

/** Compression settings of the fixtures: file suffix → zstd arguments. */
export const ZSTD_LEVELS = { l1: ['-1'], l3: ['-3'], l19: ['-19'], l22: ['--ultra', '-22'], fast: ['--fast=5'] };

/** The settings each input is compressed with (all, for those that compress well). */
export function levelsOf(name) {
  if (name === 'text') return ['l1', 'l19', 'fast'];
  return ['random', 'skewed', 'varints'].includes(name) ? ['l3', 'l19'] : Object.keys(ZSTD_LEVELS);
}
