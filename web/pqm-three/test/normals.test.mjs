// Smooth normals (`PQMProgressiveMesh` with `normals: true`): whatever path
// reaches a level — streamed in random pieces, stepped one level at a time,
// or jumped across in either direction — a GPU copy updated only through
// the `normal` attribute's update ranges holds exactly the normals computed
// at that level from scratch; a step uploads only the corners of the quads
// it adds, removes or moves a vertex of; without the option there is no
// normal attribute.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError } from 'pqm-decoder';
import { PQMLoader, PQMProgressiveMesh } from '../src/index.js';
import { FakeGpu } from './fake-gpu.mjs';
import { testFiles, rng, randomPieces, fnv1a64, VECTORS_DIR } from '../../pqm-decoder/test/helpers.mjs';

const files = testFiles();
/** Steps whose upload bound was checked (steps that move no vertex). */
let boundChecked = 0;

/**
 * The level's unit normals from scratch: per vertex the sum over its quads
 * of `(p2 − p0) × (p3 − p1)` on the dequantized positions (spec §5: code ×
 * step per axis, the grid's minimum cancels in the differences), rounded to
 * f32; zero where the sum is.
 */
function reference(dec) {
  const { step } = dec.grid;
  const c = dec.positionCodes;
  const q = dec.quads;
  const sum = new Float64Array(3 * dec.vertexCount);
  const p = (v, k) => c[3 * v + k] * step[k];
  for (let f = 0; f < dec.faceCount; f++) {
    const [a, b, cc, d] = q.subarray(4 * f, 4 * f + 4);
    const u = [0, 1, 2].map((k) => p(cc, k) - p(a, k));
    const w = [0, 1, 2].map((k) => p(d, k) - p(b, k));
    const n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
    for (const v of [a, b, cc, d]) for (let k = 0; k < 3; k++) sum[3 * v + k] += n[k];
  }
  const out = new Float32Array(3 * dec.vertexCount);
  for (let v = 0; v < dec.vertexCount; v++) {
    const len = Math.hypot(sum[3 * v], sum[3 * v + 1], sum[3 * v + 2]);
    for (let k = 0; k < 3; k++) out[3 * v + k] = len > 0 ? sum[3 * v + k] / len : 0;
  }
  return out;
}

/** The GPU copy's normals against the reference: the same directions (products in another order round differently). */
function checkNormals(gpu, pm, where) {
  const dec = pm.decoder;
  const got = gpu.buffers.get(pm.geometry.attributes.normal).data;
  const want = reference(dec);
  for (let v = 0; v < dec.vertexCount; v++) {
    const g = got.subarray(3 * v, 3 * v + 3);
    const w = want.subarray(3 * v, 3 * v + 3);
    const zero = (x) => x[0] === 0 && x[1] === 0 && x[2] === 0;
    if (zero(w) || zero(g)) {
      if (!(zero(w) && zero(g))) assert.fail(`${where}: vertex ${v} normal ${g} vs ${w}`);
      continue;
    }
    const dot = g[0] * w[0] + g[1] * w[1] + g[2] * w[2];
    if (!(dot > 1 - 1e-6)) assert.fail(`${where}: vertex ${v} normal ${g} vs ${w} (cos ${dot})`);
  }
}

for (const file of files) {
  test(`${file.name}: normals streamed, stepped and walked equal the level's own`, () => {
    const pm = new PQMProgressiveMesh(new PqmDecoder(), { normals: true, maxGap: 0 });
    const gpu = new FakeGpu();
    for (const piece of randomPieces(file.bytes, rng(9), 1200)) {
      pm.push(piece);
      if (pm.geometry && pm.decoder.deepestLevel !== null) {
        gpu.render(pm);
        checkNormals(gpu, pm, `${file.name} streaming`);
      }
    }
    pm.decoder.end();
    const final = pm.decoder.deepestLevel;
    const big = final > 2000;
    // one level at a time, down and up again: each step's normal uploads
    // are the corners of its quads (old and new) and of the quads around
    // its moved vertices
    const stride = big ? Math.ceil(final / 300) : 1;
    const q = pm.decoder.quads;
    for (const dir of [-1, 1]) {
      for (let k = dir < 0 ? final - 1 : 1; k >= 0 && k <= final; k += dir * stride) {
        const L = pm.wireframeGeometry.index.array.slice();
        const before = pm.uploaded.normal;
        const c = pm.setLevel({ level: k });
        gpu.render(pm);
        if (stride === 1 && c.verticesMoved.length === 0) {
          const corners = new Set();
          const slots = c.rewrittenRanges().flatMap((r) => Array.from({ length: r.end - r.start }, (_, i) => r.start + i));
          for (let f = c.facesAppended.start; f < c.facesAppended.end; f++) slots.push(f);
          for (let f = c.facesTruncated.start; f < c.facesTruncated.end; f++) slots.push(f);
          for (const f of slots) {
            for (let j = 0; j < 8; j += 2) corners.add(L[8 * f + j]);
            if (f < pm.decoder.faceCount) for (let j = 0; j < 4; j++) corners.add(q[4 * f + j]);
          }
          const drawn = [...corners].filter((v) => v < pm.decoder.vertexCount).length;
          assert.ok(pm.uploaded.normal - before <= 3 * drawn, `${file.name} level ${k}: ${pm.uploaded.normal - before} normal elements for ${drawn} corners`);
          boundChecked++;
        }
        if (!big || k % (50 * stride) < stride) checkNormals(gpu, pm, `${file.name} level ${k}`);
      }
    }
    checkNormals(gpu, pm, `${file.name} stepped back to the end`);
    // random jumps, and several moves between two renders
    const r = rng(final + 7);
    for (let s = 0; s < 15; s++) {
      pm.setLevel({ level: Math.floor(r() * (final + 1)) });
      if (s % 3 === 0) pm.setLevel({ level: Math.floor(r() * (final + 1)) });
      gpu.render(pm);
      checkNormals(gpu, pm, `${file.name} jump ${s} to ${pm.level}`);
      gpu.check(pm, `${file.name} jump ${s}`);
    }
  });
}

