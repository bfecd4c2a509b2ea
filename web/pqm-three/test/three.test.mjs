// PQMProgressiveMesh and PQMLoader in node (three.js works headless for
// BufferGeometry): a simulated GPU that uploads only `updateRanges` (as
// three's WebGLAttributes does) always ends up equal to the decoder's level;
// the wireframe holds the quad edges and no diagonal; uploads stay within
// the changed ranges; the loader streams over HTTP and stops at a target.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import http from 'node:http';
import { PQMProgressiveMesh, PQMLoader, coalesce, splitShorter } from '../src/index.js';
import { FakeGpu } from './fake-gpu.mjs';
import { Box3, Vector3 } from 'three';
import { PqmDecoder, decodeAll } from 'pqm-decoder';
import { testFiles, rng, randomPieces, serveBytes } from '../../pqm-decoder/test/helpers.mjs';
import { withBounds } from '../../pqm-decoder/test/repack.mjs';

const files = testFiles();

for (const file of files) {
  test(`${file.name}: a forward-only decoder streams into the same GPU copy, uploading the same elements`, () => {
    const run = (decoder) => {
      const pm = new PQMProgressiveMesh(decoder, { maxGap: 0 });
      const gpu = new FakeGpu();
      for (const piece of randomPieces(file.bytes, rng(5), 1500)) {
        pm.push(piece);
        if (pm.geometry && pm.decoder.deepestLevel !== null) {
          gpu.render(pm);
          gpu.check(pm, `${file.name} streaming`);
          assert.equal(pm.level, pm.decoder.deepestLevel);
        }
      }
      pm.decoder.end();
      return { pm, gpu };
    };
    const g = run(new PqmDecoder());
    const w = run(new PqmDecoder({ forwardOnly: true }));
    assert.equal(w.gpu.elementsUploaded, g.gpu.elementsUploaded);
    assert.deepEqual([...w.pm.decoder.triangleIndices], [...g.pm.decoder.triangleIndices]);
    assert.deepEqual([...w.pm.decoder.positions], [...g.pm.decoder.positions]);
  });
}

test('coalesce merges runs with small gaps', () => {
  assert.deepEqual(coalesce([{ start: 0, end: 2 }, { start: 5, end: 6 }, { start: 50, end: 51 }], 3), [
    { start: 0, end: 6 },
    { start: 50, end: 51 },
  ]);
  assert.deepEqual(coalesce([], 3), []);
});

for (const file of files) {
  test(`${file.name}: streamed, then walked: the GPU copy equals the level, uploads stay in the changed ranges`, () => {
    const pm = new PQMProgressiveMesh(new PqmDecoder(), { maxGap: 0 });
    const gpu = new FakeGpu();
    // stream with auto-refinement, rendering after every piece
    for (const piece of randomPieces(file.bytes, rng(3), 997)) {
      pm.push(piece);
      if (pm.geometry && pm.decoder.deepestLevel !== null) {
        gpu.render(pm);
        gpu.check(pm, `${file.name} streaming`);
        assert.equal(pm.level, pm.decoder.deepestLevel, 'auto-refined to the deepest level');
      }
    }
    pm.decoder.end();
    const final = pm.decoder.deepestLevel;
    assert.equal(pm.level, final);
    // the header's bounds contain every level
    const box = pm.geometry.boundingBox;
    const rand = rng(final + 1);
    for (let s = 0; s < 30; s++) {
      const before = gpu.elementsUploaded;
      const k = Math.floor(rand() * (final + 1));
      const c = rand() < 0.5 ? pm.setLevel({ level: k }) : k > pm.level ? pm.refineTo(k) : pm.coarsenTo(k);
      // with maxGap 0, exactly the Change's ranges are uploaded
      const expect =
        3 * (c.verticesMoved.length + c.verticesAppended.end - c.verticesAppended.start) +
        14 * (c.facesRewritten.length + c.facesAppended.end - c.facesAppended.start);
      gpu.render(pm);
      assert.equal(gpu.elementsUploaded - before, expect, `${file.name}: level ${c.fromLevel} → ${c.toLevel}`);
      gpu.check(pm, `${file.name} level ${pm.level}`);
      // the header's bounds (or the quantization grid) hold every level, up to f32 rounding
      const p = pm.decoder.positions;
      const tol = 1e-6 * (box.max.distanceTo(box.min) + 1);
      const lo = [box.min.x - tol, box.min.y - tol, box.min.z - tol];
      const hi = [box.max.x + tol, box.max.y + tol, box.max.z + tol];
      for (let i = 0; i < p.length; i++) {
        if (!(p[i] >= lo[i % 3] && p[i] <= hi[i % 3])) assert.fail(`coordinate ${i} = ${p[i]} outside the box`);
      }
    }
    // several moves between two renders accumulate their ranges
    pm.setLevel(0);
    pm.setLevel(Math.floor(final / 2));
    pm.refineTo(final);
    gpu.render(pm);
    gpu.check(pm, `${file.name} accumulated`);
  });
}

