/**
 * Fetches a `.pqm` file over HTTP with Range requests that stop where the
 * chunk table says a target is reached (a face count, a screen-space /
 * geometric error, a level), so a client that wants 20k faces of a 2M-face
 * file downloads only the bytes up to the chunk that gets there.
 *
 * ```js
 * const src = new PqmRangeLoader('bunny.pqm');
 * const dec = await src.load({ faces: 20000 }); // header + table, then bytes=…-end
 * dec.refineTo({ faces: 20000 });
 * await src.load({ error: 0.001 });             // later: one more Range request
 * ```
 *
 * Requests:
 * 1. `Range: bytes=0-(firstBytes − 1)` — the header and usually the whole
 *    chunk table (header 120 bytes, 168 with the 3.2 bounds, + 36 bytes per chunk); if the table is
 *    longer, one more request for exactly the bytes it still needs (and one
 *    for the rest of a header longer than `firstBytes`).
 * 2. `Range: bytes=loaded-(end − 1)` where `end = decoder.bytesFor(target)`
 *    — the end of the chunk that reaches the target. Nothing is requested
 *    twice: every request starts where the previous bytes stopped.
 * 3. A later `load(target2)` asks for `bytes=loaded-(end2 − 1)`; `load()`
 *    without a target asks for the rest (`bytes=loaded-`).
 *
 * A 206 answer is read to its end, not cancelled once its last byte is in
 * (browsers report a cancelled request as failed); one that sends more
 * than its `Content-Range` says is cancelled there.
 *
 * A server that ignores Range answers 200 with the whole file: the bytes
 * already pushed are skipped, the rest is pushed until the target's end (the
 * header is read from the same response when it was not there yet), and
 * the response is cancelled there. `rangeSupported` turns false and later
 * loads use plain GETs the same way. A 416 (nothing at or after `loaded`)
 * means the file has ended. Any other status is an `Error` naming the URL
 * and the status; format faults are the decoder's `PqmError`s.
 *
 * Parameters (constructor `options`):
 * - `decoder` — the `PqmDecoder` to feed (default: a new one with `limits`);
 * - `limits` — decoder limits when `decoder` is not given;
 * - `push(bytes) → events` — how bytes reach the decoder (default
 *   `decoder.push`; `PQMProgressiveMesh.push` keeps GPU buffers in step);
 * - `fetch` — the fetch function (default `globalThis.fetch`);
 * - `init` — extra `fetch` options (`headers`, `credentials`, `signal`, …);
 *   the `Range` header is set here;
 * - `firstBytes` — size in bytes of the first request (default 4096);
 * - `onEvents(events, loader)` — called after each piece that completed
 *   something (decoder events: `headerReady`, `baseMeshReady`, …).
 */
import { PqmDecoder } from './decoder.js';
import { PqmError } from './errors.js';

const CONTENT_RANGE = /^bytes\s+(\d+)-(\d+)\/(\d+|\*)$/i;

export class PqmRangeLoader {
  /**
   * @param {string|URL} url
   * @param {object} [options] see the module documentation
   */
  constructor(url, options = {}) {
    this.url = url;
    /** @type {PqmDecoder} */
    this.decoder = options.decoder ?? new PqmDecoder({ limits: options.limits });
    this._push = options.push ?? ((bytes) => this.decoder.push(bytes));
    this._fetch = options.fetch ?? ((...a) => globalThis.fetch(...a));
    this.init = options.init ?? {};
    this.firstBytes = Math.max(16, Math.floor(options.firstBytes ?? 4096));
    this.onEvents = options.onEvents ?? null;
    /** Bytes pushed into the decoder: the offset of the next byte wanted. */
    this.loaded = 0;
    /** File size once a response told it (Content-Range total or a 200's length), else null. */
    this.size = null;
    /** null until the first response, then whether the server honoured Range. */
    this.rangeSupported = null;
    /** Every request made: `{range, status, bytes}` (`bytes` = body bytes read). */
    this.requests = [];
    this._queue = Promise.resolve();
  }

  /** True once every byte of the file has been pushed. */
  get complete() {
    return this.size !== null && this.loaded >= this.size;
  }

  /**
   * Makes sure the bytes up to `target` are pushed — `{faces}`, `{error}`,
   * `{level}` (as `decoder.bytesFor`), or null / omitted for the whole file
   * — and resolves to the decoder. The decoder then holds every level up to
   * the target (call `refineTo(target)` or let a `PQMProgressiveMesh`
   * refine). Reaching the end of the file calls `decoder.end()`, so a
   * truncated file rejects with a `truncated` error. Calls made while
   * another is running wait for it (one request at a time, so no byte is
   * pushed twice); a failed call does not stop later ones.
   * @param {object|number|null} [target]
   * @returns {Promise<PqmDecoder>}
   */
  load(target = null) {
    const run = this._queue.then(() => this._load(target));
    this._queue = run.catch(() => {});
    return run;
  }

