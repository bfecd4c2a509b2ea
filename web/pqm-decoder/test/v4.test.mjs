// Version 4.0's prediction of a new vertex (spec §7.6, "Version 4
// (stencil)") on hand-written records over grid_small's base (a 4×4 vertex
// grid, quad (x, y) = [4y+x, 4y+x+1, 4y+x+5, 4y+x+4] at slot 3y+x), in
// every form and on every decoder path: the face split's closed form, the
// split form with bit 7 clear (side C empty or not), the general form with
// one new vertex, with a few (≤ 4) and with many (> 4), the fallback to
// version 1's rule. The same bytes in a 3.0 file keep the mean of
// parallelograms. Expected values come from a transcription of the spec
// text (predict below), not from the decoder.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll } from '../src/index.js';
import { testFiles, handmadeFile } from './helpers.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const base = decodeAll(grid.bytes); // level 0: 16 vertices, 9 quads
const Q = base.positionCodes.slice();
const qmax = base.grid.qmax;
const clamp = (x) => Math.min(Math.max(x, 0), qmax);
const quadAt = (quads, s) => [...quads.subarray(4 * s, 4 * s + 4)];
const codeIn = (codes, v) => [codes[3 * v], codes[3 * v + 1], codes[3 * v + 2]];
const add = (p, r) => p.map((x, a) => x + r[a]);

/**
 * Spec §7.6 for new vertex `x` given the record's quads in order
 * (appended, then rewritten by ascending slot), the codes of the known
 * vertices (`code(v)` for v < x) and the record's first new id `V`.
 */
function predict(version, quads, x, V, code) {
  const known = (v) => v < x;
  if (version >= 2) {
    const [wN, wO, div] = version >= 4 ? [5, 2, 8] : [1, 1, 1];
    let sum = [0, 0, 0];
    let n = 0;
    for (const q of quads) {
      const k = q.indexOf(x);
      if (k < 0) continue;
      const [n1, o, n3] = [q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]];
      if (!(known(n1) && known(o) && known(n3))) continue;
      sum = sum.map((s, a) => s + wN * (code(n1)[a] + code(n3)[a]) - wO * code(o)[a]);
      n++;
    }
    if (n > 0) return sum.map((s) => clamp(Math.floor(s / (div * n))));
  }
  const q = quads.find((qq) => qq.includes(x));
  if (q) {
    const k = q.indexOf(x);
    const [n1, o, n3] = [q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]];
    if (known(n1) && known(o) && known(n3)) return [0, 1, 2].map((a) => clamp(code(n1)[a] + code(n3)[a] - code(o)[a]));
    const ks = [n1, o, n3].filter(known);
    if (ks.length) return [0, 1, 2].map((a) => Math.floor(ks.reduce((s, v) => s + code(v)[a], 0) / ks.length));
  }
  if (x > V) return code(x - 1);
  const half = (qmax + 1) / 2;
  return [half, half, half];
}

test('the base decodes the same in a 4.0 file (the delta layout behind layout byte 0)', () => {
  const d = decodeAll(handmadeFile(grid.bytes, { ops: [0x0c], conn: [0], refs: [{ s: 5 }], pos: [0, 0, 0].map((s) => ({ s })) }, 17, 10, 4));
  assert.equal(d.header.versionMajor, 4);
  d.setLevel(0);
  assert.deepEqual([...d.positionCodes], [...Q]);
  assert.deepEqual([...d.quads], [...base.quads]);
});

test('face split, version 4: ⌊(10 (m + o) − 2 (p + q)) / 16⌋ for every face, swap and rotation', () => {
  const m = 5;
  const S = [0, 1, 3, 4];
  const residual = [3, -2, 1];
  let differ = 0;
  for (let t = 0; t < S.length; t++) {
    for (const swap of [0, 1]) {
      for (const [rotX, rotY] of [
        [0, 0],
        [1, 2],
        [3, 1],
      ]) {
        const sym = 0x03 | (3 << 2) | (rotX << 4) | (rotY << 6);
        const streams = { ops: [sym], conn: [2 * t + swap], refs: [{ s: m }], pos: residual.map((s) => ({ s })) };
        const d = decodeAll(handmadeFile(grid.bytes, streams, 17, 10, 4));
        d.setLevel(1);
        const s = S[t];
        const old = quadAt(base.quads, s);
        const k = old.indexOf(m);
        const [p, o, q] = [old[(k + 1) % 4], old[(k + 2) % 4], old[(k + 3) % 4]];
        const want = [0, 1, 2].map((a) => clamp(Math.floor((10 * (Q[3 * m + a] + Q[3 * o + a]) - 2 * (Q[3 * p + a] + Q[3 * q + a])) / 16)));
        const X = quadAt(d.quads, s);
        const Y = quadAt(d.quads, 9);
        assert.deepEqual(predict(4, [Y, X], 16, 16, (v) => codeIn(Q, v)), want, 'the closed form is §7.6 over both halves');
        assert.deepEqual(codeIn(d.positionCodes, 16), add(want, residual), `t ${t} swap ${swap} rot ${rotX}/${rotY}`);
        const v3 = decodeAll(handmadeFile(grid.bytes, streams, 17, 10, 3));
        v3.setLevel(1);
        const old3 = [0, 1, 2].map((a) => clamp(Math.floor((2 * (Q[3 * m + a] + Q[3 * o + a]) - Q[3 * p + a] - Q[3 * q + a]) / 2)));
        assert.deepEqual(codeIn(v3.positionCodes, 16), add(old3, residual), 'version 3 keeps the mean of parallelograms');
        if (old3.join() !== want.join()) differ++;
      }
    }
  }
  assert.ok(differ > 0, 'the grid is not flat enough for the rules to agree');
});