/**
 * The shorter-diagonal split of every slot of the decoder's level, computed
 * here from the f64 positions (spec §5), as the Rust glTF export does.
 */
function shorterSplits(dec) {
  const p = dec.positionsF64();
  const q = dec.quads;
  const out = [];
  const d2 = (u, v) => (p[3 * u] - p[3 * v]) ** 2 + (p[3 * u + 1] - p[3 * v + 1]) ** 2 + (p[3 * u + 2] - p[3 * v + 2]) ** 2;
  for (let f = 0; f < dec.faceCount; f++) {
    const [a, b, c, d] = q.subarray(4 * f, 4 * f + 4);
    out.push(d2(b, d) < d2(a, c) ? [b, c, d, b, d, a] : [a, b, c, a, c, d]);
  }
  return out;
}

for (const name of ['spot', 'v4_canonical', 'box_vnbr']) {
  test(`${name}: quadSplit 'shorter' draws every quad along its shorter diagonal, streamed and walked`, () => {
    const file = files.find((f) => f.name === name);
    const pm = new PQMProgressiveMesh(new PqmDecoder(), { maxGap: 0, quadSplit: 'shorter' });
    const gpu = new FakeGpu();
    let moves = false;
    const check = (where) => {
      gpu.render(pm);
      const dec = pm.decoder;
      const idx = gpu.buffers.get(pm.geometry.index).data;
      const files = dec.triangleIndices;
      const want = shorterSplits(dec);
      let other = 0;
      for (let f = 0; f < dec.faceCount; f++) {
        const got = [...idx.subarray(6 * f, 6 * f + 6)];
        const own = [...files.subarray(6 * f, 6 * f + 6)];
        const flipped = [own[1], own[2], own[5], own[1], own[5], own[0]];
        // one of the quad's two splits; the shorter one unless a vertex
        // moved since the slot was written
        if (got.join() !== own.join() && got.join() !== flipped.join()) assert.fail(`${where}: slot ${f} ${got}`);
        if (got.join() !== want[f].join()) {
          if (!moves) assert.fail(`${where}: slot ${f} ${got}, shorter ${want[f]}`);
          other++;
        }
      }
      return other;
    };
    for (const piece of randomPieces(file.bytes, rng(7), 1201)) {
      pm.push(piece);
      if (pm.geometry && pm.decoder.deepestLevel !== null) {
        moves ||= (pm.lastChange?.verticesMoved.length ?? 0) > 0;
        check(`${name} streaming`);
      }
    }
    pm.decoder.end();
    assert.equal(pm.drawnSplit, 'shorter');
    const final = pm.decoder.deepestLevel;
    const rand = rng(11);
    let flips = 0;
    for (let s = 0; s < 20; s++) {
      const c = pm.setLevel({ level: Math.floor(rand() * (final + 1)) });
      moves ||= c.verticesMoved.length > 0;
      check(`${name} level ${pm.level}`);
      const idx = gpu.buffers.get(pm.geometry.index).data;
      const own = pm.decoder.triangleIndices;
      for (let i = 0; i < own.length; i += 6) flips += idx[i] !== own[i] ? 1 : 0;
    }
    // the shorter diagonal is not always the file's
    assert.ok(flips > 0, `${name}: no quad drawn along v1-v3`);
  });
}