  async _load(target) {
    while (!this.decoder.status().headerReady) {
      if (this.complete) this.decoder.end(); // throws 'truncated'
      const before = this.loaded;
      const n = before === 0 ? this.firstBytes : this._headerBytesWanted();
      await this._get(before, before + n, target);
      if (this.loaded === before && !this.complete) {
        throw new Error(`${this.url}: no bytes at offset ${before} (reading the header)`);
      }
    }
    const end = this.endFor(target);
    // a server may answer a Range with fewer bytes than asked (206 with a
    // shorter Content-Range): ask again for the rest
    while (end > this.loaded && !this.complete) {
      const before = this.loaded;
      await this._get(this.loaded, end, target);
      if (this.loaded === before && !this.complete) {
        throw new Error(`${this.url}: no bytes at offset ${before} (wanted up to ${end})`);
      }
    }
    if (this.complete) this.decoder.end();
    return this.decoder;
  }

  /**
   * File offset up to which bytes are needed for `target` (Infinity for the
   * whole file); needs the header and chunk table.
   */
  endFor(target) {
    return target === null || target === undefined ? Infinity : this.decoder.bytesFor(target);
  }

  /** Bytes the header / chunk table still need (at least 1). */
  _headerBytesWanted() {
    const st = this.decoder.status();
    return Math.max(1, st.bytesNeeded ?? 16 - st.bytesBuffered);
  }

  /**
   * One request for the bytes `[start, end)` (`end` may be Infinity). On a
   * 200 the stop point is recomputed as the header arrives in the same
   * response (`endFor(target)`, Infinity before the header).
   */
  async _get(start, end, target) {
    const headers = new Headers(this.init.headers ?? {});
    const range = end === Infinity ? `bytes=${start}-` : `bytes=${start}-${end - 1}`;
    if (this.rangeSupported !== false) headers.set('Range', range);
    const res = await this._fetch(this.url, { ...this.init, headers });
    const record = { range: this.rangeSupported === false ? null : range, status: res.status, bytes: 0 };
    this.requests.push(record);
    let pos; // file offset of the next body byte
    let fixedEnd; // where a 206 stops; null: follow the target (200)
    let bodyEnd = null; // where a 206's body ends (its Content-Range)
    if (res.status === 206) {
      const m = CONTENT_RANGE.exec(res.headers.get('Content-Range') ?? '');
      if (!m || Number(m[1]) !== start) {
        await res.body?.cancel();
        throw new Error(`${this.url}: asked for ${range}, the server sent Content-Range ${res.headers.get('Content-Range')}`);
      }
      this.rangeSupported = true;
      if (m[3] !== '*') this.size = Number(m[3]);
      pos = start;
      bodyEnd = Number(m[2]) + 1;
      fixedEnd = Math.min(end, bodyEnd);
    } else if (res.status === 200) {
      this.rangeSupported = false;
      const len = Number(res.headers.get('Content-Length'));
      if (res.headers.get('Content-Length') !== null && Number.isFinite(len) && !res.headers.get('Content-Encoding')) {
        this.size = len;
      }
      pos = 0;
      fixedEnd = null;
    } else if (res.status === 416) {
      // nothing at or after `start`: the file ends there
      await res.body?.cancel();
      this.size = start;
      return;
    } else {
      await res.body?.cancel();
      throw new Error(`${this.url}: HTTP ${res.status} for ${range}`);
    }
    if (!res.body) throw new Error(`${this.url}: HTTP ${res.status} without a body`);
    const reader = res.body.getReader();
    const stop = () => {
      if (fixedEnd !== null) return fixedEnd;
      return this.decoder.status().headerReady ? Math.max(start, this.endFor(target)) : Infinity;
    };
    let ended = false;
    // the whole 206 body is in: read its end rather than cancel the
    // response (a browser reports a cancelled request as failed)
    let expectEnd = false;
    try {
      for (;;) {
        const { done, value } = await reader.read();
        if (done) {
          ended = true;
          break;
        }
        if (expectEnd) break; // more than the Content-Range said: cancel
        record.bytes += value.length;
        let piece = value;
        if (pos < start) {
          // a 200 repeats the bytes already pushed
          const skip = Math.min(piece.length, start - pos);
          piece = piece.subarray(skip);
          pos += skip;
        }
        // Before the header is complete the stop point is unknown: push
        // only what the header / table still need, then decide.
        while (piece.length > 0) {
          let take = Math.min(piece.length, Math.max(0, stop() - pos));
          if (!this.decoder.status().headerReady) take = Math.min(take, this._headerBytesWanted());
          if (take === 0) break;
          pos += take;
          this.loaded = pos;
          const events = this._push(piece.subarray(0, take));
          piece = piece.subarray(take);
          if (events.length && this.onEvents) this.onEvents(events, this);
        }
        if (pos >= stop()) {
          if (bodyEnd !== null && pos >= bodyEnd) {
            expectEnd = true;
            continue;
          }
          break;
        }
      }
    } finally {
      if (!ended) await reader.cancel().catch(() => {});
      reader.releaseLock?.();
    }
    if (ended && fixedEnd === null) this.size = pos; // a 200 read to its end
    if (ended && fixedEnd !== null && pos < fixedEnd) {
      throw new PqmError('truncated', `${this.url}: the response for ${range} ended after ${pos - start} bytes`, {
        section: this.decoder.status().waitingFor,
      });
    }
  }
}
