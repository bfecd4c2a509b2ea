// The rules of spec §1, §3 and §8 that tie the pieces of a file together,
// mirroring the Rust decoder's tests (crates/pqm-format/tests/roundtrip.rs):
// - header flag bit 0 is set if and only if the file holds exactly one VORD
//   section (vord_flag_must_match_the_section);
// - a compressed section is exactly one zstd frame stating its content size
//   (a_compressed_section_is_exactly_one_frame_with_its_size);
// - a chunk's records become available all-or-nothing
//   (a_failing_record_discards_its_whole_chunk).
// Files are crafted with the test-only repacker (raw zstd frames, every
// length and CRC recomputed) so that only the rule under test is broken.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError, decodeAll } from '../src/index.js';
import { testFiles, levelDigests } from './helpers.mjs';
import { unpack, pack, setHeader, rawZstdFrame, concat } from './repack.mjs';

const byName = Object.fromEntries(testFiles().map((f) => [f.name, f]));

/** Runs `fn`, asserts it throws a PqmError with `fields`; returns the error. */
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

/** Digests of every level of a fully decoded file, from level 0 up. */
function allDigests(bytes) {
  const d = decodeAll(bytes);
  const out = [];
  for (let k = 0; k <= d.deepestLevel; k++) {
    d.setLevel({ level: k });
    out.push(JSON.stringify(levelDigests(d)));
  }
  return out;
}

const VORD_SECTION = 'optional section 0 ("VORD")';

test('the test files: box_vord has flag bit 0 and one VORD, grid_small neither', () => {
  const withV = decodeAll(byName.box_vord.bytes);
  assert.equal(withV.header.flags & 1, 1);
  assert.equal(withV.header.sectionCount, 1);
  assert.ok(withV.vertexOrder instanceof Uint32Array);
  const without = decodeAll(byName.grid_small.bytes);
  assert.equal(without.header.flags & 1, 0);
  assert.equal(without.header.sectionCount, 0);
  assert.equal(without.vertexOrder, null);
  // the repacker alone keeps them valid
  decodeAll(pack(unpack(byName.box_vord.bytes)));
  decodeAll(pack(unpack(byName.grid_small.bytes)));
});

test('a VORD section with header flag bit 0 clear is an error naming the section', () => {
  const f = byName.box_vord;
  const final = decodeAll(f.bytes).finalLevel;
  const parts = setHeader(unpack(f.bytes), 16, 'Uint32', 0);
  const d = new PqmDecoder();
  const e = throwsPqm(() => d.push(pack(parts)), { kind: 'invalid', section: VORD_SECTION, message: /flag bit 0 is clear/ }, 'flag clear');
  // every chunk before the section was decoded
  assert.equal(d.deepestLevel, final);
  assert.equal(e.events.filter((x) => x.type === 'finished').length, 0);
  assert.equal(d.status().finished, false);
  // the same section under an unknown tag is skipped: the file is valid
  const renamed = unpack(f.bytes);
  setHeader(renamed, 16, 'Uint32', 0);
  renamed.sections[0].tag = 'XORD';
  const ok = decodeAll(pack(renamed));
  assert.equal(ok.vertexOrder, null);
  assert.deepEqual(allDigests(pack(renamed)), allDigests(f.bytes));
});

test('header flag bit 0 without a VORD section is an error at the end of the file', () => {
  // no section at all: known only with the last byte
  const parts = setHeader(unpack(byName.grid_small.bytes), 16, 'Uint32', 1);
  const bytes = pack(parts);
  const d = new PqmDecoder();
  const final = decodeAll(byName.grid_small.bytes).finalLevel;
  d.push(bytes.subarray(0, bytes.length - 1));
  assert.equal(d.status().failed, false);
  const chunks = decodeAll(byName.grid_small.bytes).chunks;
  assert.equal(d.deepestLevel, chunks[chunks.length - 2].level);
  const e = throwsPqm(() => d.push(bytes.subarray(bytes.length - 1)), { kind: 'invalid', section: 'trailer', message: /flag bit 0 announces a VORD section/ }, 'flag set, no section');
  // the last chunk's event came with the failing call; every level stays usable
  assert.equal(e.events.filter((x) => x.type === 'chunkReady').length, 1);
  assert.equal(d.deepestLevel, final);
  assert.equal(d.status().finished, false);
  d.setLevel({ level: final });
  assert.equal(JSON.stringify(levelDigests(d)), allDigests(byName.grid_small.bytes)[final]);
  throwsPqm(() => decodeAll(bytes), { kind: 'invalid', section: 'trailer' }, 'decodeAll');
  // only an unknown section: the flag still announces a VORD that never comes
  const renamed = unpack(byName.box_vord.bytes);
  renamed.sections[0].tag = 'XORD';
  throwsPqm(() => decodeAll(pack(renamed)), { kind: 'invalid', section: 'trailer', message: /flag bit 0/ }, 'unknown section only');
});

