// The frontier's vertex→slot lists (12 slots in each vertex record, the
// rest in a map; exact, no stale entries): after any sequence of corner
// rewrites, whole-quad rewrites (rotations, the way records rewrite) and
// appended quads, the star of every vertex equals a brute-force scan of the
// quads (slots ascending, the vertex's corner in each), and every list's
// length is the number of slots holding the vertex — also for vertices in
// many more than 12 slots, whose lists spill out of their record and back.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Frontier, RecordLog, rewriteSlot, degree } from '../src/codec.js';
import { rng, randomQuad, randomFrontierEdit } from './helpers.mjs';

/** Brute force: slots holding m ascending, and m's corner in each. */
function bruteStar(st, m) {
  const slots = [];
  const corners = [];
  for (let s = 0; s < st.nf; s++) {
    for (let k = 0; k < 4; k++) {
      if (st.f[4 * s + k] === m) {
        slots.push(s);
        corners.push(k);
      }
    }
  }
  return { slots, corners };
}

function walk(st, m) {
  const S = new Int32Array(256);
  const C = new Int32Array(256);
  const K = st.star(m, S, C);
  // sortedSlots (what the face split and canonicalStar read) lists the same
  // slots in the same order
  const T = new Int32Array(256);
  assert.equal(st.sortedSlots(m, T), K);
  assert.deepEqual([...T.subarray(0, K)], [...S.subarray(0, K)]);
  return { slots: [...S.subarray(0, K)], corners: [...C.subarray(0, K)] };
}

/** Four distinct random vertices below nv. */
/** Rewrites a random slot as record forms do: a rotation of its quad with 0–2 corners replaced. */
function rewriteRandomQuad(st, ctx, rand) {
  const s = Math.floor(rand() * st.nf);
  const q = [...st.f.subarray(4 * s, 4 * s + 4)];
  const replace = Math.floor(rand() * 3);
  for (let r = 0; r < replace; r++) {
    const v = Math.floor(rand() * st.nv);
    if (!q.includes(v)) q[Math.floor(rand() * 4)] = v;
  }
  const t = Math.floor(rand() * 4);
  rewriteSlot(ctx, s, q[t], q[(t + 1) & 3], q[(t + 2) & 3], q[(t + 3) & 3]);
}

for (const seed of [1, 2, 3, 4, 5]) {
  test(`seed ${seed}: stars equal a brute-force scan through corner and quad rewrites, appends and walks`, () => {
    const rand = rng(seed);
    const st = new Frontier();
    // few vertices, so stars are big (lists spill past their block) and
    // corners return to old vertices
    const maxV = 12 + Math.floor(rand() * 30);
    const maxF = 400;
    st.maxV = maxV;
    st.maxF = maxF;
    st.nv = 6 + Math.floor(rand() * 6);
    st.nf = 1 + Math.floor(rand() * 20);
    st.reserve(st.nv, st.nf);
    for (let s = 0; s < st.nf; s++) st.f.set(randomQuad(rand, st.nv), 4 * s);
    st.rebuild();
    const ctx = { st, log: new RecordLog() };
    let spilled = 0;
    for (let step = 0; step < 4000; step++) {
      if (rand() < 0.2) {
        rewriteRandomQuad(st, ctx, rand);
      } else if (!randomFrontierEdit(st, rand, maxF, maxV)) {
        const m = Math.floor(rand() * st.nv);
        const want = bruteStar(st, m);
        if (want.slots.length > 12) spilled++;
        assert.equal(degree(st, m), want.slots.length, `step ${step}: list length of ${m}`);
        if (want.slots.length <= 255) assert.deepEqual(walk(st, m), want, `step ${step}: star of ${m}`);
      }
    }
    for (let m = 0; m < st.nv; m++) assert.deepEqual(walk(st, m), bruteStar(st, m), `final star of ${m}`);
    assert.ok(spilled > 0, 'some stars had more than 12 faces');
  });
}

test('a star of more than 255 faces is an error, not an overflow', () => {
  const st = new Frontier();
  st.maxV = 600;
  st.maxF = 300;
  st.nv = 600;
  st.nf = 256;
  st.reserve(st.nv, st.nf);
  for (let s = 0; s < st.nf; s++) st.f.set([0, 1 + 2 * s, 2 + 2 * s, 599], 4 * s);
  st.rebuild();
  assert.throws(() => st.star(0, new Int32Array(256), new Int32Array(256)), (e) => /more than 255 faces/.test(e));
  assert.throws(() => st.sortedSlots(0, new Int32Array(256)), (e) => /more than 255 faces/.test(e));
});
