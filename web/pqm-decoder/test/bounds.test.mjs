// The header's bounds (spec §3, flag bit 2, version 3.2), on files made from
// grid_small by lengthening its header to 168 bytes (`withBounds`: the
// payloads stay byte for byte, the table offsets and CRCs are redone): they
// are read and exposed, decoding is unchanged, bad bounds are refused, and a
// file without them gets the grid box.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError, decodeAll } from '../src/index.js';
import { testFiles, levelDigests, positionBounds, randomPieces, rng } from './helpers.mjs';
import { withBounds } from './repack.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const plain = decodeAll(grid.bytes);
const [exactMin, exactMax] = positionBounds(plain);

/** Asserts that decoding `bytes` fails with an invalid-header error matching `message`. */
function refused(bytes, message, what) {
  let err = null;
  try {
    decodeAll(bytes);
  } catch (e) {
    err = e;
  }
  assert.ok(err instanceof PqmError, `${what}: expected a PqmError, got ${err}`);
  assert.equal(err.kind, 'invalid', `${what}: ${err.message}`);
  assert.equal(err.section, 'header', `${what}: ${err.message}`);
  assert.match(err.message, message, what);
}

test('a file without flag bit 2: bounds are copies of the grid box, hasBounds false', () => {
  const h = plain.header;
  assert.equal(h.flags & 4, 0);
  assert.equal(h.hasBounds, false);
  assert.deepEqual(h.boundsMin, h.bboxMin);
  assert.deepEqual(h.boundsMax, h.bboxMax);
  assert.notEqual(h.boundsMin, h.bboxMin, 'a copy, not the same array');
  assert.notEqual(h.boundsMax, h.bboxMax, 'a copy, not the same array');
  // the grid holds every level (for grid_small, a box grid, it is the exact box up to rounding)
  for (let k = 0; k < 3; k++) {
    assert.ok(h.boundsMin[k] <= exactMin[k] && exactMax[k] <= h.boundsMax[k], `axis ${k}`);
  }
});

test('a 168-byte header with bounds decodes to the same levels and exposes them', () => {
  const bytes = withBounds(grid.bytes, exactMin, exactMax);
  assert.equal(bytes.length, grid.bytes.length + 48);
  const d = decodeAll(bytes);
  const h = d.header;
  assert.equal(h.headerLen, 168);
  assert.equal(h.versionMajor, 3);
  assert.equal(h.versionMinor, 2);
  assert.equal(h.flags & 4, 4);
  assert.equal(h.hasBounds, true);
  assert.deepEqual(h.boundsMin, exactMin);
  assert.deepEqual(h.boundsMax, exactMax);
  assert.deepEqual(h.bboxMin, plain.header.bboxMin);
  assert.deepEqual(h.bboxMax, plain.header.bboxMax);
  assert.equal(h.hasVertexOrder, plain.header.hasVertexOrder);
  assert.equal(d.chunks[0].offset, plain.chunks[0].offset + 48);
  assert.equal(d.deepestLevel, grid.digest.final_level);
  for (const l of grid.digest.levels) {
    d.setLevel({ level: l.level });
    assert.deepEqual(levelDigests(d), { positions: l.positions_fnv1a64, quads: l.quads_fnv1a64 }, `level ${l.level}`);
  }
  // the same, byte by byte and in small pieces (the header arrives in parts)
  for (const [how, pieces] of [
    ['one byte at a time', randomPieces(bytes, () => 0, 1)],
    ['pieces of 1..50 bytes', randomPieces(bytes, rng(7), 50)],
  ]) {
    const s = new PqmDecoder();
    for (const p of pieces) s.push(p);
    s.end();
    assert.deepEqual(s.header, h, how);
    s.setLevel({ level: d.level });
    assert.deepEqual(levelDigests(s), levelDigests(d), how);
  }
});

test('bounds are read as written: the decoder does not recompute them', () => {
  // (any finite box with min ≤ max passes the header checks; a writer must
  // write the exact one, spec §3)
  const min = [-1.5, 0, 2 ** -1074];
  const max = [-1.5, 1e300, 3];
  const h = decodeAll(withBounds(grid.bytes, min, max)).header;
  assert.deepEqual([h.boundsMin, h.boundsMax], [min, max]);
});

test('a longer header with bounds: bytes after them are ignored (a newer minor)', () => {
  const bytes = withBounds(grid.bytes, exactMin, exactMax, { headerLen: 200 });
  const d = decodeAll(bytes);
  assert.equal(d.header.headerLen, 200);
  assert.deepEqual([d.header.boundsMin, d.header.boundsMax], [exactMin, exactMax]);
  plain.setLevel({ level: plain.deepestLevel });
  d.setLevel({ level: d.deepestLevel });
  assert.deepEqual(levelDigests(d), levelDigests(plain));
});

test('flag bit 2 with a header shorter than 168 bytes is an invalid header', () => {
  refused(withBounds(grid.bytes, exactMin, exactMax, { headerLen: 120 }), /flag bit 2.*header_len 120 < 168/, '120');
  refused(withBounds(grid.bytes, exactMin, exactMax, { headerLen: 164 }), /flag bit 2.*header_len 164 < 168/, '164');
  // without the flag, a 168-byte header is a newer minor's: the bytes are ignored
  const d = decodeAll(withBounds(grid.bytes, [NaN, NaN, NaN], [0, 0, 0], { flag: false }));
  assert.equal(d.header.hasBounds, false);
  assert.deepEqual(d.header.boundsMin, d.header.bboxMin);
  assert.deepEqual(d.header.boundsMax, d.header.bboxMax);
});

test('non-finite bounds and bounds_min > bounds_max are invalid headers naming the axis', () => {
  const cases = [
    ['NaN min', [0, NaN, 0], [1, 1, 1], /bounds axis 1 is \[NaN, 1\]/],
    ['NaN max', [0, 0, 0], [1, 1, NaN], /bounds axis 2 is \[0, NaN\]/],
    ['-inf min', [-Infinity, 0, 0], [1, 1, 1], /bounds axis 0 is \[-Infinity, 1\]/],
    ['+inf max', [0, 0, 0], [1, Infinity, 1], /bounds axis 1 is \[0, Infinity\]/],
    ['min > max', [0, 0, 2], [1, 1, 1], /bounds axis 2 is \[2, 1\]/],
    ['min > max by one ulp', [1 + 2 ** -52, 0, 0], [1, 1, 1], /bounds axis 0/],
  ];
  for (const [what, min, max, message] of cases) refused(withBounds(grid.bytes, min, max), message, what);
  // min = max is a flat box, allowed
  const h = decodeAll(withBounds(grid.bytes, [1, 2, 3], [1, 2, 3])).header;
  assert.deepEqual(h.boundsMax, [1, 2, 3]);
});
