// Every file of spec/vectors (and the committed real-mesh file in test/data)
// decodes to the meshes its JSON digest and OBJ files record, at every listed
// level, whether the bytes come whole, in random small pieces or one at a
// time.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, decodeAll } from '../src/index.js';
import { testFiles, levelDigests, parseObj, meshOf, rng, randomPieces, positionBounds } from './helpers.mjs';

const files = testFiles();

test('the test files are there', () => {
  const names = files.map((f) => f.name);
  for (const n of ['grid_small', 'box_vord', 'general_bits8', 'mixed_bits24', 'cube_grid', 'spot', 'v4_traversal', 'v4_delta_base', 'v4_canonical', 'v4_1_diagonals']) {
    assert.ok(names.includes(n), `missing test file ${n}`);
  }
  // the header-bounds checks below see at least one 3.2 file with bounds
  assert.ok(files.some((f) => 'bounds_min' in f.digest), 'no test file with bounds_min in its JSON');
});

/** Checks every level listed in the digest; returns the meshes by level. */
function checkLevels(dec, file, how) {
  const { digest } = file;
  assert.equal(dec.deepestLevel, digest.final_level, `${file.name} (${how}): deepest level`);
  assert.equal(dec.finalLevel, digest.final_level);
  const meshes = {};
  for (const l of digest.levels) {
    dec.setLevel({ level: l.level });
    const where = `${file.name} level ${l.level} (${how})`;
    assert.equal(dec.level, l.level, where);
    assert.equal(dec.vertexCount, l.vertex_count, `${where}: vertex count`);
    assert.equal(dec.faceCount, l.face_count, `${where}: face count`);
    assert.deepEqual(dec.levelCounts(l.level), [l.vertex_count, l.face_count]);
    const d = levelDigests(dec);
    assert.equal(d.positions, l.positions_fnv1a64, `${where}: positions digest`);
    assert.equal(d.quads, l.quads_fnv1a64, `${where}: quads digest`);
    meshes[l.level] = meshOf(dec);
  }
  return meshes;
}

