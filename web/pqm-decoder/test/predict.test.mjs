// The counting sort that groups a record's corners by new vertex before
// predicting (spec §7.6: every quad holding the vertex, appended quads
// first, then rewritten ones by slot; records with more than 4 new
// vertices) gives the same lists as a brute-force scan, on random records;
// and floorDiv floors exactly. (Records with at most 4 bucket their corners
// in finishRecord; the vectors and the big files' digests cover them.)
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { groupCorners, groupedCorners, floorDiv } from '../src/codec.js';
import { rng, randomQuad } from './helpers.mjs';

test('corner grouping: the counting sort equals brute force', () => {
  const rand = rng(5);
  for (let trial = 0; trial < 500; trial++) {
    const V = 10 + Math.floor(rand() * 20);
    const nNew = 1 + Math.floor(rand() * 8);
    const nApp = Math.floor(rand() * 6);
    const nRw = Math.floor(rand() * 6);
    const app = Int32Array.from({ length: 4 * nApp }, () => 0);
    const rw = Int32Array.from({ length: 4 * nRw }, () => 0);
    for (let i = 0; i < nApp; i++) app.set(randomQuad(rand, V + nNew), 4 * i);
    for (let i = 0; i < nRw; i++) rw.set(randomQuad(rand, V + nNew), 4 * i);
    const want = [];
    for (let k = 0; k < nNew; k++) {
      const list = [];
      for (let i = 0; i < 4 * nApp; i++) if (app[i] === V + k) list.push(i);
      for (let i = 0; i < 4 * nRw; i++) if (rw[i] === V + k) list.push(4 * nApp + i);
      want.push(list);
    }
    groupCorners(V, nNew, rw, nRw, app, nApp);
    assert.deepEqual(groupedCorners(nNew), want, `trial ${trial}: counting sort`);
  }
});

test('floorDiv rounds toward −∞ exactly', () => {
  const rand = rng(6);
  for (let i = 0; i < 2000; i++) {
    const c = 1 + Math.floor(rand() * 300);
    const s = Math.floor((rand() - 0.5) * 2 ** 35);
    const q = floorDiv(s, c);
    assert.ok(q * c <= s && s < (q + 1) * c, `${s} / ${c} → ${q}`);
  }
  assert.equal(floorDiv(-3, 2), -2);
  assert.equal(floorDiv(7, 2), 3);
});