test('a second VORD section is an error naming it', () => {
  const parts = unpack(byName.box_vord.bytes);
  parts.sections.push({ ...parts.sections[0] });
  setHeader(parts, 48, 'Uint32', 2);
  const d = new PqmDecoder();
  const e = throwsPqm(() => d.push(pack(parts)), { kind: 'invalid', section: 'optional section 1 ("VORD")', message: /second vertex-order section \(VORD/ }, 'two VORDs');
  // the first one was read and reported
  assert.equal(e.events.filter((x) => x.type === 'sectionReady').length, 1);
  assert.ok(d.vertexOrder instanceof Uint32Array);
  // an unknown section next to the VORD is fine
  const p2 = unpack(byName.box_vord.bytes);
  p2.sections.push({ tag: 'XTRA', payload: Uint8Array.of(1, 2, 3) });
  setHeader(p2, 48, 'Uint32', 2);
  decodeAll(pack(p2));
});

// ---- one zstd frame per section --------------------------------------------

/** A zstd frame without the content size field (window descriptor instead). */
function frameWithoutSize(payload) {
  const f = rawZstdFrame(payload, { windowDescriptor: 15 << 3 });
  // FHD 0x80 (4-byte size) → 0x00 (no size); drop the 4 size bytes
  return concat([Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0x00, f[5]), f.subarray(10)]);
}

/** A skippable frame holding `n` zero bytes. */
function skippable(n) {
  const h = Uint8Array.of(0x50, 0x2a, 0x4d, 0x18, n & 0xff, (n >> 8) & 0xff, 0, 0);
  return concat([h, new Uint8Array(n)]);
}

/** Bad framings of a payload, each with the message it must produce. */
const badFrames = [
  ['an empty frame after the frame', /\d+ bytes after the zstd frame/, (p) => concat([rawZstdFrame(p), rawZstdFrame(new Uint8Array(0))])],
  ['3 zero bytes after the frame', /3 bytes after the zstd frame/, (p) => concat([rawZstdFrame(p), new Uint8Array(3)])],
  ['no content size', /lacks the content size/, frameWithoutSize],
  [
    // their sizes add up to the stated length: zstd alone would decode both
    'two frames of half the payload each',
    /bytes after the zstd frame/,
    (p) => concat([rawZstdFrame(p.subarray(0, p.length >> 1)), rawZstdFrame(p.subarray(p.length >> 1))]),
  ],
  ['a frame of one byte more', /zstd frame holds \d+ bytes.*the file states/, (p) => rawZstdFrame(concat([p, Uint8Array.of(0)]))],
  ['a skippable frame first', /skippable/, (p) => concat([skippable(5), rawZstdFrame(p)])],
  ['a skippable frame after', /bytes after the zstd frame/, (p) => concat([rawZstdFrame(p), skippable(0)])],
  ['the last block cut short', /truncated/, (p) => rawZstdFrame(p).subarray(0, 9 + p.length)],
  ['a block of the reserved type', /reserved type/, (p) => {
    const f = rawZstdFrame(p);
    f[9] |= 6; // first block header: type 3
    return f;
  }],
];

/**
 * Packs `parts` with `bad` framing only the payload `target` (the others
 * in valid raw frames); the stated uncompressed length stays the payload's.
 */
function packWith(parts, target, bad) {
  return pack(parts, { frame: (p) => (p === target ? bad(p) : rawZstdFrame(p)) });
}

test('a compressed chunk is exactly one zstd frame with its content size', () => {
  const f = byName.mixed_bits24;
  const whole = decodeAll(f.bytes);
  const level1 = whole.chunks[0].level;
  for (const [what, message, bad] of badFrames) {
    const parts = unpack(f.bytes);
    const bytes = packWith(parts, parts.chunks[1], bad);
    const d = new PqmDecoder();
    throwsPqm(() => d.push(bytes), { kind: 'invalid', section: 'chunk 1', message }, what);
    // chunk 0 stays usable
    assert.equal(d.deepestLevel, level1, what);
    assert.equal(d.status().chunksReady, 1, what);
  }
});

