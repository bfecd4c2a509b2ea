/**
 * A bounds-checked reader of varints (spec §1) over a byte range.
 *
 * Values are JavaScript numbers. Every value a valid file holds is far below
 * 2^53 (signed values lie in [-2^33, 2^33], unsigned ones are counts, masks,
 * codes and gaps bounded by u32 fields), so a varint above 2^53 is rejected
 * as invalid rather than decoded with BigInt. Errors are thrown as plain
 * strings; the caller wraps them with the section / record they belong to.
 */

const TWO_53 = 2 ** 53;

export class Reader {
  /**
   * @param {Uint8Array} bytes
   * @param {number} start first byte
   * @param {number} end one past the last byte
   * @param {string} name stream name for messages
   */
  constructor(bytes, start, end, name) {
    this.b = bytes;
    this.p = start;
    this.end = end;
    this.name = name;
  }

  /** Bytes left. */
  remaining() {
    return this.end - this.p;
  }

  /** One byte. */
  byte() {
    if (this.p >= this.end) throw `stream ${this.name} ends early`;
    return this.b[this.p++];
  }

  /**
   * An unsigned LEB128 varint (at most 10 bytes, at most 64 bits). Counts,
   * indices and masks: nearly always one byte, which is tested first.
   */
  u() {
    const b = this.b;
    const p = this.p;
    if (p < this.end) {
      const x = b[p];
      if (x < 0x80) {
        this.p = p + 1;
        return x;
      }
    }
    return this.uLong();
  }

  /**
   * u() for the streams whose varints vary in length (vertex deltas,
   * residuals: the signed ones, s()): 1 to 3 bytes without a branch on
   * their length, which is data and would mispredict — c1 / c2 say whether
   * the first / second byte continues.
   */
  u3() {
    const b = this.b;
    const p = this.p;
    if (p + 2 < this.end) {
      const x = b[p];
      const y = b[p + 1];
      const z = b[p + 2];
      if ((x & y & z & 0x80) === 0) {
        const c1 = x >> 7;
        const c2 = c1 & (y >> 7);
        this.p = p + 1 + c1 + c2;
        return (x & 0x7f) | (((y & 0x7f) << 7) & -c1) | (((z & 0x7f) << 14) & -c2);
      }
    }
    return this.uLong();
  }

  /** The general varint path (any length; errors). */
  uLong() {
    const b = this.b;
    let p = this.p;
    // General path: 7 bits per byte; the 32-bit part with bit operations,
    // the rest with multiplications (exact up to 2^53).
    let v = 0;
    let mul = 1;
    for (let i = 0; i < 10; i++) {
      if (p >= this.end) throw `stream ${this.name} ends inside a varint`;
      const x = b[p++];
      if (i === 9 && x > 1) throw `varint in stream ${this.name} exceeds 64 bits`;
      v += (x & 0x7f) * mul;
      mul *= 128;
      if (x < 0x80) {
        this.p = p;
        if (v > TWO_53) throw `varint in stream ${this.name} is too large (${v})`;
        return v;
      }
    }
    throw `varint in stream ${this.name} is longer than 10 bytes`;
  }

  /** A zigzag signed varint. */
  s() {
    const u = this.u3();
    // (u >> 1) ^ -(u & 1), on doubles: u is at most 2^53.
    if (u < 0x80000000) return (u >>> 1) ^ -(u & 1);
    return u % 2 === 0 ? u / 2 : -(u + 1) / 2;
  }
}
