/**
 * The push (streaming) decoder of `.pqm` files, written from `spec/pqm.md`.
 *
 * Feed bytes as they arrive with `push(bytes)` — any number at a time; one
 * byte at a time gives exactly the same result — and get events as sections
 * complete (`headerReady`, `baseMeshReady`, `chunkReady`, `sectionReady`,
 * `finished`). Then move between any two decoded levels with `refineTo`,
 * `coarsenTo` or `setLevel`, each returning a `Change` that says which
 * buffer ranges a renderer must update.
 *
 * Internally there are two meshes: the *frontier* (the deepest decoded
 * level, with vertex→face adjacency, needed to decode the next record) and
 * the *current* level the caller sees. Every decoded record is kept in
 * explicit form with its undo data, so moving between levels never decodes
 * anything again.
 *
 * Every byte is hostile: the header's counts and the chunk table's sizes are
 * checked against `limits` before anything is allocated for them, every
 * section's CRC-32 is checked, every count and index is checked before use;
 * a fault is a `PqmError` naming the section, chunk and record.
 */
import { crc32 } from './crc32.js';
import { checkFrameHeader, decompressFrame, decompressFrameInto } from './zstd.js';
import { RecordLog, decodeBase, decodeChunk } from './codec.js';
import { ByteQueue } from './queue.js';
import { ensure } from './grow.js';
import { Reader } from './reader.js';
import { decodeVnbr } from './vertex-order.js';
import { PqmError, crcMismatch, invalid, limitsExceeded } from './errors.js';

const MAGIC = [0x89, 0x50, 0x51, 0x4d, 0x0d, 0x0a, 0x1a, 0x0a];
/** The `version_major`s this decoder reads (spec §3, §9): 1.x, 2.0, 3.x and 4.0 files, each with its own rules. */
const VERSION_MAJORS = [1, 2, 3, 4];
const VERSION_MAJOR = 4;
const HEADER_PREFIX = 16;
const HEADER_LEN = 120;
/** The shortest header holding `bounds_min` / `bounds_max` (flag bit 2, spec §3, version 3.2). */
const HEADER_LEN_BOUNDS = 168;
const FLAG_BOUNDS = 4;
const MAX_HEADER_LEN = 65536;
const CHUNK_ENTRY_LEN = 36;
const MAX_CHUNK_ENTRY_LEN = 4096;
const SECTION_HEADER_LEN = 16;

/**
 * Default resource budget: 2^26 vertices, 2^26 faces, 4 GiB (the Rust
 * decoder's defaults).
 */
export const DEFAULT_LIMITS = Object.freeze({
  maxVertices: 2 ** 26,
  maxFaces: 2 ** 26,
  maxMemoryBytes: 4 * 2 ** 30,
});

/**
 * Conservative memory estimate of a decoder for a file with `v` final
 * vertices, `f` final faces, `r` records and `payload` uncompressed payload
 * bytes in all (the same formula as the Rust decoder's `Limits::estimate`).
 */
export function estimateMemory(v, f, r, payload) {
  return v * 96 + f * 80 + r * 40 + payload * 20;
}

/**
 * What changed between two levels, in buffer terms. Quad slot `f` is
 * triangles `2f = (v0, v1, v2)` and `2f + 1 = (v0, v2, v3)`, i.e. indices
 * `6f .. 6f + 6` of `triangleIndices`. Ranges are `{start, end}`, end
 * exclusive.
 */
export class Change {
  constructor(fields) {
    /** Level before. */
    this.fromLevel = fields.fromLevel;
    /** Level after. */
    this.toLevel = fields.toLevel;
    /** New vertex ids (refining): upload these positions. */
    this.verticesAppended = fields.verticesAppended;
    /** Removed vertex ids (coarsening): the vertex count drops to `start`. */
    this.verticesRemoved = fields.verticesRemoved;
    /** Vertices that exist before and after and moved (sorted, distinct). */
    this.verticesMoved = fields.verticesMoved;
    /** Face slots that exist before and after and changed (sorted, distinct). */
    this.facesRewritten = fields.facesRewritten;
    /** New face slots (refining). */
    this.facesAppended = fields.facesAppended;
    /** Removed face slots (coarsening): the face count drops to `start`. */
    this.facesTruncated = fields.facesTruncated;
  }

  /** True when no buffer range changed. */
  isEmpty() {
    return (
      this.verticesAppended.start === this.verticesAppended.end &&
      this.verticesRemoved.start === this.verticesRemoved.end &&
      this.verticesMoved.length === 0 &&
      this.facesRewritten.length === 0 &&
      this.facesAppended.start === this.facesAppended.end &&
      this.facesTruncated.start === this.facesTruncated.end
    );
  }

  /** `verticesMoved` as maximal runs of consecutive ids. */
  movedRanges() {
    return runs(this.verticesMoved);
  }

  /** `facesRewritten` as maximal runs of consecutive slots. */
  rewrittenRanges() {
    return runs(this.facesRewritten);
  }
}

/**
 * Maximal runs of consecutive values of a sorted list.
 * @param {ArrayLike<number>} sorted
 * @returns {{start:number, end:number}[]}
 */
export function runs(sorted) {
  const out = [];
  for (let i = 0; i < sorted.length; i++) {
    const x = sorted[i];
    const last = out[out.length - 1];
    if (last && last.end === x) last.end = x + 1;
    else out.push({ start: x, end: x + 1 });
  }
  return out;
}

const range = (start, end) => ({ start, end });

/**
 * Streaming decoder. See the module documentation.
 */
export class PqmDecoder {
  /**
   * `forwardOnly: true` makes a one-way decoder (like the Rust decoder's
   * `Decoder::forward_only`), for a loader that only streams towards full
   * detail: it keeps no per-record log (a chunk's undo data only until the
   * chunk commits), so it moves only *to the deepest decoded level* —
   * `refineTo` / `setLevel` with a target that resolves to it; any other
   * move is a `parameter` error. Everything else (input, checks, limits,
   * events, the levels it reaches and the `Change`s it reports) is the same
   * as the default decoder's; it needs less memory and decodes faster.
   * @param {{limits?: {maxVertices?: number, maxFaces?: number, maxMemoryBytes?: number}, forwardOnly?: boolean}} [options]
   */
  constructor(options = {}) {
    const l = options.limits ?? {};
    this.limits = {
      maxVertices: l.maxVertices ?? DEFAULT_LIMITS.maxVertices,
      maxFaces: l.maxFaces ?? DEFAULT_LIMITS.maxFaces,
      maxMemoryBytes: l.maxMemoryBytes ?? DEFAULT_LIMITS.maxMemoryBytes,
    };
    this._queue = new ByteQueue();
    this._consumed = 0;
    this._stage = 'prefix';
    this._stageArg = 0; // header length, chunk index or section index
    this._section = null; // {tag, compressedLen, uncompressedLen, crc32} of the section being read
    this._failed = null;
    /** @type {object|null} */
    this._header = null;
    this._chunks = [];
    this._chunksReady = 0;
    this._payload = new Uint8Array(0); // chunk payloads, decompressed
    this._frontier = null;
    this._forward = options.forwardOnly === true;
    this._log = new RecordLog(this._forward);
    // forward-only: the ids below the current level's counts that committed
    // chunks moved / rewrote since the last move (what its Change reports),
    // each once (marked with the pending epoch in _vMark / _fMark)
    this._pendMoved = new Uint32Array(64);
    this._nPendMoved = 0;
    this._pendRw = new Uint32Array(64);
    this._nPendRw = 0;
    this._pendEpoch = 0;
    // The vertex-order section is kept compressed when it arrives and
    // decoded on the first read of `vertexOrder` (only exporters need it,
    // and decoding it costs a large part of a whole-file decode).
    this._vertexOrderTag = null; // which section is present: 'VORD' or 'VNBR'
    this._vertexOrderSection = null; // {section, bytes, uncompressedLen}
    this._vertexOrder = null; // the decoded order, once read
    this._vertexOrderError = null; // or why the section is bad
    this._sectionsRead = [];
    // quantization grid
    this._min = [0, 0, 0];
    this._step = [0, 0, 0];
    // the current level
    this._level = 0;
    this._nv = 0;
    this._nf = 0;
    this._q = new Uint32Array(0);
    // true when the current level is the final frontier's: its codes are
    // then read from the frontier's vertex records and `_q` is stale until
    // `_ownCodes` copies them (see `_goTo`)
    this._qShared = false;
    this._pos = new Float32Array(0);
    this._quads = new Uint32Array(0);
    this._tris = new Uint32Array(0);
    // _goTo scratch: marks per vertex / slot, and the touched ids
    this._vMark = new Uint32Array(0);
    this._fMark = new Uint32Array(0);
    this._epoch = 0;
    this._movedScratch = new Uint32Array(64);
    this._rwScratch = new Uint32Array(64);
    // Arrays of an earlier file that `reset` handed on, for the next base
    // mesh to take (`_onBase`): the frontier and the current level's.
    this._spare = { frontier: null, q: null, pos: null, quads: null, tris: null };
  }

