// The vertex-order sections of spec §8: VORD (3.0, deltas) and VNBR (3.1,
// coded against the finest level's adjacency), mirroring the Rust tests
// (crates/pqm-format/tests/vertex_order.rs): every file's order matches its
// JSON digest (the Rust decoder's), whatever level the caller is at and
// however the bytes come; each reject rule of §8.2 as a hand-made section
// (the payload's rules when the order is first read: the levels stay usable,
// spec §8).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError, decodeAll, estimateMemory } from '../src/index.js';
import { testFiles, fnv1a64, randomPieces, rng, varint, svarint } from './helpers.mjs';
import { unpack, pack, setHeader } from './repack.mjs';

const files = testFiles();
const byName = Object.fromEntries(files.map((f) => [f.name, f]));
const orderDigest = (o) => fnv1a64(new Uint8Array(o.buffer, o.byteOffset, o.byteLength));

function throwsPqm(fn, fields, what) {
  let err = null;
  try {
    fn();
  } catch (e) {
    err = e;
  }
  assert.ok(err instanceof PqmError, `${what}: expected a PqmError, got ${err && err.stack}`);
  for (const [k, v] of Object.entries(fields)) {
    if (k === 'message') assert.match(err.message, v, what);
    else assert.equal(err[k], v, `${what}: ${k} (message: ${err.message})`);
  }
  return err;
}

test('box_vnbr is a 3.1 file with a VNBR section, box_vord a VORD one', () => {
  const v = decodeAll(byName.box_vnbr.bytes);
  assert.deepEqual([v.header.versionMajor, v.header.versionMinor, v.header.flags], [3, 1, 2]);
  assert.equal(unpack(byName.box_vnbr.bytes).sections[0].tag, 'VNBR');
  assert.equal(unpack(byName.box_vord.bytes).sections[0].tag, 'VORD');
  // the vector exercises all three kinds of symbols
  const p = unpack(byName.box_vnbr.bytes).sections[0].payload;
  const n = v.header.finalVertexCount;
  const syms = p.subarray(0, n);
  assert.ok(syms.some((s) => s === 254), 'base-vertex symbol');
  assert.ok(syms.some((s) => s === 255), 'escape');
  assert.ok(syms.some((s) => s < 254), 'candidate');
});

for (const file of files) {
  if (!file.digest.vertex_order_fnv1a64) continue;
  test(`${file.name}: the vertex order matches its digest, whole, in pieces and from a coarse level`, () => {
    const whole = decodeAll(file.bytes);
    assert.equal(orderDigest(whole.vertexOrder), file.digest.vertex_order_fnv1a64);
    for (const [how, pieces] of [
      ['pieces of 1..50 bytes', randomPieces(file.bytes, rng(3), 50)],
      ['one byte at a time', randomPieces(file.bytes, () => 0, 1)],
    ]) {
      const d = new PqmDecoder();
      for (const piece of pieces) {
        for (const e of d.push(piece)) {
          // stay at level 0 while the rest arrives
          if (e.type === 'baseMeshReady') d.setLevel({ level: 0 });
        }
      }
      d.end();
      assert.equal(d.level, 0, how);
      assert.equal(orderDigest(d.vertexOrder), file.digest.vertex_order_fnv1a64, how);
    }
    // forward-only, one byte at a time: the order read after the end, twice
    const f = new PqmDecoder({ forwardOnly: true });
    for (const piece of randomPieces(file.bytes, () => 0, 1)) f.push(piece);
    f.end();
    assert.equal(orderDigest(f.vertexOrder), file.digest.vertex_order_fnv1a64, 'forward-only');
    assert.equal(f.vertexOrder, f.vertexOrder, 'cached');
  });
}

/** box_vnbr with its VNBR payload replaced (flags, other sections as given). */
function withVnbr(payload, { flags = 2, sections = null } = {}) {
  const parts = unpack(byName.box_vnbr.bytes);
  parts.sections = sections ?? [{ tag: 'VNBR', payload: Uint8Array.from(payload) }];
  setHeader(parts, 16, 'Uint32', flags);
  setHeader(parts, 48, 'Uint32', parts.sections.length);
  return pack(parts);
}

