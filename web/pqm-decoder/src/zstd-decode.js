/**
 * A Zstandard frame decoder (RFC 8878) for the frames a `.pqm` file holds:
 * one frame, content size stated, no dictionary, no checksum (zstd.js
 * checks those rules before this runs). Written for speed in JavaScript:
 * the sections are entropy-coded literals for the most part (the records'
 * varints compress by ≈ 10 %: few matches, many literals), so the Huffman
 * literal decoder is what counts — four streams decoded in one loop, two
 * symbols per refill, one table read per symbol — and everything is
 * decoded straight into the output buffer with no per-block allocation.
 *
 * Errors are thrown as message strings (zstd.js names the section).
 *
 * Invariants: `out` is written only below `out.length` (every copy is
 * checked against it first, so a frame that decodes to more than it
 * states is an error, not a silent truncation); every table index is in
 * range by construction (FSE states are `base + bits` with `bits <
 * 2^nb`, `base + 2^nb ≤ table size`; Huffman lookups are masked to the
 * table size); reads past a bitstream's start return zeros and are then
 * an error, never a value.
 */

/** Largest block content (RFC 8878: Block_Maximum_Size ≤ 128 KiB). */
const BLOCK_MAX = 1 << 17;

// ---- literals scratch (one block's literals, at most 128 KiB) ------------
const LIT = new Uint8Array(BLOCK_MAX + 8);
const LIT_VIEW = new DataView(LIT.buffer);
// ---- a block's sequences bitstream between zero pads (decodeSequences) ---
const SEQ_PAD = 16;
const SEQ = new Uint8Array(BLOCK_MAX + 2 * SEQ_PAD);
// Its bits are read 4 bytes at a time through a DataView (one load, not
// four byte loads and three shifts); every read stays inside SEQ: a
// sequence consumes at most 83 bits (offset code ≤ 25, two lengths' extra
// bits ≤ 16 each, three state updates ≤ 9 + 9 + 8), less than the 128 of
// the front pad, and the position is checked after each one.
const SV = new DataView(SEQ.buffer);

// ---- Huffman table (literals), kept across the blocks of a frame --------
const HUF_MAX_BITS = 11;
/** Per peeked `maxBits`-bit value: symbol | (code length << 8). */
const hufTable = new Uint16Array(1 << HUF_MAX_BITS);
let hufBits = 0; // 0: no table yet in this frame
const hufWeights = new Uint8Array(256);
const hufRank = new Int32Array(HUF_MAX_BITS + 2);

// ---- FSE tables ---------------------------------------------------------
/**
 * A decoding table of up to 2^9 states: per state its symbol, the bits to
 * read for the next state and the next state's base; for the sequence
 * tables also the symbol's value base and its additional bits (RFC 8878
 * §3.1.1.3.2.1: literal length, match length and offset codes).
 */
class FseTable {
  constructor(size) {
    this.log = 0;
    this.sym = new Uint8Array(size);
    this.nb = new Uint8Array(size);
    this.next = new Uint16Array(size);
    this.base = new Int32Array(size);
    this.add = new Uint8Array(size);
  }
}

const NORM = new Int16Array(256);
const SYM_NEXT = new Uint16Array(256);

/** Highest set bit of `x` > 0. */
const highbit = (x) => 31 - Math.clz32(x);

/**
 * Builds `t` from the normalized counts NORM[0 .. nSym) of a table of
 * 2^log states (FSE_buildDTable: symbols of count −1 at the top, the rest
 * spread with step 5/8 · size + 3).
 */
function buildFse(t, log, nSym) {
  const size = 1 << log;
  const sym = t.sym;
  let high = size - 1;
  for (let s = 0; s < nSym; s++) {
    if (NORM[s] === -1) {
      sym[high--] = s;
      SYM_NEXT[s] = 1;
    } else SYM_NEXT[s] = NORM[s];
  }
  const step = (size >> 1) + (size >> 3) + 3;
  const mask = size - 1;
  let pos = 0;
  for (let s = 0; s < nSym; s++) {
    const n = NORM[s];
    for (let i = 0; i < n; i++) {
      sym[pos] = s;
      do pos = (pos + step) & mask;
      while (pos > high);
    }
  }
  if (pos !== 0) throw 'zstd: corrupted FSE table (symbols do not spread)';
  const nb = t.nb;
  const next = t.next;
  for (let u = 0; u < size; u++) {
    const ns = SYM_NEXT[sym[u]]++;
    const b = log - highbit(ns);
    nb[u] = b;
    next[u] = (ns << b) - size;
  }
  t.log = log;
}

