// Hostile and damaged input: CRC errors name the section or chunk (and the
// levels decoded before stay usable), structural errors name the section,
// record errors name the chunk and record, limits are checked before
// anything is allocated, and no input makes the decoder throw anything but
// a PqmError.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError, decodeAll } from '../src/index.js';
import { testFiles, levelDigests, rng } from './helpers.mjs';
import { unpack, pack, setHeader, setEntry, rawZstdFrame, concat } from './repack.mjs';

const files = testFiles();
const byName = Object.fromEntries(files.map((f) => [f.name, f]));

/** Asserts that `fn` throws a PqmError with the given fields; returns it. */
function throwsPqm(fn, fields, what) {
  let err = null;
  try {
    fn();
  } catch (e) {
    err = e;
  }
  assert.ok(err instanceof PqmError, `${what}: expected a PqmError, got ${err}`);
  for (const [k, v] of Object.entries(fields)) {
    if (k === 'message') assert.match(err.message, v, what);
    else assert.equal(err[k], v, `${what}: ${k} (message: ${err.message})`);
  }
  return err;
}

const flip = (bytes, at) => {
  const b = bytes.slice();
  b[at] ^= 0x10;
  return b;
};

for (const file of files) {
  test(`${file.name}: a flipped byte in each section is a CRC error naming it`, () => {
    const whole = decodeAll(file.bytes);
    const h = whole.header;
    const tableStart = h.headerLen;
    const baseStart = h.headerLen + h.chunkCount * h.chunkEntryLen + 4;
    throwsPqm(() => decodeAll(flip(file.bytes, 30)), { kind: 'crc', section: 'header' }, 'header');
    throwsPqm(() => decodeAll(flip(file.bytes, tableStart + 3)), { kind: 'crc', section: 'chunk table' }, 'table');
    throwsPqm(() => decodeAll(flip(file.bytes, baseStart + 7)), { kind: 'crc', section: 'base mesh' }, 'base');
    const reference = [];
    for (const c of whole.chunks) {
      whole.setLevel({ level: c.level });
      reference.push(JSON.stringify(levelDigests(whole)));
    }
    for (const c of whole.chunks) {
      for (const at of [c.offset, c.offset + (c.compressedLen >> 1), c.end - 1]) {
        const bad = flip(file.bytes, at);
        const d = new PqmDecoder();
        const e = throwsPqm(() => d.push(bad), { kind: 'crc', section: `chunk ${c.index}`, chunk: c.index }, `chunk ${c.index}`);
        assert.match(e.message, new RegExp(`CRC mismatch in chunk ${c.index}\\b`));
        // what came before is usable, and the failed call reported its events
        const before = c.index === 0 ? 0 : whole.chunks[c.index - 1].level;
        assert.equal(d.deepestLevel, before);
        assert.equal(e.events.filter((x) => x.type === 'chunkReady').length, c.index);
        if (c.index > 0) {
          d.setLevel({ level: before });
          assert.equal(JSON.stringify(levelDigests(d)), reference[c.index - 1]);
        }
        const s = d.status();
        assert.equal(s.failed, true);
        assert.equal(s.error, e);
        throwsPqm(() => d.push(new Uint8Array(1)), { kind: 'failed' }, 'push after failure');
      }
    }
    // optional sections
    let p = whole.chunks.length ? whole.chunks.at(-1).end : baseStart + h.baseCompressedLen;
    for (let i = 0; i < h.sectionCount; i++) {
      const clen = new DataView(file.bytes.buffer, file.bytes.byteOffset).getUint32(p + 4, true);
      const tag = String.fromCharCode(...file.bytes.subarray(p, p + 4)); // VORD or VNBR
      throwsPqm(() => decodeAll(flip(file.bytes, p + 16)), { kind: 'crc', section: `optional section ${i} ("${tag}")` }, tag);
      p += 16 + clen;
    }
  });
}

