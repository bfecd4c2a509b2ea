// Version 3.0: the edge-split form (spec §7.10) on hand-written records,
// independently of the reference encoder. The base is the spec's worked
// example, a 5 × 4 vertex grid (vertex i + 5j at (i, j), slot s = i + 4j =
// (v(i,j), v(i+1,j), v(i+1,j+1), v(i,j+1))). Expected quads come from the
// spec text (its worked example, and `explicit` below, a transcription of
// steps 2–9 with its own star walk), positions from a transcription of
// §7.6; neither uses the decoder's code.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll, PqmDecoder, PqmError } from '../src/index.js';
import { testFiles, handmadeFile, rng, svarint } from './helpers.mjs';
import { unpack, pack, setHeader } from './repack.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');

// The 5 × 4 grid as a base mesh (grid_small's header, grid and chunk entry
// reused: handmadeFile replaces the chunks).
const GW = 5;
const GH = 4;
const gridQuads = [];
for (let j = 0; j < GH - 1; j++) {
  for (let i = 0; i < GW - 1; i++) {
    const v = i + GW * j;
    gridQuads.push([v, v + 1, v + 1 + GW, v + GW]);
  }
}
// codes: a slightly bumpy sheet, so that predictions are not all exact
const gridCodes = [];
for (let j = 0; j < GH; j++) for (let i = 0; i < GW; i++) gridCodes.push([100 * i + 40, 100 * j + 60, 300 + ((3 * i + 7 * j) % 5) * 11]);
const baseFile = (() => {
  const parts = unpack(grid.bytes);
  const bytes = [];
  let prev = 0;
  for (const q of gridQuads) for (const v of q) bytes.push(...svarint(v - prev)), (prev = v);
  let p = [0, 0, 0];
  for (const c of gridCodes) {
    for (let a = 0; a < 3; a++) bytes.push(...svarint(c[a] - p[a]));
    p = c;
  }
  parts.base = Uint8Array.from(bytes);
  setHeader(parts, 24, 'Uint32', GW * GH);
  setHeader(parts, 28, 'Uint32', gridQuads.length);
  return pack(parts);
})();
const NV = GW * GH; // 20
const NQ = gridQuads.length; // 12

/** A file: the grid and one chunk with these streams, final counts v, f. */
const file = (streams, v = NV + 4, f = NQ + 4, major = 3) => handmadeFile(baseFile, streams, v, f, major);
const R0 = Array(12).fill({ s: 0 }); // 12 zero residuals

const quadsOf = (d) => {
  const out = [];
  for (let s = 0; s < d.faceCount; s++) out.push([...d.quads.subarray(4 * s, 4 * s + 4)]);
  return out;
};
const codesOf = (d) => {
  const out = [];
  for (let v = 0; v < d.vertexCount; v++) out.push([...d.positionCodes.subarray(3 * v, 3 * v + 3)]);
  return out;
};

function badRecord(bytes, message, record = 0) {
  let err = null;
  try {
    decodeAll(bytes);
  } catch (e) {
    err = e;
  }
  assert.ok(err instanceof PqmError, `expected ${message}, got ${err}`);
  assert.equal(err.kind, 'bad-record', err.message);
  assert.equal(err.chunk, 0);
  assert.equal(err.record, record, err.message);
  assert.match(err.message, message);
}

test('the base is the spec example grid', () => {
  const d = decodeAll(file({ ops: [0x11], refs: [{ s: 6 }], conn: [2, 0, 0, 0, 0, 0, 0, 0, 0], pos: R0 }));
  assert.equal(d.header.versionMajor, 3);
  assert.deepEqual(quadsOf(d), gridQuads);
  assert.deepEqual(codesOf(d), gridCodes);
});