/** Forward little-endian bit read of up to 25 bits at bit `bp` of d[.. end) (zeros past `end`). */
function peekFwd(d, bp, end) {
  const b = bp >> 3;
  let v = 0;
  for (let k = 3; k >= 0; k--) v = (v << 8) | (b + k < end ? d[b + k] : 0);
  return (v >>> (bp & 7)) >>> 0;
}

/**
 * Reads an FSE table description (RFC 8878 §4.1.1, libzstd's
 * FSE_readNCount) at byte `p` of d[.. end) into NORM; sets fseRead to the
 * byte after it, the accuracy log and the symbol count.
 */
const fseRead = { end: 0, log: 0, nSym: 0 };
function readFseDescription(d, p, end, maxLog, maxSym) {
  if (p >= end) throw 'zstd: FSE table description runs past the block';
  let bp = p * 8;
  const log = (d[p] & 15) + 5;
  if (log > maxLog) throw `zstd: FSE accuracy log ${log} exceeds ${maxLog}`;
  bp += 4;
  let remaining = (1 << log) + 1;
  let threshold = 1 << log;
  let nbBits = log + 1;
  let s = 0;
  let prev0 = false;
  const maxSV1 = maxSym + 1;
  for (;;) {
    if (prev0) {
      // 2-bit repeat flags after a zero count: each 3 adds 3 more zeros
      // and another flag, the last adds 0 to 2
      let z = 0;
      let r = peekFwd(d, bp, end) & 3;
      while (r === 3 && s + z < maxSV1) {
        z += 3;
        bp += 2;
        r = peekFwd(d, bp, end) & 3;
      }
      z += r;
      bp += 2;
      if (s + z >= maxSV1) throw 'zstd: corrupted FSE table description (too many symbols)';
      for (; z > 0; z--) NORM[s++] = 0;
    }
    const v = peekFwd(d, bp, end);
    const max = 2 * threshold - 1 - remaining;
    let count;
    if ((v & (threshold - 1)) < max) {
      count = v & (threshold - 1);
      bp += nbBits - 1;
    } else {
      count = v & (2 * threshold - 1);
      if (count >= threshold) count -= max;
      bp += nbBits;
    }
    count--;
    if (count >= 0) remaining -= count;
    else remaining += count;
    NORM[s++] = count;
    prev0 = count === 0;
    if (remaining < threshold) {
      if (remaining <= 1) break;
      nbBits = highbit(remaining) + 1;
      threshold = 1 << (nbBits - 1);
    }
    if (s >= maxSV1) break;
  }
  if (remaining !== 1 || s > maxSV1) throw 'zstd: corrupted FSE table description';
  const e = p + ((bp - p * 8 + 7) >> 3);
  if (e > end) throw 'zstd: FSE table description runs past the block';
  fseRead.end = e;
  fseRead.log = log;
  fseRead.nSym = s;
}

// Sequence codes (RFC 8878 §3.1.1.3.2.1.1): value bases and extra bits.
const LL_BITS = [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 3, 3, 4, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16];
const ML_BITS = [
  0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 3, 3, 4, 4, 5, 7, 8, 9,
  10, 11, 12, 13, 14, 15, 16,
];
const bases = (bits, first) => {
  const out = [];
  let b = first;
  for (const n of bits) {
    out.push(b);
    b += 2 ** n;
  }
  return out;
};
const LL_BASE = bases(LL_BITS, 0);
const ML_BASE = bases(ML_BITS, 3);
const LL_MAX = 35;
const ML_MAX = 52;
const OF_MAX = 31;

/** Fills a sequence table's value base / extra bits from its symbols (kind 0 LL, 1 OF, 2 ML). */
function finishSeqTable(t, kind) {
  const size = 1 << t.log;
  for (let u = 0; u < size; u++) {
    const c = t.sym[u];
    if (kind === 0) {
      t.base[u] = LL_BASE[c];
      t.add[u] = LL_BITS[c];
    } else if (kind === 2) {
      t.base[u] = ML_BASE[c];
      t.add[u] = ML_BITS[c];
    } else {
      // offset code c: value 2^c + c extra bits (c ≤ 31; c > 25 gives an
      // offset past any frame of ≤ 2^25 bytes and is refused when used)
      t.base[u] = c;
      t.add[u] = c;
    }
  }
}

const PREDEF = [
  // literal lengths, log 6
  [4, 3, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 3, 2, 1, 1, 1, 1, 1, -1, -1, -1, -1],
  // offsets, log 5
  [1, 1, 1, 1, 1, 1, 2, 2, 2, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, -1, -1, -1, -1, -1],
  // match lengths, log 6
  [
    1, 4, 3, 2, 2, 2, 2, 2, 2, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    -1, -1, -1, -1, -1, -1, -1,
  ],
];
const PREDEF_LOG = [6, 5, 6];
const MAX_LOG = [9, 8, 9];
const MAX_SYM = [LL_MAX, OF_MAX, ML_MAX];

