// Moving between levels: any walk of refineTo / coarsenTo / setLevel gives
// the same mesh as going to that level directly, and the Change returned by
// each move, applied to renderer-side copies of the buffers (sub-range
// writes only, as a GPU upload would), reproduces the decoder's buffers
// exactly. Face-count and error targets pick the levels the spec says.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, decodeAll, runs } from '../src/index.js';
import { testFiles, levelDigests, rng } from './helpers.mjs';

const files = testFiles();

/** Renderer-side buffers, updated only through Change ranges. */
class Mirror {
  constructor(dec) {
    this.pos = new Float32Array(0);
    this.tris = new Uint32Array(0);
    this.nv = 0;
    this.nf = 0;
    this.apply(dec, dec.fullUpload());
  }

  apply(dec, c) {
    const pos = dec.positions;
    const tris = dec.triangleIndices;
    assert.equal(c.toLevel, dec.level);
    // removals only shrink the counts
    if (c.verticesRemoved.end > c.verticesRemoved.start) {
      assert.equal(c.verticesRemoved.end, this.nv);
      this.nv = c.verticesRemoved.start;
    }
    if (c.facesTruncated.end > c.facesTruncated.start) {
      assert.equal(c.facesTruncated.end, this.nf);
      this.nf = c.facesTruncated.start;
    }
    const grow = (arr, n) => {
      if (arr.length >= n) return arr;
      const out = new arr.constructor(n * 2);
      out.set(arr);
      return out;
    };
    for (const r of c.movedRanges()) {
      assert.ok(r.end <= this.nv, 'moved vertices exist before and after');
      this.pos.set(pos.subarray(3 * r.start, 3 * r.end), 3 * r.start);
    }
    if (c.verticesAppended.end > c.verticesAppended.start) {
      assert.equal(c.verticesAppended.start, this.nv);
      this.pos = grow(this.pos, 3 * c.verticesAppended.end);
      this.pos.set(pos.subarray(3 * c.verticesAppended.start, 3 * c.verticesAppended.end), 3 * c.verticesAppended.start);
      this.nv = c.verticesAppended.end;
    }
    for (const r of c.rewrittenRanges()) {
      assert.ok(r.end <= this.nf, 'rewritten slots exist before and after');
      this.tris.set(tris.subarray(6 * r.start, 6 * r.end), 6 * r.start);
    }
    if (c.facesAppended.end > c.facesAppended.start) {
      assert.equal(c.facesAppended.start, this.nf);
      this.tris = grow(this.tris, 6 * c.facesAppended.end);
      this.tris.set(tris.subarray(6 * c.facesAppended.start, 6 * c.facesAppended.end), 6 * c.facesAppended.start);
      this.nf = c.facesAppended.end;
    }
    assert.equal(this.nv, dec.vertexCount);
    assert.equal(this.nf, dec.faceCount);
    assert.deepEqual(this.pos.subarray(0, 3 * this.nv), pos, 'positions mirror the decoder');
    assert.deepEqual(this.tris.subarray(0, 6 * this.nf), tris, 'triangles mirror the decoder');
    // and the decoder's buffers are its level: triangles from quads, f32 from f64
    const q = dec.quads;
    for (let f = 0; f < this.nf; f++) {
      const [a, b, c, d] = q.subarray(4 * f, 4 * f + 4);
      const t = tris.subarray(6 * f, 6 * f + 6);
      if (t[0] !== a || t[1] !== b || t[2] !== c || t[3] !== a || t[4] !== c || t[5] !== d) {
        assert.fail(`slot ${f}: triangles ${t} do not split quad ${[a, b, c, d]}`);
      }
    }
    const p64 = dec.positionsF64();
    for (let i = 0; i < p64.length; i++) {
      if (pos[i] !== Math.fround(p64[i])) assert.fail(`position ${i}: f32 ${pos[i]} != f64 ${p64[i]}`);
    }
  }
}

test('runs() merges sorted ids into maximal ranges', () => {
  assert.deepEqual(runs([]), []);
  assert.deepEqual(runs(Uint32Array.of(1, 2, 3, 7, 9, 10)), [
    { start: 1, end: 4 },
    { start: 7, end: 8 },
    { start: 9, end: 11 },
  ]);
});

