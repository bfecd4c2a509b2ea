// A test-only .pqm (re)writer: splits a file into its sections, decompresses
// them (fzstd), and writes files back with *raw* zstd frames (no
// compression: a frame header with the content size, then raw blocks) and
// recomputed offsets, lengths and CRCs. This lets tests change payload bytes,
// header fields or table entries and still get past the CRC and zstd checks,
// so the decoder's structural checks are exercised.
import { decompress } from 'fzstd';
import { crc32 } from '../src/crc32.js';

/** One zstd frame holding `payload` in raw blocks, content size stated. */
export function rawZstdFrame(payload, { windowDescriptor = null } = {}) {
  const blocks = [];
  const MAX = 1 << 17;
  for (let i = 0; i < payload.length || (i === 0 && payload.length === 0); i += MAX) {
    const part = payload.subarray(i, Math.min(i + MAX, payload.length));
    const last = i + MAX >= payload.length ? 1 : 0;
    const hdr = last | (0 << 1) | (part.length << 3);
    blocks.push(Uint8Array.of(hdr & 0xff, (hdr >> 8) & 0xff, (hdr >> 16) & 0xff), part);
    if (payload.length === 0) break;
  }
  let head;
  if (windowDescriptor === null) {
    // single segment, 4-byte content size
    head = Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0xa0, ...u32(payload.length));
  } else {
    // window descriptor, 4-byte content size
    head = Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0x80, windowDescriptor, ...u32(payload.length));
  }
  return concat([head, ...blocks]);
}

function u32(x) {
  return [x & 0xff, (x >>> 8) & 0xff, (x >>> 16) & 0xff, (x >>> 24) & 0xff];
}

export function concat(parts) {
  const n = parts.reduce((s, p) => s + p.length, 0);
  const out = new Uint8Array(n);
  let o = 0;
  for (const p of parts) {
    out.set(p, o);
    o += p.length;
  }
  return out;
}

/**
 * Splits a valid file: `header` (bytes, CRC excluded rewritten on build),
 * `entries` (chunk table entries as byte arrays), decompressed `base` and
 * `chunks` payloads, and `sections` ({tag, payload, raw}).
 */
export function unpack(bytes) {
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const headerLen = dv.getUint32(12, true);
  const entryLen = dv.getUint16(22, true);
  const chunkCount = dv.getUint32(44, true);
  const sectionCount = dv.getUint32(48, true);
  const baseLen = dv.getUint32(52, true);
  const header = bytes.slice(0, headerLen);
  let p = headerLen;
  const entries = [];
  for (let i = 0; i < chunkCount; i++) entries.push(bytes.slice(p + i * entryLen, p + (i + 1) * entryLen));
  p += chunkCount * entryLen + 4;
  const base = decompress(bytes.subarray(p, p + baseLen));
  p += baseLen;
  const chunks = [];
  for (const e of entries) {
    const n = new DataView(e.buffer).getUint32(8, true);
    chunks.push(decompress(bytes.subarray(p, p + n)));
    p += n;
  }
  const sections = [];
  for (let i = 0; i < sectionCount; i++) {
    const tag = String.fromCharCode(...bytes.subarray(p, p + 4));
    const clen = dv.getUint32(p + 4, true);
    const body = bytes.subarray(p + 16, p + 16 + clen);
    sections.push({ tag, payload: decompress(body) });
    p += 16 + clen;
  }
  return { header, entries, base, chunks, sections };
}

/**
 * Writes a file from `unpack`'s parts (modified or not): payloads in raw zstd
 * frames; offsets, compressed/uncompressed lengths and every CRC recomputed.
 * `frame(payload)` may replace the frame writer.
 */