const predefTables = [0, 1, 2].map((kind) => {
  const t = new FseTable(1 << PREDEF_LOG[kind]);
  const n = PREDEF[kind];
  for (let s = 0; s < n.length; s++) NORM[s] = n[s];
  buildFse(t, PREDEF_LOG[kind], n.length);
  finishSeqTable(t, kind);
  return t;
});
const fseTables = [new FseTable(512), new FseTable(512), new FseTable(512)];
const rleTables = [new FseTable(1), new FseTable(1), new FseTable(1)];
/** The table each kind used last in this frame (null: none yet). */
const curTables = [null, null, null];
const wTable = new FseTable(64);

/** Repeat offsets of the frame. */
const rep = new Int32Array(3);

/**
 * Decodes the zstd frame whose blocks start at byte `p` of `data` into
 * `out` (exactly `out.length` bytes; the header was checked by zstd.js).
 * @param {Uint8Array} data
 * @param {number} p first block header
 * @param {Uint8Array} out
 * @param {number} blockMax min(window, 128 KiB)
 */
export function decodeFrameInto(data, p, out, blockMax) {
  const outLen = out.length;
  hufBits = 0;
  curTables[0] = curTables[1] = curTables[2] = null;
  rep[0] = 1;
  rep[1] = 4;
  rep[2] = 8;
  let op = 0;
  for (;;) {
    if (p + 3 > data.length) throw 'zstd frame is truncated';
    const bh = data[p] | (data[p + 1] << 8) | (data[p + 2] << 16);
    const last = bh & 1;
    const type = (bh >> 1) & 3;
    const size = bh >>> 3;
    p += 3;
    if (size > blockMax) throw `zstd block of ${size} bytes exceeds the maximum block size ${blockMax}`;
    if (type === 0) {
      if (p + size > data.length) throw 'zstd frame is truncated';
      if (op + size > outLen) throw `zstd frame decodes to more than ${outLen} bytes`;
      out.set(data.subarray(p, p + size), op);
      op += size;
      p += size;
    } else if (type === 1) {
      if (p + 1 > data.length) throw 'zstd frame is truncated';
      if (op + size > outLen) throw `zstd frame decodes to more than ${outLen} bytes`;
      out.fill(data[p], op, op + size);
      op += size;
      p += 1;
    } else if (type === 2) {
      if (p + size > data.length) throw 'zstd frame is truncated';
      op = decodeBlock(data, p, p + size, out, op, blockMax);
      p += size;
    } else throw 'zstd block of the reserved type 3';
    if (last) break;
  }
  if (op !== outLen) throw `zstd frame decodes to ${op} bytes, expected ${outLen}`;
  return p;
}

/** Literals of the block being decoded: `litBuf[litAt .. litAt + litLen)`. */
let litBuf = LIT;
let litAt = 0;
let litLen = 0;

/**
 * One compressed block d[p .. end) (RFC 8878 §3.1.1.3) into out from `op`;
 * returns the new output position.
 */
function decodeBlock(d, p, end, out, op, blockMax) {
  p = decodeLiterals(d, p, end, blockMax);
  // sequences section header
  if (p >= end) throw 'zstd: block ends before its sequences section';
  let nSeq = d[p++];
  if (nSeq === 0) {
    if (p !== end) throw 'zstd: bytes after a block without sequences';
    if (op + litLen > out.length) throw `zstd frame decodes to more than ${out.length} bytes`;
    copyLiterals(out, op, litAt, litLen);
    return op + litLen;
  }
  if (nSeq >= 128) {
    if (nSeq === 255) {
      if (p + 2 > end) throw 'zstd: truncated sequences header';
      nSeq = d[p] + (d[p + 1] << 8) + 0x7f00;
      p += 2;
    } else {
      if (p + 1 > end) throw 'zstd: truncated sequences header';
      nSeq = ((nSeq - 128) << 8) + d[p++];
    }
  }
  if (p >= end) throw 'zstd: truncated sequences header';
  const modes = d[p++];
  if (modes & 3) throw 'zstd: reserved bits of the sequence compression modes are set';
  // tables in the order literal lengths, offsets, match lengths
  for (let kind = 0; kind < 3; kind++) {
    const mode = (modes >> (6 - 2 * kind)) & 3;
    if (mode === 0) curTables[kind] = predefTables[kind];
    else if (mode === 1) {
      if (p >= end) throw 'zstd: truncated RLE sequence table';
      const s = d[p++];
      if (s > MAX_SYM[kind]) throw `zstd: RLE sequence code ${s} out of range`;
      const t = rleTables[kind];
      t.sym[0] = s;
      t.nb[0] = 0;
      t.next[0] = 0;
      t.log = 0;
      finishSeqTable(t, kind);
      curTables[kind] = t;
    } else if (mode === 2) {
      readFseDescription(d, p, end, MAX_LOG[kind], MAX_SYM[kind]);
      p = fseRead.end;
      const t = fseTables[kind];
      buildFse(t, fseRead.log, fseRead.nSym);
      finishSeqTable(t, kind);
      curTables[kind] = t;
    } else if (curTables[kind] === null) throw 'zstd: repeated sequence table without a previous one';
  }
  return decodeSequences(d, p, end, out, op, nSeq, blockMax);
}

