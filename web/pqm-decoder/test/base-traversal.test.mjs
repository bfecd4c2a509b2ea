// Format 4.0's base section (spec §6, §6.1): the layout byte, the delta
// layout behind it, and the traversal layout — meshes written by a
// test-only writer (traversal.mjs, mirroring the Rust reference's
// encode_traversal) decode to exactly their faces and codes; hostile
// payloads (every truncation, bad gates, candidates, escapes, repeated
// half-edges, crowded vertices, wrong counts, unused bytes, random
// mutations) are an `invalid` error of the base mesh and nothing else.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeBase } from '../src/codec.js';
import { PqmError, decodeAll } from '../src/index.js';
import { testFiles, rng, varint, svarint } from './helpers.mjs';
import { unpack, pack, setHeader } from './repack.mjs';
import {
  encodeTraversal,
  joinStreams,
  walkOrder,
  gridMesh,
  torusMesh,
  boxMesh,
  unionMesh,
  fanMesh,
  randomCodes,
  predictBase,
} from './traversal.mjs';

const QMAX = (1 << 14) - 1;

/** A mesh generator's mesh with codes, in the walk's order (as the coarsener numbers a base). */
function prepared(mesh, seed, qmax = QMAX) {
  const codes = randomCodes(mesh.nv, qmax, rng(seed));
  return walkOrder(codes, mesh.quads);
}

/** Smooth codes (a bumpy surface) for a mesh of `nv` vertices: small residuals. */
function smoothCodes(nv, qmax) {
  return Array.from({ length: nv }, (_, v) => [0, 1, 2].map((t) => Math.floor((qmax / 2) * (1 + Math.sin(0.37 * v + t)))));
}

/** Decodes a base payload as a 4.0 file's; returns {quads, codes} as arrays. */
function decode(payload, nv, nf, qmax = QMAX) {
  const st = decodeBase(payload, nv, nf, qmax, nv, nf, 4);
  const quads = [];
  for (let i = 0; i < nf; i++) quads.push([...st.f.subarray(4 * i, 4 * i + 4)]);
  const codes = [];
  for (let v = 0; v < nv; v++) codes.push([st.q[16 * v], st.q[16 * v + 1], st.q[16 * v + 2]]);
  return { quads, codes, st };
}

/** Asserts that decoding throws an `invalid` PqmError of the base mesh (message matching `re`, if given). */
function invalidBase(payload, nv, nf, re, what, qmax = QMAX) {
  let err = null;
  try {
    decodeBase(payload, nv, nf, qmax, nv, nf, 4);
  } catch (e) {
    err = e;
  }
  assert.ok(err instanceof PqmError, `${what}: expected a PqmError, got ${err}`);
  assert.equal(err.kind, 'invalid', `${what}: ${err.message}`);
  assert.equal(err.section, 'base mesh', what);
  if (re) assert.match(err.message, re, what);
  return err;
}

const meshes = {
  'single quad': { nv: 4, quads: [[0, 1, 2, 3]] },
  'grid 5×4 (boundary)': gridMesh(5, 4),
  'torus 6×5': torusMesh(6, 5),
  'box 3×3 per side': boxMesh(3),
  'box 1×1 per side': boxMesh(1),
  'fan of 9 (valence 9)': fanMesh(9),
  'fan of 255 (valence 255)': fanMesh(255),
  'three components': unionMesh(gridMesh(2, 3), torusMesh(4, 3), boxMesh(2)),
  'a long strip': gridMesh(60, 1),
};

for (const [name, mesh] of Object.entries(meshes)) {
  test(`traversal layout round trip: ${name}`, () => {
    for (const [seed, smooth] of [
      [1, false],
      [2, true],
    ]) {
      const m = prepared(mesh, seed);
      if (smooth) m.codes = smoothCodes(m.codes.length, QMAX);
      const payload = encodeTraversal(m.codes, m.quads, QMAX);
      assert.ok(payload !== null, `${name}: the writer takes a walk-ordered base`);
      assert.equal(payload[0], 1);
      const got = decode(payload, m.codes.length, m.quads.length);
      assert.deepEqual(got.quads, m.quads, `${name}: faces`);
      assert.deepEqual(got.codes, m.codes, `${name}: codes`);
      // the frontier's slot lists hold every face of each vertex
      for (let v = 0; v < m.codes.length; v++) {
        const want = m.quads.filter((g) => g.includes(v)).length;
        assert.equal(got.st.q[16 * v + 3], want, `${name}: vertex ${v}'s slot count`);
      }
    }
  });
}