  /**
   * Makes this decoder a new one for the next file — what
   * `new PqmDecoder(options)` makes (the same options: `limits`,
   * `forwardOnly`; none gives the defaults, a general decoder, whatever
   * this one was) — keeping the large arrays it allocated as room for the
   * next file: the frontier's vertex records and quads, the current
   * level's codes, positions, quads and triangles, the per-record log
   * (its undo lists; when the kind, general or forward-only, stays the
   * same), the chunk payload buffer and the move scratch. Nothing of the
   * previous file is kept but capacity: every field not handed on is the
   * fresh decoder's, and every decode after a reset gives what a fresh
   * decoder gives — events, statuses, errors, levels, `Change`s
   * (`test/reset.test.mjs`).
   *
   * For a client that decodes file after file (a game streaming its
   * assets, a viewer switching models): a fresh decoder's arrays are new
   * memory, zeroed and mapped by the system page by page as they are
   * first written, and garbage for the collector afterwards.
   *
   * The previous file's mesh is gone after the call, so take what you need
   * from it first: the views `positions`, `positionCodes`, `quads` and
   * `triangleIndices` returned before (and any `subarray` of them) are
   * the arrays the next file is decoded into — copy them (or upload them
   * to the GPU) before `reset`. What the decoder returned as new objects
   * stays valid: `header`, `chunks`, `vertexOrder`, `positionsF64()`,
   * `status()`, events, errors and `Change`s.
   * @param {{limits?: {maxVertices?: number, maxFaces?: number, maxMemoryBytes?: number}, forwardOnly?: boolean}} [options]
   */
  reset(options = {}) {
    const fresh = new PqmDecoder(options);
    const old = {
      frontier: this._frontier,
      spare: this._spare,
      log: this._log,
      forward: this._forward,
      // the current level's quads may be the frontier's own (`_goTo`)
      quads: this._frontier !== null && this._quads === this._frontier.f ? null : this._quads,
      q: this._q,
      pos: this._pos,
      tris: this._tris,
      payload: this._payload,
      vMark: this._vMark,
      fMark: this._fMark,
      epoch: this._epoch,
      pendMoved: this._pendMoved,
      pendRw: this._pendRw,
      movedScratch: this._movedScratch,
      rwScratch: this._rwScratch,
    };
    // Every field starts as the fresh decoder's (the constructor creates
    // them all, so this object keeps its shape): nothing of the previous
    // file can leak into the next but what is handed on below.
    for (const k of Object.keys(fresh)) this[k] = fresh[k];
    // Scratch whose contents are never read before being written: the
    // chunk payload buffer (decompressed into), the Change id lists
    // (counted by _nPendMoved, _nPendRw and per move).
    this._payload = old.payload;
    this._pendMoved = old.pendMoved;
    this._pendRw = old.pendRw;
    this._movedScratch = old.movedScratch;
    this._rwScratch = old.rwScratch;
    // The marks are stamps of epochs up to `_epoch`, which goes on from
    // there: no mark of the previous file equals a later stamp.
    this._vMark = old.vMark;
    this._fMark = old.fMark;
    this._epoch = old.epoch;
    // The log's arrays, its counts the fresh log's (zero). Only to a log of
    // the same kind: a one-way log's arrays lack the level lists
    // (`movedAt`, `rwAt`, `ops`) that a general log grows with `vAt`.
    if (old.forward === this._forward) {
      const log = this._log;
      const o = old.log;
      log.ops = o.ops;
      log.vAt = o.vAt;
      log.fAt = o.fAt;
      log.movedAt = o.movedAt;
      log.rwAt = o.rwAt;
      log.moved = o.moved;
      log.rw = o.rw;
      log.newCodes = o.newCodes;
      log.app = o.app;
    }
    // The frontier and the current level's arrays wait for the next base
    // mesh (`_onBase`); of two candidates (this file's and a spare not
    // taken, if its base never came) the larger.
    const larger = (a, b) => (a === null ? b : b === null || a.length >= b.length ? a : b);
    const sp = this._spare;
    const f0 = old.frontier;
    const f1 = old.spare.frontier;
    sp.frontier = f0 === null ? f1 : f1 === null || f0.q.length >= f1.q.length ? f0 : f1;
    // (its lists past the 12th slot of a vertex are the previous file's
    // only: dropped now, not kept alive until the next base)
    if (sp.frontier !== null) sp.frontier.big.clear();
    sp.q = larger(old.q, old.spare.q);
    sp.pos = larger(old.pos, old.spare.pos);
    sp.quads = larger(old.quads, old.spare.quads);
    sp.tris = larger(old.tris, old.spare.tris);
  }

  // ---- input ---------------------------------------------------------------

  /**
   * Feeds the next bytes of the file and returns the events they completed,
   * in file order. The bytes are copied if kept, so the caller may reuse its
   * buffer. On a fault throws a `PqmError` (its `events` holds what the call
   * completed before the fault); the decoder is then failed and every
   * further push throws, but every level decoded before stays usable.
   * @param {Uint8Array} bytes
   * @returns {object[]} events
   */
  push(bytes) {
    if (this._failed) {
      const e = new PqmError('failed', `the decoder failed earlier: ${this._failed.message}`);
      e.cause = this._failed;
      throw e;
    }
    if (!(bytes instanceof Uint8Array)) {
      throw new PqmError('parameter', 'push() takes a Uint8Array');
    }
    const events = [];
    this._queue.push(bytes);
    try {
      this._run(events);
    } catch (err) {
      const e =
        err instanceof PqmError
          ? err
          : new PqmError('internal', `internal error: ${err && err.message ? err.message : err}`);
      if (e !== err) e.cause = err;
      e.events = events;
      this._failed = e;
      throw e;
    } finally {
      this._queue.own(bytes);
    }
    return events;
  }

  /**
   * Reads a `ReadableStream` of bytes (e.g. `fetch(url).then(r => r.body)`)
   * to its end, pushing every piece; `onEvents(events, decoder)` is called
   * after each piece that completed something. Resolves to all events.
   * @param {ReadableStream<Uint8Array>} stream
   * @param {(events: object[], decoder: PqmDecoder) => void} [onEvents]
   */
  async pushStream(stream, onEvents) {
    const reader = stream.getReader();
    const all = [];
    try {
      for (;;) {
        const { done, value } = await reader.read();
        if (done) break;
        const ev = this.push(value);
        if (ev.length) {
          all.push(...ev);
          if (onEvents) onEvents(ev, this);
        }
      }
    } finally {
      reader.releaseLock();
    }
    return all;
  }

  /**
   * Declares the input complete: throws a `truncated` error naming the
   * section still missing unless the whole file was read (the levels
   * decoded so far stay usable either way).
   */
  end() {
    if (this._failed) throw this._failed;
    const s = this.status();
    if (!s.finished) {
      throw new PqmError(
        'truncated',
        `input ends after ${this._consumed + this._queue.length} bytes while waiting for the ${s.waitingFor}`,
        { section: s.waitingFor },
      );
    }
  }

  /** Bytes the current stage needs, or null when the file is complete. */
  _need() {
    const h = this._header;
    switch (this._stage) {
      case 'prefix':
        return HEADER_PREFIX;
      case 'header':
        return this._stageArg;
      case 'table':
        return h.chunkCount * h.chunkEntryLen + 4;
      case 'base':
        return h.baseCompressedLen;
      case 'chunk':
        return this._chunks[this._stageArg].compressedLen;
      case 'sectionHead':
        return SECTION_HEADER_LEN;
      case 'sectionBody':
        return this._section.compressedLen;
      default:
        return null;
    }
  }

  _take(n) {
    this._consumed += n;
    return this._queue.take(n);
  }

