// The big files of bench/data (written by tools/make-pqm, not committed),
// when present: the same digests as the Rust reference decoder at levels
// 0, n/3, 2n/3 and n, and the same vertex order, streamed in 64 KiB pieces.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder } from '../src/index.js';
import { testFiles, levelDigests, fnv1a64, BENCH_DATA_DIR } from './helpers.mjs';

const files = testFiles({ includeBench: true }).filter((f) => f.dir === BENCH_DATA_DIR);

if (files.length === 0) {
  test.skip('no .pqm + .json in bench/data (see README: tools/make-pqm)', () => {});
}

for (const file of files) {
  test(`${file.name} (${(file.bytes.length / 1e6).toFixed(1)} MB): digests of the reference decoder`, () => {
    const dec = new PqmDecoder();
    for (let o = 0; o < file.bytes.length; o += 65536) dec.push(file.bytes.subarray(o, o + 65536));
    dec.end();
    assert.equal(dec.deepestLevel, file.digest.final_level);
    if (file.digest.vertex_order_fnv1a64) {
      const o = dec.vertexOrder;
      assert.equal(fnv1a64(new Uint8Array(o.buffer, o.byteOffset, o.byteLength)), file.digest.vertex_order_fnv1a64, 'vertex order');
    }
    for (const l of file.digest.levels) {
      dec.setLevel({ level: l.level });
      assert.equal(dec.faceCount, l.face_count);
      assert.deepEqual(levelDigests(dec), { positions: l.positions_fnv1a64, quads: l.quads_fnv1a64 }, `level ${l.level}`);
    }
  });
}