for (const file of files) {
  test(`${file.name}: random walks equal direct decoding, and Changes keep mirrors exact`, () => {
    const direct = decodeAll(file.bytes);
    const final = direct.deepestLevel;
    const want = new Map();
    const wantAt = (k) => {
      if (!want.has(k)) {
        const d = decodeAll(file.bytes); // a fresh decoder jumps 0 → k directly
        d.setLevel({ level: k });
        want.set(k, JSON.stringify(levelDigests(d)));
      }
      return want.get(k);
    };
    const dec = decodeAll(file.bytes);
    const mirror = new Mirror(dec);
    const rand = rng(final * 31 + 7);
    const steps = final > 500 ? 40 : 80;
    for (let s = 0; s < steps; s++) {
      const before = dec.level;
      const r = rand();
      let target;
      let c;
      if (r < 0.3) {
        target = Math.floor(rand() * (final + 1));
        c = dec.setLevel({ level: target });
        assert.equal(dec.level, target);
      } else if (r < 0.5) {
        target = before + 1 + Math.floor(rand() * 3);
        c = dec.refineTo({ level: target });
        assert.equal(dec.level, Math.min(target, final));
      } else if (r < 0.7) {
        target = Math.max(0, before - 1 - Math.floor(rand() * 3));
        c = dec.coarsenTo({ level: target });
        assert.equal(dec.level, target);
      } else if (r < 0.8) {
        // refineTo never coarsens, coarsenTo never refines
        const k = Math.floor(rand() * (final + 1));
        c = k < before ? dec.refineTo({ level: k }) : dec.coarsenTo({ level: k });
        assert.equal(dec.level, before);
        assert.ok(c.isEmpty());
      } else {
        target = rand() < 0.5 ? 0 : final;
        c = dec.setLevel(target);
      }
      assert.equal(c.fromLevel, before);
      mirror.apply(dec, c);
      assert.equal(JSON.stringify(levelDigests(dec)), wantAt(dec.level), `${file.name}: level ${dec.level}`);
    }
    // one level at a time up and down the whole range
    if (final <= 200) {
      dec.setLevel(0);
      const m = new Mirror(dec); // fullUpload() into empty buffers
      for (let k = 1; k <= final; k++) {
        m.apply(dec, dec.refineTo({ level: k }));
        assert.equal(JSON.stringify(levelDigests(dec)), wantAt(k));
      }
      for (let k = final - 1; k >= 0; k--) {
        m.apply(dec, dec.coarsenTo({ level: k }));
        assert.equal(JSON.stringify(levelDigests(dec)), wantAt(k));
      }
    }
  });

  test(`${file.name}: face-count and error targets`, () => {
    const dec = decodeAll(file.bytes);
    const final = dec.deepestLevel;
    const fAt = (k) => dec.levelCounts(k)[1];
    const probes = new Set([0, fAt(0) - 1, fAt(0), fAt(final), fAt(final) + 5]);
    for (let i = 0; i < 20; i++) probes.add(fAt(0) + Math.floor(((fAt(final) - fAt(0)) * i) / 19));
    for (const n of probes) {
      if (n < 0) continue;
      dec.setLevel({ faces: n });
      const k = dec.level;
      if (fAt(0) > n) assert.equal(k, 0);
      else {
        assert.ok(fAt(k) <= n, `${n} faces: level ${k} has ${fAt(k)}`);
        if (k < final) assert.ok(fAt(k + 1) > n, `${n} faces: level ${k + 1} also fits`);
      }
    }
    const h = dec.header;
    dec.setLevel({ error: h.baseError });
    assert.equal(dec.level, 0);
    for (const c of dec.chunks) {
      dec.setLevel({ error: c.error });
      // the coarsest chunk boundary whose error is ≤ e
      const first = dec.chunks.find((x) => x.error <= c.error);
      assert.equal(dec.level, h.baseError <= c.error ? 0 : first.level);
    }
    dec.setLevel({ error: -0 });
    assert.ok(dec.level === final || dec.chunks.some((x) => x.error === 0 && x.level === dec.level));
    // bytesFor: a prefix of that many bytes reaches the target
    for (const t of [{ level: Math.floor(final / 2) }, { faces: fAt(Math.floor(final / 3)) }, { error: dec.chunks[0]?.error ?? 0 }]) {
      const n = dec.bytesFor(t);
      const p = new PqmDecoder();
      p.push(file.bytes.subarray(0, n));
      const full = dec.resolve(t);
      assert.equal(p.resolve(t), full, `bytesFor(${JSON.stringify(t)}) = ${n}`);
    }
  });
}

test('bad targets are parameter errors', () => {
  const dec = decodeAll(files[0].bytes);
  for (const t of [{}, { level: -1 }, { faces: NaN }, { level: 1, faces: 2 }, { lvl: 3 }, null]) {
    assert.throws(() => dec.setLevel(t), (e) => e.kind === 'parameter');
  }
  assert.throws(() => new PqmDecoder().setLevel(0), (e) => e.kind === 'parameter');
});
