// The frontier's vertex→corner lists (an append-only node pool with lazy
// deletion, rebuilt when 1.5× over): after any sequence of corner rewrites
// and appended quads, the star of every vertex equals a brute-force scan of
// the quads (slots ascending, the vertex's corner in each), whether or not
// stale nodes were dropped by earlier walks or by a rebuild; the pool stays
// within 1.5 nodes per corner of the final face count (+ 1024).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Frontier } from '../src/codec.js';
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
  return { slots: [...S.subarray(0, K)], corners: [...C.subarray(0, K)] };
}

/** Four distinct random vertices below nv. */
for (const seed of [1, 2, 3, 4, 5]) {
  test(`seed ${seed}: stars equal a brute-force scan through rewrites, appends, walks and rebuilds`, () => {
    const rand = rng(seed);
    const st = new Frontier();
    // few vertices, so stars are big and corners return to old vertices
    const maxV = 12 + Math.floor(rand() * 30);
    const maxF = 400;
    st.maxV = maxV;
    st.maxF = maxF;
    st.nv = 6 + Math.floor(rand() * 6);
    st.nf = 1 + Math.floor(rand() * 20);
    st.reserve(st.nv, st.nf);
    st.head = new Int32Array(st.nv);
    for (let s = 0; s < st.nf; s++) st.f.set(randomQuad(rand, st.nv), 4 * s);
    st.rebuild();
    let rebuilds = 0;
    const rebuild = st.rebuild.bind(st);
    st.rebuild = () => {
      rebuilds++;
      rebuild();
    };
    for (let step = 0; step < 4000; step++) {
      if (!randomFrontierEdit(st, rand, maxF, maxV)) {
        const m = Math.floor(rand() * st.nv);
        assert.deepEqual(walk(st, m), bruteStar(st, m), `step ${step}: star of ${m}`);
      }
      assert.ok(st.nNodes <= 6 * maxF + 1024, `pool of ${st.nNodes} nodes, final faces ${maxF}`);
    }
    for (let m = 0; m < st.nv; m++) {
      assert.deepEqual(walk(st, m), bruteStar(st, m), `final star of ${m}`);
      assert.deepEqual(walk(st, m), bruteStar(st, m), `second walk of ${m} (after dropping stale nodes)`);
    }
    assert.ok(rebuilds > 0, 'the pool was rebuilt at least once');
  });
}

test('a star of more than 255 faces is an error, not an overflow', () => {
  const st = new Frontier();
  st.maxV = 600;
  st.maxF = 300;
  st.nv = 600;
  st.nf = 256;
  st.reserve(st.nv, st.nf);
  st.head = new Int32Array(st.nv);
  for (let s = 0; s < st.nf; s++) st.f.set([0, 1 + 2 * s, 2 + 2 * s, 599], 4 * s);
  st.rebuild();
  assert.throws(() => st.star(0, new Int32Array(256), new Int32Array(256)), (e) => /more than 255 faces/.test(e));
});
