// The traversal layout's decoder (spec §6.1; codec.js decodeTraversal,
// whose faces coded across an edge take their half-edges from how their
// corners were named, and whose predictions walk each vertex's list of the
// faces it is the largest corner of) against decodeTraversalReference (the
// straightforward decoder: every half-edge looked up in the lists, every
// prediction over all the faces at its vertex) — as the Rust side holds
// `base::decode` to `base::decode_reference`: the same frontier or the same
// error on walk-ordered bases, the bases of the test and bench files,
// damaged payloads, payloads whose symbols are changed to other small
// symbols, a vertex crowded across edges and faces across two candidates.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeBase, decodeBaseReference } from '../src/codec.js';
import { PqmError } from '../src/index.js';
import { existsSync, readdirSync, readFileSync } from 'node:fs';
import path from 'node:path';
import { testFiles, rng, BENCH_DATA_DIR } from './helpers.mjs';
import { unpack } from './repack.mjs';
import { encodeTraversal, joinStreams, walkOrder, gridMesh, torusMesh, boxMesh, unionMesh, fanMesh, randomCodes } from './traversal.mjs';

const QMAX = (1 << 14) - 1;

/** decodeBase's outcome: {f, q} (the whole frontier arrays) or {error: [kind, section, message]}. */
function outcome(decode, payload, nv, nf, qmax) {
  try {
    const st = decode(payload, nv, nf, qmax, nv, nf, 4);
    return { f: st.f, q: st.q, nv: st.nv, nf: st.nf };
  } catch (e) {
    if (!(e instanceof PqmError)) throw e;
    return { error: [e.kind, e.section, e.message] };
  }
}

/** Asserts decodeBase and decodeBaseReference agree on `payload`; returns decodeBase's outcome. */
function same(payload, nv, nf, what, qmax = QMAX) {
  const fast = outcome(decodeBase, payload, nv, nf, qmax);
  const ref = outcome(decodeBaseReference, payload, nv, nf, qmax);
  if (fast.error || ref.error) {
    assert.deepEqual(fast.error, ref.error, what);
  } else {
    assert.equal(fast.nv, ref.nv, what);
    assert.equal(fast.nf, ref.nf, what);
    assert.ok(sameArray(fast.f, ref.f), `${what}: faces differ`);
    assert.ok(sameArray(fast.q, ref.q), `${what}: codes (or slot lists) differ`);
  }
  return fast;
}

function sameArray(a, b) {
  if (a.length !== b.length) return false;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
  return true;
}

/** `mesh` with codes, faces shuffled (so that the walk starts elsewhere), in the walk's order. */
function prepared(mesh, seed) {
  const rand = rng(seed);
  const quads = mesh.quads.map((g) => g.slice());
  for (let i = quads.length - 1; i > 0; i--) {
    const j = Math.floor(rand() * (i + 1));
    [quads[i], quads[j]] = [quads[j], quads[i]];
  }
  return walkOrder(randomCodes(mesh.nv, QMAX, rand), quads);
}

const meshes = [
  { nv: 4, quads: [[0, 1, 2, 3]] },
  gridMesh(5, 4),
  gridMesh(60, 1),
  torusMesh(6, 5),
  torusMesh(3, 3),
  boxMesh(1),
  boxMesh(3),
  fanMesh(3),
  fanMesh(9),
  fanMesh(255),
  unionMesh(gridMesh(2, 3), torusMesh(4, 3), boxMesh(2), fanMesh(5)),
];

/** The traversal payloads of the test and bench files with a traversal-layout base: {name, payload, nv, nf, qmax}. */
function fileBases() {
  const out = [];
  const files = testFiles({ includeBench: true });
  // the bench files (makehuman_base, loki, …), digests or not, when there
  if (existsSync(BENCH_DATA_DIR)) {
    for (const f of readdirSync(BENCH_DATA_DIR).sort()) {
      const name = f.slice(0, -4);
      if (f.endsWith('.pqm') && !files.some((t) => t.name === name)) {
        files.push({ name, bytes: new Uint8Array(readFileSync(path.join(BENCH_DATA_DIR, f))) });
      }
    }
  }
  for (const file of files) {
    const b = file.bytes;
    const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    if (dv.getUint16(8, true) < 4) continue;
    const payload = unpack(b).base;
    if (payload[0] !== 1) continue;
    out.push({ name: file.name, payload, nv: dv.getUint32(24, true), nf: dv.getUint32(28, true), qmax: 2 ** b[20] - 1 });
  }
  return out;
}

