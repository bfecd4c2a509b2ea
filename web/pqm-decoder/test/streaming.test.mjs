// Truncated input: every prefix of a file yields exactly the levels whose
// sections are complete in it (spec §10), with the same meshes as the whole
// file; status() reports what is missing.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError } from '../src/index.js';
import { testFiles, levelDigests } from './helpers.mjs';

const files = testFiles();

/** Digests of level 0 and of every chunk boundary, stepping up one level at a time. */
function boundaryDigests(bytes) {
  const d = new PqmDecoder();
  d.push(bytes);
  const wanted = new Set([0, ...d.chunks.map((c) => c.level)]);
  const out = [];
  for (let k = 0; k <= d.deepestLevel; k++) {
    d.refineTo({ level: k });
    if (wanted.has(k)) out[k] = JSON.stringify(levelDigests(d));
  }
  return { digests: out, dec: d };
}

for (const file of files) {
  test(`${file.name}: truncated prefixes give the deepest complete level`, () => {
    const { digests, dec: whole } = boundaryDigests(file.bytes);
    const h = whole.header;
    const baseEnd = h.headerLen + h.chunkCount * h.chunkEntryLen + 4 + h.baseCompressedLen;
    const chunks = whole.chunks;
    const expectedDeepest = (p) => {
      if (p < baseEnd) return null;
      let level = 0;
      for (const c of chunks) if (c.end <= p) level = c.level;
      return level;
    };
    // every prefix of small files; a sample plus every section boundary of larger ones
    const n = file.bytes.length;
    const lengths = new Set();
    if (n <= 3000) for (let p = 0; p < n; p++) lengths.add(p);
    else for (let p = 0; p < n; p += Math.ceil(n / 150)) lengths.add(p);
    for (const c of chunks) for (const p of [c.offset - 1, c.offset, c.end - 1, c.end]) lengths.add(p);
    for (const p of [baseEnd - 1, baseEnd, h.headerLen - 1, h.headerLen]) lengths.add(p);
    for (const p of lengths) {
      if (p < 0 || p >= n) continue;
      const d = new PqmDecoder();
      const events = d.push(file.bytes.subarray(0, p));
      const want = expectedDeepest(p);
      assert.equal(d.deepestLevel, want, `${file.name}: prefix of ${p} bytes`);
      const s = d.status();
      assert.equal(s.finished, false);
      assert.equal(s.failed, false);
      assert.ok(s.waitingFor, 'names the section it waits for');
      assert.equal(s.bytesConsumed + s.bytesBuffered, p);
      assert.equal(events.filter((e) => e.type === 'chunkReady').length, s.chunksReady);
      assert.throws(
        () => d.end(),
        (e) => e instanceof PqmError && e.kind === 'truncated' && e.message.includes(s.waitingFor),
      );
      if (want !== null) {
        d.setLevel({ level: want });
        assert.equal(JSON.stringify(levelDigests(d)), digests[want], `${file.name}: prefix ${p}, level ${want}`);
        // targets beyond the decoded levels clamp to the deepest one
        d.setLevel({ level: 1e9 });
        assert.equal(d.level, want);
      }
    }
  });

  test(`${file.name}: pushing the rest after a pause continues where it stopped`, () => {
    const { digests } = boundaryDigests(file.bytes);
    const d = new PqmDecoder();
    const cut = Math.floor(file.bytes.length * 0.6);
    d.push(file.bytes.subarray(0, cut));
    const before = d.deepestLevel ?? 0;
    if (d.deepestLevel !== null) d.refineTo({ level: before });
    const ev = d.push(file.bytes.subarray(cut));
    assert.equal(ev.at(-1).type, 'finished');
    assert.equal(d.level, before, 'the current level does not move by itself');
    d.refineTo({ level: d.finalLevel });
    assert.equal(JSON.stringify(levelDigests(d)), digests.at(-1));
    assert.equal(d.status().finished, true);
    assert.equal(d.status().bytesNeeded, null);
  });
}

test('pushStream reads a ReadableStream to its end', async () => {
  const file = files.find((f) => f.name === 'box_vord');
  const pieces = [];
  for (let o = 0; o < file.bytes.length; o += 100) pieces.push(file.bytes.slice(o, o + 100));
  const stream = new ReadableStream({
    pull(c) {
      if (pieces.length) c.enqueue(pieces.shift());
      else c.close();
    },
  });
  const d = new PqmDecoder();
  const seen = [];
  const all = await d.pushStream(stream, (ev) => seen.push(...ev));
  assert.deepEqual(all, seen);
  assert.equal(all.at(-1).type, 'finished');
  assert.equal(d.deepestLevel, d.finalLevel);
});
