// PqmRangeLoader against a local HTTP server that honours Range (or not) and
// counts the body bytes it sends: a target costs no more bytes than the
// chunk table's end offset for it, the levels reached equal those of the
// whole file, a later load continues where the first stopped (no byte is
// sent twice), a server that ignores Range (200) still works, and faults
// (404, truncated file) are errors.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmRangeLoader, decodeAll } from '../src/index.js';
import { testFiles, levelDigests, serveBytes as serve } from './helpers.mjs';

const files = testFiles();
const spot = files.find((f) => f.name === 'spot');

const whole = decodeAll(spot.bytes);
const finalFaces = whole.header.finalFaceCount;

test('a face target fetches the header and table, then only up to the chunk that reaches it', async () => {
  const srv = await serve(spot.bytes);
  try {
    const n = whole.levelCounts(Math.floor(whole.finalLevel / 3))[1];
    const end = whole.bytesFor({ faces: n });
    assert.ok(end < spot.bytes.length, 'the target is inside the file');
    const src = new PqmRangeLoader(srv.url);
    const dec = await src.load({ faces: n });
    assert.ok(srv.stats.served <= end, `served ${srv.stats.served} bytes, the table says ${end}`);
    assert.equal(src.loaded, end);
    assert.equal(src.rangeSupported, true);
    assert.equal(srv.stats.requests[0], `bytes=0-${src.firstBytes - 1}`);
    assert.deepEqual(srv.stats.requests, [`bytes=0-${src.firstBytes - 1}`, `bytes=${src.firstBytes}-${end - 1}`]);
    // the deepest decoded level reaches the target; the target level is the whole file's
    const deepestFaces = dec.levelCounts(dec.deepestLevel)[1];
    assert.ok(deepestFaces >= n, `deepest level has ${deepestFaces} faces, target ${n}`);
    dec.refineTo({ faces: n });
    assert.equal(dec.level, whole.resolve({ faces: n }));
    assert.ok(dec.faceCount <= n);
    whole.setLevel(dec.level);
    assert.deepEqual(levelDigests(dec), levelDigests(whole));
  } finally {
    await srv.close();
  }
});

test('an error target stops at the first chunk whose error is small enough', async () => {
  const srv = await serve(spot.bytes);
  try {
    const e = whole.chunks[2].error;
    const end = whole.bytesFor({ error: e });
    const src = new PqmRangeLoader(srv.url);
    const dec = await src.load({ error: e });
    assert.ok(srv.stats.served <= end, `served ${srv.stats.served}, table end ${end}`);
    dec.refineTo({ error: e });
    assert.equal(dec.level, whole.resolve({ error: e }));
    assert.ok(dec.chunks.find((c) => c.level === dec.level).error <= e);
  } finally {
    await srv.close();
  }
});

test('loading further continues with another Range request, never resending a byte', async () => {
  const srv = await serve(spot.bytes);
  try {
    const n1 = whole.levelCounts(100)[1];
    const n2 = whole.levelCounts(700)[1];
    const src = new PqmRangeLoader(srv.url);
    await src.load({ faces: n1 });
    const first = srv.stats.served;
    const reqs = srv.stats.requests.length;
    const dec = await src.load({ faces: n2 });
    assert.equal(srv.stats.requests.length, reqs + 1, 'one more request');
    assert.equal(srv.stats.requests.at(-1), `bytes=${first}-${whole.bytesFor({ faces: n2 }) - 1}`);
    assert.equal(srv.stats.served, whole.bytesFor({ faces: n2 }), 'every byte sent once');
    dec.refineTo({ faces: n2 });
    assert.equal(dec.level, whole.resolve({ faces: n2 }));
    // the rest of the file: the decoder finishes and equals the whole file
    await src.load();
    assert.equal(srv.stats.served, spot.bytes.length);
    assert.ok(src.complete);
    assert.ok(dec.status().finished);
    dec.setLevel(dec.finalLevel);
    whole.setLevel(whole.finalLevel);
    assert.equal(dec.faceCount, finalFaces);
    assert.deepEqual(levelDigests(dec), levelDigests(whole));
    // a load past the end asks for nothing
    await src.load({ faces: finalFaces });
    assert.equal(srv.stats.served, spot.bytes.length);
  } finally {
    await srv.close();
  }
});

test('a header and table longer than the first request take more requests of just the missing bytes', async () => {
  const srv = await serve(spot.bytes);
  try {
    const src = new PqmRangeLoader(srv.url, { firstBytes: 100 });
    const dec = await src.load({ level: 0 });
    const h = dec.header;
    const tableEnd = h.headerLen + h.chunkCount * h.chunkEntryLen + 4;
    assert.deepEqual(srv.stats.requests.slice(0, 3), [
      'bytes=0-99',
      `bytes=100-${h.headerLen - 1}`,
      `bytes=${h.headerLen}-${tableEnd - 1}`,
    ]);
    assert.equal(srv.stats.served, dec.bytesFor({ level: 0 }));
    assert.equal(dec.deepestLevel, 0);
  } finally {
    await srv.close();
  }
});