  _run(events) {
    for (;;) {
      const need = this._need();
      if (need === null) {
        if (this._queue.length > 0) {
          throw invalid('trailer', `${this._queue.length} bytes after the end of the file`);
        }
        return;
      }
      if (this._queue.length < need) return;
      switch (this._stage) {
        case 'prefix':
          this._onPrefix(this._queue.peek(HEADER_PREFIX));
          break;
        case 'header':
          this._onHeader(this._take(need));
          break;
        case 'table':
          this._onTable(this._take(need));
          events.push({ type: 'headerReady' });
          break;
        case 'base':
          this._onBase(this._take(need));
          events.push({ type: 'baseMeshReady', level: 0 });
          this._afterChunks(0, events);
          break;
        case 'chunk': {
          const i = this._stageArg;
          this._onChunk(i, this._take(need));
          events.push({ type: 'chunkReady', chunk: i, level: this._chunks[i].level });
          this._afterChunks(i + 1, events);
          break;
        }
        case 'sectionHead': {
          const b = this._take(need);
          const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
          this._section = {
            tag: String.fromCharCode(b[0], b[1], b[2], b[3]),
            compressedLen: dv.getUint32(4, true),
            uncompressedLen: dv.getUint32(8, true),
            crc32: dv.getUint32(12, true),
          };
          this._stage = 'sectionBody';
          break;
        }
        case 'sectionBody': {
          const i = this._stageArg;
          this._onSection(i, this._section, this._take(need));
          events.push({ type: 'sectionReady', section: i, tag: this._section.tag });
          this._sectionsRead.push(this._section.tag);
          if (i + 1 < this._header.sectionCount) {
            this._stage = 'sectionHead';
            this._stageArg = i + 1;
          } else {
            this._finish(events);
          }
          break;
        }
        default:
          throw new PqmError('internal', `internal error: stage ${this._stage}`);
      }
    }
  }

  /** After the base (next = 0) or chunk next − 1: the next chunk, the sections or the end. */
  _afterChunks(next, events) {
    const h = this._header;
    if (next < h.chunkCount) {
      this._stage = 'chunk';
      this._stageArg = next;
    } else if (h.sectionCount > 0) {
      this._stage = 'sectionHead';
      this._stageArg = 0;
    } else {
      this._finish(events);
    }
  }

  /**
   * The end of the file: header flag bit 0 / 1 announces a `VORD` / `VNBR`
   * section, so one must have been read (spec §3, §8) — known only here,
   * since the sections come last.
   */
  _finish(events) {
    this._stage = 'done';
    for (const [bit, tag] of [
      [0, 'VORD'],
      [1, 'VNBR'],
    ]) {
      if ((this._header.flags & (1 << bit)) !== 0 && this._vertexOrderTag !== tag) {
        throw invalid('trailer', `header flag bit ${bit} announces a ${tag} section but the file has none`);
      }
    }
    events.push({ type: 'finished' });
  }

  _onPrefix(b) {
    for (let i = 0; i < 8; i++) {
      if (b[i] !== MAGIC[i]) {
        throw new PqmError('bad-magic', 'not a .pqm file (bad magic)', { section: 'header' });
      }
    }
    const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    const major = dv.getUint16(8, true);
    const minor = dv.getUint16(10, true);
    if (!VERSION_MAJORS.includes(major)) {
      throw new PqmError(
        'unsupported-version',
        `unsupported .pqm version ${major}.${minor} (this decoder reads 1.x to ${VERSION_MAJOR}.x)`,
        { section: 'header' },
      );
    }
    const len = dv.getUint32(12, true);
    if (len < HEADER_LEN || len > MAX_HEADER_LEN) {
      throw invalid('header', `header_len ${len} outside ${HEADER_LEN}..=${MAX_HEADER_LEN}`);
    }
    this._stage = 'header';
    this._stageArg = len;
  }

  _onHeader(b) {
    const len = b.length;
    const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    const stored = dv.getUint32(len - 4, true);
    const computed = crc32(b, 0, len - 4);
    if (stored !== computed) throw crcMismatch('header', stored, computed);
    const u32 = (o) => dv.getUint32(o, true);
    const h = {
      versionMajor: dv.getUint16(8, true),
      versionMinor: dv.getUint16(10, true),
      headerLen: u32(12),
      flags: u32(16),
      quantBits: b[20],
      chunkEntryLen: dv.getUint16(22, true),
      baseVertexCount: u32(24),
      baseFaceCount: u32(28),
      finalVertexCount: u32(32),
      finalFaceCount: u32(36),
      recordCount: u32(40),
      chunkCount: u32(44),
      sectionCount: u32(48),
      baseCompressedLen: u32(52),
      baseUncompressedLen: u32(56),
      baseCrc32: u32(60),
      bboxMin: [dv.getFloat64(64, true), dv.getFloat64(72, true), dv.getFloat64(80, true)],
      bboxMax: [dv.getFloat64(88, true), dv.getFloat64(96, true), dv.getFloat64(104, true)],
      baseError: dv.getFloat32(112, true),
    };
    // flag bit 0 announces a VORD section, bit 1 a VNBR one (spec §3, §8)
    h.hasVertexOrder = (h.flags & 3) !== 0;
    // flag bit 2: the exact bounds of every position any level shows (spec §3,
    // version 3.2); without it the grid is the bounding volume
    h.hasBounds = (h.flags & FLAG_BOUNDS) !== 0;
    // flag bit 3 (version 4.1): at the finest level each quad's v0-v2 diagonal
    // is the one meant (a triangle mesh paired into quads): a renderer or
    // exporter splits along it there rather than choosing
    h.finestDiagonals = (h.flags & 8) !== 0;
    const bad = (m) => invalid('header', m);
    if (h.hasBounds) {
      if (len < HEADER_LEN_BOUNDS) {
        throw bad(`flag bit 2 (bounds) set but header_len ${len} < ${HEADER_LEN_BOUNDS}`);
      }
      h.boundsMin = [dv.getFloat64(116, true), dv.getFloat64(124, true), dv.getFloat64(132, true)];
      h.boundsMax = [dv.getFloat64(140, true), dv.getFloat64(148, true), dv.getFloat64(156, true)];
    } else {
      h.boundsMin = h.bboxMin.slice();
      h.boundsMax = h.bboxMax.slice();
    }
    if (h.quantBits < 8 || h.quantBits > 24) throw bad(`quantization bits ${h.quantBits} outside 8..=24`);
    if (h.chunkEntryLen < CHUNK_ENTRY_LEN || h.chunkEntryLen > MAX_CHUNK_ENTRY_LEN) {
      throw bad(`chunk entry length ${h.chunkEntryLen} outside ${CHUNK_ENTRY_LEN}..=${MAX_CHUNK_ENTRY_LEN}`);
    }
    for (let k = 0; k < 3; k++) {
      const lo = h.bboxMin[k];
      const hi = h.bboxMax[k];
      if (!Number.isFinite(lo) || !Number.isFinite(hi) || lo > hi || !Number.isFinite(hi - lo)) {
        throw bad(`bounding box axis ${k} is [${lo}, ${hi}]`);
      }
    }
    if (h.hasBounds) {
      for (let k = 0; k < 3; k++) {
        const lo = h.boundsMin[k];
        const hi = h.boundsMax[k];
        if (!Number.isFinite(lo) || !Number.isFinite(hi) || lo > hi) {
          throw bad(`bounds axis ${k} is [${lo}, ${hi}]`);
        }
      }
    }
    if (h.baseVertexCount > h.finalVertexCount || h.baseFaceCount > h.finalFaceCount) {
      throw bad(
        `base counts (${h.baseVertexCount} vertices, ${h.baseFaceCount} faces) exceed the final counts (${h.finalVertexCount}, ${h.finalFaceCount})`,
      );
    }
    if (h.chunkCount > h.recordCount || (h.recordCount > 0 && h.chunkCount === 0)) {
      throw bad(`${h.chunkCount} chunks cannot hold ${h.recordCount} records`);
    }
    if (Number.isNaN(h.baseError) || h.baseError < 0) {
      throw bad(`base error ${h.baseError} is not a non-negative number`);
    }
    const lim = this.limits;
    if (h.finalVertexCount > lim.maxVertices) {
      throw limitsExceeded(`${h.finalVertexCount} vertices > maxVertices ${lim.maxVertices}`);
    }
    if (h.finalFaceCount > lim.maxFaces) {
      throw limitsExceeded(`${h.finalFaceCount} faces > maxFaces ${lim.maxFaces}`);
    }
    const est = estimateMemory(h.finalVertexCount, h.finalFaceCount, h.recordCount, h.baseUncompressedLen);
    if (est > lim.maxMemoryBytes) {
      throw limitsExceeded(`estimated memory ${est} bytes > maxMemoryBytes ${lim.maxMemoryBytes}`);
    }
    const qmax = 2 ** h.quantBits - 1;
    for (let k = 0; k < 3; k++) {
      this._min[k] = h.bboxMin[k];
      // spec §5: step = (max − min) / qmax, in f64
      this._step[k] = (h.bboxMax[k] - h.bboxMin[k]) / qmax;
    }
    this._header = Object.freeze(h);
    this._stage = 'table';
  }

