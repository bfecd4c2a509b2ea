// Test helpers: the spec §11 digests, OBJ parsing, the test files, random
// byte splits.
import { readFileSync, readdirSync, existsSync } from 'node:fs';
import { endianness } from 'node:os';
import { fileURLToPath } from 'node:url';
import path from 'node:path';
import http from 'node:http';
import { unpack, pack, setHeader } from './repack.mjs';

if (endianness() !== 'LE') throw new Error('these tests read typed arrays as little-endian bytes');

const here = path.dirname(fileURLToPath(import.meta.url));
export const VECTORS_DIR = path.resolve(here, '../../../spec/vectors');
export const DATA_DIR = path.resolve(here, 'data');
export const BENCH_DATA_DIR = path.resolve(here, '../../bench/data');

/**
 * FNV-1a 64 (offset basis 0xcbf29ce484222325, prime 0x100000001b3) of a
 * byte array, as 16 lowercase hex digits. Computed on four 16-bit limbs so
 * it stays exact in doubles: h * prime = h * 0x1b3 + (h << 40) mod 2^64.
 */
export function fnv1a64(bytes) {
  let h0 = 0x2325, h1 = 0x8422, h2 = 0x9ce4, h3 = 0xcbf2;
  for (let i = 0; i < bytes.length; i++) {
    h0 ^= bytes[i];
    const add2 = (h0 & 0xff) << 8;
    const add3 = (h0 >> 8) | ((h1 & 0xff) << 8);
    let r0 = h0 * 0x1b3;
    let r1 = h1 * 0x1b3 + (r0 >>> 16);
    let r2 = h2 * 0x1b3 + add2 + (r1 >>> 16);
    let r3 = h3 * 0x1b3 + add3 + (r2 >>> 16);
    h0 = r0 & 0xffff;
    h1 = r1 & 0xffff;
    h2 = r2 & 0xffff;
    h3 = r3 & 0xffff;
  }
  const hex = (x) => x.toString(16).padStart(4, '0');
  return hex(h3) + hex(h2) + hex(h1) + hex(h0);
}

const bytesOf = (ta) => new Uint8Array(ta.buffer, ta.byteOffset, ta.byteLength);

/** `{positions, quads}` digests of the decoder's current level (spec §11). */
export function levelDigests(dec) {
  return {
    positions: fnv1a64(bytesOf(dec.positionsF64())),
    quads: fnv1a64(bytesOf(dec.quads)),
  };
}

/** A copy of the decoder's current level: f64 positions and quads. */
export function meshOf(dec) {
  return { positions: dec.positionsF64(), quads: dec.quads.slice() };
}

/**
 * The box of every position any decoded level shows (the f64 of spec §5),
 * `[min, max]` of 3 numbers each (what a 3.2 header's bounds must be, spec
 * §3); `null` if no level has a vertex. Visits every level from 0 to the
 * deepest and leaves the decoder at the deepest.
 */
export function positionBounds(dec) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  let any = false;
  for (let l = 0; l <= dec.deepestLevel; l++) {
    dec.setLevel({ level: l });
    const p = dec.positionsF64();
    for (let i = 0; i < p.length; i++) {
      const k = i % 3;
      if (p[i] < min[k]) min[k] = p[i];
      if (p[i] > max[k]) max[k] = p[i];
      any = true;
    }
  }
  return any ? [min, max] : null;
}

/** Parses the OBJ files of spec/vectors: `v x y z` and `f a b c d` (1-based). */
export function parseObj(text) {
  const pos = [];
  const quads = [];
  for (const line of text.split('\n')) {
    const t = line.trim().split(/\s+/);
    if (t[0] === 'v') pos.push(Number(t[1]), Number(t[2]), Number(t[3]));
    else if (t[0] === 'f') {
      if (t.length !== 5) throw new Error(`not a quad: ${line}`);
      for (let k = 1; k < 5; k++) quads.push(Number(t[k]) - 1);
    }
  }
  return { positions: Float64Array.from(pos), quads: Uint32Array.from(quads) };
}

/**
 * Every test file: the spec vectors, the committed real-mesh file in
 * test/data and (if present) the bench files. Each has `name`, `bytes` and
 * `digest` (the JSON of spec §11) and `obj` (level → OBJ text) for vectors.
 */