test('edge split: the worked example of spec §7.10, its variants, and the way back', () => {
  const streams = { ops: [0x11], refs: [{ s: 6 }], conn: [2, 0, 0, 0, 0, 0, 0, 0, 0], pos: R0 };
  const d = decodeAll(file(streams));
  d.setLevel(1);
  const expected = gridQuads.map((q) => [...q]);
  expected[0] = [0, 1, 21, 5];
  expected[1] = [1, 2, 22, 21];
  expected[2] = [7, 3, 8, 23];
  expected[4] = [6, 10, 5, 21];
  expected[5] = [20, 23, 12, 11];
  expected[6] = [23, 8, 13, 12];
  expected.push([6, 21, 22, 7], [6, 7, 23, 20], [6, 20, 11, 10], [7, 22, 2, 3]);
  assert.deepEqual(quadsOf(d), expected);
  assert.equal(d.vertexCount, NV + 4);
  // every directed edge at most once (the spec's remark): a manifold result
  const edges = new Set();
  for (const q of quadsOf(d)) for (let k = 0; k < 4; k++) {
    const e = `${q[k]}>${q[(k + 1) % 4]}`;
    assert.ok(!edges.has(e), e);
    edges.add(e);
  }
  // positions: §7.6 over the record's quads (appended, then rewritten by slot)
  const recordQuads = [...expected.slice(NQ), ...[0, 1, 2, 4, 5, 6].map((s) => expected[s])];
  assert.deepEqual(codesOf(d).slice(NV), predictAll(recordQuads, NV, 4, gridCodes, R0));
  // the change and the way back
  const c = d.setLevel(0);
  assert.deepEqual([...c.facesRewritten], [0, 1, 2, 4, 5, 6]);
  assert.deepEqual(c.verticesRemoved, { start: NV, end: NV + 4 });
  assert.deepEqual(quadsOf(d), gridQuads);
  assert.deepEqual(codesOf(d), gridCodes);

  // p = 1: π_f = (0, 1, 3, 2), T_6 and T_7 swap slots
  const d1 = decodeAll(file({ ...streams, conn: [2, 0, 0, 0, 0, 1, 0, 0, 0] }));
  d1.setLevel(1);
  assert.deepEqual(quadsOf(d1).slice(NQ), [[6, 21, 22, 7], [6, 7, 23, 20], [7, 22, 2, 3], [6, 20, 11, 10]]);
  // ra = 4: C_1 rotated by 1 at slot 13
  const d2 = decodeAll(file({ ...streams, conn: [2, 0, 0, 0, 0, 0, 4, 0, 0] }));
  d2.setLevel(1);
  assert.deepEqual(quadsOf(d2)[13], [7, 23, 20, 6]);
  // anchoring 7 (r = 0: D = 6) gives the same record, positions included
  const d3 = decodeAll(file({ ...streams, refs: [{ s: 7 }], conn: [0, 0, 0, 0, 0, 0, 0, 0, 0] }));
  d3.setLevel(1);
  assert.deepEqual(quadsOf(d3), expected);
  d.setLevel(1);
  assert.deepEqual(codesOf(d3), codesOf(d));
});