test("quadSplit 'auto': the file's diagonals where the header says they are meant (4.1), else the shorter", () => {
  for (const [name, drawn] of [
    ['v4_1_diagonals', 'file'],
    ['v4_canonical', 'shorter'],
    ['spot', 'shorter'],
  ]) {
    const file = files.find((f) => f.name === name);
    // a mesh made at the finest level writes every slot from its positions
    const dec = decodeAll(file.bytes);
    dec.setLevel({ level: dec.finalLevel });
    const pm = new PQMProgressiveMesh(dec, { quadSplit: 'auto' });
    assert.equal(pm.drawnSplit, drawn, name);
    const idx = pm.geometry.index.array.subarray(0, 6 * pm.faceCount);
    if (drawn === 'file') assert.deepEqual(idx, pm.decoder.triangleIndices, name);
    else assert.deepEqual([...idx], shorterSplits(pm.decoder).flat(), name);
  }
  assert.throws(() => new PQMProgressiveMesh(new PqmDecoder(), { quadSplit: 'longer' }), /quadSplit/);
  // the exported helper writes the same as the mesh
  const dec = decodeAll(files.find((f) => f.name === 'spot').bytes);
  dec.setLevel({ level: dec.finalLevel });
  const out = new Uint32Array(6 * dec.faceCount);
  for (let f = 0; f < dec.faceCount; f++) splitShorter(out, f, dec.quads, dec.positionCodes, dec.grid.step);
  assert.deepEqual([...out], shorterSplits(dec).flat());
});

/** Asserts that both geometries' bounding volumes are the header's bounds. */
function assertBoundsVolumes(pm, where) {
  const h = pm.decoder.header;
  for (const g of [pm.geometry, pm.wireframeGeometry]) {
    const box = g.boundingBox;
    assert.deepEqual([box.min.x, box.min.y, box.min.z], h.boundsMin, `${where}: box min`);
    assert.deepEqual([box.max.x, box.max.y, box.max.z], h.boundsMax, `${where}: box max`);
    const c = box.getCenter(new Vector3());
    assert.deepEqual(g.boundingSphere.center.toArray(), c.toArray(), `${where}: sphere centre`);
    assert.equal(g.boundingSphere.radius, box.getSize(new Vector3()).length() / 2, `${where}: sphere radius`);
  }
}

test('the geometries\' bounding box and sphere are the header\'s bounds, for every file', () => {
  for (const file of files) {
    const pm = new PQMProgressiveMesh(new PqmDecoder());
    pm.push(file.bytes);
    pm.decoder.end();
    assertBoundsVolumes(pm, file.name);
    // bounds in the file (cube_grid): inside the grid, tighter on some axis
    if (pm.decoder.header.hasBounds) {
      const h = pm.decoder.header;
      const box = pm.geometry.boundingBox;
      const grid = new Box3(new Vector3(...h.bboxMin), new Vector3(...h.bboxMax));
      assert.ok(grid.containsBox(box), `${file.name}: bounds inside the grid`);
      assert.ok(!grid.equals(box), `${file.name}: the grid is not the box`);
    }
    // no bounds in the file: the grid box
    if (!pm.decoder.header.hasBounds) {
      const box = pm.geometry.boundingBox;
      assert.deepEqual(box.min.toArray(), pm.decoder.header.bboxMin, file.name);
      assert.deepEqual(box.max.toArray(), pm.decoder.header.bboxMax, file.name);
    }
  }
});

