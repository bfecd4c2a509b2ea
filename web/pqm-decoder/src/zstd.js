/**
 * One Zstandard frame → exactly `expectedLen` bytes (spec §1), with this
 * package's own decoder (zstd-decode.js; it replaced the `fzstd` package,
 * which decoded these frames about 2× slower).
 *
 * A compressed section is exactly one frame and nothing else (spec §1): it
 * starts with the frame magic (a skippable frame is refused), the frame ends
 * at the section's last byte (no second frame, no trailing bytes — zstd
 * libraries would decode concatenated frames as one payload where small
 * decoders stop after the first, so readers would disagree), and its header
 * states the content size, equal to the length the .pqm file states.
 *
 * The frame header is checked here before anything is allocated for it:
 * the magic, no reserved bit, no dictionary, no checksum, a window of at
 * most 2^25 bytes (for single-segment frames the window is the content
 * size), the frame's extent (walked through its block headers without
 * decoding), then the content size. The decoder then writes into a buffer
 * of exactly the stated length and counts what it produces: a frame that
 * decodes to more or fewer bytes than it claims is an error.
 */
import { decodeFrameInto } from './zstd-decode.js';

/** Largest window accepted (spec §1). */
export const MAX_WINDOW = 2 ** 25;

/** Little-endian u32 `28 B5 2F FD`: the zstd frame magic. */
const FRAME_MAGIC = 0xfd2fb528;

/**
 * Length in bytes of the zstd frame whose blocks start at `p` in `data`
 * (`checksum`: the frame ends with a 4-byte content checksum), walking the
 * 3-byte block headers: raw and compressed blocks carry `size` bytes, an RLE
 * block one byte. Throws a message string when the frame runs past the end
 * of `data`, has a reserved block type, or a block size above `blockMax`
 * (RFC 8878: the smaller of the window and 128 KiB; the decoder would otherwise
 * fail inside with an unhelpful message).
 * @param {Uint8Array} data
 * @param {number} p offset of the first block header
 * @param {boolean} checksum
 * @param {number} blockMax largest block size allowed
 * @returns {number}
 */
function frameLength(data, p, checksum, blockMax) {
  for (;;) {
    if (p + 3 > data.length) throw 'zstd frame is truncated (cannot find its end)';
    const bh = data[p] | (data[p + 1] << 8) | (data[p + 2] << 16);
    const last = bh & 1;
    const type = (bh >> 1) & 3;
    const size = bh >>> 3;
    if (type === 3) throw 'zstd block of the reserved type 3';
    if (size > blockMax) {
      throw `zstd block of ${size} bytes exceeds the frame's maximum block size ${blockMax} (window or 128 KiB)`;
    }
    p += 3 + (type === 1 ? 1 : size);
    if (p > data.length) throw 'zstd frame is truncated (cannot find its end)';
    if (last) break;
  }
  if (checksum) p += 4;
  if (p > data.length) throw 'zstd frame is truncated (cannot find its end)';
  return p;
}

/**
 * Checks that `data` is exactly one zstd frame whose header states the
 * content size `expectedLen` and a window of at most 2^25 bytes; throws a
 * message string on failure.
 * @param {Uint8Array} data
 * @param {number} expectedLen
 */
export function checkFrameHeader(data, expectedLen) {
  frameHeader(data, expectedLen);
}

/** What frameHeader found: the first block's offset and the largest block allowed. */
const header = { blocks: 0, blockMax: 0 };

/** checkFrameHeader's work; fills `header`. */
function frameHeader(data, expectedLen) {
  if (data.length < 4) throw `zstd frame of ${data.length} bytes is too short`;
  const magic = (data[0] | (data[1] << 8) | (data[2] << 16) | (data[3] << 24)) >>> 0;
  if ((magic & 0xfffffff0) === 0x184d2a50) {
    throw 'a skippable zstd frame (a section holds exactly one zstd data frame)';
  }
  if (magic !== FRAME_MAGIC) throw 'not a zstd frame (bad frame magic)';
  if (data.length < 6) throw `zstd frame of ${data.length} bytes is too short`;
  const fhd = data[4];
  const fcsFlag = fhd >> 6;
  const single = (fhd >> 5) & 1;
  const checksum = (fhd & 0x04) !== 0;
  if (fhd & 0x08) throw 'zstd frame header has the reserved bit set';
  if (checksum) throw 'zstd frame carries a content checksum (not allowed: the section CRC covers it)';
  const didFlag = fhd & 3;
  let p = 5;
  let window = 0;
  if (!single) {
    const wd = data[p++];
    const base = 2 ** (10 + (wd >> 3));
    window = base + (base / 8) * (wd & 7);
  }
  const didLen = [0, 1, 2, 4][didFlag];
  if (p + didLen > data.length) throw 'zstd frame header is truncated';
  let did = 0;
  for (let i = 0; i < didLen; i++) did += data[p + i] * 2 ** (8 * i);
  p += didLen;
  if (did !== 0) throw `zstd frame needs dictionary ${did}`;
  const fcsLen = fcsFlag === 0 ? single : 1 << fcsFlag;
  if (p + fcsLen > data.length) throw 'zstd frame header is truncated';
  // Doubles are exact below 2^53; an 8-byte size beyond that is > 2^32 and
  // differs from any stated u32 length either way.
  let fcs = 0;
  for (let i = 0; i < fcsLen; i++) fcs += data[p + i] * 2 ** (8 * i);
  if (fcsLen === 2) fcs += 256;
  p += fcsLen;
  if (single) window = fcs;
  if (window > MAX_WINDOW) throw `zstd window of ${window} bytes exceeds 2^25`;
  const blockMax = Math.min(window, 1 << 17);
  const end = frameLength(data, p, checksum, blockMax);
  if (end !== data.length) {
    throw `${data.length - end} bytes after the zstd frame (a section holds exactly one frame)`;
  }
  if (fcsLen === 0) throw 'zstd frame header lacks the content size';
  if (fcs !== expectedLen) {
    throw `zstd frame holds ${fcs} bytes (its content size), the file states ${expectedLen}`;
  }
  header.blocks = p;
  header.blockMax = blockMax;
}

/**
 * Decompresses one frame to exactly `expectedLen` bytes.
 * Throws a message string on any failure.
 * @param {Uint8Array} data compressed bytes (one frame)
 * @param {number} expectedLen the uncompressed length the file states
 * @returns {Uint8Array}
 */
export function decompressFrame(data, expectedLen) {
  frameHeader(data, expectedLen);
  const out = new Uint8Array(expectedLen);
  decodeFrameInto(data, header.blocks, out, header.blockMax);
  return out;
}

/**
 * decompressFrame into the first `expectedLen` bytes of `scratch` (a
 * subarray of it: every byte is written, or it throws), for a payload read
 * once and dropped (a chunk's), so that each chunk does not allocate a
 * fresh, zeroed buffer. Returns the subarray; `scratch` must be at least
 * `expectedLen` long.
 * @param {Uint8Array} data
 * @param {number} expectedLen
 * @param {Uint8Array} scratch
 * @returns {Uint8Array}
 */
export function decompressFrameInto(data, expectedLen, scratch) {
  frameHeader(data, expectedLen);
  const out = scratch.subarray(0, expectedLen);
  decodeFrameInto(data, header.blocks, out, header.blockMax);
  return out;
}