test('not a .pqm file, another major version, a bad header length', () => {
  const b = byName.grid_small.bytes;
  throwsPqm(() => decodeAll(new TextEncoder().encode('v 0 0 0\nv 1 0 0\nf 1 2 3\n' + ' '.repeat(20))), { kind: 'bad-magic' }, 'OBJ text');
  // majors 1, 2, 3 and 4 are read (spec §9); 5 is not (the CRC is not even looked at)
  const v5 = b.slice();
  v5[8] = 5;
  throwsPqm(() => decodeAll(v5), { kind: 'unsupported-version', message: /version 5\.\d/ }, 'v5');
  for (const major of [1, 2, 3, 4]) {
    const p = unpack(b);
    setHeader(p, 8, 'Uint16', major);
    const d = new PqmDecoder();
    d.push(pack(p).subarray(0, 200));
    assert.equal(d.header.versionMajor, major, `version ${major} is read`);
    assert.equal(d.status().failed, false);
  }
  const hl = b.slice();
  new DataView(hl.buffer).setUint32(12, 100000, true);
  throwsPqm(() => decodeAll(hl), { kind: 'invalid', section: 'header', message: /header_len 100000/ }, 'header_len');
  // an error is reported as soon as the 16-byte prefix is in, not at the end
  const d = new PqmDecoder();
  throwsPqm(() => d.push(v5.subarray(0, 16)), { kind: 'unsupported-version' }, 'prefix only');
});

test('bytes after the end, and a truncated file at end()', () => {
  const b = byName.box_vord.bytes;
  throwsPqm(() => decodeAll(concat([b, Uint8Array.of(0)])), { kind: 'invalid', section: 'trailer' }, 'trailer');
  throwsPqm(() => decodeAll(b.subarray(0, b.length - 1)), { kind: 'truncated', message: /optional section 0/ }, 'truncated');
  throwsPqm(() => decodeAll(b.subarray(0, 10)), { kind: 'truncated', message: /header/ }, 'truncated header');
});

test('limits are checked against the header and table before allocating', () => {
  const b = byName.spot.bytes;
  const h = decodeAll(b).header;
  throwsPqm(() => decodeAll(b, { limits: { maxVertices: h.finalVertexCount - 1 } }), { kind: 'limits', message: /vertices/ }, 'vertices');
  throwsPqm(() => decodeAll(b, { limits: { maxFaces: h.finalFaceCount - 1 } }), { kind: 'limits', message: /faces/ }, 'faces');
  throwsPqm(() => decodeAll(b, { limits: { maxMemoryBytes: 100000 } }), { kind: 'limits', message: /memory/ }, 'memory');
  decodeAll(b, { limits: { maxVertices: h.finalVertexCount, maxFaces: h.finalFaceCount } });
  // a header claiming 2^32-1 vertices: refused at once (default limits)
  const parts = unpack(byName.grid_small.bytes);
  setHeader(parts, 32, 'Uint32', 0xffffffff);
  const d = new PqmDecoder();
  const prefix = pack(parts).subarray(0, 120);
  throwsPqm(() => d.push(prefix), { kind: 'limits' }, 'huge claim');
});