/** litBuf[from .. from + n) → out[op ..). */
function copyLiterals(out, op, from, n) {
  const L = litBuf;
  if (n > 32) out.set(L.subarray(from, from + n), op);
  else for (let k = 0; k < n; k++) out[op + k] = L[from + k];
}

/** The literals section at p: sets litBuf / litAt / litLen; returns the byte after it. */
function decodeLiterals(d, p, end, blockMax) {
  if (p >= end) throw 'zstd: empty compressed block';
  const b0 = d[p];
  const type = b0 & 3;
  const sf = (b0 >> 2) & 3;
  if (type < 2) {
    let n;
    if (sf === 0 || sf === 2) {
      n = b0 >> 3;
      p += 1;
    } else if (sf === 1) {
      if (p + 2 > end) throw 'zstd: truncated literals header';
      n = (b0 >> 4) + (d[p + 1] << 4);
      p += 2;
    } else {
      if (p + 3 > end) throw 'zstd: truncated literals header';
      n = (b0 >> 4) + (d[p + 1] << 4) + (d[p + 2] << 12);
      p += 3;
    }
    if (n > blockMax) throw `zstd: ${n} literals exceed the block maximum ${blockMax}`;
    if (type === 0) {
      if (p + n > end) throw 'zstd: raw literals run past the block';
      litBuf = d;
      litAt = p;
      litLen = n;
      return p + n;
    }
    if (p + 1 > end) throw 'zstd: RLE literals run past the block';
    LIT.fill(d[p], 0, n);
    litBuf = LIT;
    litAt = 0;
    litLen = n;
    return p + 1;
  }
  // compressed (2) or treeless (3)
  let n, c, hl;
  if (sf < 2) {
    hl = 3;
    if (p + 3 > end) throw 'zstd: truncated literals header';
    const v = d[p] | (d[p + 1] << 8) | (d[p + 2] << 16);
    n = (v >> 4) & 0x3ff;
    c = (v >> 14) & 0x3ff;
  } else if (sf === 2) {
    hl = 4;
    if (p + 4 > end) throw 'zstd: truncated literals header';
    const v = (d[p] | (d[p + 1] << 8) | (d[p + 2] << 16) | (d[p + 3] << 24)) >>> 0;
    n = (v >>> 4) & 0x3fff;
    c = (v >>> 18) & 0x3fff;
  } else {
    hl = 5;
    if (p + 5 > end) throw 'zstd: truncated literals header';
    const v = (d[p] | (d[p + 1] << 8) | (d[p + 2] << 16) | (d[p + 3] << 24)) >>> 0;
    n = (v >>> 4) & 0x3ffff;
    c = (v >>> 22) + (d[p + 4] << 10);
  }
  p += hl;
  if (n > blockMax) throw `zstd: ${n} literals exceed the block maximum ${blockMax}`;
  const e = p + c;
  if (e > end) throw 'zstd: compressed literals run past the block';
  let s = p;
  if (type === 2) s = readHuffmanTable(d, p, e);
  else if (hufBits === 0) throw 'zstd: treeless literals without a previous Huffman table';
  if (sf === 0) huf1(d, s, e, LIT, 0, n);
  else huf4(d, s, e, LIT, n);
  litBuf = LIT;
  litAt = 0;
  litLen = n;
  return e;
}

/**
 * Huffman tree description at p (RFC 8878 §4.2.1) into hufTable / hufBits;
 * returns the byte after it.
 */
