/**
 * `pqm-decoder`: a streaming decoder of `.pqm` progressive quad meshes,
 * written from `spec/pqm.md` (pure JavaScript, no dependencies: zstd by zstd-decode.js).
 *
 * ```js
 * import { PqmDecoder } from 'pqm-decoder';
 * const dec = new PqmDecoder();
 * for (const ev of dec.push(bytes)) if (ev.type === 'chunkReady') dec.refineTo({ level: ev.level });
 * dec.positions; dec.triangleIndices; // current level
 * dec.reset(); // the next file, in the arrays of this one (take what you need first)
 * ```
 */
export { PqmDecoder, Change, decodeAll, runs, estimateMemory, DEFAULT_LIMITS } from './decoder.js';
export { PqmError } from './errors.js';
export { crc32 } from './crc32.js';
export { PqmRangeLoader } from './range.js';