test('the upload bound was checked on steps that move no vertex', () => {
  assert.ok(boundChecked > 20, `${boundChecked} steps`);
});

test('without the option there is no normal attribute, and nothing is spent on it', () => {
  const f = files.find((x) => x.name === 'spot') ?? files[0];
  const pm = new PQMProgressiveMesh(new PqmDecoder());
  pm.push(f.bytes);
  pm.setLevel({ level: 0 });
  assert.equal(pm.geometry.attributes.normal, undefined);
  assert.equal(pm.uploaded.normal, 0);
  assert.equal(pm.normals, false);
});

test('PQMLoader.setMeshOptions gives its meshes normals and a split', () => {
  const f = files.find((x) => x.name === 'spot') ?? files[0];
  const data = f.bytes.buffer.slice(f.bytes.byteOffset, f.bytes.byteOffset + f.bytes.length);
  const loader = new PQMLoader().setMeshOptions({ normals: true, quadSplit: 'shorter' });
  const pm = loader.parse(data);
  assert.equal(pm.normals, true);
  assert.equal(pm.drawnSplit, 'shorter');
  const gpu = new FakeGpu();
  gpu.render(pm);
  checkNormals(gpu, pm, 'parsed');
  pm.setLevel({ level: 0 });
  gpu.render(pm);
  checkNormals(gpu, pm, 'parsed, then the base');
  assert.equal(new PQMLoader().parse(data).geometry.attributes.normal, undefined, 'no normals unless asked');
  assert.throws(() => loader.setMeshOptions({ normal: true }), PqmError);
});

// Cross-check with Rust: spec/vectors list, per level, the digest of the
// normals `pqm_format::normals::SmoothNormals` computes (spec §11,
// `normals_fnv1a64`). The same integer sums and the same f64 arithmetic
// give the same f32 normals bit for bit, whichever way the level was
// reached: stepped down from the finest level, or jumped to from level 0.
const vectors = files.filter((f) => f.dir === VECTORS_DIR);
test("every spec vector lists its levels' normals digests", () => {
  assert.ok(vectors.length >= 10, `${vectors.length} vectors`);
  for (const f of vectors) for (const l of f.digest.levels) assert.match(l.normals_fnv1a64 ?? '', /^[0-9a-f]{16}$/, `${f.name} level ${l.level}`);
});
for (const file of vectors) {
  test(`${file.name}: normals equal Rust's SmoothNormals bit for bit`, () => {
    const pm = new PQMProgressiveMesh(new PqmDecoder(), { normals: true });
    const gpu = new FakeGpu();
    pm.push(file.bytes);
    pm.decoder.end();
    const digest = () => {
      gpu.render(pm);
      const n = gpu.buffers.get(pm.geometry.attributes.normal).data.subarray(0, 3 * pm.decoder.vertexCount);
      return fnv1a64(new Uint8Array(n.buffer, n.byteOffset, n.byteLength));
    };
    const levels = file.digest.levels;
    for (const l of [...levels].reverse()) {
      pm.setLevel({ level: l.level });
      assert.equal(digest(), l.normals_fnv1a64, `level ${l.level}, stepping down`);
    }
    for (const l of levels) {
      pm.setLevel({ level: 0 });
      pm.setLevel({ level: l.level });
      assert.equal(digest(), l.normals_fnv1a64, `level ${l.level}, from level 0`);
    }
  });
}