/** The byte range of a traversal payload's gates, corners and escapes (the streams before the positions). */
function symbolStreams(p) {
  let at = 1;
  for (let s = 0; s < 3; s++) {
    let len = 0;
    let mul = 1;
    for (;;) {
      const b = p[at++];
      len += (b & 0x7f) * mul;
      mul *= 128;
      if (b < 0x80) break;
    }
    at += len;
  }
  return [1, at];
}

/** Symbols a change writes: new, candidates 1–5, 254 and an escape. */
const SMALL = [0, 1, 2, 3, 4, 5, 254, 255];

test('traversal decode = reference decode: walk-ordered bases, any start', () => {
  for (const [i, mesh] of meshes.entries()) {
    for (let seed = 1; seed <= 4; seed++) {
      const m = prepared(mesh, 100 * i + seed);
      const payload = encodeTraversal(m.codes, m.quads, QMAX);
      assert.ok(payload !== null);
      const got = same(payload, m.codes.length, m.quads.length, `mesh ${i} seed ${seed}`);
      assert.ok(!got.error, `mesh ${i} seed ${seed}: ${got.error}`);
      assert.deepEqual([...got.f.subarray(0, 4 * m.quads.length)], m.quads.flat());
      for (let v = 0; v < m.codes.length; v++) assert.deepEqual([...got.q.subarray(16 * v, 16 * v + 3)], m.codes[v]);
    }
  }
});

test('traversal decode = reference decode: the bases of the test and bench files', () => {
  const bases = fileBases();
  assert.ok(bases.length > 0, 'a file with a traversal-layout base');
  for (const { name, payload, nv, nf, qmax } of bases) {
    const got = same(payload, nv, nf, name, qmax);
    assert.ok(!got.error, `${name}: ${got.error}`);
  }
});

test('traversal decode = reference decode: damaged payloads (bytes changed, truncations)', () => {
  const rand = rng(7);
  const sources = meshes.slice(1).map((mesh, i) => {
    const m = prepared(mesh, 900 + i);
    return { payload: encodeTraversal(m.codes, m.quads, QMAX), nv: m.codes.length, nf: m.quads.length };
  });
  let errors = 0;
  for (let trial = 0; trial < 3000; trial++) {
    const src = sources[trial % sources.length];
    const p = src.payload.slice();
    const edits = 1 + Math.floor(rand() * 3);
    for (let e = 0; e < edits; e++) {
      const at = Math.floor(rand() * p.length);
      p[at] = rand() < 0.5 ? Math.floor(rand() * 256) : p[at] ^ (1 << Math.floor(rand() * 8));
    }
    const cut = rand() < 0.1 ? Math.floor(rand() * p.length) : p.length;
    if (same(p.subarray(0, cut), src.nv, src.nf, `trial ${trial}`).error) errors++;
  }
  assert.ok(errors > 1000, `${errors} refused`);
});