test('hand-made VNBR sections breaking each rule of spec §8.2 are rejected', () => {
  const good = unpack(byName.box_vnbr.bytes).sections[0].payload;
  const h = decodeAll(byName.box_vnbr.bytes).header;
  const n = h.finalVertexCount;
  const base = h.baseVertexCount;
  const S = 'optional section 0 ("VNBR")';
  // the repacker alone keeps it valid
  assert.equal(orderDigest(decodeAll(withVnbr(good)).vertexOrder), byName.box_vnbr.digest.vertex_order_fnv1a64);
  // a bad payload: the file decodes, every level is reachable, and reading
  // the order throws, on every read, in both modes
  const reject = (payload, message, what) => {
    const bytes = withVnbr(payload);
    for (const forwardOnly of [false, true]) {
      const d = new PqmDecoder({ forwardOnly });
      d.push(bytes);
      d.end();
      assert.ok(d.status().finished, what);
      const levels = forwardOnly ? [d.finalLevel] : [d.finalLevel, 0, d.finalLevel];
      for (let i = 0; i < 2; i++) throwsPqm(() => d.vertexOrder, { kind: 'invalid', section: S, message }, what);
      for (const level of levels) {
        d.setLevel({ level });
        assert.equal(d.level, level, what);
      }
    }
  };
  // bounds checked when the section arrives: the push throws, naming it
  const rejectEarly = (payload, message, what) =>
    throwsPqm(() => decodeAll(withVnbr(payload)), { kind: 'invalid', section: S, message }, what);
  reject([0, ...good.subarray(1)], /list has 0 candidates/, 'symbol past the list');
  reject(new Array(n).fill(254), /no base vertex is left/, 'symbol 254 with no base vertex left');
  const escapes = [...new Array(base).fill(254), ...new Array(n - base).fill(255)];
  reject([...escapes, ...svarint(n)], /rank/, 'rank too large');
  reject([...escapes, ...svarint(-1)], /rank/, 'negative rank');
  reject(escapes, /ends/, 'ranks missing');
  reject([255, ...new Array(n - 1).fill(0), ...varint(0)], /which symbol 254 names/, 'escape naming the base vertex');
  reject([...good, 0], /unused bytes/, 'bytes left over');
  // uncompressed length outside n..=11n, before decompressing: the repacker
  // states the real length, so shorten or pad the payload itself
  rejectEarly(good.subarray(0, n - 1), /uncompressed length/, 'fewer than n bytes');
  rejectEarly(new Uint8Array(11 * n + 1), /uncompressed length/, 'more than 11 n bytes');
});

test('VNBR and the header flags: bit 1 iff the section, at most one VORD or VNBR', () => {
  const vnbr = unpack(byName.box_vnbr.bytes).sections[0];
  const vord = unpack(byName.box_vord.bytes).sections[0]; // another file's: rejected before it is decoded
  const cases = [
    [0, [vnbr], /flag bit 1 is clear/],
    [1, [vnbr], /flag bit 1 is clear/],
    [2, [vnbr, vnbr], /second vertex-order section/],
    [3, [vnbr, { ...vord, tag: 'VORD' }], /second vertex-order section/],
  ];
  for (const [flags, sections, message] of cases) {
    throwsPqm(() => decodeAll(withVnbr(null, { flags, sections })), { kind: 'invalid', message }, `flags ${flags}`);
  }
  for (const [flags, sections] of [
    [2, []],
    [3, [vnbr]],
  ]) {
    throwsPqm(() => decodeAll(withVnbr(null, { flags, sections })), { kind: 'invalid', section: 'trailer', message: /announces/ }, `flags ${flags}`);
  }
  // a 3.0 reader's view: the tag unknown, the file valid without an order
  const d = decodeAll(withVnbr(null, { flags: 0, sections: [{ ...vnbr, tag: 'XNBR' }] }));
  assert.equal(d.vertexOrder, null);
});

test('random VNBR payloads never crash: a PqmError or a permutation', () => {
  const n = decodeAll(byName.box_vnbr.bytes).header.finalVertexCount;
  const rand = rng(11);
  for (let i = 0; i < 300; i++) {
    const len = n + Math.floor(rand() * 40);
    const p = new Uint8Array(len);
    for (let k = 0; k < len; k++) {
      const x = Math.floor(rand() * 256);
      p[k] = k < n && x < 250 ? x % 6 : x;
    }
    try {
      const o = decodeAll(withVnbr(p)).vertexOrder;
      assert.equal(new Set(o).size, n);
    } catch (e) {
      assert.ok(e instanceof PqmError, e.stack);
    }
  }
});

test('the vertex-order section counts against the memory budget, as in Rust', () => {
  for (const name of ['box_vnbr', 'box_vord']) {
    const whole = decodeAll(byName[name].bytes);
    const h = whole.header;
    const payload = h.baseUncompressedLen + whole.chunks.reduce((a, c) => a + c.uncompressedLen, 0);
    const before = estimateMemory(h.finalVertexCount, h.finalFaceCount, h.recordCount, payload);
    const d = new PqmDecoder({ limits: { maxMemoryBytes: before } });
    throwsPqm(() => d.push(byName[name].bytes), { kind: 'limits', message: new RegExp(`${name === 'box_vnbr' ? 'VNBR' : 'VORD'} section`) }, name);
    assert.equal(d.deepestLevel, d.finalLevel, `${name}: every chunk decoded`);
    const roomy = new PqmDecoder({ limits: { maxMemoryBytes: before + 1e6 } });
    roomy.push(byName[name].bytes);
    assert.ok(roomy.vertexOrder);
  }
});