test('structural checks of the header and the chunk table name the field', () => {
  const base = byName.box_vord;
  const cases = [
    [(p) => setHeader(p, 20, 'Uint8', 7), 'header', /quantization bits 7/],
    [(p) => setHeader(p, 20, 'Uint8', 25), 'header', /quantization bits 25/],
    [(p) => setHeader(p, 64, 'Float64', NaN), 'header', /bounding box axis 0/],
    [(p) => setHeader(p, 96, 'Float64', -1e300), 'header', /bounding box axis 1/],
    [(p) => setHeader(p, 88, 'Float64', 1.7e308).header && setHeader(p, 64, 'Float64', -1.7e308), 'header', /bounding box axis 0/],
    [(p) => setHeader(p, 24, 'Uint32', 1000), 'header', /base counts/],
    [(p) => setHeader(p, 44, 'Uint32', 0), 'header', /chunks cannot hold/],
    [(p) => setHeader(p, 112, 'Float32', -1), 'header', /base error/],
    [(p) => setEntry(p, 1, 16, 'Uint32', 0), 'chunk table', /chunk 1 has no records/],
    [(p) => setEntry(p, 0, 16, 'Uint32', 11), 'chunk table', /records/],
    [(p) => setEntry(p, 1, 20, 'Uint32', 1), 'chunk table', /decrease/],
    [(p) => setEntry(p, 2, 28, 'Float32', 1e30), 'chunk table', /chunk 2 error/],
    [(p) => setEntry(p, 4, 24, 'Uint32', 1e6), 'chunk table', /header says/],
    [(p) => setEntry(p, 3, 24, 'Uint32', 1e6), 'chunk table', /chunk 4 vertex\/face counts decrease/],
  ];
  for (const [edit, section, message] of cases) {
    const parts = unpack(base.bytes);
    edit(parts);
    throwsPqm(() => decodeAll(pack(parts)), { kind: 'invalid', section, message }, `${message}`);
  }
  // a chunk whose stated counts differ from what its records reach
  const parts = unpack(base.bytes);
  setEntry(parts, 0, 20, 'Uint32', new DataView(parts.entries[0].buffer).getUint32(20, true) + 1);
  setEntry(parts, 1, 20, 'Uint32', new DataView(parts.entries[1].buffer).getUint32(20, true) + 1);
  throwsPqm(() => decodeAll(pack(parts)), { kind: 'invalid', section: 'chunk 0', message: /the chunk table says/ }, 'counts');
});

test('zstd frames: content size required and equal, window at most 2^25', () => {
  const parts = unpack(byName.grid_small.bytes);
  // a frame with a 2^26 window
  const big = (payload) => rawZstdFrame(payload, { windowDescriptor: (16 << 3) });
  throwsPqm(() => decodeAll(pack(parts, { frame: big })), { kind: 'invalid', section: 'base mesh', message: /window/ }, 'window');
  // 2^25 is fine
  const ok = (payload) => rawZstdFrame(payload, { windowDescriptor: (15 << 3) });
  decodeAll(pack(parts, { frame: ok }));
  // content size that differs from the stated length
  const lying = (payload) => {
    const f = rawZstdFrame(payload);
    new DataView(f.buffer).setUint32(5, payload.length + 1, true);
    return f;
  };
  throwsPqm(() => decodeAll(pack(parts, { frame: lying })), { kind: 'invalid', section: 'base mesh', message: /content size/ }, 'fcs');
  // a frame that decodes to fewer bytes than it states
  const short = (payload) => {
    const f = rawZstdFrame(payload.subarray(0, payload.length - 1));
    new DataView(f.buffer).setUint32(5, payload.length, true);
    return f;
  };
  throwsPqm(() => decodeAll(pack(parts, { frame: short })), { kind: 'invalid', section: 'base mesh', message: /decodes to/ }, 'short');
  // not zstd at all
  const junk = (payload) => concat([Uint8Array.of(1, 2, 3, 4, 5, 6), payload]);
  throwsPqm(() => decodeAll(pack(parts, { frame: junk })), { kind: 'invalid', section: 'base mesh', message: /zstd/ }, 'junk');
});

