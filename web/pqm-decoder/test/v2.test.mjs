// Version 2.0 rules on hand-written records (grid_small's base: a 4×4
// vertex grid, quad (x, y) = [4y+x, 4y+x+1, 4y+x+5, 4y+x+4] at slot 3y+x):
// the face-split form (spec §7.9) against its explicit result for every
// face, swap and rotation; the multi-parallelogram prediction (§7.6) where
// a new vertex lies in 2–3 record quads, with the version-1 fallback; the
// same bytes in a 1.x file keep the version-1 prediction and refuse form 3.
// Expected values come from an independent transcription of the spec text
// (predict below), not from the decoder.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll, PqmError } from '../src/index.js';
import { testFiles, handmadeFile } from './helpers.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const base = decodeAll(grid.bytes); // level 0: 16 vertices, 9 quads
const Q = base.positionCodes.slice();
const F = base.quads.slice();
const qmax = base.grid.qmax;
const clamp = (x) => Math.min(Math.max(x, 0), qmax);
const floorDiv = (s, c) => Math.floor(s / c); // exact here: small integers
const quadAt = (quads, s) => [...quads.subarray(4 * s, 4 * s + 4)];
const codeIn = (codes, v) => [codes[3 * v], codes[3 * v + 1], codes[3 * v + 2]];

/**
 * Spec §7.6 for new vertex `x` given the record's quads in order
 * (appended, then rewritten by ascending slot), the codes of the known
 * vertices (`code(v)` for v < x) and the record's first new id `V`.
 */