for (const version of [3, 4]) {
  test(`split form, version ${version}: c without reflection, side C non-empty and empty`, () => {
    // vertex 5, i = 1, e = 1: b = 1, d = 9; side C = slots 0 and 3 get c = 16;
    // appended (5, 9, 16, 1). No move.
    const d = decodeAll(handmadeFile(grid.bytes, { ops: [0x05], conn: [1, 1], refs: [{ s: 5 }], pos: [0, 0, 0].map((s) => ({ s })) }, 17, 10, version));
    d.setLevel(1);
    const quads = [quadAt(d.quads, 9), quadAt(d.quads, 0), quadAt(d.quads, 3)];
    assert.deepEqual(quads, [
      [5, 9, 16, 1],
      [0, 1, 16, 4],
      [4, 16, 9, 8],
    ]);
    const code = (v) => codeIn(d.positionCodes, v);
    assert.deepEqual(code(16), predict(version, quads, 16, 16, code));
    // boundary vertex 1 (slots 0, 1; K = 2, L = 3): i = 0, e = 1 → j = 2,
    // side A is both faces, side C empty: c is only in the appended quad
    // (1, 0, 16, 2) — version 4's stencil of it, version 3's parallelogram
    const e = decodeAll(handmadeFile(grid.bytes, { ops: [0x05], conn: [0, 1], refs: [{ s: 1 }], pos: [1, 2, 3].map((s) => ({ s })) }, 17, 10, version));
    e.setLevel(1);
    const app = quadAt(e.quads, 9);
    assert.deepEqual(app, [1, 0, 16, 2]);
    assert.deepEqual(quadAt(e.quads, 0), quadAt(base.quads, 0), 'side C is empty: nothing rewritten');
    const codeE = (v) => codeIn(e.positionCodes, v);
    const want = [0, 1, 2].map((a) =>
      version >= 4
        ? clamp(Math.floor((5 * (Q[6 + a] + Q[a]) - 2 * Q[3 + a]) / 8))
        : clamp(Q[6 + a] + Q[a] - Q[3 + a]),
    );
    assert.deepEqual(codeE(16), add(want, [1, 2, 3]));
    assert.deepEqual(codeE(16), add(predict(version, [app], 16, 16, codeE), [1, 2, 3]));
  });
}

// A general-form record with two new vertices 16, 17 (corner codes: 1 → 16,
// 2 → 17, 3..6 → old corners 5 6 10 9 of slot 4, 0 → explicit): slot 4
// gets 17 at corner 3 → (5, 6, 10, 17); appended (16, 17, 10, 9) and
// (16, 9, 13, 12) (13 and 12 explicit). 16: one qualifying quad; 17: two.
const twoNew = {
  ops: [0x00],
  conn: [2, 0, 1, 2, 0b1000, 2, 1, 2, 5, 6, 1, 6, 0, 0],
  slots: [{ s: 4 }],
  refs: [{ s: 13 }, { s: -1 }],
  pos: [1, -1, 2, -3, 0, 5].map((s) => ({ s })),
};
const twoNewQuads = [
  [16, 17, 10, 9],
  [16, 9, 13, 12],
  [5, 6, 10, 17],
];

test('general form, version 4: a few new vertices (the bucketed path)', () => {
  const d = decodeAll(handmadeFile(grid.bytes, twoNew, 18, 11, 4));
  d.setLevel(1);
  assert.deepEqual([9, 10, 4].map((s) => quadAt(d.quads, s)), twoNewQuads);
  const code = (v) => codeIn(d.positionCodes, v);
  const p16 = predict(4, twoNewQuads, 16, 16, code);
  const p17 = predict(4, twoNewQuads, 17, 16, code);
  assert.deepEqual(code(16), add(p16, [1, -1, 2]));
  assert.deepEqual(code(17), add(p17, [-3, 0, 5]));
  const st = (n1, o, n3) => [0, 1, 2].map((a) => 5 * (code(n1)[a] + code(n3)[a]) - 2 * code(o)[a]);
  assert.deepEqual(p16, st(9, 13, 12).map((x) => clamp(Math.floor(x / 8))));
  const a = st(10, 9, 16);
  const b = st(5, 6, 10);
  assert.deepEqual(p17, [0, 1, 2].map((k) => clamp(Math.floor((a[k] + b[k]) / 16))));
  assert.notDeepEqual([p16, p17], [predict(3, twoNewQuads, 16, 16, code), predict(3, twoNewQuads, 17, 16, code)]);
});

