// `PqmDecoder.reset(options)`: a decoder reset after any first file —
// decoded whole, cut short, failed on a flipped byte or a damaged record,
// or (general decoder) moved below its deepest level and back — decodes
// the next file exactly as `new PqmDecoder(options)` does: the same events,
// errors and statuses after every push, the same levels, buffers and
// Changes on a walk over the levels, the same header, chunks and vertex
// order. Second files are whole, cut short or damaged too; first and
// second files of every size order (the reset decoder's arrays larger or
// smaller than the next file needs), both kinds, and a reset that changes
// the kind.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PqmDecoder, PqmError } from '../src/index.js';
import { testFiles, rng, randomPieces, plainChange as plain } from './helpers.mjs';
import { unpack, pack } from './repack.mjs';

const files = testFiles();

/** An error as plain data (its events too), or null. */
const plainError = (e) =>
  e === null || e === undefined
    ? null
    : { name: e.constructor.name, kind: e.kind, message: e.message, section: e.section, chunk: e.chunk, events: e.events };

/** A status as plain data (its error as plainError). */
const plainStatus = (s) => ({ ...s, error: plainError(s.error) });

/** Everything a caller can read of a decoder's current level and file. */
function state(d) {
  const out = {
    level: d.level,
    deepest: d.deepestLevel,
    final: d.finalLevel,
    nv: d.vertexCount,
    nf: d.faceCount,
    codes: [...d.positionCodes],
    positions: [...d.positions],
    quads: [...d.quads],
    tris: [...d.triangleIndices],
    header: d.header,
    chunks: d.chunks,
    grid: d.grid,
    status: plainStatus(d.status()),
  };
  if (d.deepestLevel !== null) {
    out.f64 = [...d.positionsF64()];
    out.counts = [];
    for (let k = 0; k <= d.deepestLevel + 1; k++) out.counts.push(d.levelCounts(k));
    out.resolved = [{ faces: 0 }, { faces: d.faceCount }, { faces: 1e9 }, { error: 0 }, { error: 1e-3 }, { error: 1 }].map(
      (t) => d.resolve(t),
    );
  }
  if (d.header) out.bytesFor = [0, 1, 5, d.finalLevel].map((l) => d.bytesFor({ level: l }));
  try {
    const o = d.vertexOrder;
    out.order = o === null ? null : [...o];
  } catch (e) {
    out.order = plainError(e);
  }
  return out;
}

/** Runs `fn`: its result, or the error it threw, as plain data. */
function attempt(fn, asPlain = (x) => x) {
  try {
    return { ok: asPlain(fn()) };
  } catch (e) {
    if (!(e instanceof PqmError)) throw e;
    return { error: plainError(e) };
  }
}

/**
 * Pushes the same pieces into decoders `a` (reset) and `b` (fresh),
 * comparing every result; then walks both over the levels (`levels`:
 * targets; a forward-only decoder goes to its deepest level instead) and
 * compares every Change and state; then `end()`.
 */
function sameDecode(a, b, pieces, levels, what) {
  for (let i = 0; i < pieces.length; i++) {
    const ra = attempt(() => a.push(pieces[i]));
    const rb = attempt(() => b.push(pieces[i]));
    assert.deepEqual(ra, rb, `${what}: push ${i}`);
    assert.deepEqual(plainStatus(a.status()), plainStatus(b.status()), `${what}: status after push ${i}`);
    if (rb.error) break;
  }
  assert.deepEqual(state(a), state(b), `${what}: after the pushes`);
  if (b.deepestLevel !== null) {
    for (const t of levels) {
      const target = b._forward ? { level: b.deepestLevel } : t;
      const ca = attempt(() => a.setLevel(target), plain);
      const cb = attempt(() => b.setLevel(target), plain);
      assert.deepEqual(ca, cb, `${what}: move to ${JSON.stringify(target)}`);
      assert.deepEqual(state(a), state(b), `${what}: at ${JSON.stringify(target)}`);
    }
  }
  assert.deepEqual(attempt(() => a.end()), attempt(() => b.end()), `${what}: end()`);
}

/** `bytes` with one byte of chunk `i`'s payload changed (the file repacked: the damage reaches the records), or null. */
function damagedRecord(bytes, rand) {
  const parts = unpack(bytes);
  if (parts.chunks.length === 0) return null;
  const i = Math.floor(rand() * parts.chunks.length);
  const pl = parts.chunks[i];
  if (pl.length === 0) return null;
  const at = Math.floor(rand() * pl.length);
  pl[at] = (pl[at] + 1 + Math.floor(rand() * 255)) & 0xff;
  return pack(parts);
}

/** Variants of a file: whole, cut short, a flipped byte, a damaged record. */
function variants(bytes, rand) {
  const cut = bytes.subarray(0, 1 + Math.floor(rand() * (bytes.length - 1)));
  const flipped = bytes.slice();
  flipped[Math.floor(rand() * bytes.length)] ^= 0x5a;
  const out = [
    ['whole', bytes],
    ['cut', cut],
    ['flipped', flipped],
  ];
  // a few tries for a damage the records refuse (some decode to another valid mesh)
  for (let k = 0; k < 8; k++) {
    const d = damagedRecord(bytes, rand);
    if (d === null) break;
    const probe = new PqmDecoder();
    if (attempt(() => probe.push(d)).error?.kind === 'bad-record') {
      out.push(['bad record', d]);
      break;
    }
  }
  return out;
}

/**
 * Decodes a first file with `d` as `how` says: pushes it (in pieces), and
 * for 'coarsened' moves below the deepest level and back (the general
 * decoder's log and first states then built, its current level its own);
 * moves to the deepest level in any case and reads the vertex order.
 */