test('with header bounds (flag bit 2) the bounding box is the bounds, not the grid', () => {
  const grid = files.find((f) => f.name === 'grid_small');
  const g = decodeAll(grid.bytes).header;
  // any bounds inside the grid (the decoder takes them as written)
  const min = [0, 1, 2].map((k) => g.bboxMin[k] + 0.25 * (g.bboxMax[k] - g.bboxMin[k]));
  const max = [0, 1, 2].map((k) => g.bboxMin[k] + 0.5 * (g.bboxMax[k] - g.bboxMin[k]));
  const pm = new PQMProgressiveMesh(new PqmDecoder());
  pm.push(withBounds(grid.bytes, min, max));
  pm.decoder.end();
  assert.equal(pm.decoder.header.hasBounds, true);
  assertBoundsVolumes(pm, 'grid_small with bounds');
  assert.deepEqual(pm.geometry.boundingBox.min.toArray(), min);
  assert.deepEqual(pm.geometry.boundingBox.max.toArray(), max);
  assert.equal(pm.level, pm.decoder.deepestLevel, 'decodes as before');
});

test('maxGap merges nearby ranges but never misses one', () => {
  const file = files.find((f) => f.name === 'spot');
  const pm = new PQMProgressiveMesh(decodeAll(file.bytes), { maxGap: 64, autoRefine: false });
  const gpu = new FakeGpu();
  gpu.render(pm);
  for (const k of [300, 20, 1152, 0, 700, 701, 699]) {
    pm.setLevel(k);
    gpu.render(pm);
    gpu.check(pm, `level ${k}`);
  }
});

test('a mesh created on a decoded decoder starts at its level; maxFaces caps auto-refinement', () => {
  const file = files.find((f) => f.name === 'spot');
  const dec = decodeAll(file.bytes);
  dec.setLevel(100);
  const pm = new PQMProgressiveMesh(dec);
  assert.equal(pm.level, 100);
  assert.equal(pm.geometry.drawRange.count, 6 * pm.faceCount);
  const capped = new PQMProgressiveMesh(new PqmDecoder(), { maxFaces: 1500 });
  capped.push(file.bytes);
  assert.ok(capped.faceCount <= 1500);
  assert.equal(capped.level, capped.decoder.resolve({ faces: 1500 }));
});

/** Serves `bytes` in small delayed writes; returns {url, close, served()}. */
function serve(bytes, pieceSize = 512) {
  let served = 0;
  const server = http.createServer(async (req, res) => {
    res.writeHead(200, { 'Content-Type': 'application/octet-stream', 'Content-Length': bytes.length });
    for (let o = 0; o < bytes.length; o += pieceSize) {
      if (res.destroyed) return;
      const ok = res.write(bytes.subarray(o, o + pieceSize));
      served = o + pieceSize;
      if (!ok) await new Promise((r) => res.once('drain', r));
      await new Promise((r) => setImmediate(r));
    }
    res.end();
  });
  return new Promise((resolve) => {
    server.listen(0, '127.0.0.1', () => {
      resolve({
        url: `http://127.0.0.1:${server.address().port}/file.pqm`,
        close: () => new Promise((r) => server.close(r)),
        served: () => served,
      });
    });
  });
}

test('PQMLoader streams over HTTP: onLoad at the base mesh, refinement as chunks arrive', async () => {
  const file = files.find((f) => f.name === 'spot');
  const srv = await serve(file.bytes);
  try {
    const progress = [];
    const pm = await new Promise((resolve, reject) => {
      let mesh = null;
      new PQMLoader().load(
        srv.url,
        (m) => {
          mesh = m;
          assert.equal(m.level, 0, 'delivered at the base mesh');
          assert.equal(m.faceCount, m.decoder.header.baseFaceCount);
        },
        (p) => {
          progress.push(p);
          if (p.events.some((e) => e.type === 'finished')) resolve(mesh);
        },
        reject,
      );
    });
    assert.equal(pm.level, pm.decoder.finalLevel);
    assert.equal(pm.faceCount, pm.decoder.header.finalFaceCount);
    const levels = progress.map((p) => p.level);
    assert.ok(new Set(levels).size > 3, `refined in steps: ${[...new Set(levels)]}`);
    for (let i = 1; i < levels.length; i++) assert.ok(levels[i] >= levels[i - 1]);
    assert.equal(progress.at(-1).loaded, file.bytes.length);
    const gpu = new FakeGpu();
    gpu.render(pm);
    gpu.check(pm, 'loaded');
  } finally {
    await srv.close();
  }
});

