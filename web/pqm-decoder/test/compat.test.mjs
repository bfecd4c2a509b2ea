// Files the reference writer does not produce but the spec allows: no
// records, an empty mesh, unknown optional sections (skipped), and a newer
// minor version with a longer header and longer chunk table entries (the
// extra bytes ignored, spec §9).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decodeAll } from '../src/index.js';
import { testFiles, levelDigests } from './helpers.mjs';
import { unpack, pack, setHeader } from './repack.mjs';

const grid = testFiles().find((f) => f.name === 'grid_small');
const levels = grid.digest.levels;
const want = (l) => ({ positions: l.positions_fnv1a64, quads: l.quads_fnv1a64 });

function finest(bytes) {
  const d = decodeAll(bytes);
  d.setLevel({ level: d.deepestLevel });
  return { d, g: levelDigests(d) };
}

test('a file without records is its base mesh', () => {
  const p = unpack(grid.bytes);
  p.chunks = [];
  p.entries = [];
  setHeader(p, 32, 'Uint32', 16).header;
  setHeader(p, 36, 'Uint32', 9);
  setHeader(p, 40, 'Uint32', 0);
  setHeader(p, 44, 'Uint32', 0);
  const { d, g } = finest(pack(p));
  assert.equal(d.deepestLevel, 0);
  assert.deepEqual(g, want(levels[0]));
  assert.equal(d.vertexOrder, null, 'a VORD of the final (= base) count would be checked, none here');
});

test('an empty mesh', () => {
  const p = unpack(grid.bytes);
  p.chunks = [];
  p.entries = [];
  p.sections = [];
  p.base = new Uint8Array(0);
  for (const o of [16, 24, 28, 32, 36, 40, 44, 48]) setHeader(p, o, 'Uint32', 0);
  const { d, g } = finest(pack(p));
  assert.equal(d.vertexCount, 0);
  assert.equal(d.faceCount, 0);
  assert.deepEqual(g, { positions: 'cbf29ce484222325', quads: 'cbf29ce484222325' });
});

test('unknown optional sections are skipped (after their CRC)', () => {
  const p = unpack(grid.bytes);
  p.sections = [{ tag: 'XTRA', payload: Uint8Array.of(1, 2, 3) }, { tag: 'ZZZZ', payload: new Uint8Array(0) }];
  setHeader(p, 48, 'Uint32', 2);
  const bytes = pack(p);
  const { d, g } = finest(bytes);
  assert.deepEqual(g, want(levels.at(-1)));
  assert.equal(d.status().finished, true);
});

test('a newer minor version: longer header and chunk entries, extra bytes ignored', () => {
  const p = unpack(grid.bytes);
  const h = new Uint8Array(136);
  h.set(p.header.subarray(0, 116));
  const dv = new DataView(h.buffer);
  dv.setUint16(10, 7, true); // version 1.7
  dv.setUint32(12, 136, true);
  dv.setUint32(16, dv.getUint32(16, true) | 0x80, true); // an unknown flag bit
  h.fill(0xab, 116, 132);
  p.header = h;
  setHeader(p, 22, 'Uint16', 44);
  p.entries = p.entries.map((e) => {
    const x = new Uint8Array(44).fill(0xcd);
    x.set(e);
    return x;
  });
  const { d, g } = finest(pack(p));
  assert.equal(d.header.versionMinor, 7);
  assert.equal(d.header.chunkEntryLen, 44);
  assert.deepEqual(g, want(levels.at(-1)));
});