test('traversal layout: a closed mesh costs a gate byte and two corner symbols per face, mostly 0 or 1', () => {
  const m = prepared(torusMesh(12, 10), 3);
  const p = encodeTraversal(m.codes, m.quads, QMAX, { parts: true });
  assert.equal(p.corners.length, 4 + 2 * (m.quads.length - 1));
  assert.ok(p.corners.filter((c) => c <= 1).length >= 0.9 * p.corners.length, `${p.corners}`);
  assert.equal(p.gates.filter((g) => g !== 0).length, m.quads.length - 1);
});

test('traversal layout: vertex 0 is predicted as (0, 0, 0), then the previous vertex, the edge mean, the stencil', () => {
  // one quad: vertices 0..3 have no face with earlier n1, o, n3 but 3 (its
  // n1 = 0 and n3 = 2 are earlier, o = 1 too: the stencil)
  const codes = [
    [5, 6, 7],
    [100, 200, 300],
    [1000, 50, 9],
    [4000, 4000, 4000],
  ];
  const quads = [[0, 1, 2, 3]];
  const p = encodeTraversal(codes, quads, QMAX, { parts: true });
  const around = [[0], [0], [0], [0]];
  assert.deepEqual(predictBase(0, codes, quads, around[0], QMAX), [0, 0, 0]);
  // vertex 1: n1 = 2 (later), n3 = 0 (earlier): the edge mean is code 0
  assert.deepEqual(predictBase(1, codes, quads, around[1], QMAX), [5, 6, 7]);
  // vertex 3: n1 = 0, o = 1, n3 = 2: ⌊(5 (Q0 + Q2) − 2 Q1) / 8⌋, clamped (y and z are negative)
  const st = [0, 1, 2].map((t) => Math.max(0, Math.floor((5 * (codes[0][t] + codes[2][t]) - 2 * codes[1][t]) / 8)));
  assert.deepEqual(st, [603, 0, 0]);
  assert.deepEqual(predictBase(3, codes, quads, around[3], QMAX), st);
  const res = [];
  for (let i = 0; i < p.pos.length; ) {
    let u = 0;
    let mul = 1;
    for (;;) {
      const b = p.pos[i++];
      u += (b & 0x7f) * mul;
      mul *= 128;
      if (b < 0x80) break;
    }
    res.push(u % 2 ? -(u + 1) / 2 : u / 2);
  }
  assert.deepEqual(res.slice(9, 12), [0, 1, 2].map((t) => codes[3][t] - st[t]));
  assert.deepEqual(decode(joinStreams(p), 4, 1).codes, codes);
});

test('traversal layout: predictions clamp to 0..=qmax', () => {
  // a stencil far outside the grid: 5 (Q0 + Q2) − 2 Q1 with Q1 large, Q0, Q2 small
  const qmax = 255;
  const codes = [
    [0, 255, 0],
    [255, 0, 255],
    [0, 255, 0],
    [0, 255, 0],
  ];
  const payload = encodeTraversal(codes, [[0, 1, 2, 3]], qmax);
  assert.deepEqual(decode(payload, 4, 1, qmax).codes, codes);
});

test('the writer refuses what the layout cannot hold (ids out of walk order, a vertex in no face, 256 faces at a vertex)', () => {
  const m = prepared(gridMesh(2, 2), 4);
  const swapped = m.quads.map((g) => g.map((v) => (v === 1 ? 2 : v === 2 ? 1 : v)));
  assert.equal(encodeTraversal(m.codes, swapped, QMAX), null);
  assert.equal(encodeTraversal([...m.codes, [0, 0, 0]], m.quads, QMAX), null);
  const fan = prepared(fanMesh(256), 5);
  assert.equal(encodeTraversal(fan.codes, fan.quads, QMAX), null);
});