  _onTable(b) {
    const h = this._header;
    const n = b.length - 4;
    const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    const stored = dv.getUint32(n, true);
    const computed = crc32(b, 0, n);
    if (stored !== computed) throw crcMismatch('chunk table', stored, computed);
    const bad = (m) => invalid('chunk table', m);
    let offset = BigInt(h.headerLen) + BigInt(n) + 4n + BigInt(h.baseCompressedLen);
    let records = 0;
    let v = h.baseVertexCount;
    let f = h.baseFaceCount;
    let err = h.baseError;
    let payload = h.baseUncompressedLen;
    const chunks = [];
    for (let i = 0; i < h.chunkCount; i++) {
      const o = i * h.chunkEntryLen;
      const e = {
        offset: dv.getBigUint64(o, true),
        compressedLen: dv.getUint32(o + 8, true),
        uncompressedLen: dv.getUint32(o + 12, true),
        recordCount: dv.getUint32(o + 16, true),
        vertexCount: dv.getUint32(o + 20, true),
        faceCount: dv.getUint32(o + 24, true),
        error: dv.getFloat32(o + 28, true),
        crc32: dv.getUint32(o + 32, true),
      };
      if (e.offset !== offset) throw bad(`chunk ${i} offset ${e.offset} != expected ${offset}`);
      if (e.recordCount === 0) throw bad(`chunk ${i} has no records`);
      if (e.vertexCount < v || e.faceCount < f) {
        throw bad(`chunk ${i} vertex/face counts decrease (${v} → ${e.vertexCount}, ${f} → ${e.faceCount})`);
      }
      if (Number.isNaN(e.error) || e.error < 0 || e.error > err) {
        throw bad(`chunk ${i} error ${e.error} is not in [0, ${err}]`);
      }
      records += e.recordCount;
      offset += BigInt(e.compressedLen);
      payload += e.uncompressedLen;
      v = e.vertexCount;
      f = e.faceCount;
      err = e.error;
      chunks.push(
        Object.freeze({
          index: i,
          offset: Number(e.offset),
          end: Number(offset),
          compressedLen: e.compressedLen,
          uncompressedLen: e.uncompressedLen,
          recordCount: e.recordCount,
          vertexCount: e.vertexCount,
          faceCount: e.faceCount,
          error: e.error,
          crc32: e.crc32,
          level: records, // level reached after this chunk
        }),
      );
    }
    if (records !== h.recordCount) {
      throw bad(`chunks hold ${records} records, the header says ${h.recordCount}`);
    }
    if (v !== h.finalVertexCount || f !== h.finalFaceCount) {
      throw bad(
        `chunks end at ${v} vertices and ${f} faces, the header says ${h.finalVertexCount} and ${h.finalFaceCount}`,
      );
    }
    const est = estimateMemory(h.finalVertexCount, h.finalFaceCount, h.recordCount, payload);
    if (est > this.limits.maxMemoryBytes) {
      throw limitsExceeded(`estimated memory ${est} bytes > maxMemoryBytes ${this.limits.maxMemoryBytes}`);
    }
    this._chunks = chunks;
    this._stage = 'base';
  }

  _onBase(b) {
    const h = this._header;
    const computed = crc32(b);
    if (computed !== h.baseCrc32) throw crcMismatch('base mesh', h.baseCrc32, computed);
    const nv = h.baseVertexCount;
    const nf = h.baseFaceCount;
    // The smallest payload that can hold the counts (spec §6): 4 F + 3 V
    // (delta layout); from version 4 a layout byte and, at the least, the
    // traversal layout's 2 F + 3 V (§6.1).
    const least = h.versionMajor >= 4 ? 1 + 2 * nf + 3 * nv : 4 * nf + 3 * nv;
    if (least > h.baseUncompressedLen) {
      throw invalid(
        'base mesh',
        `${nf} faces and ${nv} vertices need at least ${least} bytes, base_uncompressed_len is ${h.baseUncompressedLen}`,
      );
    }
    let payload;
    try {
      payload = decompressFrame(b, h.baseUncompressedLen);
    } catch (e) {
      if (typeof e === 'string') throw invalid('base mesh', e);
      throw e;
    }
    // Room for the file's final counts as far as the delivered bytes can
    // hold them (as _onChunk reserves: memory follows what was delivered)
    // for the frontier: a whole file is one allocation per frontier array,
    // not a base-sized one and then a copy into a final-sized one. (The
    // current level's arrays too, measured: same speed, but bunny decodes
    // then took 2,200–3,100 fresh pages from the kernel instead of
    // 1,050–3,000, glibc placing the arrays differently.)
    const got = this._consumed + this._queue.length;
    const capV = Math.max(nv, Math.min(h.finalVertexCount, got));
    const capF = Math.max(nf, Math.min(h.finalFaceCount, got));
    // A reset decoder's previous frontier takes the base (kept while the
    // base fails: the next reset hands it on again).
    const sp = this._spare;
    const st = decodeBase(payload, nv, nf, 2 ** h.quantBits - 1, capV, capF, h.versionMajor, sp.frontier);
    sp.frontier = null;
    st.maxV = h.finalVertexCount;
    st.maxF = h.finalFaceCount;
    this._log.maxLevels = h.recordCount + 1;
    this._frontier = st;
    this._log.pushLevel(nv, nf);
    // level 0 becomes the current level
    this._nv = nv;
    this._nf = nf;
    // (in a reset decoder's arrays of the previous file where they have
    // room: every element below the counts is written here, and none above
    // is read before a move writes it)
    this._q = codesOf(st.q, nv, takeSpare(sp.q, 3 * nv));
    this._qShared = false;
    this._pos = takeSpare(sp.pos, 3 * nv) ?? new Float32Array(3 * nv);
    this._dequantizeInto(this._pos, this._q, 0, nv);
    const quads = takeSpare(sp.quads, 4 * nf);
    if (quads === null) this._quads = st.f.slice(0, 4 * nf);
    else {
      quads.set(st.f.subarray(0, 4 * nf));
      this._quads = quads;
    }
    this._tris = takeSpare(sp.tris, 6 * nf) ?? new Uint32Array(6 * nf);
    sp.q = sp.pos = sp.quads = sp.tris = null;
    this._writeTrisRange(0, nf);
    this._level = 0;
  }

  _onChunk(i, b) {
    const info = this._chunks[i];
    const section = `chunk ${i}`;
    const computed = crc32(b);
    if (computed !== info.crc32) throw crcMismatch(section, info.crc32, computed, i);
    let payload;
    try {
      // one buffer for every chunk's payload (decodeChunk keeps none of it)
      const n = info.uncompressedLen;
      if (n > this._payload.length) this._payload = new Uint8Array(Math.max(n, 2 * this._payload.length));
      payload = decompressFrameInto(b, n, this._payload);
    } catch (e) {
      if (typeof e === 'string') throw invalid(section, e);
      throw e;
    }
    // Room for the file's final counts up front, as far as the delivered
    // bytes can hold them (at most one vertex and one face per byte of the
    // file received so far: memory still follows what was delivered, not
    // what the header claims). A whole file is then one allocation per
    // frontier array instead of ×4 steps, each a copy and fresh pages.
    const st = this._frontier;
    const h = this._header;
    const got = this._consumed + this._queue.length;
    const nv = Math.min(h.finalVertexCount, got);
    const nf = Math.min(h.finalFaceCount, got);
    st.reserve(nv, nf);
    const log = this._log;
    // (the one-way log's rw holds this chunk's entries only)
    const nApp = this._forward ? Math.min(info.faceCount, nf) - st.nf : nf - h.baseFaceCount;
    log.reserve(Math.min(h.recordCount + 1, got), nApp);
    decodeChunk(payload, i, info, st, log, h);
    this._chunksReady = i + 1;
    if (this._forward) this._dropChunkLog();
  }

