// Hand-written records on the base mesh of grid_small (a 4×4 vertex grid,
// quad (x, y) = [4y+x, 4y+x+1, 4y+x+5, 4y+x+4]): each rule of spec §7.4–7.6
// checked on its own, independently of the reference encoder.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll, PqmError } from '../src/index.js';
import { testFiles, handmadeFile } from './helpers.mjs';
import { concat } from './repack.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const base = decodeAll(grid.bytes); // level 0: 16 vertices, 9 quads
const Q = base.positionCodes.slice();
const F = base.quads.slice();

/**
 * A file: grid_small's base and one chunk with the given streams, reaching
 * `v` vertices and `f` faces; a version 1.1 file (the version-1 prediction
 * of spec §7.6, form 3 invalid) whatever version the vectors have.
 */
const file = (streams, v, f) => handmadeFile(grid.bytes, streams, v, f, 1);

const code = (v) => [Q[3 * v], Q[3 * v + 1], Q[3 * v + 2]];
const qmax = base.grid.qmax;
const clamp = (x) => Math.min(Math.max(x, 0), qmax);

function badRecord(bytes, message) {
  assert.throws(
    () => decodeAll(bytes),
    (e) => e instanceof PqmError && e.kind === 'bad-record' && e.chunk === 0 && e.record === 0 && message.test(e.message),
    `expected ${message}`,
  );
}

test('general form: an appended quad and a new vertex predicted by the parallelogram rule', () => {
  // n_new 1, n_moved 0, n_rw 0, n_app 1; quad (3, new 16, 7, 2) with
  // corners explicit, new, explicit, explicit.
  const bytes = file({ ops: [0x01], conn: [1, 0, 0, 1, 0, 1, 0, 0], refs: [{ s: 3 }, { s: 4 }, { s: -5 }], pos: [{ s: -5 }, { s: -2 }, { s: 0 }] }, 17, 10);
  const d = decodeAll(bytes);
  d.setLevel({ level: 1 });
  assert.deepEqual([...d.quads.subarray(36, 40)], [3, 16, 7, 2]);
  // x = 16 at corner 1: n1 = 7, o = 2, n3 = 3 → Q[7] + Q[3] − Q[2], then residuals
  const pred = [0, 1, 2].map((k) => clamp(code(7)[k] + code(3)[k] - code(2)[k]));
  assert.deepEqual([...d.positionCodes.subarray(48, 51)], [pred[0] - 5, pred[1] - 2, pred[2]]);
  assert.deepEqual([...d.quads.subarray(0, 36)], [...F]);
});

test('general form: moved and rewritten with old-corner and extra-list codes', () => {
  // n_new 0, n_moved 2 (vertices 1 and 6), n_rw 2 (slots 0 and 4), n_app 0.
  // slot 0 = [0 1 5 4]: mask 0b0001, corner 0 := explicit 2 (extra[0]).
  // slot 4 = [5 6 10 9]: mask 0b1000, corner 3 := old corner 2 of slot 0 (= 5)?
  //   that repeats 5; use old corner 0 of slot 0 (= 0): x = n_new + 1 + 0 = 1.
  // then an extra-list reference: none left to test here, see below.
  const bytes = file(
    {
      ops: [0x00],
      conn: [0, 2, 2, 0, 0b0001, 0, 0b1000, 1],
      refs: [{ s: 1 }, { s: 5 }, { s: -4 }],
      slots: [{ s: 0 }, 3],
      pos: [{ s: 1 }, { s: 0 }, { s: 0 }, { s: 0 }, { s: -1 }, { s: 0 }],
    },
    16,
    9,
  );
  const d = decodeAll(bytes);
  d.setLevel({ level: 1 });
  assert.deepEqual([...d.quads.subarray(0, 4)], [2, 1, 5, 4]);
  assert.deepEqual([...d.quads.subarray(16, 20)], [5, 6, 10, 0]);
  assert.deepEqual([...d.positionCodes.subarray(3, 6)], [code(1)[0] + 1, code(1)[1], code(1)[2]]);
  assert.deepEqual([...d.positionCodes.subarray(18, 21)], [code(6)[0], code(6)[1] - 1, code(6)[2]]);
  const c = d.setLevel({ level: 0 });
  assert.deepEqual([...c.verticesMoved], [1, 6]);
  assert.deepEqual([...c.facesRewritten], [0, 4]);
  assert.deepEqual([...d.quads], [...F]);
  assert.deepEqual([...d.positionCodes], [...Q]);
});