export function testFiles({ includeBench = false } = {}) {
  const out = [];
  const dirs = [VECTORS_DIR, DATA_DIR];
  if (includeBench && existsSync(BENCH_DATA_DIR)) dirs.push(BENCH_DATA_DIR);
  for (const dir of dirs) {
    if (!existsSync(dir)) continue;
    for (const f of readdirSync(dir).sort()) {
      if (!f.endsWith('.pqm')) continue;
      const name = f.slice(0, -4);
      const jsonPath = path.join(dir, `${name}.json`);
      if (!existsSync(jsonPath)) continue;
      const digest = JSON.parse(readFileSync(jsonPath, 'utf8'));
      const obj = {};
      for (const l of digest.levels) {
        const p = path.join(dir, `${name}.level${l.level}.obj`);
        if (existsSync(p)) obj[l.level] = readFileSync(p, 'utf8');
      }
      out.push({ name, dir, bytes: new Uint8Array(readFileSync(path.join(dir, f))), digest, obj });
    }
  }
  return out;
}

/** Deterministic PRNG (mulberry32) returning floats in [0, 1). */
export function rng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

/** Splits `bytes` into pieces of random lengths 1..maxLen (copies, as from a socket). */
export function randomPieces(bytes, rand, maxLen) {
  const out = [];
  for (let i = 0; i < bytes.length; ) {
    const n = 1 + Math.floor(rand() * maxLen);
    out.push(bytes.slice(i, i + n));
    i += n;
  }
  return out;
}

/**
 * Serves `bytes` at /f.pqm: with `ranges`, `Range: bytes=a-b` / `bytes=a-`
 * gets a 206 with exactly those bytes (416 past the end); without, every
 * request gets the whole file with 200. Bodies go out in `piece`-byte
 * writes; `stats.served` counts the body bytes written. `maxRange` caps the
 * bytes of one 206 (as some servers do: the client must ask again).
 */
export async function serveBytes(bytes, { ranges = true, piece = 997, maxRange = Infinity } = {}) {
  const stats = { served: 0, requests: [] };
  const server = http.createServer((req, res) => {
    const m = /^bytes=(\d+)-(\d*)$/.exec(req.headers.range ?? '');
    stats.requests.push(req.headers.range ?? null);
    let a = 0;
    let b = bytes.length;
    let status = 200;
    const headers = { 'Content-Type': 'application/octet-stream', 'Accept-Ranges': ranges ? 'bytes' : 'none' };
    if (ranges && m) {
      a = Number(m[1]);
      b = m[2] === '' ? bytes.length : Math.min(Number(m[2]) + 1, bytes.length);
      b = Math.min(b, a + maxRange);
      if (a >= bytes.length) {
        res.writeHead(416, { 'Content-Range': `bytes */${bytes.length}` });
        res.end();
        return;
      }
      status = 206;
      headers['Content-Range'] = `bytes ${a}-${b - 1}/${bytes.length}`;
    }
    headers['Content-Length'] = String(b - a);
    res.writeHead(status, headers);
    let o = a;
    let closed = false;
    res.on('close', () => (closed = true));
    const pump = () => {
      while (o < b && !closed) {
        const k = Math.min(piece, b - o);
        stats.served += k;
        const ok = res.write(bytes.subarray(o, o + k));
        o += k;
        if (!ok) {
          res.once('drain', pump);
          return;
        }
      }
      res.end();
    };
    pump();
  });
  await new Promise((r) => server.listen(0, '127.0.0.1', r));
  return {
    url: `http://127.0.0.1:${server.address().port}/f.pqm`,
    stats,
    close: () => new Promise((r) => server.close(r)),
  };
}

/** Four distinct random vertex ids below `nv`. */
export function randomQuad(rand, nv) {
  const q = [];
  while (q.length < 4) {
    const v = Math.floor(rand() * nv);
    if (!q.includes(v)) q.push(v);
  }
  return q;
}

/**
 * One random edit of a `Frontier` as records make them (f first, then the
 * per-vertex slot lists): 60 % rewrite a corner (corners move between
 * vertices and come back), 10 % append a quad, 5 % add a vertex. Returns
 * false (nothing done) otherwise, so the caller checks something instead.
 */