  /**
   * Forward-only, after a chunk commits: keeps of its log only the ids the
   * next move's Change reports (below the current level's counts, each
   * once), then empties the log, so its buffers are reused by the next
   * chunk and stay the size of one chunk's entries.
   */
  _dropChunkLog() {
    const log = this._log;
    const vl = this._nv;
    const fl = this._nf;
    if (this._pendEpoch === 0) this._pendEpoch = this._nextEpoch(vl, fl);
    const epoch = this._pendEpoch;
    const vMark = this._vMark;
    const fMark = this._fMark;
    const M = log.moved;
    const R = log.rw;
    let moved = this._pendMoved;
    let n = this._nPendMoved;
    for (let e = 0; e < log.nMoved; e++) {
      const v = M[4 * e];
      if (v < vl && vMark[v] !== epoch) {
        vMark[v] = epoch;
        if (n === moved.length) moved = this._pendMoved = ensure(moved, n + 1);
        moved[n++] = v;
      }
    }
    this._nPendMoved = n;
    let rw = this._pendRw;
    n = this._nPendRw;
    for (let e = 0; e < log.nRw; e++) {
      const s = R[2 * e] >> 2;
      if (s < fl && fMark[s] !== epoch) {
        fMark[s] = epoch;
        if (n === rw.length) rw = this._pendRw = ensure(rw, n + 1);
        rw[n++] = s;
      }
    }
    this._nPendRw = n;
    log.nMoved = 0;
    log.nRw = 0;
  }

  _onSection(i, sec, b) {
    const section = `optional section ${i} (${JSON.stringify(sec.tag)})`;
    const computed = crc32(b);
    if (computed !== sec.crc32) throw crcMismatch(section, sec.crc32, computed);
    // VORD (deltas, §8.1) and VNBR (coded against the mesh, §8.2, version
    // 3.1) give the same permutation; others are skipped (spec §8).
    const neighbours = sec.tag === 'VNBR';
    if (sec.tag !== 'VORD' && !neighbours) return;
    // Flag bit 0 / 1 is set if and only if the file holds a VORD / VNBR
    // section, and a file holds at most one of them (spec §3, §8).
    const bit = neighbours ? 1 : 0;
    if ((this._header.flags & (1 << bit)) === 0) {
      throw invalid(section, `a ${sec.tag} section is present but header flag bit ${bit} is clear`);
    }
    if (this._vertexOrderTag !== null) {
      throw invalid(section, `a second vertex-order section (${sec.tag}; a file holds at most one VORD or VNBR)`);
    }
    const n = this._header.finalVertexCount;
    // VORD: each entry is one varint of 1 to 10 bytes (spec §1); VNBR: one
    // symbol byte per vertex and at most one rank varint per vertex. Bound
    // the payload before allocating for it.
    const max = (neighbours ? 11 : 10) * n;
    if (sec.uncompressedLen < n || sec.uncompressedLen > max) {
      throw invalid(
        section,
        `${sec.tag} uncompressed length ${sec.uncompressedLen} outside ${n}..=${max} for ${n} vertices`,
      );
    }
    // The section's buffer and working arrays count against the memory
    // budget, which the header and table checks did not cover (the same
    // estimate as the Rust decoder's): VORD 5 bytes per vertex, VNBR at most
    // 48 per vertex and 64 per quad.
    const h = this._header;
    let payloadTotal = h.baseUncompressedLen + sec.uncompressedLen;
    for (const c of this._chunks) payloadTotal += c.uncompressedLen;
    const est =
      estimateMemory(n, h.finalFaceCount, h.recordCount, payloadTotal) +
      (neighbours ? 48 * n + 64 * h.finalFaceCount : 5 * n);
    if (est > this.limits.maxMemoryBytes) {
      throw limitsExceeded(
        `${sec.tag} section: estimated memory ${est} bytes > maxMemoryBytes ${this.limits.maxMemoryBytes}`,
      );
    }
    // The frame's structure is cheap to check now; decompressing and the
    // permutation wait until the order is first read (spec §8: a reader may
    // defer them). The bytes are copied: they may view the caller's buffer.
    try {
      checkFrameHeader(b, sec.uncompressedLen);
    } catch (e) {
      if (typeof e === 'string') throw invalid(section, e);
      throw e;
    }
    this._vertexOrderTag = sec.tag;
    this._vertexOrderSection = { section, bytes: b.slice(), uncompressedLen: sec.uncompressedLen };
  }

  /** Decodes the kept vertex-order section (see `vertexOrder`). */
  _decodeVertexOrder() {
    const { section, bytes, uncompressedLen } = this._vertexOrderSection;
    const n = this._header.finalVertexCount;
    try {
      const payload = decompressFrame(bytes, uncompressedLen);
      if (this._vertexOrderTag === 'VNBR') {
        // Sections come after the last chunk and nothing changes the
        // frontier after it: it is the finest level whatever level the
        // caller shows.
        const st = this._frontier;
        return decodeVnbr(payload, n, st.f, st.nf, this._header.baseVertexCount);
      }
      const r = new Reader(payload, 0, payload.length, 'VORD');
      const order = new Uint32Array(n);
      const seen = new Uint8Array(n);
      let prev = 0;
      for (let k = 0; k < n; k++) {
        const v = prev + r.s();
        if (v < 0 || v >= n || seen[v]) throw `VORD entry ${k} = ${v} is out of range or repeated`;
        seen[v] = 1;
        order[k] = v;
        prev = v;
      }
      if (r.remaining() !== 0) throw `${r.remaining()} unused bytes in VORD`;
      return order;
    } catch (e) {
      if (typeof e === 'string') throw invalid(section, e);
      throw e;
    }
  }

  // ---- navigation ------------------------------------------------------------

  /** The current level. */
  get level() {
    return this._level;
  }

  /** Deepest level reachable now (null before the base mesh). */
  get deepestLevel() {
    return this._log.levels > 0 ? this._log.levels - 1 : null;
  }

  /** The finest level of the file (null before the header). */
  get finalLevel() {
    return this._header ? this._header.recordCount : null;
  }

  /**
   * Resolves a target among the decoded levels:
   * - `{level: k}` (or a number): level `k`, clamped to the deepest decoded;
   * - `{faces: n}`: the finest decoded level with at most `n` faces (level 0
   *   if none);
   * - `{error: e}`: the coarsest chunk boundary (or level 0) whose geometric
   *   error is ≤ `e`; the deepest decoded level if none is.
   * @returns {number} a level
   */
  resolve(target) {
    const deepest = this.deepestLevel;
    if (deepest === null) {
      throw new PqmError('parameter', 'no level is available before the base mesh is decoded');
    }
    const t = typeof target === 'number' ? { level: target } : target;
    const keys = t && typeof t === 'object' ? Object.keys(t).filter((k) => t[k] !== undefined) : [];
    if (keys.length !== 1 || !['level', 'faces', 'error'].includes(keys[0])) {
      throw new PqmError('parameter', 'a target is {level}, {faces} or {error}');
    }
    const x = t[keys[0]];
    if (typeof x !== 'number' || Number.isNaN(x) || x < 0) {
      throw new PqmError('parameter', `target ${keys[0]} must be a non-negative number, got ${x}`);
    }
    if (keys[0] === 'level') return Math.min(Math.floor(x), deepest);
    if (keys[0] === 'faces') {
      // face counts never decrease with the level: binary search
      const fAt = this._log.fAt;
      let lo = 0;
      let hi = deepest + 1; // first level with more than x faces
      while (lo < hi) {
        const mid = (lo + hi) >> 1;
        if (fAt[mid] <= x) lo = mid + 1;
        else hi = mid;
      }
      return Math.max(lo - 1, 0);
    }
    if (this._header.baseError <= x) return 0;
    for (let c = 0; c < this._chunksReady; c++) {
      if (this._chunks[c].error <= x) return this._chunks[c].level;
    }
    return deepest;
  }

  /** Goes to `target` if that is finer than the current level (else no change). */
  refineTo(target) {
    return this._goTo(Math.max(this.resolve(target), this._level));
  }

  /** Goes to `target` if that is coarser than the current level (else no change). */
  coarsenTo(target) {
    return this._goTo(Math.min(this.resolve(target), this._level));
  }

  /** Goes to `target`, refining or coarsening. */
  setLevel(target) {
    return this._goTo(this.resolve(target));
  }

  /**
   * A change that uploads the whole current level into empty buffers: what a
   * renderer applies once, when `baseMeshReady` arrives or after it recreates
   * its buffers.
   */
  fullUpload() {
    return new Change({
      fromLevel: this._level,
      toLevel: this._level,
      verticesAppended: range(0, this._nv),
      verticesRemoved: range(this._nv, this._nv),
      verticesMoved: new Uint32Array(0),
      facesRewritten: new Uint32Array(0),
      facesAppended: range(0, this._nf),
      facesTruncated: range(this._nf, this._nf),
    });
  }