test('general form, version 4: one new vertex in three quads; none qualifying falls back to version 1', () => {
  const three = {
    ops: [0x00],
    conn: [1, 0, 1, 2, 0b1000, 1, 1, 4, 5, 2, 1, 5, 0, 0],
    slots: [{ s: 4 }],
    refs: [{ s: 13 }, { s: -1 }],
    pos: [0, 0, 0].map((s) => ({ s })),
  };
  const quads = [
    [16, 10, 9, 5],
    [16, 9, 13, 12],
    [5, 6, 10, 16],
  ];
  const d = decodeAll(handmadeFile(grid.bytes, three, 17, 11, 4));
  d.setLevel(1);
  assert.deepEqual([9, 10, 4].map((s) => quadAt(d.quads, s)), quads);
  const code = (v) => codeIn(d.positionCodes, v);
  const st = (n1, o, n3) => [0, 1, 2].map((a) => 5 * (code(n1)[a] + code(n3)[a]) - 2 * code(o)[a]);
  const sum = [st(10, 9, 5), st(9, 13, 12), st(5, 6, 10)].reduce((s, p) => s.map((x, a) => x + p[a]));
  assert.deepEqual(code(16), sum.map((x) => clamp(Math.floor(x / 24))));
  assert.deepEqual(code(16), predict(4, quads, 16, 16, code));

  // (16, 17, 3, 2): 16 has no qualifying quad (version 1: the mean of 3
  // and 2), 17 has one (the stencil)
  const fallback = {
    ops: [0x00],
    conn: [2, 0, 0, 1, 1, 2, 0, 0],
    refs: [{ s: 3 }, { s: -1 }],
    pos: [0, 0, 0, 0, 0, 0].map((s) => ({ s })),
  };
  const e = decodeAll(handmadeFile(grid.bytes, fallback, 18, 10, 4));
  e.setLevel(1);
  const codeE = (v) => codeIn(e.positionCodes, v);
  assert.deepEqual(quadAt(e.quads, 9), [16, 17, 3, 2]);
  assert.deepEqual(codeE(16), [0, 1, 2].map((a) => Math.floor((Q[9 + a] + Q[6 + a]) / 2)));
  assert.deepEqual(codeE(17), [0, 1, 2].map((a) => clamp(Math.floor((5 * (codeE(3)[a] + codeE(16)[a]) - 2 * codeE(2)[a]) / 8))));
});

test('general form, version 4: many new vertices (the counting-sort path)', () => {
  // 5 new vertices 16..20: appended quad k (k < 5) = (16 + k, k, k + 1,
  // k + 5) with three explicit corners, then (16, 17, 18, 19)
  const explicit = [];
  for (let k = 0; k < 5; k++) explicit.push(k, k + 1, k + 5);
  const refs = explicit.map((v, i) => ({ s: v - (i === 0 ? 0 : explicit[i - 1]) }));
  const conn = [5, 0, 0, 6];
  for (let k = 0; k < 5; k++) conn.push(1 + k, 0, 0, 0);
  conn.push(1, 2, 3, 4);
  const residuals = [4, -4, 1, 0, 0, 0, -2, 7, 3, 1, 1, 1, 9, -9, 0];
  const d = decodeAll(handmadeFile(grid.bytes, { ops: [0x00], conn, refs, pos: residuals.map((s) => ({ s })) }, 21, 15, 4));
  d.setLevel(1);
  const quads = [];
  for (let s = 9; s < 15; s++) quads.push(quadAt(d.quads, s));
  assert.deepEqual(quads, [
    [16, 0, 1, 5],
    [17, 1, 2, 6],
    [18, 2, 3, 7],
    [19, 3, 4, 8],
    [20, 4, 5, 9],
    [16, 17, 18, 19],
  ]);
  const code = (v) => codeIn(d.positionCodes, v);
  for (let x = 16; x < 21; x++) {
    const r = residuals.slice(3 * (x - 16), 3 * (x - 16) + 3);
    assert.deepEqual(code(x), add(predict(4, quads, x, 16, code), r), `vertex ${x}`);
  }
  // 19 is in two qualifying quads (its own and the last)
  const st = (n1, o, n3) => [0, 1, 2].map((a) => 5 * (code(n1)[a] + code(n3)[a]) - 2 * code(o)[a]);
  const s19 = add(st(3, 4, 8), st(16, 17, 18));
  assert.deepEqual(code(19), add(s19.map((x) => clamp(Math.floor(x / 16))), [1, 1, 1]));
});