for (const major of [3, 4]) test(`edge split: every field against a transcription of the spec, many anchors and parameters (version ${major})`, () => {
  // two meshes: the grid (valence 4 inside) and the grid after the worked
  // example (valences 3 to 5 around the new vertices), whose record comes
  // first in the file
  const example = { ops: [0x11], refs: [{ s: 6 }], conn: [2, 0, 0, 0, 0, 0, 0, 0, 0], pos: R0 };
  const after = decodeAll(file(example, NV + 4, NQ + 4, major));
  after.setLevel(1);
  // and the grid after a face split of slot 0 at 6 (valence 5 at 6, a
  // doublet at 20): fans over a doublet repeat a corner (rejected)
  const split = { ops: [0x0c], refs: [{ s: 6 }], conn: [0], pos: R0.slice(0, 3) };
  const afterSplit = decodeAll(file(split, NV + 1, NQ + 1, major));
  afterSplit.setLevel(1);
  const meshes = [
    { quads: gridQuads, codes: gridCodes, V: NV, prefix: null },
    { quads: quadsOf(after), codes: codesOf(after), V: NV + 4, prefix: example },
    { quads: quadsOf(afterSplit), codes: codesOf(afterSplit), V: NV + 1, prefix: split },
  ];
  for (const mesh of meshes) {
    mesh.interior = [];
    for (let v = 0; v < mesh.V; v++) if (!star(mesh.quads, v).boundary) mesh.interior.push(v);
  }
  const rand = rng(46);
  let checked = 0;
  let rejected = 0;
  const stars = new Set();
  for (let iter = 0; iter < 600; iter++) {
    const mesh = meshes[Math.floor(rand() * 3)];
    const A = mesh.interior[Math.floor(rand() * mesh.interior.length)];
    const starA = star(mesh.quads, A);
    const r = Math.floor(rand() * starA.faces.length);
    const D = starA.link[r];
    const starD = star(mesh.quads, D);
    if (starD.boundary) continue;
    const [X0, X1] = A < D ? [A, D] : [D, A];
    const fields = [];
    const side = [];
    let small = null; // an endpoint with K < 3 (a doublet): no sector / fan split exists
    for (const X of [X0, X1]) {
      const K = (X === A ? starA : starD).faces.length;
      stars.add(K);
      if (K < 3 && small === null) small = X;
      const n1 = Math.floor(rand() * (K - 2));
      const e = Math.floor(rand() * (K - 2 - n1));
      fields.push(n1, e);
      side.push({ n1, m: e + 1 });
    }
    const p = Math.floor(rand() * 576);
    const ra = Math.floor(rand() * 256);
    const rots = [side[0].m, side[1].m].map((m) => Array.from({ length: m }, () => Math.floor(rand() * 4)));
    const want = small === null ? explicit(mesh.quads, mesh.V, { A, r, side, p, ra, rots }) : null;
    const residuals = Array.from({ length: 12 }, () => ({ s: Math.floor(rand() * 21) - 10 }));
    const sym = 0x10 | Math.floor(rand() * 4); // any op: informational
    const rec = { ops: [sym], refs: [{ s: A }], conn: [r, ...fields, p, ra, ...rots.flat()], pos: residuals };
    const pre = mesh.prefix;
    const bytes = pre
      ? file({ ops: [...pre.ops, sym], refs: [...pre.refs, { s: A - 6 }], conn: [...pre.conn, ...rec.conn], pos: [...pre.pos, ...residuals] }, mesh.V + 4, mesh.quads.length + 4, major)
      : file(rec, NV + 4, NQ + 4, major);
    const level = pre ? 2 : 1;
    if (small !== null) {
      badRecord(bytes, new RegExp(`first-sector length 0 at vertex ${small} exceeds -1`), level - 1);
      rejected++;
      continue;
    }
    if (want.error) {
      badRecord(bytes, /fan of one endpoint|repeats a vertex/, level - 1);
      rejected++;
      continue;
    }
    const d = decodeAll(bytes);
    d.setLevel(level);
    const expected = mesh.quads.map((q) => [...q]);
    for (const [s, q] of want.rewritten) expected[s] = q;
    expected.push(...want.appended);
    assert.deepEqual(quadsOf(d), expected, JSON.stringify({ A, r, side, p, ra, rots }));
    const recordQuads = [...want.appended, ...want.rewritten.map(([, q]) => q)];
    assert.deepEqual(codesOf(d).slice(mesh.V), predictAll(recordQuads, mesh.V, 4, mesh.codes, residuals, major));
    d.setLevel(level - 1);
    assert.deepEqual(quadsOf(d), mesh.quads);
    assert.deepEqual(codesOf(d), mesh.codes);
    checked++;
  }
  assert.ok(checked > 250 && rejected > 0, `${checked} records checked, ${rejected} rejected`);
  assert.ok([2, 3, 4, 5].every((k) => stars.has(k)), `star sizes ${[...stars]}`);
});

test('edge split: byte at a time equals whole, two records in a row', () => {
  // record 0: the worked example; record 1: an edge split of 12–13 on the
  // result (both interior, valence 4 after the first record)
  const first = { conn: [2, 0, 0, 0, 0, 0, 0, 0, 0], refs: [{ s: 6 }] };
  const d0 = decodeAll(file({ ops: [0x11], ...first, pos: R0 }));
  d0.setLevel(1);
  const q1 = quadsOf(d0);
  const s12 = star(q1, 12);
  const r = s12.link.indexOf(13);
  assert.ok(r >= 0 && !s12.boundary && !star(q1, 13).boundary);
  const bytes = file(
    { ops: [0x11, 0x11], refs: [{ s: 6 }, { s: 6 }], conn: [...first.conn, r, 0, 0, 1, 0, 7, 201, 0, 3], pos: [...R0, ...R0.map((_, i) => ({ s: i - 6 }))] },
    NV + 8,
    NQ + 8,
  );
  const whole = new PqmDecoder();
  const wholeEvents = whole.push(bytes);
  whole.end();
  const bytewise = new PqmDecoder();
  const events = [];
  for (let i = 0; i < bytes.length; i++) events.push(...bytewise.push(bytes.subarray(i, i + 1)));
  bytewise.end();
  assert.deepEqual(events, wholeEvents);
  for (const level of [2, 1, 0, 2]) {
    whole.setLevel(level);
    bytewise.setLevel(level);
    assert.deepEqual(quadsOf(bytewise), quadsOf(whole));
    assert.deepEqual(codesOf(bytewise), codesOf(whole));
  }
  const want = explicit(q1, NV + 4, { A: 12, r, side: [{ n1: 0, m: 1 }, { n1: 1, m: 1 }], p: 7, ra: 201, rots: [[0], [3]] });
  whole.setLevel(2);
  const after = q1.map((q) => [...q]);
  for (const [s, q] of want.rewritten) after[s] = q;
  after.push(...want.appended);
  assert.deepEqual(quadsOf(whole), after);
});