  _goTo(to) {
    if (this._forward) return this._forwardTo(to);
    const from = this._level;
    const log = this._log;
    const vFrom = log.vAt[from];
    const vTo = log.vAt[to];
    const fFrom = log.fAt[from];
    const fTo = log.fAt[to];
    const bv = log.vAt[0];
    const bf = log.fAt[0];
    // Only ids below the smaller count are reported as moved / rewritten
    // (and need their positions / triangles recomputed one by one): the
    // appended range is recomputed in bulk, the removed one is never read.
    const vMin = Math.min(vFrom, vTo);
    const fMin = Math.min(fFrom, fTo);
    const M = log.moved;
    const R = log.rw;
    // Marks: a vertex / slot below vMin / fMin touched by a logged entry is
    // collected once (stamp = this move's epoch), so repeated entries cost
    // no sort or dedupe later.
    const epoch = this._nextEpoch(vMin, fMin);
    const vMark = this._vMark;
    const fMark = this._fMark;
    let moved = this._movedScratch;
    let rewritten = this._rwScratch;
    let nMoved = 0;
    let nRw = 0;
    if (to > from && to === log.levels - 1 && this._failed === null) {
      // To the deepest decoded level, which is the frontier (no chunk has
      // failed half-applied): its codes and quads are copied as the
      // forward-only move does, not rebuilt from the log's first states and
      // changes; the log is only scanned for the ids the Change reports.
      // Once every chunk is decoded the frontier never changes again, so
      // the current level's quads are the frontier's own (no copy; a later
      // coarsening copies them first, `_ownQuads`).
      // Likewise its codes are the frontier's records' (no copy into `_q`:
      // bunny 2.5 MB written and as many fresh pages; `_ownCodes` copies
      // them when a later move or a caller needs them as an array).
      const st = this._frontier;
      const final = this._chunksReady === this._chunks.length;
      if (final) this._quads = st.f;
      if (!final) this._ownCodes();
      this._qShared = final;
      this._reserve(vTo, fTo);
      const qq = final ? null : this._q;
      const quads = final ? null : this._quads;
      const sq = st.q;
      const sf = st.f;
      for (let e = log.movedAt[from], end = log.movedAt[to]; e < end; e++) {
        const v = M[4 * e];
        if (v < vMin && vMark[v] !== epoch) {
          vMark[v] = epoch;
          if (nMoved === moved.length) moved = this._movedScratch = ensure(moved, nMoved + 1);
          moved[nMoved++] = v;
          copyVertices(qq, this._pos, sq, v, v + 1, this._min, this._step);
        }
      }
      for (let e = log.rwAt[from], end = log.rwAt[to]; e < end; e++) {
        const s = R[2 * e] >> 2;
        if (s < fMin && fMark[s] !== epoch) {
          fMark[s] = epoch;
          if (nRw === rewritten.length) rewritten = this._rwScratch = ensure(rewritten, nRw + 1);
          rewritten[nRw++] = s;
          if (quads !== null) {
            quads[4 * s] = sf[4 * s];
            quads[4 * s + 1] = sf[4 * s + 1];
            quads[4 * s + 2] = sf[4 * s + 2];
            quads[4 * s + 3] = sf[4 * s + 3];
          }
        }
      }
      copyVertices(qq, this._pos, sq, vFrom, vTo, this._min, this._step);
      copyQuads(quads, this._tris, sf, fFrom, fTo);
    } else if (to > from) {
      this._firstStates();
      this._ownCodes();
      this._reserve(vTo, fTo);
      const qq = this._q;
      const quads = this._quads;
      // Bulk: the first codes of the appended vertices and the first quads
      // of the appended slots. A later record's move / rewrite of one of
      // them is applied below, in record order, after this copy.
      qq.set(log.newCodes.subarray(3 * (vFrom - bv), 3 * (vTo - bv)), 3 * vFrom);
      quads.set(log.app.subarray(4 * (fFrom - bf), 4 * (fTo - bf)), 4 * fFrom);
      for (let e = log.movedAt[from], end = log.movedAt[to]; e < end; e++) {
        const v = M[4 * e];
        qq[3 * v] += M[4 * e + 1];
        qq[3 * v + 1] += M[4 * e + 2];
        qq[3 * v + 2] += M[4 * e + 3];
        if (v < vMin && vMark[v] !== epoch) {
          vMark[v] = epoch;
          if (nMoved === moved.length) moved = this._movedScratch = ensure(moved, nMoved + 1);
          moved[nMoved++] = v;
        }
      }
      for (let e = log.rwAt[from], end = log.rwAt[to]; e < end; e++) {
        const c = R[2 * e];
        const s = c >> 2;
        quads[c] ^= R[2 * e + 1];
        if (s < fMin && fMark[s] !== epoch) {
          fMark[s] = epoch;
          if (nRw === rewritten.length) rewritten = this._rwScratch = ensure(rewritten, nRw + 1);
          rewritten[nRw++] = s;
        }
      }
      this._dequantizeInto(this._pos, qq, vFrom, vTo);
      this._writeTrisRange(fFrom, fTo);
    } else if (to < from) {
      const quads = this._ownQuads();
      const q = this._ownCodes();
      // Undo in reverse record order; truncation is implicit (ids ≥ vTo /
      // slots ≥ fTo are never read), so entries of those are skipped.
      for (let e = log.movedAt[from] - 1, end = log.movedAt[to]; e >= end; e--) {
        const v = M[4 * e];
        if (v >= vTo) continue;
        q[3 * v] -= M[4 * e + 1];
        q[3 * v + 1] -= M[4 * e + 2];
        q[3 * v + 2] -= M[4 * e + 3];
        if (vMark[v] !== epoch) {
          vMark[v] = epoch;
          if (nMoved === moved.length) moved = this._movedScratch = ensure(moved, nMoved + 1);
          moved[nMoved++] = v;
        }
      }
      for (let e = log.rwAt[from] - 1, end = log.rwAt[to]; e >= end; e--) {
        const c = R[2 * e];
        const s = c >> 2;
        if (s >= fTo) continue;
        quads[c] ^= R[2 * e + 1];
        if (fMark[s] !== epoch) {
          fMark[s] = epoch;
          if (nRw === rewritten.length) rewritten = this._rwScratch = ensure(rewritten, nRw + 1);
          rewritten[nRw++] = s;
        }
      }
    }
    const movedSorted = moved.slice(0, nMoved).sort();
    const rwSorted = rewritten.slice(0, nRw).sort();
    // positions and triangles of what exists before and after and changed
    // (the move to the final frontier wrote its moved positions already)
    const pos = this._pos;
    const qq = this._q;
    const [x0, y0, z0] = this._min;
    const [sx, sy, sz] = this._step;
    for (let i = 0; i < nMoved && !this._qShared; i++) {
      const o = 3 * movedSorted[i];
      pos[o] = x0 + qq[o] * sx;
      pos[o + 1] = y0 + qq[o + 1] * sy;
      pos[o + 2] = z0 + qq[o + 2] * sz;
    }
    for (let i = 0; i < nRw; i++) this._writeTrisRange(rwSorted[i], rwSorted[i] + 1);
    this._level = to;
    this._nv = vTo;
    this._nf = fTo;
    return new Change({
      fromLevel: from,
      toLevel: to,
      verticesAppended: range(vMin, vTo),
      verticesRemoved: range(vTo, Math.max(vFrom, vTo)),
      verticesMoved: movedSorted,
      facesRewritten: rwSorted,
      facesAppended: range(fMin, fTo),
      facesTruncated: range(fTo, Math.max(fFrom, fTo)),
    });
  }

