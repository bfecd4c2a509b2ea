// The one-way decoder (`forwardOnly: true`) against the general one: pushed
// the same pieces and moved to the deepest decoded level at the same times,
// it reports the same events and the same Changes and holds the same
// buffers; after a truncation or a bad record it keeps the same deepest
// level (its frontier goes back to the last committed chunk) and can still
// move there; every other move is refused with a `parameter` error that
// changes nothing.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError } from '../src/index.js';
import { testFiles, levelDigests, rng, randomPieces, plainChange as plain } from './helpers.mjs';
import { unpack, pack } from './repack.mjs';
import { degree } from '../src/codec.js';

const files = testFiles({ includeBench: true });

/** The current level of a decoder, all of it. */
const state = (d) => ({
  level: d.level,
  deepest: d.deepestLevel,
  nv: d.vertexCount,
  nf: d.faceCount,
  codes: [...d.positionCodes],
  positions: [...d.positions],
  f64: [...d.positionsF64()],
  quads: [...d.quads],
  tris: [...d.triangleIndices],
});

/**
 * Pushes `pieces` into a general and a forward-only decoder, both moving to
 * the deepest level after a push when `rand() < p` (and after the last);
 * asserts the same events, Changes and buffers at every step. Returns both
 * decoders and the error both threw (same message), if any.
 */
function lockstep(pieces, rand, p, what) {
  const g = new PqmDecoder();
  const w = new PqmDecoder({ forwardOnly: true });
  let error = null;
  for (const piece of pieces) {
    let eg = null;
    let ew = null;
    let evg;
    let evw;
    try {
      evg = g.push(piece);
    } catch (e) {
      eg = e;
    }
    try {
      evw = w.push(piece);
    } catch (e) {
      ew = e;
    }
    assert.equal(ew?.message, eg?.message, `${what}: same error`);
    if (eg) {
      assert.ok(eg instanceof PqmError && ew instanceof PqmError);
      assert.deepEqual(ew.events, eg.events, `${what}: same events before the error`);
      error = eg;
    } else {
      assert.deepEqual(evw, evg, `${what}: same events`);
    }
    if (g.deepestLevel !== null && (error || rand() < p)) {
      assert.deepEqual(plain(w.refineTo({ level: w.deepestLevel })), plain(g.refineTo({ level: g.deepestLevel })), what);
      assert.deepEqual(state(w), state(g), `${what}: same level`);
    }
    if (error) break;
  }
  if (!error && g.deepestLevel !== null) {
    assert.deepEqual(plain(w.setLevel({ level: w.deepestLevel })), plain(g.setLevel({ level: g.deepestLevel })), what);
    assert.deepEqual(state(w), state(g), `${what}: same final level`);
  }
  return { g, w, error };
}

for (const file of files) {
  test(`${file.name}: forward-only = general (events, Changes, buffers) under random pieces and moves`, () => {
    const rand = rng(file.bytes.length);
    const big = file.bytes.length > 200000;
    for (let round = 0; round < (big ? 2 : 6); round++) {
      const maxLen = [1 + Math.floor(file.bytes.length / 40), 4096, 65536, file.bytes.length][round % 4];
      const pieces = randomPieces(file.bytes, rand, maxLen);
      const { g, w, error } = lockstep(pieces, rand, [0.5, 0.1, 1][round % 3], `${file.name} round ${round}`);
      assert.equal(error, null);
      w.end();
      assert.equal(w.deepestLevel, file.digest.final_level);
      const last = file.digest.levels[file.digest.levels.length - 1];
      if (last.level === w.deepestLevel) {
        assert.deepEqual(levelDigests(w), { positions: last.positions_fnv1a64, quads: last.quads_fnv1a64 });
      }
      assert.equal(g.level, w.level);
    }
  });
}