function readHuffmanTable(d, p, end) {
  if (p >= end) throw 'zstd: missing Huffman tree description';
  const hb = d[p++];
  const w = hufWeights;
  let nw;
  if (hb < 128) {
    // FSE-compressed weights: hb bytes, table then a backward bitstream
    const e = p + hb;
    if (hb === 0 || e > end) throw 'zstd: Huffman weights run past the literals';
    readFseDescription(d, p, e, 6, 255);
    buildFse(wTable, fseRead.log, fseRead.nSym);
    nw = fseWeights(d, fseRead.end, e, wTable);
    p = e;
  } else {
    nw = hb - 127;
    const nb = (nw + 1) >> 1;
    if (p + nb > end) throw 'zstd: Huffman weights run past the literals';
    for (let i = 0; i < nw; i += 2) {
      const x = d[p + (i >> 1)];
      w[i] = x >> 4;
      w[i + 1] = x & 15;
    }
    p += nb;
  }
  // weights → code lengths; the last symbol's weight is implied
  const rank = hufRank;
  rank.fill(0);
  let sum = 0;
  for (let i = 0; i < nw; i++) {
    const x = w[i];
    if (x > HUF_MAX_BITS) throw `zstd: Huffman weight ${x} exceeds ${HUF_MAX_BITS}`;
    if (x > 0) sum += 1 << (x - 1);
  }
  if (sum === 0) throw 'zstd: Huffman weights are all zero';
  const maxBits = highbit(sum) + 1;
  if (maxBits > HUF_MAX_BITS) throw `zstd: Huffman code of ${maxBits} bits`;
  const rest = (1 << maxBits) - sum;
  if (rest & (rest - 1)) throw 'zstd: Huffman weights do not sum to a power of 2';
  w[nw] = highbit(rest) + 1;
  const nSym = nw + 1;
  for (let i = 0; i < nSym; i++) rank[w[i]]++;
  if (rank[1] < 2 || rank[1] & 1) throw 'zstd: corrupted Huffman weights';
  // start of each weight's codes: lighter weights (longer codes) first
  let pos = 0;
  for (let x = 1; x <= maxBits; x++) {
    const n = rank[x];
    rank[x] = pos;
    pos += n << (x - 1);
  }
  const t = hufTable;
  for (let i = 0; i < nSym; i++) {
    const x = w[i];
    if (x === 0) continue;
    const len = 1 << (x - 1);
    const at = rank[x];
    const v = i | ((maxBits + 1 - x) << 8);
    // most runs are short: a loop beats a fill() call for them
    if (len > 16) t.fill(v, at, at + len);
    else for (let k = at; k < at + len; k++) t[k] = v;
    rank[x] = at + len;
  }
  hufBits = maxBits;
  return p;
}

/**
 * The FSE-coded Huffman weights of d[p .. end) (two interleaved states,
 * RFC 8878 §4.2.1.2) into hufWeights; returns their number.
 */
function fseWeights(d, p, end, t) {
  const last = d[end - 1];
  if (end <= p || last === 0) throw 'zstd: corrupted Huffman weights stream';
  let pos = 8 * (end - p - 1) + highbit(last); // bits left
  const lo = p;
  const read = (n) => {
    pos -= n;
    if (n === 0) return 0;
    // bits [pos, pos + n) of the stream (n ≤ 6), zeros below its start
    if (pos >= 0) {
      const b = lo + (pos >> 3);
      const v = (d[b] | (b + 1 < end ? d[b + 1] << 8 : 0)) >>> (pos & 7);
      return v & ((1 << n) - 1);
    }
    let v = 0;
    for (let k = 0; k < n; k++) {
      const bit = pos + n - 1 - k;
      v = (v << 1) | (bit >= 0 ? (d[lo + (bit >> 3)] >> (bit & 7)) & 1 : 0);
    }
    return v;
  };
  const sym = t.sym;
  const nb = t.nb;
  const next = t.next;
  let s1 = read(t.log);
  let s2 = read(t.log);
  const w = hufWeights;
  let n = 0;
  for (;;) {
    if (n > 253) throw 'zstd: too many Huffman weights';
    w[n++] = sym[s1];
    s1 = next[s1] + read(nb[s1]);
    if (pos < 0) {
      w[n++] = sym[s2];
      break;
    }
    w[n++] = sym[s2];
    s2 = next[s2] + read(nb[s2]);
    if (pos < 0) {
      w[n++] = sym[s1];
      break;
    }
  }
  return n;
}

/**
 * One Huffman stream d[s .. e) → out[o .. oEnd) (read backwards from its
 * end marker), with the frame's table.
 */
function huf1(d, s, e, out, o, oEnd) {
  if (e <= s) throw 'zstd: empty Huffman stream';
  const last = d[e - 1];
  if (last === 0) throw 'zstd: Huffman stream without an end marker';
  hufTail(d, s, last, highbit(last), e - 1, out, o, oEnd);
}