test('general form: every count, order and range rule is enforced', () => {
  const cases = [
    [{ ops: [0x00], conn: [2, 0, 0, 0] }, /new vertices exceed/],
    [{ ops: [0x00], conn: [0, 17, 0, 0] }, /moved vertices, only 16/],
    [{ ops: [0x00], conn: [0, 0, 10, 0] }, /rewritten faces, only 9/],
    [{ ops: [0x00], conn: [0, 0, 0, 2] }, /appended faces exceed/],
    [{ ops: [0x00], conn: [0, 2, 0, 0], refs: [{ s: 5 }, { s: -2 }], pos: [0, 0, 0, 0, 0, 0].map((s) => ({ s })) }, /moved vertex 3 does not follow 5/],
    [{ ops: [0x00], conn: [0, 1, 0, 0], refs: [{ s: 16 }], pos: [0, 0, 0].map((s) => ({ s })) }, /moved vertex 16 outside/],
    [{ ops: [0x00], conn: [0, 1, 0, 0], refs: [{ s: 3 }], pos: [0, 0].map((s) => ({ s })) }, /exceed what the streams hold/],
    [{ ops: [0x00], conn: [0, 0, 0, 1, 1, 2, 3] }, /exceed what the streams hold/],
    [{ ops: [0x00], conn: [0, 1, 0, 0], refs: [{ s: 0 }], pos: [{ s: -(1 << 24) }, { s: 0 }, { s: 0 }] }, /moved vertex 0 code .* outside 0..=/],
    [{ ops: [0x00], conn: [0, 0, 1, 0, 0], slots: [{ s: 9 }] }, /rewritten slot 9 outside/],
    [{ ops: [0x00], conn: [0, 0, 2, 0, 0, 0], slots: [{ s: 7 }, 1] }, /rewritten slot 9 outside/],
    [{ ops: [0x00], conn: [0, 0, 1, 0, 16], slots: [{ s: 0 }] }, /corner mask 16/],
    [{ ops: [0x00], conn: [0, 0, 1, 0, 1, 2], slots: [{ s: 0 }] }, /repeats a vertex/],
    [{ ops: [0x00], conn: [0, 0, 1, 0, 1, 6], slots: [{ s: 0 }] }, /extra entry 1, only 0/],
    [{ ops: [0x00], conn: [0, 0, 1, 0, 1, 0], slots: [{ s: 0 }], refs: [{ s: 16 }] }, /explicit vertex 16 outside/],
    [{ ops: [0x20], conn: [] }, /bits 4-7 set/],
    [{ ops: [0x11], conn: [] }, /record form 4 \(edge split, symbol 0x11\) is invalid in a version 1 file/],
    [{ ops: [0x0c], conn: [] }, /record form 3/],
    [{ ops: [0x00], conn: [0, 0, 0] }, /stream conn ends/],
  ];
  for (const [streams, message] of cases) badRecord(file(streams, 17, 10), message);
});

test('split form at a boundary corner: wings, sides, rotation, reflection', () => {
  // vertex 0 is in quad 0 = [0 1 5 4] only: K = 1, boundary, link (1, 4).
  // i = 0, e = 0: j = 1, b = 1, d = 4; face 0 is on side A (i ≤ 0 < j).
  // bit 6: a moves (residual (1, 0, 0)), bit 7: c by reflection, rot 1.
  const sym = 0x04 | (1 << 4) | 0x40 | 0x80;
  const bytes = file({ ops: [sym], conn: [0, 0], refs: [{ s: 0 }], pos: [1, 0, 0, 0, 2, 0].map((s) => ({ s })) }, 17, 10);
  const d = decodeAll(bytes);
  d.setLevel(1);
  // side C is empty: meanC = Q[m]; meanA = code of corner 5 (opposite 0)
  const m = code(0);
  const predA = [0, 1, 2].map((k) => clamp(m[k] + Math.floor((code(5)[k] - m[k]) / 4)));
  const a = [predA[0] + 1, predA[1], predA[2]];
  assert.deepEqual([...d.positionCodes.subarray(0, 3)], a);
  const predC = [0, 1, 2].map((k) => clamp(2 * m[k] - a[k]));
  assert.deepEqual([...d.positionCodes.subarray(48, 51)], [predC[0], predC[1] + 2, predC[2]]);
  // B = (m, d, c, b) = (0, 4, 16, 1), rotated by 1: (4, 16, 1, 0)
  assert.deepEqual([...d.quads.subarray(36, 40)], [4, 16, 1, 0]);
  assert.deepEqual([...d.quads.subarray(0, 36)], [...F], 'no face on side C');
});