test('layout byte 0: the delta layout behind it; other layout bytes and an empty payload are invalid', () => {
  // the delta layout of one quad (0 1 2 3) and its 4 codes
  const delta = [0, 1, 1, 1].flatMap((d) => svarint(d)).concat([1, 2, 3, 0, 0, 0, 5, 5, 5, 1, 1, 1].flatMap((d) => svarint(d)));
  const got = decode(Uint8Array.of(0, ...delta), 4, 1);
  assert.deepEqual(got.quads, [[0, 1, 2, 3]]);
  assert.deepEqual(got.codes, [
    [1, 2, 3],
    [1, 2, 3],
    [6, 7, 8],
    [7, 8, 9],
  ]);
  // versions 1–3 have no layout byte
  for (const major of [1, 2, 3]) {
    const st = decodeBase(Uint8Array.from(delta), 4, 1, QMAX, 4, 1, major);
    assert.deepEqual([...st.f.subarray(0, 4)], [0, 1, 2, 3]);
  }
  invalidBase(Uint8Array.from(delta), 4, 1, null, 'a 3.x payload in a 4.0 file');
  invalidBase(Uint8Array.of(2, ...delta), 4, 1, /unknown base layout 2/, 'layout 2');
  invalidBase(Uint8Array.of(255, ...delta), 4, 1, /unknown base layout 255/, 'layout 255');
  invalidBase(new Uint8Array(0), 0, 0, /empty/, 'empty');
  invalidBase(Uint8Array.of(0, ...delta, 0), 4, 1, /unused/, 'delta: trailing byte');
  // an empty base (no vertex, no face) in either layout
  assert.equal(decodeBase(Uint8Array.of(0), 0, 0, QMAX, 0, 0, 4).nv, 0);
  assert.equal(decodeBase(Uint8Array.of(1, 0, 0, 0, 0), 0, 0, QMAX, 0, 0, 4).nf, 0);
});

test('hostile traversal payloads: every truncation is invalid', () => {
  for (const mesh of [meshes['box 1×1 per side'], meshes['three components'], meshes['grid 5×4 (boundary)']]) {
    const m = prepared(mesh, 6);
    const payload = encodeTraversal(m.codes, m.quads, QMAX);
    const [nv, nf] = [m.codes.length, m.quads.length];
    for (let len = 0; len < payload.length; len++) {
      invalidBase(payload.subarray(0, len), nv, nf, null, `truncated to ${len} of ${payload.length}`);
    }
    // and every truncation of one stream (its length fixed to match)
    const p = encodeTraversal(m.codes, m.quads, QMAX, { parts: true });
    for (const name of ['gates', 'corners', 'escapes', 'pos']) {
      for (let len = 0; len < p[name].length; len++) {
        const q = { ...p, [name]: p[name].slice(0, len) };
        invalidBase(joinStreams(q), nv, nf, null, `${name} truncated to ${len}`);
      }
    }
  }
});

test('hostile traversal payloads: bad gate, candidate, escape, repeated half-edge, crowded vertex', () => {
  const box = prepared(boxMesh(1), 7);
  const p = encodeTraversal(box.codes, box.quads, QMAX, { parts: true });
  const [nv, nf] = [8, 6];
  const withPart = (name, i, value) => {
    const arr = p[name].slice();
    arr[i] = value;
    return joinStreams({ ...p, [name]: arr });
  };
  assert.deepEqual(decode(joinStreams(p), nv, nf).quads, box.quads);
  for (const g of [5, 6, 127, 255]) invalidBase(withPart('gates', 0, g), nv, nf, /gate byte/, `gate ${g}`);
  // a component start has no candidates
  invalidBase(withPart('corners', 0, 1), nv, nf, /candidate 1 of 0/, 'candidate at a start');
  // face 1 (across face 0's first edge, a gate): its x from X of a —
  // name one past the end of that list
  const ci = 4;
  invalidBase(withPart('corners', ci, 254), nv, nf, /candidate 254 of/, 'candidate 254');
  // an escape u ≥ s: at face 0's corner 0, s = 0
  invalidBase(joinStreams({ ...p, corners: [255, ...p.corners.slice(1)], escapes: [0, ...p.escapes] }), nv, nf, /escapes to vertex -1/, 'escape at s = 0');
  invalidBase(
    joinStreams({ ...p, corners: [0, 0, 0, 0, 255, ...p.corners.slice(5)], escapes: [...varint(4), ...p.escapes] }),
    nv,
    nf,
    /escapes/,
    'escape u = s',
  );
  invalidBase(
    joinStreams({ ...p, corners: [0, 0, 0, 0, 255, ...p.corners.slice(5)], escapes: [...varint(2 ** 40), ...p.escapes] }),
    nv,
    nf,
    /escapes/,
    'escape u huge',
  );
  // a repeated corner: face 1 = (1, 0, x, y) with x = 1 (escape u = 2)
  const f1 = [0, 0, 0, 0];
  invalidBase(joinStreams({ gates: [1], corners: [...f1, 255, 0], escapes: [2], pos: new Array(15).fill(0) }), 5, 2, /repeats a vertex/, 'repeated corner');
  // a repeated half-edge: face 0 = (0 1 2 3), face 1 across 0 → 1 as
  // (1, 0, 2, 3): its 2 → 3 is face 0's (escapes u = 1 → 2, u = 0 → 3)
  const pos8 = new Array(3 * 4).fill(0);
  invalidBase(
    joinStreams({ gates: [1], corners: [...f1, 255, 255], escapes: [1, 0], pos: pos8 }),
    4,
    2,
    /half-edge 2 -> 3 is in two faces/,
    'repeated half-edge',
  );
  // the pillow (1, 0, 3, 2) glued to (0 1 2 3) along all four edges is valid
  const pillow = decode(joinStreams({ gates: [1], corners: [...f1, 255, 255], escapes: [0, 1], pos: pos8 }), 4, 2);
  assert.deepEqual(pillow.quads, [
    [0, 1, 2, 3],
    [1, 0, 3, 2],
  ]);
  // vertex 0 in 256 faces: a fan written past the bound
  const fan = prepared(fanMesh(256), 8);
  const crowded = encodeTraversal(fan.codes, fan.quads, QMAX, { maxFaces: 1000 });
  invalidBase(crowded, fan.codes.length, 256, /vertex 0 is in more than 255 faces/, 'valence 256');
  const ok = prepared(fanMesh(255), 8);
  decode(encodeTraversal(ok.codes, ok.quads, QMAX), ok.codes.length, 255);
});