  /**
   * Forward-only move: to the deepest decoded level, which is the
   * frontier, so the current level copies the frontier's codes and quads of
   * what the committed chunks appended, moved or rewrote since the last
   * move (the pending ids, collected when each chunk committed). The same
   * level and Change as the general decoder's move.
   */
  _forwardTo(to) {
    const from = this._level;
    const deepest = this.deepestLevel;
    if (to !== from && (to < from || to !== deepest)) {
      throw new PqmError(
        'parameter',
        `a forward-only decoder moves only to the deepest decoded level (${deepest}), not from level ${from} to ${to}`,
      );
    }
    const st = this._frontier;
    const vFrom = this._nv;
    const fFrom = this._nf;
    const vTo = to === from ? vFrom : st.nv;
    const fTo = to === from ? fFrom : st.nf;
    const movedSorted = this._pendMoved.slice(0, to === from ? 0 : this._nPendMoved).sort();
    const rwSorted = this._pendRw.slice(0, to === from ? 0 : this._nPendRw).sort();
    if (to !== from) {
      // Once every chunk is decoded the frontier never changes again, so the
      // current level's quads can be the frontier's own: no copy, and no
      // fresh pages for one (bunny: 3.3 MB, ≈ 800 page faults).
      // Its codes likewise (`_qShared`: read from the frontier's records
      // until `_ownCodes` copies them).
      const final = this._chunksReady === this._chunks.length;
      if (final) this._quads = st.f;
      this._qShared = final;
      this._reserve(vTo, fTo);
      // One pass per buffer pair, straight from the frontier: each code is
      // copied and dequantized in the same step, each quad copied and split
      // into its triangles (not a copy, then a second pass over the copy).
      const qq = final ? null : this._q;
      copyVertices(qq, this._pos, st.q, vFrom, vTo, this._min, this._step);
      for (let i = 0; i < movedSorted.length; i++) {
        const v = movedSorted[i];
        copyVertices(qq, this._pos, st.q, v, v + 1, this._min, this._step);
      }
      const quads = final ? null : this._quads;
      copyQuads(quads, this._tris, st.f, fFrom, fTo);
      for (let i = 0; i < rwSorted.length; i++) {
        const s = rwSorted[i];
        copyQuads(quads, this._tris, st.f, s, s + 1);
      }
      this._nPendMoved = 0;
      this._nPendRw = 0;
      this._pendEpoch = 0;
      this._level = to;
      this._nv = vTo;
      this._nf = fTo;
    }
    return new Change({
      fromLevel: from,
      toLevel: to,
      verticesAppended: range(vFrom, vTo),
      verticesRemoved: range(vTo, vTo),
      verticesMoved: movedSorted,
      facesRewritten: rwSorted,
      facesAppended: range(fFrom, fTo),
      facesTruncated: range(fTo, fTo),
    });
  }

  /**
   * A fresh stamp for the vertex / slot marks, which grow to hold `nv`
   * vertices and `nf` slots (like every buffer: with what was decoded, not
   * with what the header claims; new marks are 0, never a live stamp).
   * When the counter wraps the marks are cleared.
   */
  _nextEpoch(nv, nf) {
    const h = this._header;
    this._vMark = ensure(this._vMark, nv, this._vMark.length, h.finalVertexCount);
    this._fMark = ensure(this._fMark, nf, this._fMark.length, h.finalFaceCount);
    if (this._epoch === 0xffffffff) {
      this._vMark.fill(0);
      this._fMark.fill(0);
      this._epoch = 0;
    }
    return ++this._epoch;
  }

  /**
   * Builds the log's first states (`newCodes`, `app`: RecordLog) up to the
   * frontier, the deepest decoded level: the codes and quads of what was
   * appended since the last build, as the frontier has them, with every
   * later change undone, newest first. Every entry naming such an id was
   * logged after the id was appended (ids only grow), and so after the last
   * build: only the entries since then are read. O(what was decoded since
   * the last build).
   */
  _firstStates() {
    const log = this._log;
    const st = this._frontier;
    const bv = log.vAt[0];
    const bf = log.fAt[0];
    const v0 = bv + log.nNew;
    const f0 = bf + log.nApp;
    const v1 = st.nv;
    const f1 = st.nf;
    if (v1 > v0) {
      const C = (log.newCodes = ensure(log.newCodes, 3 * (v1 - bv), 3 * log.nNew, 3 * st.maxV));
      const q = st.q;
      for (let v = v0; v < v1; v++) {
        const o = 3 * (v - bv);
        C[o] = q[16 * v];
        C[o + 1] = q[16 * v + 1];
        C[o + 2] = q[16 * v + 2];
      }
      const M = log.moved;
      for (let e = log.nMoved - 1; e >= log.movedBuilt; e--) {
        const v = M[4 * e];
        if (v < v0) continue;
        const o = 3 * (v - bv);
        C[o] -= M[4 * e + 1];
        C[o + 1] -= M[4 * e + 2];
        C[o + 2] -= M[4 * e + 3];
      }
    }
    if (f1 > f0) {
      const A = (log.app = ensure(log.app, 4 * (f1 - bf), 4 * log.nApp, 4 * st.maxF));
      const f = st.f;
      A.set(f.subarray(4 * f0, 4 * f1), 4 * (f0 - bf));
      const R = log.rw;
      for (let e = log.nRw - 1; e >= log.rwBuilt; e--) {
        const c = R[2 * e];
        if (c < 4 * f0) continue;
        A[c - 4 * bf] ^= R[2 * e + 1];
      }
    }
    log.nNew = v1 - bv;
    log.nApp = f1 - bf;
    log.movedBuilt = log.nMoved;
    log.rwBuilt = log.nRw;
  }

  /**
   * The current level's quads as a buffer of the decoder's own: when they
   * are the frontier's (general decoder at the final level), a copy first,
   * since the frontier must stay the finest level (VNBR reads it).
   */
  _ownQuads() {
    const f = this._frontier;
    if (f !== null && this._quads === f.f) this._quads = f.f.slice(0, 4 * this._nf);
    return this._quads;
  }

  /**
   * The current level's codes as an array of the decoder's own (3 per
   * vertex): when they are the final frontier's (`_qShared`), copied from
   * its vertex records first.
   */
  _ownCodes() {
    if (this._qShared) {
      this._q = codesOf(this._frontier.q, this._nv);
      this._qShared = false;
    }
    return this._q;
  }

  /**
   * Grows the current-level buffers to hold `nv` vertices and `nf` faces
   * (the codes unless they are the frontier's, `_qShared`).
   */
  _reserve(nv, nf) {
    const v = this._nv;
    const f = this._nf;
    const mv = this._header.finalVertexCount;
    const mf = this._header.finalFaceCount;
    if (!this._qShared) this._q = ensure(this._q, 3 * nv, 3 * v, 3 * mv);
    this._pos = ensure(this._pos, 3 * nv, 3 * v, 3 * mv);
    this._quads = ensure(this._quads, 4 * nf, 4 * f, 4 * mf);
    this._tris = ensure(this._tris, 6 * nf, 6 * f, 6 * mf);
  }

  /** f32 positions of vertices `a .. b` from their codes (spec §5). */
  _dequantizeInto(out, q, a, b) {
    const [x0, y0, z0] = this._min;
    const [sx, sy, sz] = this._step;
    for (let v = a; v < b; v++) {
      const o = 3 * v;
      out[o] = x0 + q[o] * sx;
      out[o + 1] = y0 + q[o + 1] * sy;
      out[o + 2] = z0 + q[o + 2] * sz;
    }
  }

  /** Triangles 2s, 2s + 1 of every slot s in `a .. b` from its quad. */
  _writeTrisRange(a, b) {
    const q = this._quads;
    const t = this._tris;
    for (let s = a; s < b; s++) {
      quadTriangles(t, s, q[4 * s], q[4 * s + 1], q[4 * s + 2], q[4 * s + 3]);
    }
  }

  // ---- access ----------------------------------------------------------------

  /**
   * The header (after `headerReady`), or null. Field names are the spec's, in
   * camelCase (`bboxMin`, `bboxMax`: the quantization grid). `boundsMin` /
   * `boundsMax` (3 numbers each) bound every position of every level: the
   * header's bounds when `hasBounds` (flag bit 2, version 3.2; exact), else
   * copies of the grid box (which `min + q × step` can pass by an ulp at the
   * max end, spec §5). `hasVertexOrder`: flag bit 0 or 1.
   */
  get header() {
    return this._header;
  }

  /**
   * The chunk table (empty before `headerReady`): per chunk `offset`, `end`
   * (file offset one past it), `compressedLen`, `uncompressedLen`,
   * `recordCount`, `vertexCount`, `faceCount`, `error`, `crc32` and `level`
   * (the level reached after it).
   */
  get chunks() {
    return this._chunks;
  }

  /**
   * Bytes of the file needed to reach a target — `{level}`, `{faces}` (the
   * finest level with at most that many faces) or `{error}` (the first
   * chunk boundary with error ≤ e): the end offset of the chunk that gets
   * there (the end of the base section for level 0), for an HTTP Range
   * request. Needs only the header and chunk table.
   */
  bytesFor(target) {
    const h = this._header;
    if (!h) throw new PqmError('parameter', 'bytesFor() needs the header and chunk table');
    const baseEnd = h.headerLen + h.chunkCount * h.chunkEntryLen + 4 + h.baseCompressedLen;
    const t = typeof target === 'number' ? { level: target } : target;
    const cs = this._chunks;
    const lastEnd = cs.length ? cs[cs.length - 1].end : baseEnd;
    const endOf = (c) => (c ? c.end : lastEnd);
    if (t && t.level !== undefined) {
      return t.level <= 0 ? baseEnd : endOf(cs.find((c) => c.level >= t.level));
    }
    if (t && t.faces !== undefined) {
      // The finest level with at most n faces lies before the first chunk
      // that ends above n, or inside it: that chunk is needed.
      if (h.baseFaceCount > t.faces) return baseEnd;
      return endOf(cs.find((c) => c.faceCount > t.faces));
    }
    if (t && t.error !== undefined) {
      if (h.baseError <= t.error) return baseEnd;
      return endOf(cs.find((c) => c.error <= t.error));
    }
    throw new PqmError('parameter', 'a target is {level}, {faces} or {error}');
  }