test('traversal decode = reference decode: symbols changed to other small symbols', () => {
  const rand = rng(8);
  const sources = meshes.slice(1).map((mesh, i) => {
    const m = prepared(mesh, 500 + i);
    return { name: `mesh ${i + 1}`, payload: encodeTraversal(m.codes, m.quads, QMAX), nv: m.codes.length, nf: m.quads.length, qmax: QMAX };
  });
  // the real bases too (their candidates and escapes are the irregular ones)
  for (const b of fileBases()) if (b.nf <= 5000) sources.push(b);
  const seen = new Map();
  let decoded = 0;
  for (let trial = 0; trial < 4000; trial++) {
    const src = sources[trial % sources.length];
    const p = src.payload.slice();
    const [lo, hi] = symbolStreams(p);
    const changes = 1 + Math.floor(rand() * 5);
    for (let c = 0; c < changes; c++) p[lo + Math.floor(rand() * (hi - lo))] = SMALL[Math.floor(rand() * SMALL.length)];
    const got = same(p, src.nv, src.nf, `${src.name} trial ${trial}`, src.qmax);
    if (got.error) {
      const kind = got.error[2].replace(/\d+/g, '#');
      seen.set(kind, (seen.get(kind) || 0) + 1);
    } else decoded++;
  }
  // the shortcuts' fallbacks are all exercised: repeats of either kind
  const kinds = [...seen.keys()].join('\n');
  for (const re of [/repeats a vertex/, /half-edge # -> # is in two faces/, /names candidate/, /escapes to vertex/]) {
    assert.match(kinds, re, `no error like ${re} among:\n${kinds}`);
  }
  assert.ok(decoded > 50, `${decoded} decoded`);
});

/**
 * A closed surface of two fans of `k` quads glued along their rims, in the
 * walk's order: the top fan (fanMesh: centre 0, rim r_i = 1 + 2i, o_i =
 * 2 + 2i), then the bottom one around 1 + 2k, from its face across the top
 * fan's last rim edge on — so that the bottom centre comes last and is the
 * largest corner of all its k faces.
 */
function doubleFan(k) {
  const { quads } = fanMesh(k);
  const b = 1 + 2 * k;
  for (let j = 0; j < k; j++) {
    const i = (j + k - 1) % k;
    quads.push([b, 1 + 2 * ((i + 1) % k), 2 + 2 * i, 1 + 2 * i]);
  }
  return { nv: 2 + 2 * k, quads };
}

test('traversal decode = reference decode: predictions over 1 to 12 faces, codes at 0 and qmax = 2^24 − 1', () => {
  // P(v)'s sums at their extremes (5 (qmax + qmax) per face, or −2 qmax),
  // over as many faces as v is the largest corner of (a power-of-two count
  // takes a shift, the others a division)
  const qmax = 2 ** 24 - 1;
  for (let k = 2; k <= 12; k++) {
    const mesh = doubleFan(k);
    for (let seed = 1; seed <= 8; seed++) {
      const rand = rng(1000 * k + seed);
      const codes = Array.from({ length: mesh.nv }, () => [0, 1, 2].map(() => (rand() < 0.5 ? 0 : qmax)));
      const payload = encodeTraversal(codes, mesh.quads, qmax);
      assert.ok(payload !== null, `double fan ${k}`);
      const got = same(payload, mesh.nv, mesh.quads.length, `double fan ${k} seed ${seed}`, qmax);
      assert.ok(!got.error, `${got.error}`);
      assert.deepEqual([...got.f.subarray(0, 8 * k)], mesh.quads.flat());
      for (let v = 0; v < mesh.nv; v++) assert.deepEqual([...got.q.subarray(16 * v, 16 * v + 3)], codes[v]);
    }
  }
});

/**
 * A strip of `nf` quads around vertex 0, each face across the edge it
 * shares with the one before (not a component start): face 0 = [0, 1, 2,
 * 3]; face i + 1 = [0, v, m, w] across face i's half-edge v → 0 (gate 1 at
 * its k = 3: 0 is the gate's b), m and w new — or, `at = 'a'`, face i + 1
 * = [v, 0, m, w] across face i's 0 → v (gate 1 at its k = 0, then k = 1:
 * 0 is the gate's a).
 */
function strip(nf, at = 'b') {
  const gates = at === 'a' ? [1, 0, 0, 0] : [0, 0, 0, 1];
  for (let i = 1; i < nf - 1; i++) gates.push(...(at === 'a' ? [1, 0, 0] : [0, 0, 1]));
  if (at === 'a') gates.length -= 2; // the last face ends the walk
  const corners = new Array(4 + 2 * (nf - 1)).fill(0);
  const nv = 4 + 2 * (nf - 1);
  return { payload: joinStreams({ gates, corners, escapes: [], pos: new Array(3 * nv).fill(0) }), nv };
}

/**
 * `nf − 1` faces around vertex 0 as a strip, then a face that names vertex
 * 0 as a candidate: `x` (`as = 'x'`: the strip's faces are [0, 1, 2, 3]
 * and [v, 0, x, y] across the previous face's 0 → v, the last face across
 * the strip's last x → y with 0 → x open: 0 is candidate 1 of X) or `y`
 * (`as = 'y'`: the strip of strip(), the last face across its last m → w
 * with w → 0 open: 0 is candidate 1 of Y).
 */
function candidateAfterStrip(nf, as) {
  const gates = as === 'x' ? [1, 0, 0, 0] : [0, 0, 0, 1];
  for (let i = 1; i < nf - 2; i++) gates.push(...(as === 'x' ? [1, 0, 0] : [0, 0, 1]));
  gates.push(0, 1);
  const corners = [...new Array(4 + 2 * (nf - 2)).fill(0), ...(as === 'x' ? [1, 0] : [0, 1])];
  const nv = 4 + 2 * (nf - 2) + 1;
  return { payload: joinStreams({ gates, corners, escapes: [], pos: new Array(3 * nv).fill(0) }), nv };
}

test('traversal decode = reference decode: a vertex crowded across edges', () => {
  let payload, nv;
  for (const at of ['a', 'b']) {
    ({ payload, nv } = strip(255, at));
    const ok = same(payload, nv, 255, `strip of 255 (${at})`, 255);
    assert.ok(!ok.error, `${at}: ${ok.error}`);
    assert.ok([...ok.f.subarray(4 * 254, 4 * 255)].includes(0));
    ({ payload, nv } = strip(256, at));
    const bad = same(payload, nv, 256, `strip of 256 (${at})`, 255);
    assert.match(bad.error[2], /face 255: vertex 0 is in more than 255 faces/, at);
  }
  // crowded as a candidate x or y: its 255th face decodes, a 256th is refused
  for (const as of ['x', 'y']) {
    ({ payload, nv } = candidateAfterStrip(255, as));
    const fine = same(payload, nv, 255, `candidate ${as} in its 255th face`, 255);
    assert.ok(!fine.error, `${as}: ${fine.error}`);
    assert.equal(fine.f[4 * 254 + (as === 'x' ? 2 : 3)], 0, `${as}: face 254 names 0`);
    ({ payload, nv } = candidateAfterStrip(256, as));
    const refused = same(payload, nv, 256, `candidate ${as} in a 256th face`, 255);
    assert.match(refused.error[2], /face 255: vertex 0 is in more than 255 faces/, as);
  }
});

test('traversal decode = reference decode: faces across two candidates (x → y as reverse, as repeat; x = y)', () => {
  // face 0 = [0, 1, 2, 3] and across its 2 → 3 the same four corners
  // reversed, [3, 2, 1, 0] (x = 1 candidate 1 into 2, y = 0 candidate 1 out
  // of 3): every edge of face 1 is closed, so the walk goes on to a
  // component start, face 2
  let p = joinStreams({ gates: [0, 0, 1], corners: [0, 0, 0, 0, 1, 1, 0, 0, 0, 0], escapes: [], pos: new Array(24).fill(0) });
  const got = same(p, 8, 3, 'closed pillow', 255);
  assert.deepEqual([...got.f.subarray(0, 12)], [0, 1, 2, 3, 3, 2, 1, 0, 4, 5, 6, 7]);
  // face 1 = [1, 0, 4, 5] across face 0's 0 → 1 holds 1 → 0 first: face 2
  // = [3, 2, 1, 0] repeats it
  p = joinStreams({ gates: [1, 0, 1], corners: [0, 0, 0, 0, 0, 0, 1, 1], escapes: [], pos: new Array(18).fill(0) });
  assert.match(same(p, 6, 3, 'repeat', 255).error[2], /face 2: half-edge 1 -> 0 is in two faces/);
  // face 1 = [1, 0, 2, 4] (2 by an escape) across 0 → 1 holds 0 → 2;
  // across 2 → 3, x = 0 (candidate 2 into 2: after 1) and y = 0
  // (candidate 1 out of 3): one vertex twice
  p = joinStreams({ gates: [1, 0, 1], corners: [0, 0, 0, 0, 255, 0, 2, 1], escapes: [1], pos: new Array(15).fill(0) });
  assert.match(same(p, 5, 3, 'x = y', 255).error[2], /face 2 repeats a vertex \(3 2 0 0\)/);
});
