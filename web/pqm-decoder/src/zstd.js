/**
 * One Zstandard frame → exactly `expectedLen` bytes (spec §1), with the
 * pure-JavaScript decompressor `fzstd`.
 *
 * The frame header is checked here before fzstd sees it, because fzstd
 * allocates whatever the header claims: the magic, no reserved bit, no
 * dictionary, the frame content size present and equal to the length the
 * .pqm file states, and a window of at most 2^25 bytes (for single-segment
 * frames the window is the content size). Decompression runs through
 * fzstd's streaming interface so that the produced byte count is observed:
 * a frame that decodes to more or fewer bytes than it claims is an error
 * (fzstd's one-shot call would silently leave the tail zero).
 */
import { Decompress } from 'fzstd';

/** Largest window accepted (spec §1). */
export const MAX_WINDOW = 2 ** 25;

/**
 * Checks the frame header of `data`; throws a message string on failure.
 * @param {Uint8Array} data
 * @param {number} expectedLen
 */
export function checkFrameHeader(data, expectedLen) {
  if (data.length < 6) throw `zstd frame of ${data.length} bytes is too short`;
  if (data[0] !== 0x28 || data[1] !== 0xb5 || data[2] !== 0x2f || data[3] !== 0xfd) {
    throw 'not a zstd frame (bad magic)';
  }
  const fhd = data[4];
  const fcsFlag = fhd >> 6;
  const single = (fhd >> 5) & 1;
  if (fhd & 0x08) throw 'zstd frame header has the reserved bit set';
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
  if (fcsLen === 0) throw 'zstd frame does not state its content size';
  if (p + fcsLen > data.length) throw 'zstd frame header is truncated';
  let fcs = 0;
  for (let i = 0; i < fcsLen; i++) fcs += data[p + i] * 2 ** (8 * i);
  if (fcsLen === 2) fcs += 256;
  if (single) window = fcs;
  if (window > MAX_WINDOW) throw `zstd window of ${window} bytes exceeds 2^25`;
  if (fcs !== expectedLen) {
    throw `zstd frame content size ${fcs} differs from the stated length ${expectedLen}`;
  }
}

/**
 * Decompresses one frame to exactly `expectedLen` bytes.
 * Throws a message string on any failure.
 * @param {Uint8Array} data compressed bytes (one frame)
 * @param {number} expectedLen the uncompressed length the file states
 * @returns {Uint8Array}
 */
export function decompressFrame(data, expectedLen) {
  checkFrameHeader(data, expectedLen);
  const out = new Uint8Array(expectedLen);
  let n = 0;
  let overflow = false;
  const d = new Decompress((chunk) => {
    if (n + chunk.length > expectedLen) {
      overflow = true;
      return;
    }
    out.set(chunk, n);
    n += chunk.length;
  });
  try {
    d.push(data, true);
  } catch (e) {
    throw `zstd: ${e && e.message ? e.message : e}`;
  }
  if (overflow) throw `zstd frame decodes to more than ${expectedLen} bytes`;
  if (n !== expectedLen) throw `zstd frame decodes to ${n} bytes, expected ${expectedLen}`;
  return out;
}