for (const file of files) {
  test(`${file.name}: whole file matches the JSON digest and the OBJ files`, () => {
    const dec = decodeAll(file.bytes);
    assert.equal(file.bytes.length, file.digest.bytes);
    const h = dec.header;
    assert.equal(h.recordCount, file.digest.final_level);
    const meshes = checkLevels(dec, file, 'whole');
    for (const [level, text] of Object.entries(file.obj)) {
      const want = parseObj(text);
      const got = meshes[level];
      // OBJ holds Rust's shortest round-trip f64: parsing gives the same double
      assert.deepEqual(got.positions, want.positions, `${file.name} level ${level}: OBJ positions`);
      assert.deepEqual(got.quads, want.quads, `${file.name} level ${level}: OBJ faces`);
    }
  });

  test(`${file.name}: f32 positions, triangles and codes agree with the f64 level`, () => {
    const dec = decodeAll(file.bytes);
    const g = dec.grid;
    for (const l of file.digest.levels) {
      dec.setLevel({ level: l.level });
      const f64 = dec.positionsF64();
      const f32 = dec.positions;
      const codes = dec.positionCodes;
      assert.equal(f32.length, f64.length);
      for (let i = 0; i < f64.length; i++) {
        assert.equal(f32[i], Math.fround(f64[i]));
        assert.ok(codes[i] <= g.qmax);
        assert.equal(f64[i], g.min[i % 3] + codes[i] * g.step[i % 3]);
      }
      const q = dec.quads;
      const t = dec.triangleIndices;
      assert.equal(t.length, (q.length / 4) * 6);
      for (let f = 0; f < q.length / 4; f++) {
        const [a, b, c, d] = q.subarray(4 * f, 4 * f + 4);
        assert.deepEqual([...t.subarray(6 * f, 6 * f + 6)], [a, b, c, a, c, d], `slot ${f}`);
        assert.equal(new Set([a, b, c, d]).size, 4);
        for (const v of [a, b, c, d]) assert.ok(v < dec.vertexCount);
      }
    }
  });

  test(`${file.name}: flag bit 3 (finest diagonals, 4.1) as the JSON lists it`, () => {
    const h = decodeAll(file.bytes).header;
    assert.equal(h.finestDiagonals, file.digest.finest_diagonals === true);
    assert.equal(h.finestDiagonals, (h.flags & 8) !== 0);
    if (h.finestDiagonals) assert.deepEqual([h.versionMajor, h.versionMinor], [4, 1]);
  });

  test(`${file.name}: header bounds (spec §3 flag bit 2) equal the JSON's and the box of every level`, () => {
    const dec = decodeAll(file.bytes);
    const h = dec.header;
    const got = positionBounds(dec);
    if ('bounds_min' in file.digest) {
      // a 3.2 or 4.0 file with bounds: exactly the JSON's numbers (Rust's
      // shortest round-trip f64, which parse back to the same doubles), and
      // exactly the box of the positions every level shows
      assert.equal(h.hasBounds, true, 'hasBounds');
      assert.equal(h.flags & 4, 4, 'flag bit 2');
      assert.ok(h.headerLen >= 168);
      // spec §3: version_minor 2 in a 3.x file with bounds; in a 4.x file 1
      // with flag bit 3 (finest diagonals), else 0
      assert.equal(h.versionMinor, h.versionMajor >= 4 ? (h.finestDiagonals ? 1 : 0) : 2);
      assert.deepEqual(h.boundsMin, file.digest.bounds_min, 'boundsMin = JSON bounds_min');
      assert.deepEqual(h.boundsMax, file.digest.bounds_max, 'boundsMax = JSON bounds_max');
      assert.deepEqual(got, [h.boundsMin, h.boundsMax], 'bounds = box of every level');
    } else {
      assert.ok(!('bounds_max' in file.digest));
      assert.equal(h.hasBounds, false, 'hasBounds');
      assert.equal(h.flags & 4, 0, 'flag bit 2');
      assert.deepEqual(h.boundsMin, h.bboxMin);
      assert.deepEqual(h.boundsMax, h.bboxMax);
    }
    // either way, the bounds hold every level — the grid box only up to the
    // rounding of `min + q × step` (spec §5), which can pass `bbox_max` by an ulp
    if (got) {
      for (let k = 0; k < 3; k++) {
        const lo = h.boundsMin[k];
        const hi = h.boundsMax[k];
        const tol = h.hasBounds ? 0 : 4 * Number.EPSILON * Math.max(Math.abs(lo), Math.abs(hi));
        const where = `axis ${k}: [${got[0][k]}, ${got[1][k]}] in [${lo}, ${hi}]`;
        assert.ok(lo - tol <= got[0][k] && got[1][k] <= hi + tol, where);
      }
    }
  });

  test(`${file.name}: random small pieces and single bytes give the same events and levels`, () => {
    const whole = new PqmDecoder();
    const wholeEvents = whole.push(file.bytes);
    whole.end();
    const ref = checkLevels(whole, file, 'whole');
    const kinds = wholeEvents.map((e) => e.type);
    assert.equal(kinds[0], 'headerReady');
    assert.equal(kinds[1], 'baseMeshReady');
    assert.equal(kinds.filter((k) => k === 'chunkReady').length, whole.header.chunkCount);
    assert.equal(kinds.at(-1), 'finished');
    if (whole.header.hasVertexOrder) {
      assert.ok(whole.vertexOrder, 'VORD read');
      assert.equal(whole.vertexOrder.length, whole.header.finalVertexCount);
      assert.equal(new Set(whole.vertexOrder).size, whole.vertexOrder.length);
    } else {
      assert.equal(whole.vertexOrder, null);
    }
    const splits = [
      ['pieces of 1..7 bytes', randomPieces(file.bytes, rng(1), 7)],
      ['pieces of 1..300 bytes', randomPieces(file.bytes, rng(2), 300)],
      ['one byte at a time', randomPieces(file.bytes, () => 0, 1)],
    ];
    for (const [how, pieces] of splits) {
      const dec = new PqmDecoder();
      const events = [];
      for (const p of pieces) {
        const ev = dec.push(p);
        p.fill(0xee); // the caller may reuse its buffer after push returns
        events.push(...ev);
      }
      dec.end();
      assert.deepEqual(events, wholeEvents, `${file.name} (${how}): events`);
      assert.deepEqual(dec.vertexOrder, whole.vertexOrder);
      const got = checkLevels(dec, file, how);
      assert.deepEqual(got, ref);
    }
  });
}