test('edge split: each reject rule is a bad record naming it', () => {
  const ok = { ops: [0x11], refs: [{ s: 6 }], conn: [2, 0, 0, 0, 0, 0, 0, 0, 0], pos: R0 };
  assert.doesNotThrow(() => decodeAll(file(ok)));
  // counts: 4 new vertices and 4 faces must fit the final counts
  badRecord(file(ok, NV + 3, NQ + 4), /needs 4 new vertices and 4 faces/);
  badRecord(file(ok, NV + 4, NQ + 3), /needs 4 new vertices and 4 faces/);
  // anchor
  badRecord(file({ ...ok, refs: [{ s: 20 }] }), /edge-split anchor 20 outside 0\.\.20/);
  badRecord(file({ ...ok, refs: [{ s: -1 }] }), /edge-split anchor -1 outside/);
  // open stars: A on the boundary; D on the boundary (6's link is 5, 1, 7, 11)
  badRecord(file({ ...ok, refs: [{ s: 1 }] }), /endpoint 1 is on the boundary/);
  badRecord(file({ ...ok, conn: [0, 0, 0, 0, 0, 0, 0, 0, 0] }), /endpoint 5 is on the boundary/);
  // fields beyond their bounds (K = 4 at both endpoints)
  badRecord(file({ ...ok, conn: [4, 0, 0, 0, 0, 0, 0, 0, 0] }), /edge index 4 of vertex 6 exceeds 3/);
  badRecord(file({ ...ok, conn: [2, 2, 0, 0, 0, 0, 0, 0, 0] }), /first-sector length 2 at vertex 6 exceeds 1/);
  badRecord(file({ ...ok, conn: [2, 1, 1, 0, 0, 0, 0, 0, 0] }), /fan length 2 at vertex 6 exceeds 1/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 2, 0, 0, 0, 0, 0] }), /first-sector length 2 at vertex 7 exceeds 1/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 2, 0, 0, 0, 0] }), /fan length 3 at vertex 7 exceeds 2/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 0, 576, 0, 0, 0] }), /permutation code 576 exceeds 575/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 0, 0, 256, 0, 0] }), /appended rotations 256 exceed 255/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 0, 0, 0, 4, 0] }), /rotation 4 of fan quad 0 at vertex 6 exceeds 3/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 0, 0, 0, 0, 4] }), /rotation 4 of fan quad 0 at vertex 7 exceeds 3/);
  badRecord(file({ ...ok, conn: [2, 0, 0, 0, 0, 0, 0, 0] }), /stream conn ends/);
  // a new vertex's code outside the grid
  badRecord(file({ ...ok, pos: [{ s: -(1 << 24) }, ...R0.slice(1)] }), /new vertex 20 code .* outside 0\.\.=/);
  // form 4 in a 2.0 or 1.1 file
  badRecord(file(ok, NV + 4, NQ + 4, 2), /record form 4 \(edge split, symbol 0x11\) is invalid in a version 2 file/);
  badRecord(file(ok, NV + 4, NQ + 4, 1), /record form 4 \(edge split, symbol 0x11\) is invalid in a version 1 file/);
  // symbol bits 4-7 other than 0 and 1 with form bits 0: invalid in every version
  badRecord(file({ ...ok, ops: [0x21] }), /general-form symbol 0x21 has bits 4-7 set/);

  // a star that §7.5 rejects: a general-form record first puts vertex 6 in
  // slot 11 too (corner 0 of (13, 14, 19, 18)), so 6's faces are not one fan
  const bowtie = { ops: [0x00, 0x11], conn: [0, 0, 1, 0, 0b0001, 0, ...ok.conn], refs: [{ s: 6 }, { s: 0 }], slots: [{ s: 11 }], pos: R0 };
  badRecord(file(bowtie, NV + 4, NQ + 4), /the fan around vertex 6 holds 4 of its 5 faces/, 1);

  // a built quad with a repeated corner: a face split of slot 0 at 6 first
  // (a doublet at the new vertex 20: slots 0 = (6, 5, 0, 20) and 12 =
  // (6, 20, 0, 1)), then a fan at 6 over both halves: G_0 = (6, 0, 20, 0).
  // 6's star walk is 0, 12, 1, 5, 4 (link 5, 20, 1, 7, 11): r = 3 → D = 7;
  // from ρ: g = (5, 4, 0, 12, 1); n1 = 1, m = 2
  const doublet = { ops: [0x0c, 0x11], refs: [{ s: 6 }, { s: 0 }], conn: [0, 3, 1, 1, 0, 0, 0, 0, 0, 0, 0], pos: [...R0.slice(0, 3), ...R0] };
  badRecord(file(doublet, NV + 5, NQ + 5), /rewritten slot 0 repeats a vertex \(6 0 20 0\)/, 1);
  assert.doesNotThrow(() => decodeAll(file({ ...doublet, conn: [0, 3, 0, 0, 0, 0, 0, 0, 0, 0] }, NV + 5, NQ + 5)));

  // every error is a PqmError, whatever the damage (random conn bytes)
  const rand = rng(7);
  for (let i = 0; i < 300; i++) {
    const conn = Array.from({ length: 4 + Math.floor(rand() * 10) }, () => Math.floor(rand() * 6));
    const bytes = file({ ops: [0x11], refs: [{ s: Math.floor(rand() * 22) - 1 }], conn, pos: R0 });
    try {
      decodeAll(bytes);
    } catch (e) {
      assert.ok(e instanceof PqmError && ['bad-record', 'invalid'].includes(e.kind), String(e));
    }
  }
});

