/**
 * Errors of the decoder, by kind (spec §10): every fault names the section
 * (`header`, `chunk table`, `base mesh`, `chunk 3`, `optional section 0`,
 * `trailer`) and, for a bad record, its chunk and index in the file.
 */

/**
 * Error kinds:
 * - `bad-magic`: not a .pqm file;
 * - `unsupported-version`: a `version_major` this decoder does not read;
 * - `crc`: a CRC-32 mismatch (`section`, `stored`, `computed` are set);
 * - `invalid`: invalid structure in `section`;
 * - `bad-record`: record `record` of chunk `chunk` cannot be decoded;
 * - `limits`: the header or chunk table claims more than the caller's limits;
 * - `truncated`: `end()` was called before the file was complete;
 * - `parameter`: a bad argument from the caller (not the file's fault);
 * - `failed`: the decoder failed earlier and accepts no more input.
 */
export class PqmError extends Error {
  /**
   * @param {string} kind one of the kinds above
   * @param {string} message full message (already names the section)
   * @param {object} [fields] `section`, `chunk`, `record`, `stored`, `computed`
   */
  constructor(kind, message, fields = {}) {
    super(message);
    this.name = 'PqmError';
    this.kind = kind;
    this.section = fields.section ?? null;
    this.chunk = fields.chunk ?? null;
    this.record = fields.record ?? null;
    if (fields.stored !== undefined) this.stored = fields.stored;
    if (fields.computed !== undefined) this.computed = fields.computed;
    /** Events completed by the failing `push` call before the error. */
    this.events = [];
  }
}

const hex = (x) => '0x' + (x >>> 0).toString(16).padStart(8, '0');

/** Invalid structure in `section`. */
export function invalid(section, message) {
  return new PqmError('invalid', `invalid ${section}: ${message}`, { section });
}

/** CRC mismatch in `section` (`chunk` when it is a record chunk). */
export function crcMismatch(section, stored, computed, chunk = null) {
  return new PqmError(
    'crc',
    `CRC mismatch in ${section}: stored ${hex(stored)}, computed ${hex(computed)}`,
    { section, stored, computed, chunk },
  );
}

/** Record `record` (index in the file) of chunk `chunk` is invalid. */
export function badRecord(chunk, record, message) {
  return new PqmError('bad-record', `bad record ${record} in chunk ${chunk}: ${message}`, {
    section: `chunk ${chunk}`,
    chunk,
    record,
  });
}

/** The file claims more than the caller's budget. */
export function limitsExceeded(message) {
  return new PqmError('limits', `limits exceeded: ${message}`);
}