test('hostile traversal payloads: wrong counts, unused bytes, codes out of range', () => {
  const m = prepared(unionMesh(torusMesh(4, 4), gridMesh(3, 2)), 9);
  const p = encodeTraversal(m.codes, m.quads, QMAX, { parts: true });
  const payload = joinStreams(p);
  const [nv, nf] = [m.codes.length, m.quads.length];
  decode(payload, nv, nf);
  invalidBase(payload, nv - 1, nf, null, 'one vertex fewer');
  invalidBase(payload, nv + 1, nf, null, 'one vertex more');
  invalidBase(payload, nv, nf - 1, null, 'one face fewer');
  invalidBase(payload, nv, nf + 1, null, 'one face more');
  // counts the payload cannot hold: refused before allocating
  invalidBase(payload, 2 ** 31, nf, /need at least/, 'huge vertex count');
  invalidBase(payload, nv, 2 ** 31, /need at least/, 'huge face count');
  // a vertex no face names (vertex count checked at the end of the walk)
  const spare = { ...p, pos: [...p.pos, 0, 0, 0] };
  invalidBase(joinStreams(spare), nv + 1, nf, /faces use \d+ of the \d+ base vertices/, 'a vertex in no face');
  invalidBase(Uint8Array.of(...payload, 0), nv, nf, /1 bytes after the last base stream/, 'a byte after the streams');
  for (const name of ['gates', 'corners', 'escapes', 'pos']) {
    const q = { ...p, [name]: [...p[name], 0] };
    invalidBase(joinStreams(q), nv, nf, /unused bytes/, `a byte more in ${name}`);
  }
  // a stream length past the payload's end
  invalidBase(Uint8Array.of(1, ...varint(payload.length), ...payload.subarray(1)), nv, nf, null, 'gates longer than the payload');
  // codes out of range: a residual pushing vertex 0 below 0 or past qmax
  for (const r of [-1, QMAX + 1]) {
    const q = { ...p, pos: [...svarint(r), ...p.pos.slice(svarint(m.codes[0][0]).length)] };
    invalidBase(joinStreams(q), nv, nf, /vertex 0 code .* outside 0\.\.=16383/, `residual ${r}`);
  }
});

test('hostile traversal payloads: random mutations decode or are invalid, never anything else', () => {
  const rand = rng(10);
  const sources = [prepared(boxMesh(2), 11), prepared(unionMesh(gridMesh(3, 3), torusMesh(3, 4)), 12), prepared(fanMesh(12), 13)];
  let invalid = 0;
  let decoded = 0;
  for (let trial = 0; trial < 3000; trial++) {
    const m = sources[trial % sources.length];
    const payload = encodeTraversal(m.codes, m.quads, QMAX).slice();
    const edits = 1 + Math.floor(rand() * 3);
    for (let e = 0; e < edits; e++) {
      const at = Math.floor(rand() * payload.length);
      payload[at] = rand() < 0.5 ? Math.floor(rand() * 256) : payload[at] ^ (1 << Math.floor(rand() * 8));
    }
    const [nv, nf] = [m.codes.length, m.quads.length];
    try {
      decodeBase(payload, nv, nf, QMAX, nv, nf, 4);
      decoded++;
    } catch (err) {
      assert.ok(err instanceof PqmError && err.kind === 'invalid' && err.section === 'base mesh', `trial ${trial}: ${err}`);
      invalid++;
    }
  }
  assert.ok(invalid > 1000, `${invalid} invalid, ${decoded} decoded`);
});