/**
 * The rest of a Huffman stream: `acc` holds `n` unread bits (its low ones;
 * the next bit is bit n − 1), `i` is the next byte to load (bytes at
 * s .. i − 1 remain). Decodes to out[o .. oEnd) and checks that the
 * stream is then exactly used up.
 */
function hufTail(d, s, acc, n, i, out, o, oEnd) {
  const t = hufTable;
  const mb = hufBits;
  const mask = (1 << mb) - 1;
  let pad = 0;
  while (o < oEnd) {
    while (n < mb) {
      if (i > s) acc = (acc << 8) | d[--i];
      else {
        acc <<= 8;
        pad += 8;
      }
      n += 8;
    }
    const x = t[(acc >>> (n - mb)) & mask];
    out[o++] = x & 255;
    n -= x >> 8;
  }
  if (i !== s || n !== pad) throw 'zstd: Huffman stream does not end with its last symbol';
}

/**
 * Four Huffman streams (a 6-byte jump table, then the streams) of d[s ..
 * e) → out[0 .. total): the first three decode ⌈total / 4⌉ symbols each.
 * One loop decodes all four, two symbols per stream and refill, while
 * every stream has 3 bytes and 2 symbols left; hufTail finishes each.
 * (Refilling by a computed byte count instead of two tests of the bit
 * count: every frame of bunny, loki in isolation 0.94–0.95× the time,
 * same-run medians of 60.)
 */
function huf4(d, s, e, out, total) {
  if (s + 6 > e) throw 'zstd: truncated Huffman jump table';
  const l1 = d[s] | (d[s + 1] << 8);
  const l2 = d[s + 2] | (d[s + 3] << 8);
  const l3 = d[s + 4] | (d[s + 5] << 8);
  const b1 = s + 6;
  const b2 = b1 + l1;
  const b3 = b2 + l2;
  const b4 = b3 + l3;
  if (b4 >= e) throw 'zstd: Huffman jump table points past the literals';
  const seg = (total + 3) >> 2;
  if (3 * seg > total) throw `zstd: ${total} literals cannot fill four streams`;
  if (l1 === 0 || l2 === 0 || l3 === 0) throw 'zstd: empty Huffman stream';
  const x1 = d[b2 - 1], x2 = d[b3 - 1], x3 = d[b4 - 1], x4 = d[e - 1];
  if (x1 === 0 || x2 === 0 || x3 === 0 || x4 === 0) throw 'zstd: Huffman stream without an end marker';
  let a1 = x1, a2 = x2, a3 = x3, a4 = x4;
  let n1 = highbit(x1), n2 = highbit(x2), n3 = highbit(x3), n4 = highbit(x4);
  let i1 = b2 - 1, i2 = b3 - 1, i3 = b4 - 1, i4 = e - 1;
  let o1 = 0, o2 = seg, o3 = 2 * seg, o4 = 3 * seg;
  const t = hufTable;
  const mb = hufBits;
  const mask = (1 << mb) - 1;
  // the refills' 3 bytes below i as one 4-byte load (its lowest byte,
  // below them, is shifted out; i − 4 ≥ b1 − 1 > s, inside d)
  const dv = new DataView(d.buffer, d.byteOffset, d.length);
  for (;;) {
    // iterations safe for every stream: 2 symbols out, ≤ 3 bytes in
    let k = (seg - o1) >> 1;
    let q = (total - o4) >> 1;
    if (q < k) k = q;
    q = ((i1 - b1) / 3) | 0;
    if (q < k) k = q;
    q = ((i2 - b2) / 3) | 0;
    if (q < k) k = q;
    q = ((i3 - b3) / 3) | 0;
    if (q < k) k = q;
    q = ((i4 - b4) / 3) | 0;
    if (q < k) k = q;
    if (k <= 0) break;
    for (; k > 0; k--) {
      // refill without a branch on the bit count (data: it mispredicts):
      // x = ⌊(31 − n) / 8⌋ ≤ 3 whole bytes from the 3 below i (the safe
      // count above leaves them in the stream), to 24 ≤ n ≤ 31 bits —
      // enough for two symbols of at most 11 bits
      let x;
      x = (31 - n1) >> 3;
      a1 = (a1 << (8 * x)) | ((dv.getUint32(i1 - 4, true) >>> 8) >>> (24 - 8 * x));
      i1 -= x;
      n1 += 8 * x;
      x = (31 - n2) >> 3;
      a2 = (a2 << (8 * x)) | ((dv.getUint32(i2 - 4, true) >>> 8) >>> (24 - 8 * x));
      i2 -= x;
      n2 += 8 * x;
      x = (31 - n3) >> 3;
      a3 = (a3 << (8 * x)) | ((dv.getUint32(i3 - 4, true) >>> 8) >>> (24 - 8 * x));
      i3 -= x;
      n3 += 8 * x;
      x = (31 - n4) >> 3;
      a4 = (a4 << (8 * x)) | ((dv.getUint32(i4 - 4, true) >>> 8) >>> (24 - 8 * x));
      i4 -= x;
      n4 += 8 * x;
      x = t[(a1 >>> (n1 - mb)) & mask];
      out[o1] = x;
      n1 -= x >> 8;
      x = t[(a2 >>> (n2 - mb)) & mask];
      out[o2] = x;
      n2 -= x >> 8;
      x = t[(a3 >>> (n3 - mb)) & mask];
      out[o3] = x;
      n3 -= x >> 8;
      x = t[(a4 >>> (n4 - mb)) & mask];
      out[o4] = x;
      n4 -= x >> 8;
      x = t[(a1 >>> (n1 - mb)) & mask];
      out[o1 + 1] = x;
      n1 -= x >> 8;
      x = t[(a2 >>> (n2 - mb)) & mask];
      out[o2 + 1] = x;
      n2 -= x >> 8;
      x = t[(a3 >>> (n3 - mb)) & mask];
      out[o3 + 1] = x;
      n3 -= x >> 8;
      x = t[(a4 >>> (n4 - mb)) & mask];
      out[o4 + 1] = x;
      n4 -= x >> 8;
      o1 += 2;
      o2 += 2;
      o3 += 2;
      o4 += 2;
    }
  }
  hufTail(d, b1, a1, n1, i1, out, o1, seg);
  hufTail(d, b2, a2, n2, i2, out, o2, 2 * seg);
  hufTail(d, b3, a3, n3, i3, out, o3, 3 * seg);
  hufTail(d, b4, a4, n4, i4, out, o4, total);
}

