// The zstd decoder (src/zstd-decode.js, through zstd.js's decompressFrame)
// against frames written by the zstd command line tool (levels 1 to 22 and
// --fast: raw, RLE and compressed blocks, 1- and 4-stream and treeless
// literals, predefined, RLE, FSE and repeated sequence tables, frames of
// several blocks) and against fzstd on every frame of the test files;
// damaged frames give an error message or, where the damage stays
// decodable, exactly the stated length — never an exception of another kind.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync, existsSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { decompress } from 'fzstd';
import { decompressFrame } from '../src/zstd.js';
import { PqmDecoder } from '../src/index.js';
import { zstdInputs, levelsOf } from './zstd-inputs.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const fixtures = path.join(here, 'data/zstd');

test('frames of the zstd tool decode to their inputs', () => {
  let n = 0;
  for (const [name, bytes] of Object.entries(zstdInputs())) {
    for (const level of levelsOf(name)) {
      const frame = new Uint8Array(readFileSync(path.join(fixtures, `${name}.${level}.zst`)));
      const out = decompressFrame(frame, bytes.length);
      assert.equal(out.length, bytes.length, `${name}.${level}`);
      assert.ok(Buffer.from(out).equals(Buffer.from(bytes)), `${name}.${level} decodes to its input`);
      n++;
    }
  }
  assert.equal(n, readdirSync(fixtures).length);
});

/** Every compressed section (base and chunks) of a .pqm file: [frame, stated length]. */
function sections(bytes) {
  const d = new PqmDecoder();
  d.push(bytes);
  const h = d.header;
  const out = [[h.headerLen + h.chunkCount * h.chunkEntryLen + 4, h.baseCompressedLen, h.baseUncompressedLen]];
  for (const c of d.chunks) out.push([c.offset, c.compressedLen, c.uncompressedLen]);
  return out.map(([o, c, u]) => [bytes.subarray(o, o + c), u]);
}

function pqmFiles() {
  const dirs = [path.join(here, 'data'), path.join(here, '../../../spec/vectors'), path.join(here, '../../bench/data')];
  return dirs.filter(existsSync).flatMap((d) => readdirSync(d).filter((f) => f.endsWith('.pqm')).map((f) => path.join(d, f)));
}

test('every section of the test files decodes as fzstd decodes it', () => {
  let n = 0;
  for (const file of pqmFiles()) {
    for (const [frame, len] of sections(new Uint8Array(readFileSync(file)))) {
      const ours = decompressFrame(frame, len);
      const theirs = decompress(frame);
      assert.ok(Buffer.from(ours).equals(Buffer.from(theirs)), `${path.basename(file)}: a section differs from fzstd`);
      n++;
    }
  }
  assert.ok(n > 20);
});

test('damaged frames: a message string or exactly the stated length', () => {
  const frames = [];
  for (const [name, bytes] of Object.entries(zstdInputs())) {
    if (bytes.length === 0 || name === 'random') continue;
    frames.push([new Uint8Array(readFileSync(path.join(fixtures, `${name}.l19.zst`))), bytes.length]);
  }
  frames.push(...sections(new Uint8Array(readFileSync(path.join(here, 'data/spot.pqm')))).slice(0, 4));
  let seed = 99;
  const rand = () => ((seed = (seed * 1103515245 + 12345) >>> 0) >>> 8);
  let errors = 0;
  for (let it = 0; it < 3000; it++) {
    const [frame, len] = frames[it % frames.length];
    const bad = frame.slice();
    // past the frame header: flip 1 to 3 bytes of the blocks
    for (let k = 1 + (rand() % 3); k > 0; k--) {
      const at = 9 + (rand() % (bad.length - 9));
      bad[at] ^= 1 + (rand() % 255);
    }
    try {
      const out = decompressFrame(bad, len);
      assert.equal(out.length, len);
    } catch (e) {
      assert.equal(typeof e, 'string', `a damaged frame throws a message, not ${e}`);
      errors++;
    }
  }
  assert.ok(errors > 1500, `${errors} of 3000 damaged frames rejected`);
});

test('a frame that decodes to more or fewer bytes than it states is an error', () => {
  // single-segment frame stating `stated` bytes, blocks as given
  const frame = (stated, blocks) => Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0x20, stated, ...blocks);
  const raw = (n, last) => [(n << 3) | last, n >> 5, n >> 13, ...Array.from({ length: n }, (_, k) => k)];
  const rle = (n, last) => [(n << 3) | 2 | last, n >> 5, n >> 13, 9];
  assert.deepEqual([...decompressFrame(frame(5, raw(5, 1)), 5)], [0, 1, 2, 3, 4]);
  assert.deepEqual([...decompressFrame(frame(7, [...raw(3, 0), ...rle(4, 1)]), 7)], [0, 1, 2, 9, 9, 9, 9]);
  const msg = (re) => (e) => typeof e === 'string' && re.test(e);
  assert.throws(() => decompressFrame(frame(6, raw(5, 1)), 6), msg(/decodes to 5 bytes, expected 6/));
  assert.throws(() => decompressFrame(frame(6, [...raw(3, 0), ...rle(4, 1)]), 6), msg(/more than 6 bytes/));
  // a compressed block of n raw literals and no sequences, in a frame with
  // a 1 KiB window stating `stated` (≥ 256) bytes
  const frame2 = (stated, blocks) => Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0x40, 0, (stated - 256) & 255, (stated - 256) >> 8, ...blocks);
  const lits = (n) => [((n + 3) << 3) | 4 | 1, (n + 3) >> 5, 0, 4 | ((n & 15) << 4), n >> 4, ...Array.from({ length: n }, () => 42), 0];
  assert.deepEqual([...decompressFrame(frame2(300, lits(300)), 300)], Array(300).fill(42));
  assert.throws(() => decompressFrame(frame2(301, lits(300)), 301), msg(/decodes to 300 bytes, expected 301/));
  assert.throws(() => decompressFrame(frame2(299, lits(300)), 299), msg(/more than 299 bytes/));
});
