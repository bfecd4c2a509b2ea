/**
 * The bytes pushed but not yet consumed, as a list of pieces. A section is
 * materialized only once all of its bytes are here, so pushing one byte at a
 * time costs O(1) per push and O(n) in all.
 */
export class ByteQueue {
  constructor() {
    /** @type {Uint8Array[]} */
    this.pieces = [];
    this.first = 0; // index of the first live piece
    this.head = 0; // offset into pieces[first]
    this.length = 0;
  }

  /** Adds bytes (kept by reference until `own()`). */
  push(bytes) {
    if (bytes.length === 0) return;
    this.pieces.push(bytes);
    this.length += bytes.length;
  }

  /**
   * Copies the not-yet-consumed part of `bytes` if it is still queued, so the
   * caller may reuse its buffer after `push` returns.
   */
  own(bytes) {
    const n = this.pieces.length;
    if (n === this.first || this.pieces[n - 1] !== bytes) return;
    if (n - 1 === this.first) {
      this.pieces[n - 1] = bytes.slice(this.head);
      this.head = 0;
    } else {
      this.pieces[n - 1] = bytes.slice();
    }
  }

  /** The next `n` bytes without consuming them (`n <= length`). */
  peek(n) {
    return this.read(n, false);
  }

  /** Consumes and returns the next `n` bytes (`n <= length`). */
  take(n) {
    return this.read(n, true);
  }

  read(n, consume) {
    const first = this.pieces[this.first];
    let out;
    if (n === 0) {
      out = new Uint8Array(0);
    } else if (first.length - this.head >= n) {
      out = first.subarray(this.head, this.head + n);
    } else {
      out = new Uint8Array(n);
      let got = 0;
      let i = this.first;
      let off = this.head;
      while (got < n) {
        const p = this.pieces[i];
        const k = Math.min(n - got, p.length - off);
        out.set(p.subarray(off, off + k), got);
        got += k;
        i++;
        off = 0;
      }
    }
    if (consume && n > 0) {
      let left = n;
      while (left > 0) {
        const avail = this.pieces[this.first].length - this.head;
        if (avail > left) {
          this.head += left;
          left = 0;
        } else {
          left -= avail;
          this.pieces[this.first++] = undefined;
          this.head = 0;
        }
      }
      this.length -= n;
      // Drop consumed pieces now and then (amortized O(1) per piece).
      if (this.first > 64 && this.first * 2 > this.pieces.length) {
        this.pieces = this.pieces.slice(this.first);
        this.first = 0;
      }
    }
    return out;
  }
}