/**
 * The sequences of a block (RFC 8878 §3.1.1.3.2): a backward bitstream
 * d[p .. end), nSeq sequences executed into out from op with the block's
 * literals; then the literals left. Returns the new output position.
 */
function decodeSequences(d, p, end, out, op, nSeq, blockMax) {
  if (end <= p) throw 'zstd: missing sequences bitstream';
  const lastB = d[end - 1];
  if (lastB === 0) throw 'zstd: sequences bitstream without an end marker';
  // the bitstream copied between zero pads (SEQ_PAD bytes each side), so
  // that a 4-byte read never leaves the array: past its end it reads pad
  // bytes, below its start (only a corrupt stream: the position check
  // after each sequence rejects it) zeros
  const len = end - p;
  const S = SEQ;
  S.set(d.subarray(p, end), SEQ_PAD);
  S.fill(0, SEQ_PAD + len, SEQ_PAD + len + 4);
  const base = 8 * SEQ_PAD;
  // bits left: [base, pos)
  let pos = 8 * (SEQ_PAD + len - 1) + highbit(lastB);
  const llT = curTables[0];
  const ofT = curTables[1];
  const mlT = curTables[2];
  if (pos - base < llT.log + ofT.log + mlT.log) throw 'zstd: sequences bitstream too short';
  let b, v, n;
  // read(n): pos -= n, then bits [pos, pos + n) (n ≤ 25: 4 bytes suffice), inline
  n = llT.log;
  pos -= n;
  b = pos >> 3;
  v = SV.getInt32(b, true) >>> (pos & 7);
  let sl = v & ((1 << n) - 1);
  n = ofT.log;
  pos -= n;
  b = pos >> 3;
  v = SV.getInt32(b, true) >>> (pos & 7);
  let so = v & ((1 << n) - 1);
  n = mlT.log;
  pos -= n;
  b = pos >> 3;
  v = SV.getInt32(b, true) >>> (pos & 7);
  let sm = v & ((1 << n) - 1);
  const L = litBuf;
  let lp = litAt;
  const lEnd = litAt + litLen;
  const outLen = out.length;
  const blockEnd = Math.min(op + blockMax, outLen);
  let r0 = rep[0], r1 = rep[1], r2 = rep[2];
  // Short copies (most: bunny's 123k sequences have 4.3 match bytes and
  // 8.6 literals on average, half of them none) go 4 bytes at a time
  // through DataViews, rounded up to a multiple of 4: the up to 3 bytes
  // written past the copy lie inside `out` (checked before each copy) at
  // positions a later sequence or block writes (a frame writes every byte
  // of `out` or throws), and a match reads only bytes already final when
  // its offset is at least 4.
  const ov4 = new DataView(out.buffer, out.byteOffset, outLen);
  const lv4 = L === LIT ? LIT_VIEW : new DataView(L.buffer, L.byteOffset, L.length);
  const lCap = L.length;
  const llBase = llT.base, llAdd = llT.add, llNb = llT.nb, llNext = llT.next;
  const mlBase = mlT.base, mlAdd = mlT.add, mlNb = mlT.nb, mlNext = mlT.next;
  const ofBase = ofT.base, ofNb = ofT.nb, ofNext = ofT.next;
  for (let k = nSeq; k > 0; k--) {
    const oc = ofBase[so];
    if (oc > 25) throw `zstd: offset code ${oc} is past any frame of at most 2^25 bytes`;
    pos -= oc;
    b = pos >> 3;
    v = SV.getInt32(b, true) >>> (pos & 7);
    let ov = (1 << oc) + (v & ((1 << oc) - 1));
    // most length codes carry no extra bits: no read for them
    let ml = mlBase[sm];
    n = mlAdd[sm];
    if (n > 0) {
      pos -= n;
      b = pos >> 3;
      v = SV.getInt32(b, true) >>> (pos & 7);
      ml += v & ((1 << n) - 1);
    }
    let ll = llBase[sl];
    n = llAdd[sl];
    if (n > 0) {
      pos -= n;
      b = pos >> 3;
      v = SV.getInt32(b, true) >>> (pos & 7);
      ll += v & ((1 << n) - 1);
    }
    if (k > 1) {
      // state updates (not after the last sequence): ≤ 9 bits each
      // the literal-length and match-length updates (≤ 9 bits each) from
      // one 4-byte read: ≤ 18 bits + 7 of alignment
      const n1 = llNb[sl];
      const n2 = mlNb[sm];
      pos -= n1 + n2;
      b = pos >> 3;
      v = SV.getInt32(b, true) >>> (pos & 7);
      sm = mlNext[sm] + (v & ((1 << n2) - 1));
      sl = llNext[sl] + ((v >>> n2) & ((1 << n1) - 1));
      n = ofNb[so];
      pos -= n;
      b = pos >> 3;
      v = SV.getInt32(b, true) >>> (pos & 7);
      so = ofNext[so] + (v & ((1 << n) - 1));
    }
    if (pos < base) throw 'zstd: sequences bitstream overread';
    // repeat offsets (RFC 8878 §3.1.1.5): values 1-3 name them, shifted by
    // one when the literal length is 0 (4 = the first minus 1)
    let off;
    if (ov > 3) {
      off = ov - 3;
      r2 = r1;
      r1 = r0;
      r0 = off;
    } else {
      if (ll === 0) ov++;
      if (ov === 1) off = r0;
      else {
        off = ov === 2 ? r1 : ov === 3 ? r2 : r0 - 1;
        if (ov !== 2) r2 = r1;
        r1 = r0;
        r0 = off;
      }
    }
    if (lp + ll > lEnd) throw 'zstd: a sequence uses more literals than the block has';
    if (op + ll + ml > blockEnd) {
      if (op + ll + ml > outLen) throw `zstd frame decodes to more than ${outLen} bytes`;
      throw `zstd: block decodes to more than ${blockMax} bytes`;
    }
    if (ll > 32) out.set(L.subarray(lp, lp + ll), op);
    else if (op + ll + 3 <= outLen && lp + ll + 3 <= lCap) {
      for (let j = 0; j < ll; j += 4) ov4.setUint32(op + j, lv4.getUint32(lp + j, true), true);
    } else for (let j = 0; j < ll; j++) out[op + j] = L[lp + j];
    op += ll;
    lp += ll;
    if (off > op || off <= 0) throw `zstd: match offset ${off} reaches before the frame`;
    const from = op - off;
    if (off >= ml && ml > 32) out.copyWithin(op, from, from + ml);
    else if (off >= 4 && ml <= 32 && op + ml + 3 <= outLen) {
      for (let j = 0; j < ml; j += 4) ov4.setUint32(op + j, ov4.getUint32(from + j, true), true);
    } else for (let j = 0; j < ml; j++) out[op + j] = out[from + j];
    op += ml;
  }
  if (pos !== base) throw 'zstd: sequences bitstream not used up';
  rep[0] = r0;
  rep[1] = r1;
  rep[2] = r2;
  const rest = lEnd - lp;
  if (op + rest > blockEnd) {
    if (op + rest > outLen) throw `zstd frame decodes to more than ${outLen} bytes`;
    throw `zstd: block decodes to more than ${blockMax} bytes`;
  }
  copyLiterals(out, op, lp, rest);
  return op + rest;
}