// ---- an independent transcription of the spec ------------------------------

/** Canonical star of §7.5 step 2 over `quads` (a list of 4-arrays): faces in walk order, link, boundary. */
function star(quads, m) {
  const S = [];
  quads.forEach((q, s) => q.includes(m) && S.push(s));
  const k = (s) => quads[s].indexOf(m);
  const n = (s) => quads[s][(k(s) + 1) % 4];
  const p = (s) => quads[s][(k(s) + 3) % 4];
  const succ = (f) => S.find((g) => g !== f && n(g) === p(f));
  const pred = (f) => S.find((g) => g !== f && p(g) === n(f));
  let f = S[0];
  let start;
  let boundary = false;
  for (let it = 0; it < S.length; it++) {
    const g = pred(f);
    if (g === undefined) {
      start = f;
      boundary = true;
      break;
    }
    if (g === S[0]) {
      start = S[0];
      break;
    }
    f = g;
  }
  const faces = [start];
  for (;;) {
    const g = succ(faces[faces.length - 1]);
    if (boundary ? g === undefined : g === start) break;
    faces.push(g);
  }
  assert.equal(faces.length, S.length, 'the test meshes have fan stars');
  const link = faces.map(n);
  if (boundary) link.push(p(faces[faces.length - 1]));
  return { faces, link, boundary };
}

/** The 24 permutations of 0..3 in lexicographic order. */
const PERMS = [];
for (let a = 0; a < 4; a++) for (let b = 0; b < 4; b++) for (let c = 0; c < 4; c++) for (let d = 0; d < 4; d++) {
  if (new Set([a, b, c, d]).size === 4) PERMS.push([a, b, c, d]);
}
const rotate = (q, t) => q.map((_, k) => q[(k + t) % 4]);

/**
 * Spec §7.10 steps 2–9 on `quads` with V vertices: {rewritten: [[slot,
 * quad]] ascending, appended: [quad × 4]} or {error}.
 */
