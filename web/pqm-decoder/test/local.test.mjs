// Hand-written local-form records (spec §7.7) on the base mesh of
// grid_small (a 4×4 vertex grid, quad (x, y) = [4y+x, 4y+x+1, 4y+x+5,
// 4y+x+4] at slot 3y+x): neighbourhoods, local indices, rotation bits and
// explicit corners checked independently of the reference encoder.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll, PqmError } from '../src/index.js';
import { testFiles, handmadeFile } from './helpers.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const base = decodeAll(grid.bytes);
const Q = base.positionCodes.slice();
const F = base.quads.slice();
const qmax = base.grid.qmax;
const clamp = (x) => Math.min(Math.max(x, 0), qmax);
const code = (v) => [Q[3 * v], Q[3 * v + 1], Q[3 * v + 2]];

/**
 * A file: grid_small's base and one chunk with the given streams, reaching
 * `v` vertices and `f` faces; a version 1.1 file (the version-1 prediction
 * of spec §7.6, form 3 invalid) whatever version the vectors have.
 */
const file = (streams, v, f) => handmadeFile(grid.bytes, streams, v, f, 1);

function badRecord(bytes, record, message) {
  assert.throws(
    () => decodeAll(bytes),
    (e) => e instanceof PqmError && e.kind === 'bad-record' && e.record === record && message.test(e.message),
    `expected ${message}`,
  );
}

// Record 0, anchor 0 (corner of the grid): S = {0}, A = {0, 1, 4, 5},
// R = [0, 1, 3, 4], U = [0, 1, 2, 4, 5, 6, 8, 9, 10]. It rewrites slot
// R[3] = 4 ([5, 6, 10, 9]), so the moved-vertex vocabulary is
// W = [5, 6, 10, 9, 0, 1, 2, 4, 8]; it moves W[1] = 6 and rotates slot 4 by
// one corner, replacing none.
const rec0 = {
  ops: [0x09], // op 1, form 2
  conn: [0, 1, 1, 0, 1 << 4],
  refs: [{ s: 0 }],
  slots: [3, 1],
  pos: [{ s: 3 }, { s: -1 }, { s: 0 }],
};
// Record 1, anchor 15: S = {8}, A = {10, 11, 14, 15}, R = [4, 5, 7, 8],
// U = [5, 6, 7, 9, 10, 11, 13, 14, 15]. Slot R[3] = 8 ([10, 11, 15, 14])
// gets the new vertex 16 at corner 2 (mask 4, code 1); the appended quad
// (16, 11, 15, 7) is: new, old corner 1 of the first rewritten slot
// (code 1 + 1 + 1 = 3), explicit U[8] = 15, explicit U[2] = 7.
const rec1 = {
  ops: [0x08],
  conn: [1, 0, 1, 1, 4, 1, 1, 3, 0, 0],
  refs: [{ s: 15 }],
  slots: [3, 8, 2],
  pos: [{ s: 1 }, { s: 2 }, { s: 3 }],
};
const join = (a, b) => Object.fromEntries(['ops', 'conn', 'refs', 'slots', 'pos'].map((k) => [k, [...a[k], ...b[k]]]));

test('local form: neighbourhood indices, rotation, explicit corners, prediction', () => {
  const d = decodeAll(file(join(rec0, rec1), 17, 10));
  d.setLevel({ level: 1 });
  const c6 = code(6);
  assert.deepEqual([...d.positionCodes.subarray(18, 21)], [c6[0] + 3, c6[1] - 1, c6[2]]);
  assert.deepEqual([...d.quads.subarray(16, 20)], [6, 10, 9, 5]);
  d.setLevel({ level: 2 });
  assert.deepEqual([...d.quads.subarray(32, 36)], [10, 11, 16, 14]);
  assert.deepEqual([...d.quads.subarray(36, 40)], [16, 11, 15, 7]);
  // 16 is corner 0 of the appended quad: n1 = 11, o = 15, n3 = 7
  const pred = [0, 1, 2].map((k) => clamp(code(11)[k] + code(7)[k] - code(15)[k]));
  assert.deepEqual([...d.positionCodes.subarray(48, 51)], [pred[0] + 1, pred[1] + 2, pred[2] + 3]);
  // untouched slots and the vertex cursor: record 1's anchor delta was
  // relative to record 0's anchor (0)
  for (const s of [0, 1, 2, 3, 5, 6, 7]) assert.deepEqual([...d.quads.subarray(4 * s, 4 * s + 4)], [...F.subarray(4 * s, 4 * s + 4)]);
  d.setLevel({ level: 0 });
  assert.deepEqual([...d.quads], [...F]);
  assert.deepEqual([...d.positionCodes], [...Q]);
});

test('local form: hostile indices and masks are bad records', () => {
  badRecord(file({ ...rec0, slots: [3, 9] }, 16, 9), 0, /moved vertex local index 9 outside 0\.\.9/);
  badRecord(file({ ...rec0, slots: [4, 1] }, 16, 9), 0, /rewritten face local index 4 outside 0\.\.4/);
  badRecord(file({ ...rec0, conn: [0, 10, 1, 0, 16] }, 16, 9), 0, /10 moved vertices, the neighbourhood holds 9/);
  badRecord(file({ ...rec0, conn: [0, 1, 5, 0, 16] }, 16, 9), 0, /5 rewritten faces, the neighbourhood holds 4/);
  badRecord(file({ ...rec0, conn: [0, 1, 1, 0, 64] }, 16, 9), 0, /corner mask 64/);
  badRecord(file({ ...rec0, refs: [{ s: 16 }] }, 16, 9), 0, /anchor 16 outside 0\.\.16/);
  badRecord(file({ ...rec0, ops: [0x19] }, 16, 9), 0, /bits 4-7/);
  // an explicit corner beyond U; an explicit corner U[5] = 6 replacing
  // corner 0 of [5, 6, 10, 9] repeats vertex 6
  badRecord(file({ ...rec1, refs: [{ s: 15 }], slots: [3, 9, 2] }, 17, 10), 0, /local corner index 9/);
  badRecord(file({ ...rec0, conn: [0, 1, 1, 0, 16 | 1, 0], slots: [3, 1, 5] }, 16, 9), 0, /repeats a vertex/);
});