  /** Vertex count of the current level. */
  get vertexCount() {
    return this._nv;
  }

  /** Face (quad) count of the current level. */
  get faceCount() {
    return this._nf;
  }

  /**
   * Positions of the current level, x y z per vertex, as f32 (the f64 of
   * spec §5 rounded to nearest). A view: read it again after each change.
   * @returns {Float32Array}
   */
  get positions() {
    return this._pos.subarray(0, 3 * this._nv);
  }

  /**
   * Positions of the current level in f64, exactly as spec §5 dequantizes
   * (bit-identical to every conforming decoder). A new array.
   * @returns {Float64Array}
   */
  positionsF64() {
    const n = this._nv;
    const out = new Float64Array(3 * n);
    const q = this._ownCodes();
    const [x0, y0, z0] = this._min;
    const [sx, sy, sz] = this._step;
    for (let o = 0; o < 3 * n; o += 3) {
      out[o] = x0 + q[o] * sx;
      out[o + 1] = y0 + q[o + 1] * sy;
      out[o + 2] = z0 + q[o + 2] * sz;
    }
    return out;
  }

  /** Quantization codes of the current level, 3 per vertex (a view). */
  get positionCodes() {
    return this._ownCodes().subarray(0, 3 * this._nv);
  }

  /** Quads of the current level, 4 vertex ids per slot, counter-clockwise (a view). */
  get quads() {
    return this._quads.subarray(0, 4 * this._nf);
  }

  /**
   * Triangle index buffer of the current level: quad slot `f` is triangles
   * `2f = (v0, v1, v2)` and `2f + 1 = (v0, v2, v3)` (a view).
   */
  get triangleIndices() {
    return this._tris.subarray(0, 6 * this._nf);
  }

  /** `[vertexCount, faceCount]` of level `k`, or null if not decoded. */
  levelCounts(k) {
    if (!(k >= 0 && k < this._log.levels)) return null;
    return [this._log.vAt[k], this._log.fAt[k]];
  }

  /**
   * The input vertex order (canonical id → input vertex index at the finest
   * level), or null until a `VORD` or `VNBR` section has arrived (and for
   * files without one).
   *
   * The section is decoded on the first read, not when it arrives (only
   * exporters need the order); later reads return the same array. A bad
   * section then throws a PqmError (kind 'invalid', naming the section), on
   * every read; it affects only the order, never the levels (spec §8).
   * @type {Uint32Array | null}
   */
  get vertexOrder() {
    if (this._vertexOrderSection === null) return null;
    if (this._vertexOrder === null && this._vertexOrderError === null) {
      try {
        this._vertexOrder = this._decodeVertexOrder();
      } catch (e) {
        this._vertexOrderError = e;
      }
    }
    if (this._vertexOrderError !== null) throw this._vertexOrderError;
    return this._vertexOrder;
  }

  /** The quantization grid: `{bits, qmax, min, step}` (after the header). */
  get grid() {
    const h = this._header;
    if (!h) return null;
    return { bits: h.quantBits, qmax: 2 ** h.quantBits - 1, min: [...this._min], step: [...this._step] };
  }

  /**
   * Progress: bytes consumed and buffered, what is decoded, the section being
   * waited for and the bytes it still needs.
   */
  status() {
    const h = this._header;
    let waitingFor = null;
    if (!this._failed) {
      switch (this._stage) {
        case 'prefix':
        case 'header':
          waitingFor = 'header';
          break;
        case 'table':
          waitingFor = 'chunk table';
          break;
        case 'base':
          waitingFor = 'base mesh';
          break;
        case 'chunk':
          waitingFor = `chunk ${this._stageArg}`;
          break;
        case 'sectionHead':
        case 'sectionBody':
          waitingFor = `optional section ${this._stageArg}`;
          break;
        default:
          waitingFor = null;
      }
    }
    const need = this._need();
    return {
      bytesConsumed: this._consumed,
      bytesBuffered: this._queue.length,
      headerReady: this._chunks.length > 0 || !['prefix', 'header', 'table'].includes(this._stage),
      baseReady: this._log.levels > 0,
      chunksReady: this._chunksReady,
      chunkCount: h ? h.chunkCount : null,
      deepestLevel: this.deepestLevel,
      finalLevel: this.finalLevel,
      waitingFor,
      bytesNeeded:
        waitingFor !== null && this._stage !== 'prefix' && need !== null
          ? Math.max(0, need - this._queue.length)
          : null,
      finished: this._stage === 'done' && !this._failed,
      failed: this._failed !== null,
      error: this._failed,
    };
  }
}

/**
 * The codes of vertices 0..n (3 per vertex) out of the frontier's vertex
 * records, which keep each code in the first 3 of 16 ints (codec.js).
 */
function codesOf(sq, n, into = null) {
  const q = into ?? new Uint32Array(3 * n);
  for (let v = 0; v < n; v++) {
    q[3 * v] = sq[16 * v];
    q[3 * v + 1] = sq[16 * v + 1];
    q[3 * v + 2] = sq[16 * v + 2];
  }
  return q;
}

/** `arr` if it is not null and holds `n` elements (a spare of `reset`), else null. */
function takeSpare(arr, n) {
  return arr !== null && arr.length >= n ? arr : null;
}

/**
 * Codes of vertices `a .. b` from the frontier's vertex records (16 ints
 * each, code first) into `q` (3 per vertex; unless null: the current
 * level's codes are the records themselves) and their f32 positions (spec
 * §5: min + code · step, in f64, then rounded) into `pos`.
 */
function copyVertices(q, pos, sq, a, b, min, step) {
  const x0 = min[0], y0 = min[1], z0 = min[2];
  const sx = step[0], sy = step[1], sz = step[2];
  if (q === null) {
    for (let v = a; v < b; v++) {
      const o = 3 * v;
      const i = 16 * v;
      pos[o] = x0 + sq[i] * sx;
      pos[o + 1] = y0 + sq[i + 1] * sy;
      pos[o + 2] = z0 + sq[i + 2] * sz;
    }
    return;
  }
  for (let v = a; v < b; v++) {
    const o = 3 * v;
    const i = 16 * v;
    const x = sq[i], y = sq[i + 1], z = sq[i + 2];
    q[o] = x;
    q[o + 1] = y;
    q[o + 2] = z;
    pos[o] = x0 + x * sx;
    pos[o + 1] = y0 + y * sy;
    pos[o + 2] = z0 + z * sz;
  }
}

/**
 * Quads of slots `a .. b` from the frontier's `sf` into `quads` (unless
 * null: the current level's quads are `sf` itself) and their triangles
 * into `tris`.
 */
function copyQuads(quads, tris, sf, a, b) {
  if (quads === null) {
    for (let s = a; s < b; s++) {
      const i = 4 * s;
      quadTriangles(tris, s, sf[i], sf[i + 1], sf[i + 2], sf[i + 3]);
    }
    return;
  }
  for (let s = a; s < b; s++) {
    const i = 4 * s;
    const v0 = sf[i], v1 = sf[i + 1], v2 = sf[i + 2], v3 = sf[i + 3];
    quads[i] = v0;
    quads[i + 1] = v1;
    quads[i + 2] = v2;
    quads[i + 3] = v3;
    quadTriangles(tris, s, v0, v1, v2, v3);
  }
}

/** Slot `s`'s two triangles (v0 v1 v2) and (v0 v2 v3) into `tris` (6 per slot). */
function quadTriangles(tris, s, v0, v1, v2, v3) {
  const t = 6 * s;
  tris[t] = v0;
  tris[t + 1] = v1;
  tris[t + 2] = v2;
  tris[t + 3] = v0;
  tris[t + 4] = v2;
  tris[t + 5] = v3;
}

/**
 * Decodes a complete file held in memory: every level is available, the
 * current level is 0. A file that ends early throws a `truncated` error.
 * @param {Uint8Array} bytes
 * @param {{limits?: object}} [options]
 */
export function decodeAll(bytes, options) {
  const d = new PqmDecoder(options);
  d.push(bytes);
  d.end();
  return d;
}