/**
 * A 4.0 file with no records whose base is `codes` / `quads` in the given
 * base payload (from grid_small's header: grid and quantization bits).
 */
function baseOnlyFile(payload, nv, nf, { baseLenDelta = 0 } = {}) {
  const grid = testFiles().find((f) => f.name === 'grid_small');
  const parts = unpack(grid.bytes);
  parts.base = payload;
  parts.entries = [];
  parts.chunks = [];
  parts.sections = [];
  setHeader(parts, 8, 'Uint16', 4);
  setHeader(parts, 10, 'Uint16', 0);
  setHeader(parts, 16, 'Uint32', 0);
  setHeader(parts, 24, 'Uint32', nv);
  setHeader(parts, 28, 'Uint32', nf);
  setHeader(parts, 32, 'Uint32', nv);
  setHeader(parts, 36, 'Uint32', nf);
  setHeader(parts, 40, 'Uint32', 0);
  setHeader(parts, 44, 'Uint32', 0);
  setHeader(parts, 48, 'Uint32', 0);
  const bytes = pack(parts);
  if (baseLenDelta !== 0) {
    // restate base_uncompressed_len (the header CRC follows)
    const p2 = unpack(bytes);
    const out = pack(p2);
    const dv = new DataView(out.buffer);
    dv.setUint32(56, dv.getUint32(56, true) + baseLenDelta, true);
    return out;
  }
  return bytes;
}

test('a whole 4.0 file with a traversal base decodes to its faces and codes; a bad one is an invalid base mesh', () => {
  const qbits = decodeAll(testFiles().find((f) => f.name === 'grid_small').bytes).header.quantBits;
  const qmax = 2 ** qbits - 1;
  const m = prepared(unionMesh(boxMesh(2), gridMesh(3, 2)), 14, qmax);
  const payload = encodeTraversal(m.codes, m.quads, qmax);
  const d = decodeAll(baseOnlyFile(payload, m.codes.length, m.quads.length));
  assert.equal(d.header.versionMajor, 4);
  assert.deepEqual([...d.quads], m.quads.flat());
  assert.deepEqual([...d.positionCodes], m.codes.flat());
  const bad = payload.slice();
  bad[bad.length - 1] = 0xff; // the last residual's varint now continues past the end
  assert.throws(
    () => decodeAll(baseOnlyFile(bad, m.codes.length, m.quads.length)),
    (e) => e instanceof PqmError && e.kind === 'invalid' && e.section === 'base mesh',
  );
  // counts the stated payload size cannot hold: refused before decompressing
  assert.throws(
    () => decodeAll(baseOnlyFile(payload, 1000, m.quads.length)),
    (e) => e instanceof PqmError && e.kind === 'invalid' && e.section === 'base mesh' && /need at least/.test(e.message),
  );
});

test('the 4.0 vectors: v4_traversal has a traversal-layout base, v4_delta_base the delta layout behind byte 0', () => {
  const files = Object.fromEntries(testFiles().map((f) => [f.name, f]));
  for (const [name, layout] of [
    ['v4_traversal', 1],
    ['v4_delta_base', 0],
  ]) {
    assert.ok(files[name], `missing vector ${name}`);
    assert.equal(unpack(files[name].bytes).base[0], layout, name);
    const d = decodeAll(files[name].bytes);
    assert.equal(d.header.versionMajor, 4);
    assert.equal(d.header.versionMinor, 0);
  }
});

test('the worked example of spec §6.1 decodes to its two quads and codes', () => {
  // the payload the spec lists byte by byte (and the Rust test
  // `the_spec_example_is_these_bytes` writes)
  const payload = Uint8Array.from([
    1, // layout
    2, 0, 4, // gates
    6, 0, 0, 0, 0, 0, 0, // corners
    0, // escapes
    18, 0, 0, 0, 20, 0, 0, 0, 20, 0, 5, 8, 0, 20, 0, 0, 8, 8, 0, // pos
  ]);
  const { quads, codes } = decode(payload, 6, 2, 1023);
  assert.deepEqual(quads, [[0, 1, 2, 3], [1, 4, 5, 2]]);
  assert.deepEqual(codes, [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [20, 0, 0], [20, 10, 0]]);
});