function explicit(quads, V, { A, r, side, p, ra, rots }) {
  const sA = star(quads, A);
  const D = sA.link[r];
  const sD = star(quads, D);
  const rhoD = sD.link.indexOf(A);
  const [X0, X1] = A < D ? [A, D] : [D, A];
  const stars = A < D ? [[sA, r], [sD, rhoD]] : [[sD, rhoD], [sA, r]];
  const piV = PERMS[Math.floor(p / 24)];
  const piF = PERMS[p % 24];
  const U = [0, 1, 2, 3].map((i) => V + piV[i]);
  const sub = new Map(); // slot → quad (sector replacements)
  const fan = new Map(); // slot → quad (fan quads)
  const T = [];
  let conflict = false;
  [X0, X1].forEach((X, x) => {
    const [s, rho] = stars[x];
    const K = s.faces.length;
    const g = (i) => s.faces[(rho + i) % K];
    const lam = (i) => s.link[(rho + i) % K];
    const { n1, m } = side[x];
    const [u1, u2] = [U[2 * x], U[2 * x + 1]];
    for (let i = 0; i < K; i++) {
      if (i > n1 && i <= n1 + m) continue;
      const q = sub.get(g(i)) ?? [...quads[g(i)]];
      sub.set(g(i), q.map((v) => (v === X ? (i <= n1 ? u1 : u2) : v)));
    }
    const P = [];
    for (let j = 0; j < m; j++) {
      const h = quads[g(n1 + 1 + j)];
      const k = h.indexOf(X);
      P.push(h[(k + 1) % 4], h[(k + 2) % 4]);
    }
    P.push(lam(n1 + m + 1));
    for (let j = 0; j < m; j++) {
      const G = j < m - 1 ? [X, P[2 * j + 1], P[2 * j + 2], P[2 * j + 3]] : [X, P[2 * m - 1], P[2 * m], u2];
      if (fan.has(g(n1 + 1 + j))) conflict = true;
      fan.set(g(n1 + 1 + j), rotate(G, rots[x][j]));
    }
    T.push([X, u1, P[0], P[1]]);
  });
  for (const s of fan.keys()) if (sub.has(s)) conflict = true;
  if (conflict) return { error: 'fan and star' };
  const C = [[X0, U[1], U[2], X1], [X0, X1, U[3], U[0]], T[0], T[1]];
  const appended = [];
  C.forEach((q, i) => (appended[piF[i]] = rotate(q, (ra >> (2 * i)) & 3)));
  const rewritten = [...sub, ...fan].sort((a, b) => a[0] - b[0]);
  for (const [, q] of [...rewritten, ...appended.map((q) => [0, q])]) if (new Set(q).size !== 4) return { error: 'repeat' };
  return { rewritten, appended };
}

/**
 * Spec §7.6 (version 2 rule and its version-1 fallback) for the new
 * vertices V .. V+n−1 in order, with `residuals` (3 per vertex) added.
 */
function predictAll(recordQuads, V, n, codes, residuals, major = 3) {
  // §7.6: the parallelogram (versions 2, 3) or the stencil (version 4) per quad
  const [wN, wO, div] = major >= 4 ? [5, 2, 8] : [1, 1, 1];
  const qmax = 2 ** 14 - 1;
  const clamp = (x) => Math.min(Math.max(x, 0), qmax);
  const all = codes.map((c) => [...c]);
  const out = [];
  for (let x = V; x < V + n; x++) {
    const known = (v) => v < x;
    let sum = [0, 0, 0];
    let c = 0;
    for (const q of recordQuads) {
      const k = q.indexOf(x);
      if (k < 0) continue;
      const [n1, o, n3] = [q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]];
      if (!(known(n1) && known(o) && known(n3))) continue;
      sum = sum.map((s, a) => s + wN * (all[n1][a] + all[n3][a]) - wO * all[o][a]);
      c++;
    }
    let pred;
    if (c > 0) pred = sum.map((s) => clamp(Math.floor(s / (div * c))));
    else {
      const q = recordQuads.find((qq) => qq.includes(x));
      const k = q ? q.indexOf(x) : -1;
      const ks = q ? [q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]].filter(known) : [];
      if (ks.length) pred = [0, 1, 2].map((a) => Math.floor(ks.reduce((s, v) => s + all[v][a], 0) / ks.length));
      else if (x > V) pred = all[x - 1];
      else pred = [(qmax + 1) / 2, (qmax + 1) / 2, (qmax + 1) / 2];
    }
    const r = residuals.slice(3 * (x - V), 3 * (x - V) + 3).map((e) => e.s);
    const code = pred.map((v, a) => v + r[a]);
    all[x] = code;
    out.push(code);
  }
  return out;
}