for (const file of files.filter((f) => f.bytes.length < 200000)) {
  test(`${file.name}: forward-only refuses every move but to the deepest level, and changes nothing then`, () => {
    const d = new PqmDecoder({ forwardOnly: true });
    const h = new PqmDecoder();
    assert.throws(() => d.refineTo({ level: 0 }), (e) => e instanceof PqmError && e.kind === 'parameter');
    d.push(file.bytes);
    h.push(file.bytes);
    const deepest = d.deepestLevel;
    assert.ok(deepest >= 2);
    const refused = (fn) =>
      assert.throws(fn, (e) => e instanceof PqmError && e.kind === 'parameter' && /forward-only/.test(e.message));
    // from level 0: an intermediate level is refused, the deepest is not
    const before = state(d);
    refused(() => d.refineTo({ level: deepest - 1 }));
    refused(() => d.setLevel({ level: deepest >> 1 }));
    assert.deepEqual(state(d), before, 'a refused move changes nothing');
    assert.ok(d.setLevel({ level: 0 }).isEmpty(), 'staying is not a move');
    assert.ok(d.coarsenTo({ level: deepest }).isEmpty(), 'coarsenTo never refines');
    assert.deepEqual(plain(d.refineTo({ faces: Infinity })), plain(h.refineTo({ level: deepest })));
    // from the deepest level: every coarser target is refused
    const at = state(d);
    refused(() => d.coarsenTo({ level: 0 }));
    refused(() => d.setLevel({ level: deepest - 1 }));
    refused(() => d.setLevel({ error: Infinity }));
    assert.deepEqual(state(d), at);
    assert.ok(d.refineTo({ level: 0 }).isEmpty(), 'refineTo never coarsens');
    assert.ok(d.refineTo({ level: deepest }).isEmpty());
    assert.deepEqual(state(d), state(h));
  });
}

for (const file of files.filter((f) => f.bytes.length < 200000)) {
  test(`${file.name}: truncated, forward-only keeps the general decoder's deepest level`, () => {
    const n = file.bytes.length;
    const cuts = new Set();
    for (let p = 1; p < n; p += Math.max(1, Math.floor(n / 40))) cuts.add(p);
    const probe = new PqmDecoder();
    probe.push(file.bytes);
    for (const c of probe.chunks) for (const p of [c.offset, c.end - 1, c.end]) if (p < n) cuts.add(p);
    for (const p of cuts) {
      const { g, w } = lockstep([file.bytes.subarray(0, p)], () => 1, 0, `${file.name}: prefix ${p}`);
      assert.equal(w.deepestLevel, g.deepestLevel);
      assert.throws(() => w.end(), (e) => e instanceof PqmError && e.kind === 'truncated');
    }
  });
}

for (const file of files.filter((f) => f.bytes.length < 200000)) {
  test(`${file.name}: a damaged chunk payload — forward-only fails like the general decoder and keeps the levels before`, () => {
    const rand = rng(7 + file.bytes.length);
    const parts0 = unpack(file.bytes);
    if (parts0.chunks.length === 0) return;
    let failedMidFile = 0;
    for (let k = 0; k < 40; k++) {
      const parts = unpack(file.bytes);
      const i = Math.floor(rand() * parts.chunks.length);
      const pl = parts.chunks[i];
      if (pl.length === 0) continue;
      const at = Math.floor(rand() * pl.length);
      pl[at] = (pl[at] + 1 + Math.floor(rand() * 255)) & 0xff;
      const bytes = pack(parts);
      // move after the first piece — the base, or chunks up to i − 1 — and
      // at the failure (so chunks before i commit in the failing push, or
      // not, and the failing chunk writes past the current level, or below)
      const cut = probeEnd(bytes, k % 2 === 0 ? i - 1 : -1);
      const pieces = [bytes.subarray(0, cut), bytes.subarray(cut)];
      const { g, w, error } = lockstep(pieces, () => 0, 1, `${file.name}: chunk ${i} byte ${at}`);
      if (error) {
        failedMidFile++;
        assert.equal(w.deepestLevel, g.deepestLevel);
        assert.equal(w.level, w.deepestLevel);
        assert.deepEqual(state(w), state(g));
        // the frontier itself is back at the deepest level, lists included
        const st = w._frontier;
        assert.equal(st.nv, w.vertexCount);
        assert.equal(st.nf, w.faceCount);
        assert.deepEqual([...st.f.subarray(0, 4 * st.nf)], [...g.quads]);
        for (let v = 0; v < st.nv; v++) {
          const c = g.positionCodes;
          if (st.q[16 * v] !== c[3 * v] || st.q[16 * v + 1] !== c[3 * v + 1] || st.q[16 * v + 2] !== c[3 * v + 2]) {
            assert.fail(`vertex ${v}: frontier code differs`);
          }
        }
        const deg = new Int32Array(st.nv);
        for (let x = 0; x < 4 * st.nf; x++) deg[st.f[x]]++;
        for (let v = 0; v < st.nv; v++) assert.equal(degree(st, v), deg[v], `vertex ${v}: list length`);
      }
    }
    assert.ok(failedMidFile > 0, 'some damaged payloads are refused');
  });
}

/** The end offset of chunk i of a file (i = −1: of the base mesh), from its chunk table. */
function probeEnd(bytes, i) {
  const d = new PqmDecoder();
  try {
    d.push(bytes);
  } catch {
    // the damaged chunk: the table was read before it
  }
  return i < 0 ? d.chunks[0].offset : d.chunks[i].end;
}