test('split form at an interior vertex: side C faces get the new vertex', () => {
  // vertex 5 is in slots 0 [0 1 5 4], 1 [1 2 6 5], 3 [4 5 9 8], 4 [5 6 10 9].
  // n(f)/p(f) at 5: slot 0: n 4, p 1; slot 1: n 1, p 6; slot 3: n 9, p 4;
  // slot 4: n 6, p 9. Counter-clockwise order from slot 0 (interior):
  // succ(0) = slot with n = p(0) = 1 → slot 1; succ(1): n = 6 → slot 4;
  // succ(4): n = 9 → slot 3. Link l = (4, 1, 6, 9).
  // i = 1, e = 1: j = 3, b = 1, d = 9; side A: t = 1, 2 (slots 1, 4);
  // side C: t = 0, 3 (slots 0, 3). No move, c by §7.6: Q[b] + Q[d] − Q[m].
  const bytes = file({ ops: [0x05], conn: [1, 1], refs: [{ s: 5 }], pos: [0, 0, 0].map((s) => ({ s })) }, 17, 10);
  const d = decodeAll(bytes);
  d.setLevel(1);
  assert.deepEqual([...d.quads.subarray(0, 4)], [0, 1, 16, 4]);
  assert.deepEqual([...d.quads.subarray(12, 16)], [4, 16, 9, 8]);
  assert.deepEqual([...d.quads.subarray(4, 8)], [1, 2, 6, 5]);
  assert.deepEqual([...d.quads.subarray(36, 40)], [5, 9, 16, 1]);
  const pred = [0, 1, 2].map((k) => clamp(code(1)[k] + code(9)[k] - code(5)[k]));
  assert.deepEqual([...d.positionCodes.subarray(48, 51)], pred);
  const c = d.setLevel(0);
  assert.deepEqual([...c.facesRewritten], [0, 3]);
  assert.deepEqual(c.facesTruncated, { start: 9, end: 10 });
  assert.deepEqual(c.verticesRemoved, { start: 16, end: 17 });
});

test('split form: every rule is enforced', () => {
  const cases = [
    [{ ops: [0x04], refs: [{ s: 16 }] }, /split vertex 16 outside/],
    [{ ops: [0x04], conn: [4, 0], refs: [{ s: 5 }] }, /wing index 4 exceeds 3/],
    [{ ops: [0x04], conn: [0, 3], refs: [{ s: 5 }] }, /wing offset 3 exceeds 2/],
    [{ ops: [0x04], conn: [0, 1], refs: [{ s: 0 }] }, /wing offset 1 exceeds 0/],
    [{ ops: [0x44], conn: [0, 0], refs: [{ s: 0 }], pos: [{ s: 1 << 20 }, { s: 0 }, { s: 0 }] }, /outside 0..=/],
  ];
  for (const [streams, message] of cases) badRecord(file(streams, 17, 10), message);
  // no room for the new vertex / face
  badRecord(file({ ops: [0x04], conn: [0, 0], refs: [{ s: 0 }], pos: [0, 0, 0].map((s) => ({ s })) }, 16, 10), /final counts are reached/);
});

test('streams: nothing may be left over, and chunk counts must match', () => {
  const ok = { ops: [0x04], conn: [0, 0], refs: [{ s: 0 }], pos: [0, 0, 0].map((s) => ({ s })) };
  decodeAll(file(ok, 17, 10));
  assert.throws(() => decodeAll(file({ ...ok, slots: [0] }, 17, 10)), (e) => e.kind === 'invalid' && /1 unused bytes in stream slots/.test(e.message));
  assert.throws(() => decodeAll(file({ ...ok, ops: [0x04, 0x04] }, 17, 10)), (e) => e.kind === 'bad-record' && e.record === 1);
  void concat;
});