test('the base section and the VORD section are one zstd frame each too', () => {
  for (const [what, message, bad] of badFrames) {
    const parts = unpack(byName.box_vord.bytes);
    throwsPqm(() => decodeAll(packWith(parts, parts.base, bad)), { kind: 'invalid', section: 'base mesh', message }, `base: ${what}`);
    const p2 = unpack(byName.box_vord.bytes);
    const d = new PqmDecoder();
    throwsPqm(() => d.push(packWith(p2, p2.sections[0].payload, bad)), { kind: 'invalid', section: VORD_SECTION, message }, `VORD: ${what}`);
    assert.equal(d.deepestLevel, d.finalLevel, `VORD: ${what}`);
    assert.equal(d.vertexOrder, null, `VORD: ${what}`);
  }
});

test('a frame with a content checksum is refused (spec §1: the section CRC covers it)', () => {
  const parts = unpack(byName.grid_small.bytes);
  // FHD 0xa4: single segment, 4-byte size, checksum flag (4 checksum bytes follow)
  const withSum = (p) => {
    const f = rawZstdFrame(p);
    f[4] |= 0x04;
    return concat([f, new Uint8Array(4)]);
  };
  throwsPqm(() => decodeAll(pack(parts, { frame: withSum })), { kind: 'invalid', section: 'base mesh', message: /content checksum/ }, 'checksum flag');
});

test('a block larger than the frame window is refused with a clear message', () => {
  // RFC 8878: a block holds at most min(window, 128 KiB) bytes. The raw
  // frames hold the payload in one block; a 1 KiB window is too small for it.
  const parts = unpack(byName.spot.bytes);
  const t = parts.chunks[2];
  assert.ok(t.length > 1024);
  const frame = (wd) => (p) => rawZstdFrame(p, p === t ? { windowDescriptor: wd } : {});
  throwsPqm(() => decodeAll(pack(parts, { frame: frame(0) })), { kind: 'invalid', section: 'chunk 2', message: /block of \d+ bytes exceeds the frame's maximum block size 1024/ }, '1 KiB window');
  // a window as large as the block is enough
  const e = Math.ceil(Math.log2(t.length)) - 10;
  const finest = (bytes) => {
    const d = decodeAll(bytes);
    d.setLevel({ level: d.finalLevel });
    return levelDigests(d);
  };
  assert.deepEqual(finest(pack(parts, { frame: frame(e << 3) })), finest(byName.spot.bytes));
});

// ---- all-or-nothing chunks --------------------------------------------------

test('a failing record discards its whole chunk', () => {
  const f = byName.mixed_bits24;
  const reference = allDigests(f.bytes);
  const whole = decodeAll(f.bytes);
  assert.ok(whole.chunks[0].recordCount > 7 && whole.chunks[1].recordCount > 7);
  for (const [chunk, k] of [[0, 1], [1, 7]]) {
    const level = chunk === 0 ? 0 : whole.chunks[chunk - 1].level;
    const parts = unpack(f.bytes);
    const payload = parts.chunks[chunk];
    // stream 0 (ops, one symbol per record) comes first, after its length
    // varint (one byte: fewer than 128 records)
    assert.equal(payload[0], whole.chunks[chunk].recordCount);
    payload[1 + k] = 0x20; // form-0 symbol with bit 5 set: invalid in every version
    const d = new PqmDecoder();
    const e = throwsPqm(() => d.push(pack(parts)), { kind: 'bad-record', chunk, record: level + k, message: /bits 4-7/ }, `chunk ${chunk}`);
    // the records of the chunk decoded before the bad one are not available
    assert.equal(d.deepestLevel, level);
    assert.equal(d.status().chunksReady, chunk);
    assert.equal(e.events.filter((x) => x.type === 'chunkReady').length, chunk);
    assert.equal(d.resolve({ level: Number.MAX_SAFE_INTEGER }), level);
    assert.equal(d.resolve({ faces: Number.MAX_SAFE_INTEGER }), level);
    // the levels that are available are exactly the reference ones, both
    // ways
    d.setLevel({ level });
    assert.equal(JSON.stringify(levelDigests(d)), reference[level], `chunk ${chunk}: level ${level}`);
    d.setLevel({ level: 0 });
    assert.equal(JSON.stringify(levelDigests(d)), reference[0], `chunk ${chunk}: level 0`);
    d.setLevel({ level: Number.MAX_SAFE_INTEGER });
    assert.equal(d.level, level);
    assert.equal(JSON.stringify(levelDigests(d)), reference[level], `chunk ${chunk}: back to ${level}`);
  }
});