export function pack(parts, { frame = rawZstdFrame } = {}) {
  const header = parts.header.slice();
  const hv = new DataView(header.buffer);
  const headerLen = header.length;
  const entryLen = parts.entries.length ? parts.entries[0].length : hv.getUint16(22, true);
  const baseFrame = frame(parts.base);
  hv.setUint32(52, baseFrame.length, true);
  hv.setUint32(56, parts.base.length, true);
  hv.setUint32(60, crc32(baseFrame), true);
  hv.setUint32(headerLen - 4, crc32(header, 0, headerLen - 4), true);
  const chunkFrames = parts.chunks.map((c) => frame(c));
  let offset = headerLen + parts.entries.length * entryLen + 4 + baseFrame.length;
  const table = new Uint8Array(parts.entries.length * entryLen + 4);
  const tv = new DataView(table.buffer);
  parts.entries.forEach((e, i) => {
    table.set(e, i * entryLen);
    const o = i * entryLen;
    tv.setBigUint64(o, BigInt(offset), true);
    tv.setUint32(o + 8, chunkFrames[i].length, true);
    tv.setUint32(o + 12, parts.chunks[i].length, true);
    tv.setUint32(o + 32, crc32(chunkFrames[i]), true);
    offset += chunkFrames[i].length;
  });
  tv.setUint32(table.length - 4, crc32(table, 0, table.length - 4), true);
  const secs = parts.sections.map((s) => {
    const body = frame(s.payload);
    const h = new Uint8Array(16);
    for (let k = 0; k < 4; k++) h[k] = s.tag.charCodeAt(k);
    const d = new DataView(h.buffer);
    d.setUint32(4, body.length, true);
    d.setUint32(8, s.payload.length, true);
    d.setUint32(12, crc32(body), true);
    return concat([h, body]);
  });
  return concat([header, table, baseFrame, ...chunkFrames, ...secs]);
}

/** Sets a header field (little-endian) and returns the parts (for chaining). */
export function setHeader(parts, offset, type, value) {
  const dv = new DataView(parts.header.buffer);
  dv[`set${type}`](offset, value, true);
  return parts;
}

/** Sets a chunk table entry field. */
export function setEntry(parts, i, offset, type, value) {
  const dv = new DataView(parts.entries[i].buffer);
  dv[`set${type}`](offset, value, true);
  return parts;
}

/**
 * A copy of a valid file whose header is rewritten to `headerLen` bytes
 * (default 168) with flag bit 2 set and `min` / `max` (3 numbers each) as
 * `bounds_min` / `bounds_max` at offsets 116 / 140 (spec §3, version 3.2;
 * they are written only if the header is long enough, so a short header
 * with the flag can be made). A 2.x or 3.x file becomes a 3.2 file (a 3.0
 * file differs from a 2.0 one only in `version_major`, spec §9). Unlike
 * `pack`, the payloads are kept byte for byte: only the chunk table's
 * offsets move (by the change of the header length) and the table and
 * header CRCs are recomputed. `grid` ([min, max]) replaces the grid box.
 */
export function withBounds(bytes, min, max, { headerLen = 168, flag = true, grid = null } = {}) {
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const oldLen = dv.getUint32(12, true);
  const entryLen = dv.getUint16(22, true);
  const chunkCount = dv.getUint32(44, true);
  const tableLen = chunkCount * entryLen + 4;
  const delta = headerLen - oldLen;
  const header = new Uint8Array(headerLen);
  header.set(bytes.subarray(0, Math.min(116, headerLen - 4)));
  const hv = new DataView(header.buffer);
  if (hv.getUint16(8, true) >= 2) {
    hv.setUint16(8, 3, true);
    hv.setUint16(10, 2, true);
  }
  hv.setUint32(12, headerLen, true);
  if (flag) hv.setUint32(16, hv.getUint32(16, true) | 4, true);
  if (grid) {
    for (let k = 0; k < 3; k++) {
      hv.setFloat64(64 + 8 * k, grid[0][k], true);
      hv.setFloat64(88 + 8 * k, grid[1][k], true);
    }
  }
  if (headerLen >= 168) {
    for (let k = 0; k < 3; k++) {
      hv.setFloat64(116 + 8 * k, min[k], true);
      hv.setFloat64(140 + 8 * k, max[k], true);
    }
  }
  hv.setUint32(headerLen - 4, crc32(header, 0, headerLen - 4), true);
  const table = bytes.slice(oldLen, oldLen + tableLen);
  const tv = new DataView(table.buffer);
  for (let i = 0; i < chunkCount; i++) {
    const o = i * entryLen;
    tv.setBigUint64(o, tv.getBigUint64(o, true) + BigInt(delta), true);
  }
  tv.setUint32(tableLen - 4, crc32(table, 0, tableLen - 4), true);
  return concat([header, table, bytes.subarray(oldLen + tableLen)]);
}