function useFirst(d, bytes, how, rand) {
  const pieces = randomPieces(bytes, rand, 1 + Math.floor(rand() * bytes.length));
  for (const p of pieces) {
    try {
      d.push(p);
    } catch {
      break;
    }
  }
  if (d.deepestLevel === null) return;
  d.setLevel({ level: d.deepestLevel });
  if (how === 'coarsened' && !d._forward) {
    d.setLevel({ level: 0 });
    d.setLevel({ level: d.deepestLevel >> 1 });
    d.setLevel({ level: d.deepestLevel });
    d.setLevel({ level: Math.max(0, d.deepestLevel - 3) });
  }
  try {
    d.vertexOrder;
  } catch {
    // a bad section: the order only
  }
}

/** A walk of level targets over a file of `final` levels. */
function walk(final, rand) {
  const out = [{ level: final }];
  for (let k = 0; k < 5; k++) out.push({ level: Math.floor(rand() * (final + 1)) });
  out.push({ faces: Math.floor(rand() * 1000) }, { level: 0 }, { level: final });
  return out;
}

for (const forwardOnly of [false, true]) {
  const kind = forwardOnly ? 'forward-only' : 'general';
  test(`${kind}: a reset decoder decodes the next file as a fresh one, after whole, cut, failed and coarsened first files`, () => {
    const rand = rng(forwardOnly ? 181 : 18);
    // by size: the largest first files leave arrays larger than the next
    // file needs (stale data past its counts), the smallest too small ones
    const bySize = [...files].sort((x, y) => x.bytes.length - y.bytes.length);
    let cases = 0;
    for (const first of bySize) {
      const seconds = [bySize[bySize.length - 1], bySize[0], bySize[Math.floor(rand() * bySize.length)], first];
      const firstVariants = [...variants(first.bytes, rand), ['coarsened', first.bytes]];
      for (const [how, a] of firstVariants) {
        for (const second of seconds) {
          const d = new PqmDecoder({ forwardOnly });
          useFirst(d, a, how, rand);
          const options = { forwardOnly };
          d.reset(options);
          const fresh = new PqmDecoder(options);
          assert.deepEqual(Object.keys(d), Object.keys(fresh), 'the same fields as a fresh decoder');
          const [secondHow, b] = variants(second.bytes, rand)[Math.floor(rand() * 4)] ?? ['whole', second.bytes];
          const pieces = randomPieces(b, rand, [1 + (b.length >> 3), 4096, b.length][Math.floor(rand() * 3)]);
          const what = `${kind}: ${first.name} ${how}, then ${second.name} ${secondHow}`;
          sameDecode(d, fresh, pieces, walk(second.digest.final_level, rand), what);
          cases++;
        }
      }
    }
    assert.ok(cases > 100, `${cases} cases`);
  });
}

test('a reset decoder decodes file after file as fresh ones do (one decoder, many resets, both kinds)', () => {
  const rand = rng(5);
  const d = new PqmDecoder();
  for (let k = 0; k < 40; k++) {
    const file = files[Math.floor(rand() * files.length)];
    const forwardOnly = rand() < 0.5;
    const options = { forwardOnly, limits: rand() < 0.1 ? { maxFaces: 100 } : undefined };
    d.reset(options);
    const fresh = new PqmDecoder(options);
    const [how, b] = variants(file.bytes, rand)[Math.floor(rand() * 4)] ?? ['whole', file.bytes];
    const pieces = randomPieces(b, rand, 1 + Math.floor(rand() * b.length));
    sameDecode(d, fresh, pieces, walk(file.digest.final_level, rand), `decode ${k}: ${file.name} ${how} (${JSON.stringify(options)})`);
    // leave it below its deepest level now and then
    if (!forwardOnly && d.deepestLevel !== null && rand() < 0.5) d.setLevel({ level: d.deepestLevel >> 1 });
  }
});

test('reset() takes the options of the constructor: limits, forwardOnly, defaults', () => {
  const file = files.find((f) => f.digest.final_level >= 4);
  const d = new PqmDecoder({ forwardOnly: true, limits: { maxFaces: 1 } });
  assert.throws(() => d.push(file.bytes), (e) => e.kind === 'limits');
  d.reset();
  assert.equal(d.status().failed, false);
  d.push(file.bytes);
  assert.equal(d.limits.maxFaces, new PqmDecoder().limits.maxFaces);
  d.setLevel({ level: 1 }); // a general decoder again: any level
  d.reset({ forwardOnly: true });
  d.push(file.bytes);
  assert.throws(() => d.setLevel({ level: 1 }), (e) => e.kind === 'parameter');
  d.reset({ limits: { maxVertices: 2 } });
  assert.throws(() => d.push(file.bytes), (e) => e.kind === 'limits');
});

test('reset() keeps the arrays of the previous file as room (the views handed out before are reused)', () => {
  const file = [...files].sort((x, y) => y.bytes.length - x.bytes.length)[0];
  const d = new PqmDecoder();
  d.push(file.bytes);
  d.setLevel({ level: d.deepestLevel >> 1 });
  const pos = d.positions;
  const frontierQ = d._frontier.q;
  const rw = d._log.rw;
  d.reset();
  assert.equal(d.deepestLevel, null);
  assert.equal(d.positions.length, 0);
  d.push(file.bytes);
  assert.equal(d._frontier.q, frontierQ, "the frontier's vertex records");
  assert.equal(d._log.rw, rw, 'the undo list of rewritten corners');
  d.setLevel({ level: d.deepestLevel >> 1 });
  assert.equal(d.positions.buffer, pos.buffer, "the positions' array (a view taken before reset now shows the new file)");
});