function predict(version, quads, x, V, code) {
  const known = (v) => v < x;
  if (version === 2) {
    let sum = [0, 0, 0];
    let n = 0;
    for (const q of quads) {
      const k = q.indexOf(x);
      if (k < 0) continue;
      const [n1, o, n3] = [q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]];
      if (!(known(n1) && known(o) && known(n3))) continue;
      sum = sum.map((s, a) => s + code(n1)[a] + code(n3)[a] - code(o)[a]);
      n++;
    }
    if (n > 0) return sum.map((s) => clamp(floorDiv(s, n)));
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

const add = (p, r) => p.map((x, a) => x + r[a]);

function badRecord(bytes, message) {
  assert.throws(
    () => decodeAll(bytes),
    (e) => e instanceof PqmError && e.kind === 'bad-record' && e.chunk === 0 && e.record === 0 && message.test(e.message),
    `expected ${message}`,
  );
}

test('face split: every face of the star, swap and rotation gives the explicit result of §7.9', () => {
  // vertex 5 is in slots 0 [0 1 5 4], 1 [1 2 6 5], 3 [4 5 9 8], 4 [5 6 10 9]:
  // S = (0, 1, 3, 4) ascending.
  const m = 5;
  const S = [0, 1, 3, 4];
  const residual = [3, -2, 1];
  let cases = 0;
  for (let t = 0; t < S.length; t++) {
    for (const swap of [0, 1]) {
      for (let rotX = 0; rotX < 4; rotX++) {
        for (let rotY = 0; rotY < 4; rotY++) {
          const sym = 0x03 | (3 << 2) | (rotX << 4) | (rotY << 6); // op 3 is informational
          const bytes = handmadeFile(
            grid.bytes,
            { ops: [sym], conn: [2 * t + swap], refs: [{ s: m }], pos: residual.map((s) => ({ s })) },
            17,
            10,
            2,
          );
          const d = decodeAll(bytes);
          d.setLevel(1);
          // explicit result, from the text of §7.9
          const s = S[t];
          const old = quadAt(F, s);
          const k = old.indexOf(m);
          const [p, o, q] = [old[(k + 1) % 4], old[(k + 2) % 4], old[(k + 3) % 4]];
          const c = 16;
          const A = [m, p, o, c];
          const B = [m, c, o, q];
          const [X, Y] = swap ? [B, A] : [A, B];
          const Xr = X.map((_, i) => X[(i + rotX) % 4]);
          const Yr = Y.map((_, i) => Y[(i + rotY) % 4]);
          const what = `t ${t} swap ${swap} rot ${rotX}/${rotY}`;
          assert.deepEqual(quadAt(d.quads, s), Xr, `${what}: rewritten slot`);
          assert.deepEqual(quadAt(d.quads, 9), Yr, `${what}: appended quad`);
          for (let u = 0; u < 9; u++) if (u !== s) assert.deepEqual(quadAt(d.quads, u), quadAt(F, u), `${what}: slot ${u} untouched`);
          // c in both halves, all other corners known: the mean of two parallelograms
          const pred = predict(2, [Yr, Xr], c, 16, (v) => codeIn(Q, v));
          const two = [0, 1, 2].map((a) => clamp(floorDiv(2 * Q[3 * m + a] + 2 * Q[3 * o + a] - Q[3 * p + a] - Q[3 * q + a], 2)));
          assert.deepEqual(pred, two, `${what}: §7.6 over both halves`);
          assert.deepEqual(codeIn(d.positionCodes, c), add(pred, residual), `${what}: new vertex`);
          assert.deepEqual([...d.positionCodes.subarray(0, 48)], [...Q], `${what}: no vertex moves`);
          const back = d.setLevel(0);
          assert.deepEqual([...back.facesRewritten], [s]);
          assert.deepEqual([...d.quads], [...F]);
          cases++;
        }
      }
    }
  }
  assert.equal(cases, 4 * 2 * 16);
});

test('face split: two records in a row, the second splitting a face of the first', () => {
  // record 0 splits slot 0 at vertex 0 (t 0, no swap, no rotation):
  // A = (0, 1, 5, 16) rewrites slot 0, B = (0, 16, 5, 4) is slot 9.
  // record 1: vertex 16 (cursor 0 + 16), S = (0, 9); t = 1 → slot 9 with 16 at
  // corner 1: p = 5, o = 4, q = 0; swap: X = B' = (16, 17, 4, 0), Y = A' =
  // (16, 5, 4, 17).
  const bytes = handmadeFile(
    grid.bytes,
    { ops: [0x0f, 0x0f], conn: [0, 3], refs: [{ s: 0 }, { s: 16 }], pos: [0, 0, 0, 1, 1, 1].map((s) => ({ s })) },
    18,
    11,
    2,
  );
  const d = decodeAll(bytes);
  d.setLevel(2);
  assert.deepEqual(quadAt(d.quads, 0), [0, 1, 5, 16]);
  assert.deepEqual(quadAt(d.quads, 9), [16, 17, 4, 0]);
  assert.deepEqual(quadAt(d.quads, 10), [16, 5, 4, 17]);
  const codes = d.positionCodes;
  const code = (v) => codeIn(codes, v);
  assert.deepEqual(code(16), predict(2, [[0, 16, 5, 4], [0, 1, 5, 16]], 16, 16, code));
  assert.deepEqual(code(17), add(predict(2, [[16, 5, 4, 17], [16, 17, 4, 0]], 17, 17, code), [1, 1, 1]));
});

test('face split: hostile fields are bad records; form 3 is invalid in a 1.x file', () => {
  const ok = { ops: [0x0c], conn: [0], refs: [{ s: 5 }], pos: [0, 0, 0].map((s) => ({ s })) };
  decodeAll(handmadeFile(grid.bytes, ok, 17, 10, 2));
  badRecord(handmadeFile(grid.bytes, ok, 17, 10, 1), /record form 3 is invalid in a version 1 file/);
  badRecord(handmadeFile(grid.bytes, { ...ok, conn: [8] }, 17, 10, 2), /face index 4 of vertex 5 outside 0\.\.4/);
  // vertex 0 (a grid corner) is in one face only
  badRecord(handmadeFile(grid.bytes, { ...ok, refs: [{ s: 0 }], conn: [2] }, 17, 10, 2), /face index 1 of vertex 0 outside 0\.\.1/);
  badRecord(handmadeFile(grid.bytes, { ...ok, refs: [{ s: 16 }] }, 17, 10, 2), /face-split vertex 16 outside 0\.\.16/);
  badRecord(handmadeFile(grid.bytes, { ...ok, refs: [{ s: -1 }] }, 17, 10, 2), /face-split vertex -1 outside/);
  badRecord(handmadeFile(grid.bytes, ok, 16, 10, 2), /final counts are reached/);
  badRecord(handmadeFile(grid.bytes, ok, 17, 9, 2), /final counts are reached/);
  badRecord(handmadeFile(grid.bytes, { ...ok, pos: [{ s: -(1 << 24) }, { s: 0 }, { s: 0 }] }, 17, 10, 2), /face-split vertex 5 \(c\) code .* outside 0\.\.=/);
  badRecord(handmadeFile(grid.bytes, { ...ok, conn: [] }, 17, 10, 2), /stream conn ends/);
});

// A general-form record with two new vertices 16, 17 (corner codes: 1 → 16,
// 2 → 17, 3..6 → old corners 5 6 10 9 of slot 4, 0 → explicit):
// slot 4 [5 6 10 9] gets 17 at corner 3 → (5, 6, 10, 17); appended
// (16, 17, 10, 9) and (16, 9, 13, 12) (13 and 12 explicit).
// 16 is in both appended quads; only the second has its other corners known
// (17 is not yet): version 2 takes that parallelogram, version 1 the first
// quad's mean of its known corners (10 and 9).
// 17 is in the first appended quad and slot 4, all others known: version 2
// averages both parallelograms, version 1 takes the first.
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

for (const version of [1, 2]) {
  test(`general form, version ${version}: new vertices in two and three record quads`, () => {
    const d = decodeAll(handmadeFile(grid.bytes, twoNew, 18, 11, version));
    d.setLevel(1);
    assert.deepEqual(quadAt(d.quads, 4), twoNewQuads[2]);
    assert.deepEqual(quadAt(d.quads, 9), twoNewQuads[0]);
    assert.deepEqual(quadAt(d.quads, 10), twoNewQuads[1]);
    const codes = d.positionCodes;
    const code = (v) => codeIn(codes, v);
    const p16 = predict(version, twoNewQuads, 16, 16, code);
    const p17 = predict(version, twoNewQuads, 17, 16, code);
    assert.deepEqual(code(16), add(p16, [1, -1, 2]));
    assert.deepEqual(code(17), add(p17, [-3, 0, 5]));
    // the rules differ on these quads (otherwise this test could not tell them apart)
    const other = predict(3 - version, twoNewQuads, 16, 16, code);
    const other17 = predict(3 - version, twoNewQuads, 17, 16, code);
    assert.ok(other.join() !== p16.join() && other17.join() !== p17.join(), 'the two versions predict differently here');
    if (version === 2) {
      const para = (n1, o, n3) => [0, 1, 2].map((a) => code(n1)[a] + code(n3)[a] - code(o)[a]);
      assert.deepEqual(p16, para(9, 13, 12).map(clamp));
      const a = para(10, 9, 16);
      const b = para(5, 6, 10);
      assert.deepEqual(p17, [0, 1, 2].map((k) => clamp(Math.floor((a[k] + b[k]) / 2))));
    }
  });
}

test('general form, version 2: a new vertex in three record quads; none qualifying falls back to version 1', () => {
  // n_new 1: slot 4 [5 6 10 9] gets 16 at corner 3 → (5, 6, 10, 16);
  // appended (16, 10, 9, 5) and (16, 9, 13, 12). Codes: 1 → 16, 2..5 → 5 6 10 9.
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
  const d = decodeAll(handmadeFile(grid.bytes, three, 17, 11, 2));
  d.setLevel(1);
  assert.deepEqual([9, 10, 4].map((s) => quadAt(d.quads, s)), quads);
  const code = (v) => codeIn(d.positionCodes, v);
  const para = (n1, o, n3) => [0, 1, 2].map((a) => code(n1)[a] + code(n3)[a] - code(o)[a]);
  const sum = [para(10, 9, 5), para(9, 13, 12), para(5, 6, 10)].reduce((s, p) => s.map((x, a) => x + p[a]));
  assert.deepEqual(code(16), sum.map((x) => clamp(Math.floor(x / 3))));
  assert.deepEqual(code(16), predict(2, quads, 16, 16, code));

  // one appended quad (16, 17, 3, 2): when 16 is predicted, 17 is unknown,
  // so no quad qualifies and version 1's rule gives the mean of the known
  // corners 3 and 2; 17 has all three known (16 is decoded by then).
  const fallback = {
    ops: [0x00],
    conn: [2, 0, 0, 1, 1, 2, 0, 0],
    refs: [{ s: 3 }, { s: -1 }],
    pos: [0, 0, 0, 0, 0, 0].map((s) => ({ s })),
  };
  const e = decodeAll(handmadeFile(grid.bytes, fallback, 18, 10, 2));
  e.setLevel(1);
  const codeE = (v) => codeIn(e.positionCodes, v);
  assert.deepEqual(quadAt(e.quads, 9), [16, 17, 3, 2]);
  assert.deepEqual(codeE(16), [0, 1, 2].map((a) => Math.floor((Q[9 + a] + Q[6 + a]) / 2)));
  assert.deepEqual(codeE(17), [0, 1, 2].map((a) => clamp(codeE(3)[a] + codeE(16)[a] - codeE(2)[a])));
});

for (const version of [1, 2]) {
  test(`split form, version ${version}: c without reflection uses the version's §7.6`, () => {
    // vertex 5, i = 1, e = 1 (see handmade.test.mjs): b = 1, d = 9; side C =
    // slots 0 and 3 get c = 16; appended (5, 9, 16, 1). No move.
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
    if (version === 1) assert.deepEqual(code(16), [0, 1, 2].map((a) => clamp(Q[3 + a] + Q[27 + a] - Q[15 + a])));
    else assert.notDeepEqual(code(16), predict(1, quads, 16, 16, code), 'the grid is not flat enough for the rules to agree');
  });
}