test('bad records name the chunk and the record', () => {
  const f = byName.general_bits8;
  const whole = decodeAll(f.bytes);
  const c = whole.chunks[1];
  const parts = unpack(f.bytes);
  // the ops stream starts after its length varint: make record 0 of chunk 1
  // a form-0 symbol with bit 5 set (invalid in every version)
  const payload = parts.chunks[1];
  assert.ok(payload[0] > 0 && payload[0] < 128);
  payload[1] = 0x20;
  const e = throwsPqm(() => decodeAll(pack(parts)), { kind: 'bad-record', chunk: 1, record: whole.chunks[0].level }, 'symbol 0x20');
  assert.match(e.message, new RegExp(`bad record ${whole.chunks[0].level} in chunk 1: general-form symbol 0x20 has bits 4-7 set`));
  assert.equal(c.index, 1);
  // unused bytes after the last stream
  const p2 = unpack(f.bytes);
  p2.chunks[0] = concat([p2.chunks[0], Uint8Array.of(0)]);
  throwsPqm(() => decodeAll(pack(p2)), { kind: 'invalid', section: 'chunk 0', message: /after the fifth stream/ }, 'extra');
  // base payload with an extra byte
  const p3 = unpack(f.bytes);
  p3.base = concat([p3.base, Uint8Array.of(0)]);
  throwsPqm(() => decodeAll(pack(p3)), { kind: 'invalid', section: 'base mesh', message: /unused bytes/ }, 'base extra');
});

test('random damage to payloads, table and header: only PqmErrors, never a crash', () => {
  const rand = rng(99);
  const pick = (n) => Math.floor(rand() * n);
  let rejected = 0;
  let accepted = 0;
  for (let n = 0; n < 400; n++) {
    const f = files[pick(files.length)];
    const parts = unpack(f.bytes);
    const all = [parts.base, ...parts.chunks];
    const i = pick(all.length);
    const p = all[i];
    for (let k = 0; k < 1 + pick(3); k++) p[pick(p.length)] = pick(4) === 0 ? pick(256) : (p[pick(p.length)] + 1) & 0xff;
    const bytes = pack(parts);
    try {
      const d = decodeAll(bytes);
      d.setLevel({ level: d.deepestLevel });
      // whatever decodes is a well-formed mesh
      const q = d.quads;
      for (let s = 0; s < q.length; s++) assert.ok(q[s] < d.vertexCount);
      accepted++;
    } catch (e) {
      assert.ok(e instanceof PqmError, `mutation ${n} of ${f.name}: ${e && e.stack}`);
      assert.ok(e.section, `mutation ${n}: the error names a section (${e.message})`);
      rejected++;
    }
  }
  assert.ok(rejected > 100, `most damage is detected (${rejected} rejected, ${accepted} accepted)`);
});

test('a chunk that fails after some of its records leaves the previous level exact, positions included', () => {
  // The records of a failed chunk are rolled back on the frontier, which
  // the move to the deepest level reads (codes, positions, quads): its
  // codes must go back exactly. Damage inside the last chunk's streams,
  // both decoders.
  const rand = rng(7);
  let checked = 0;
  for (const f of files) {
    const clean = decodeAll(f.bytes);
    if (clean.chunks.length < 2) continue;
    for (const forwardOnly of [false, true]) {
      for (let tries = 0; tries < 40; tries++) {
        const parts = unpack(f.bytes);
        const last = parts.chunks.length - 1;
        const p = parts.chunks[last];
        p[Math.floor(p.length / 4 + rand() * ((3 * p.length) / 4))] ^= 1 + Math.floor(rand() * 255);
        const d = new PqmDecoder({ forwardOnly });
        let err = null;
        try {
          d.push(pack(parts));
          d.end();
        } catch (e) {
          err = e;
        }
        if (!(err instanceof PqmError) || err.kind !== 'bad-record') continue;
        d.setLevel({ level: d.deepestLevel });
        clean.setLevel({ level: d.deepestLevel });
        const what = `${f.name}${forwardOnly ? ' (forward-only)' : ''}: ${err.message}`;
        assert.deepEqual(levelDigests(d), levelDigests(clean), what);
        assert.deepEqual([...d.positions], [...clean.positions], what);
        checked++;
        break;
      }
    }
  }
  assert.ok(checked >= 4, `damaged chunks checked: ${checked}`);
});
