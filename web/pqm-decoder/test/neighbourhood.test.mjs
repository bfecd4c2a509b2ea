// The local form's neighbourhood (spec §7.7 step 2) as the decoder collects
// it from its vertex→slot lists — U collected and sorted only on demand —
// equals the spec's definition evaluated by brute force over the quads,
// through random rewrites, appends and rebuilds; and the 4096-entry limit
// counts distinct (vertex, face) pairs.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Frontier } from '../src/codec.js';
import { neighbourhoodLists } from '../src/local.js';
import { rng, randomQuad, randomFrontierEdit } from './helpers.mjs';

/** Spec §7.7 step 2 by brute force: {R, U} ascending, or an error kind. */
function bruteNeighbourhood(st, m) {
  const quad = (s) => [...st.f.subarray(4 * s, 4 * s + 4)];
  const slots = [...Array(st.nf).keys()];
  const S = slots.filter((s) => quad(s).includes(m));
  if (S.length === 0) return { error: /has no face/ };
  if (S.length > 255) return { error: /more than 255 faces/ };
  const A = new Set(S.flatMap(quad));
  let entries = 0;
  for (const a of A) entries += slots.filter((s) => quad(s).includes(a)).length;
  if (entries > 4096) return { error: /more than 4096 corners/ };
  const R = slots.filter((s) => quad(s).some((v) => A.has(v)));
  const U = [...new Set(R.flatMap(quad))].sort((x, y) => x - y);
  return { R, U };
}

function check(st, m, what) {
  const want = bruteNeighbourhood(st, m);
  if (want.error) {
    assert.throws(() => neighbourhoodLists(st, m), (e) => want.error.test(e), what);
  } else {
    assert.deepEqual(neighbourhoodLists(st, m), want, what);
  }
}

for (const seed of [11, 12, 13]) {
  test(`seed ${seed}: neighbourhoods equal the spec's definition through rewrites, appends and rebuilds`, () => {
    const rand = rng(seed);
    const st = new Frontier();
    const maxV = 20 + Math.floor(rand() * 60);
    const maxF = 300;
    st.maxV = maxV;
    st.maxF = maxF;
    st.nv = 8 + Math.floor(rand() * 8);
    st.nf = 1 + Math.floor(rand() * 20);
    st.reserve(st.nv, st.nf);
    for (let s = 0; s < st.nf; s++) st.f.set(randomQuad(rand, st.nv), 4 * s);
    st.rebuild();
    for (let step = 0; step < 1500; step++) {
      if (!randomFrontierEdit(st, rand, maxF, maxV)) {
        const m = Math.floor(rand() * st.nv);
        check(st, m, `step ${step}: neighbourhood of ${m}`);
      }
    }
    for (let m = 0; m < st.nv; m++) check(st, m, `final neighbourhood of ${m}`);
  });
}

/**
 * Anchor 0 in 6 quads (0, p, q, r) with 18 distinct other corners, each of
 * which is also in `fan` more quads of fresh vertices: 6 + 18 (fan + 1)
 * entries.
 */
function fanMesh(fan) {
  const quads = [];
  let next = 1;
  const ring = [];
  for (let i = 0; i < 6; i++) {
    const q = [0, next, next + 1, next + 2];
    ring.push(next, next + 1, next + 2);
    next += 3;
    quads.push(q);
  }
  for (const v of ring) {
    for (let j = 0; j < fan; j++) {
      quads.push([v, next, next + 1, next + 2]);
      next += 3;
    }
  }
  const st = new Frontier();
  st.maxV = next;
  st.maxF = quads.length + 1;
  st.nv = next;
  st.nf = quads.length;
  st.reserve(st.nv, st.nf);
  quads.forEach((q, s) => st.f.set(q, 4 * s));
  st.rebuild();
  return st;
}

test('more than 4096 distinct entries make the neighbourhood invalid', () => {
  const st = fanMesh(227); // 6 + 18 × 228 = 4110 entries
  assert.throws(() => neighbourhoodLists(st, 0), (e) => /more than 4096 corners/.test(e));
});

test('4092 entries are valid (the limit is inclusive of everything below 4097)', () => {
  const st = fanMesh(226); // 6 + 18 × 227 = 4092 entries
  const { R, U } = neighbourhoodLists(st, 0);
  assert.equal(R.length, st.nf);
  assert.equal(U.length, st.nv);
  assert.deepEqual(R, [...Array(st.nf).keys()]);
});

test('an anchor in more than 255 faces is invalid; in 255 it is not', () => {
  for (const faces of [255, 256]) {
    const st = new Frontier();
    st.maxV = 2 * faces + 2;
    st.maxF = faces;
    st.nv = 2 * faces + 2;
    st.nf = faces;
    st.reserve(st.nv, st.nf);
    for (let s = 0; s < faces; s++) st.f.set([0, 1 + 2 * s, 2 + 2 * s, 2 * faces + 1], 4 * s);
    st.rebuild();
    check(st, 0, `${faces} faces`);
    if (faces === 256) assert.throws(() => neighbourhoodLists(st, 0), (e) => /more than 255 faces/.test(e));
    else assert.equal(neighbourhoodLists(st, 0).R.length, 255);
  }
});

test('stamps stay exact across their wrap-around (16-bit generations)', () => {
  // Component X: quad 0 on vertices 0..3; component Y: random quads on
  // 4..13. X is walked, then Y 16,382 times, then X again: the generation
  // counter cycles every 16,383 walks, so the second walk of X gets the
  // same stamp values as the first, and only the clearing at the wrap keeps
  // X's old stamps from hiding its vertices and faces.
  const rand = rng(21);
  const st = new Frontier();
  st.maxV = 14;
  st.maxF = 13;
  st.nv = 14;
  st.nf = 13;
  st.reserve(st.nv, st.nf);
  st.f.set([0, 1, 2, 3], 0);
  for (let s = 1; s < st.nf; s++) st.f.set(randomQuad(rand, 10).map((v) => v + 4), 4 * s);
  st.rebuild();
  const wantX = bruteNeighbourhood(st, 0);
  assert.deepEqual(neighbourhoodLists(st, 0), wantX);
  const ys = [];
  for (let m = 4; m < 14; m++) {
    const w = bruteNeighbourhood(st, m);
    if (!w.error) ys.push([m, w]);
  }
  for (let call = 0; call < 16382; call++) {
    const [m, w] = ys[call % ys.length];
    const got = neighbourhoodLists(st, m);
    if (got.R.length !== w.R.length || got.U.length !== w.U.length) assert.deepEqual(got, w, `call ${call}, anchor ${m}`);
  }
  assert.deepEqual(neighbourhoodLists(st, 0), wantX, 'X after a full cycle of generations');
});