test('a server that ignores Range (200) still gives the target; the response is cut there', async () => {
  const big = files.reduce((a, b) => (b.bytes.length > a.bytes.length ? b : a));
  const ref = decodeAll(big.bytes);
  const srv = await serve(big.bytes, { ranges: false, piece: 512 });
  try {
    const n = ref.levelCounts(Math.floor(ref.finalLevel / 4))[1];
    const events = [];
    const src = new PqmRangeLoader(srv.url, { onEvents: (ev) => events.push(...ev) });
    const dec = await src.load({ faces: n });
    assert.equal(src.rangeSupported, false);
    assert.equal(src.loaded, ref.bytesFor({ faces: n }));
    assert.equal(src.requests.length, 1, 'the header came with the same response');
    assert.equal(src.requests[0].status, 200);
    assert.ok(events.some((e) => e.type === 'baseMeshReady'));
    dec.refineTo({ faces: n });
    assert.equal(dec.level, ref.resolve({ faces: n }));
    // later loads are plain GETs that skip what was pushed
    await src.load();
    assert.equal(srv.stats.requests.length, 2);
    assert.deepEqual(srv.stats.requests, [`bytes=0-${src.firstBytes - 1}`, null], 'no Range header once the server ignored it');
    assert.ok(dec.status().finished);
    dec.setLevel(dec.finalLevel);
    ref.setLevel(ref.finalLevel);
    assert.deepEqual(levelDigests(dec), levelDigests(ref));
  } finally {
    await srv.close();
  }
});

test('HTTP errors and truncated files reject', async () => {
  const srv = await serve(spot.bytes.subarray(0, whole.bytesFor({ level: 0 }) + 10));
  try {
    const src = new PqmRangeLoader(srv.url);
    await assert.rejects(src.load(), (e) => e.kind === 'truncated');
    assert.equal(src.decoder.deepestLevel, 0, 'the base mesh stays usable');
    const missing = new PqmRangeLoader(srv.url, {
      fetch: async () => new Response('no', { status: 404 }),
    });
    await assert.rejects(missing.load({ faces: 10 }), /HTTP 404/);
  } finally {
    await srv.close();
  }
});

test('loads started together run one after the other: every byte is sent and pushed once', async () => {
  const srv = await serve(spot.bytes);
  try {
    const src = new PqmRangeLoader(srv.url);
    const n = [100, 400, 900].map((k) => whole.levelCounts(k)[1]);
    const decs = await Promise.all(n.map((x) => src.load({ faces: x })));
    assert.ok(decs.every((d) => d === src.decoder));
    assert.equal(srv.stats.served, whole.bytesFor({ faces: n[2] }));
    assert.equal(src.loaded, srv.stats.served);
    src.decoder.refineTo({ faces: n[2] });
    whole.setLevel(src.decoder.level);
    assert.deepEqual(levelDigests(src.decoder), levelDigests(whole));
  } finally {
    await srv.close();
  }
});

test('a server that answers a Range with fewer bytes than asked is asked again for the rest', async () => {
  const srv = await serve(spot.bytes, { maxRange: 5000 });
  try {
    const n = whole.levelCounts(600)[1];
    const end = whole.bytesFor({ faces: n });
    const src = new PqmRangeLoader(srv.url, { firstBytes: 100 });
    const dec = await src.load({ faces: n });
    assert.equal(srv.stats.served, end, 'every byte once, none past the target');
    assert.ok(srv.stats.requests.length >= Math.ceil(end / 5000), `${srv.stats.requests.length} requests`);
    dec.refineTo({ faces: n });
    assert.equal(dec.level, whole.resolve({ faces: n }));
  } finally {
    await srv.close();
  }
});

test('a 206 whose whole body was used is read to its end, not cancelled (browsers report a cancelled request as failed)', async () => {
  // a fetch that answers Range requests with in-memory bodies in small
  // pieces and records which bodies were cancelled
  const bodies = [];
  const fetch = async (url, init) => {
    const m = /bytes=(\d+)-(\d*)/.exec(new Headers(init.headers).get('Range'));
    const a = Number(m[1]);
    const b = m[2] === '' ? spot.bytes.length - 1 : Math.min(Number(m[2]), spot.bytes.length - 1);
    const slice = spot.bytes.slice(a, b + 1);
    const rec = { range: `${a}-${b}`, cancelled: false };
    bodies.push(rec);
    let at = 0;
    const body = new ReadableStream({
      pull(c) {
        if (at >= slice.length) return c.close();
        c.enqueue(slice.slice(at, at + 700));
        at += 700;
      },
      cancel() {
        rec.cancelled = true;
      },
    }, { highWaterMark: 0 }); // a piece only when read: the end is not seen until asked for
    return new Response(body, { status: 206, headers: { 'Content-Range': `bytes ${a}-${b}/${spot.bytes.length}` } });
  };
  const src = new PqmRangeLoader('mem://spot.pqm', { fetch, firstBytes: 300 });
  const n = whole.levelCounts(Math.floor(whole.finalLevel / 2))[1];
  await src.load({ faces: n });
  await src.load();
  assert.ok(bodies.length >= 3, `${bodies.length} requests`);
  assert.deepEqual(bodies.filter((b) => b.cancelled), [], 'no body cancelled');
  assert.equal(src.loaded, spot.bytes.length);
  // a body longer than its Content-Range says is cut (cancelled), not read on
  let extra = null;
  const liar = async (url, init) => {
    const m = /bytes=(\d+)-(\d*)/.exec(new Headers(init.headers).get('Range'));
    const a = Number(m[1]);
    const b = Math.min(Number(m[2]), spot.bytes.length - 1);
    extra = { cancelled: false };
    const rec = extra;
    let sent = 0;
    const body = new ReadableStream({
      pull(c) {
        c.enqueue(spot.bytes.slice(a + sent, a + sent + 500)); // never closes
        sent += 500;
      },
      cancel() {
        rec.cancelled = true;
      },
    });
    return new Response(body, { status: 206, headers: { 'Content-Range': `bytes ${a}-${b}/${spot.bytes.length}` } });
  };
  const cut = new PqmRangeLoader('mem://spot.pqm', { fetch: liar, firstBytes: 1000 });
  await cut.load({ level: 0 });
  assert.equal(extra.cancelled, true, 'an endless body is cancelled');
});