export function randomFrontierEdit(st, rand, maxF, maxV) {
  const r = rand();
  if (r < 0.6) {
    const c = Math.floor(rand() * 4 * st.nf);
    const s4 = c & ~3;
    const v = Math.floor(rand() * st.nv);
    const others = [0, 1, 2, 3].filter((k) => s4 + k !== c).map((k) => st.f[s4 + k]);
    if (!others.includes(v) && st.f[c] !== v) {
      st.setCorner(c, v);
    }
    return true;
  }
  if (r < 0.7 && st.nf < maxF) {
    const slot = st.nf;
    st.reserve(st.nv, slot + 1);
    st.f.set(randomQuad(rand, st.nv), 4 * slot);
    st.nf = slot + 1;
    st.addSlot(slot);
    return true;
  }
  if (r < 0.75 && st.nv < maxV) {
    st.reserve(st.nv + 1, st.nf);
    st.q[16 * st.nv + 3] = 0; // an empty slot list (codec.js: LEN)
    st.nv++;
    return true;
  }
  return false;
}

/** An unsigned LEB128 varint (spec §1) as bytes. */
export function varint(x) {
  const out = [];
  for (;;) {
    const b = x % 128;
    x = Math.floor(x / 128);
    if (x === 0) {
      out.push(b);
      return out;
    }
    out.push(b | 0x80);
  }
}

/** A zigzag svarint (spec §1) as bytes. */
export const svarint = (v) => varint(v >= 0 ? 2 * v : -2 * v - 1);

/** A stream from items: numbers are varints, {s: v} svarints, {b: byte} raw bytes. */
export const stream = (items) => items.flatMap((x) => (typeof x === 'number' ? varint(x) : 's' in x ? svarint(x.s) : [x.b]));

/**
 * A file for hand-written records: the base mesh of `baseFile` (a test
 * file's bytes) and one chunk holding the given streams, reaching `v`
 * vertices and `f` faces, with `version_major` = `major` (the record rules
 * of spec §7.3 and §7.6 depend on it, so tests say which they mean). The
 * base payload gets or loses the layout byte of version 4 (spec §6) as
 * `major` needs: a 3.x base becomes the delta layout behind byte 0.
 */
export function handmadeFile(baseFile, { ops, conn = [], refs = [], slots = [], pos = [] }, v, f, major) {
  const parts = unpack(baseFile);
  const from = new DataView(parts.header.buffer).getUint16(8, true);
  if (major >= 4 && from < 4) parts.base = Uint8Array.of(0, ...parts.base);
  if (major < 4 && from >= 4) {
    if (parts.base[0] !== 0) throw new Error('a traversal-layout base cannot go into a file older than 4.0');
    parts.base = parts.base.slice(1);
  }
  if (parts.entries.length === 0) parts.entries = [new Uint8Array(36)];
  const streams = [ops.map((b) => ({ b })), conn, refs, slots, pos].map(stream);
  parts.chunks = [Uint8Array.from(streams.flatMap((s) => [...varint(s.length), ...s]))];
  const e = parts.entries[0].slice();
  const dv = new DataView(e.buffer);
  dv.setUint32(16, ops.length, true);
  dv.setUint32(20, v, true);
  dv.setUint32(24, f, true);
  dv.setFloat32(28, 0, true);
  parts.entries = [e];
  parts.sections = [];
  setHeader(parts, 8, 'Uint16', major);
  setHeader(parts, 10, 'Uint16', major === 1 ? 1 : 0);
  setHeader(parts, 16, 'Uint32', 0); // no VORD
  setHeader(parts, 32, 'Uint32', v);
  setHeader(parts, 36, 'Uint32', f);
  setHeader(parts, 40, 'Uint32', ops.length);
  setHeader(parts, 44, 'Uint32', 1);
  setHeader(parts, 48, 'Uint32', 0);
  return pack(parts);
}

/** A Change as plain data (typed arrays as arrays), for deepEqual. */
export const plainChange = (c) => ({
  ...c,
  verticesMoved: [...c.verticesMoved],
  facesRewritten: [...c.facesRewritten],
  moved: c.movedRanges(),
  rewritten: c.rewrittenRanges(),
});