test('PQMLoader with a face target stops reading early', async () => {
  const file = files.find((f) => f.name === 'spot');
  const whole = decodeAll(file.bytes);
  const n = whole.levelCounts(300)[1];
  const srv = await serve(file.bytes);
  try {
    const loader = new PQMLoader().setTarget({ faces: n });
    let last = null;
    const pm = await new Promise((resolve, reject) => {
      loader.load(srv.url, resolve, (p) => (last = p), reject);
    });
    // wait until the loader has stopped (the stream is cancelled)
    for (let i = 0; i < 200 && !(last && last.loaded >= whole.bytesFor({ faces: n })); i++) {
      await new Promise((r) => setTimeout(r, 5));
    }
    assert.equal(last.loaded, whole.bytesFor({ faces: n }));
    assert.ok(last.loaded < file.bytes.length, 'did not read the whole file');
    assert.equal(pm.level, whole.resolve({ faces: n }));
    assert.ok(pm.faceCount <= n);
  } finally {
    await srv.close();
  }
});

test('PQMLoader.parse decodes a buffer; errors reach onError', async () => {
  const file = files.find((f) => f.name === 'box_vord');
  const pm = new PQMLoader().parse(file.bytes.buffer.slice(file.bytes.byteOffset, file.bytes.byteOffset + file.bytes.length));
  assert.equal(pm.level, pm.decoder.finalLevel);
  const bad = file.bytes.slice();
  bad[200] ^= 1;
  const srv = await serve(bad);
  try {
    const err = await new Promise((resolve) => new PQMLoader().load(srv.url, () => {}, undefined, resolve));
    assert.equal(err.kind, 'crc');
  } finally {
    await srv.close();
  }
});

test('PQMLoader with Range requests: bytes up to the target only, fetchMore continues, buffers follow', async () => {
  const file = files.find((f) => f.name === 'spot');
  const whole = decodeAll(file.bytes);
  const n1 = whole.levelCounts(200)[1];
  const n2 = whole.levelCounts(800)[1];
  const srv = await serveBytes(file.bytes);
  try {
    const loader = new PQMLoader().setTarget({ faces: n1 }).setRangeRequests(true);
    let onLoads = 0;
    const progress = [];
    const pm = await new Promise((resolve, reject) => {
      loader.load(
        srv.url,
        (m) => {
          onLoads++;
          assert.ok(m.decoder.deepestLevel !== null, 'onLoad once the base mesh is decoded');
        },
        (p) => {
          progress.push(p);
          if (p.loaded >= whole.bytesFor({ faces: n1 })) setImmediate(() => resolve(p.mesh));
        },
        reject,
      );
    });
    assert.equal(onLoads, 1);
    assert.ok(srv.stats.served <= whole.bytesFor({ faces: n1 }), `served ${srv.stats.served}`);
    assert.equal(srv.stats.requests.length, 2, 'header + table, then the rest up to the target');
    assert.equal(pm.level, whole.resolve({ faces: n1 }));
    const gpu = new FakeGpu();
    gpu.render(pm);
    gpu.check(pm, 'first target');
    await pm.fetchMore({ faces: n2 });
    assert.equal(srv.stats.served, whole.bytesFor({ faces: n2 }), 'no byte twice');
    assert.equal(pm.level, whole.resolve({ faces: n2 }));
    gpu.render(pm);
    gpu.check(pm, 'after fetchMore');
    // promise form, error target, then the rest
    const e = whole.chunks[1].error;
    const pm2 = await new PQMLoader().loadRange(srv.url, { error: e });
    assert.equal(pm2.level, whole.resolve({ error: e }));
    await pm2.fetchMore();
    assert.equal(pm2.level, whole.finalLevel);
    assert.ok(pm2.decoder.status().finished);
  } finally {
    await srv.close();
  }
});
