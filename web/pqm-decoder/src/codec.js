/**
 * Decoding of the base mesh section (spec §6) and of record chunks (spec §7)
 * into the decoder's *frontier* mesh (the deepest decoded level, with its
 * vertex→face adjacency) and its *record log* (every record in explicit form
 * with undo data, so that moving between levels never decodes again).
 *
 * Errors inside a record are thrown as message strings; `decodeChunk` turns
 * them into a `bad-record` error naming the chunk and the record.
 */
import { Reader } from './reader.js';
import { ensure } from './grow.js';
import { badRecord, invalid } from './errors.js';
import { decodeLocal } from './local.js';

/**
 * The deepest decoded level: per vertex a record of 16 int32 in `q` (its
 * code xyz, then the vertex→face adjacency the star walks need, spec §7.5,
 * §7.8), and the quads `f` (4 per slot).
 *
 * The adjacency is exact: per vertex the set of slots holding it, no stale
 * or repeated entries, so a star is a straight read of K slots. Vertex
 * `v`'s record is `q[16 v ..]`: code at `+ 0, 1, 2`, the number of slots
 * `n` at `+ LEN`, the first `INLINE` = 12 slots (unordered) from `+ AT`. A
 * vertex in more than 12 slots keeps the rest in `big` (vertex → a list
 * and a slot → index map, for O(1) removal: a hostile file can put one
 * vertex into millions of faces). A slot leaves a list by moving the
 * list's last entry into its place. Why one record per vertex: a record
 * reads the codes of the vertices around its edit (for predictions) and
 * then edits their lists — with both in one 64-byte record that is one
 * cache miss per vertex, not two; and a star walk reads one record and
 * then the K quads it needs anyway, where a linked list of corners costs a
 * scattered read per node. A vertex is listed by slot, not by corner, so a
 * record that rotates a quad changes no list (the corner is found in the
 * quad, `cornerIn`). Memory: 64 bytes per vertex, plus a Map entry per
 * vertex of more than 12 faces.
 */
export class Frontier {
  constructor() {
    /** Vertex records (see above): code and slot list. */
    this.q = new Int32Array(0);
    this.nv = 0;
    this.f = new Uint32Array(0);
    this.nf = 0;
    /** @type {Map<number, {s: number[], at: Map<number, number>}>} slots past the 12th of a vertex */
    this.big = new Map();
    /** Final counts of the file: capacities never grow beyond them. */
    this.maxV = Infinity;
    this.maxF = Infinity;
  }

  /** Lists slot `s` at vertex `v` (which the caller knows is not listed there). */
  add(v, s) {
    const q = this.q;
    const b = v << 4;
    const n = q[b + LEN];
    if (n < INLINE) q[b + AT + n] = s;
    else this._bigAdd(v, s);
    q[b + LEN] = n + 1;
  }

  _bigAdd(v, s) {
    let e = this.big.get(v);
    if (e === undefined) {
      e = { s: [], at: new Map() };
      this.big.set(v, e);
    }
    e.at.set(s, e.s.length);
    e.s.push(s);
  }

  /** Removes slot `s` from vertex `v`'s list (where it is listed). */
  remove(v, s) {
    const q = this.q;
    const b = v << 4;
    const n = q[b + LEN];
    const lim = n < INLINE ? n : INLINE;
    for (let i = AT; i < AT + lim; i++) {
      if (q[b + i] !== s) continue;
      // the last entry fills the hole: from `big` when there is one
      if (n > INLINE) q[b + i] = this._bigPop(v);
      else q[b + i] = q[b + AT + n - 1];
      q[b + LEN] = n - 1;
      return;
    }
    this._bigRemove(v, s);
    q[b + LEN] = n - 1;
  }

  _bigPop(v) {
    const e = this.big.get(v);
    const s = e.s.pop();
    e.at.delete(s);
    return s;
  }

  _bigRemove(v, s) {
    const e = this.big.get(v);
    const i = e.at.get(s);
    const last = e.s.pop();
    e.at.delete(s);
    if (last !== s) {
      e.s[i] = last;
      e.at.set(last, i);
    }
  }

  /**
   * Sets corner `c` (< 4 nf) to vertex `v`, keeping the lists exact; `v`
   * must not be at another corner of the slot (quads have distinct
   * corners). For edits one corner at a time (rewriteSlot does whole quads).
   */
  setCorner(c, v) {
    const old = this.f[c];
    if (old === v) return;
    this.f[c] = v;
    this.remove(old, c >> 2);
    this.add(v, c >> 2);
  }

  /** Lists every corner of slot `s` (a new quad, already in `f`). */
  addSlot(s) {
    const f = this.f;
    const s4 = 4 * s;
    this.add(f[s4], s);
    this.add(f[s4 + 1], s);
    this.add(f[s4 + 2], s);
    this.add(f[s4 + 3], s);
  }

  /** Lists every slot of `f` afresh at its four vertices. */
  rebuild() {
    this.reserve(this.nv, this.nf);
    const q = this.q;
    for (let v = 0; v < this.nv; v++) q[(v << 4) + LEN] = 0;
    this.big.clear();
    for (let s = 0; s < this.nf; s++) this.addSlot(s);
  }

  /**
   * The number of slots holding `v`, and the first `max` of them (in no
   * particular order) in `out`.
   */
  slotsOf(v, out, max) {
    const q = this.q;
    const b = v << 4;
    const n = q[b + LEN];
    const lim = n < max ? n : max;
    const inl = lim < INLINE ? lim : INLINE;
    for (let i = 0; i < inl; i++) out[i] = q[b + AT + i];
    if (lim > INLINE) {
      const xs = this.big.get(v).s;
      for (let i = INLINE; i < lim; i++) out[i] = xs[i - INLINE];
    }
    return n;
  }

  /**
   * (The reference form of what canonicalStar and the face split read
   * fused with their own work; the tests check the lists with it.)
   * The star of vertex `m`: the slots holding it, ascending, into `slots`,
   * and the corner (0..3) of `m` in each into `corners`; returns their
   * number. Throws a message string past 255 faces (spec §7.5: K ≤ 255).
   * @param {number} m
   * @param {Int32Array} slots at least 255 entries
   * @param {Int32Array} corners at least 255 entries
   */
  star(m, slots, corners) {
    const q = this.q;
    const b = m << 4;
    const K = q[b + LEN];
    if (K > 255) throw `vertex ${m} is in more than 255 faces`;
    const f = this.f;
    const xs = K > INLINE ? this.big.get(m).s : null;
    for (let t = 0; t < K; t++) {
      const slot = t < INLINE ? q[b + AT + t] : xs[t - INLINE];
      const k = cornerIn(f, 4 * slot, m);
      // insertion sort by slot: K is small
      let i = t;
      while (i > 0 && slots[i - 1] > slot) {
        slots[i] = slots[i - 1];
        corners[i] = corners[i - 1];
        i--;
      }
      slots[i] = slot;
      corners[i] = k;
    }
    return K;
  }

  /**
   * The slots holding `m`, ascending, into `slots` (at least 255 entries);
   * returns their number. Throws a message string past 255 faces (spec
   * §7.5: K ≤ 255). Reads `m`'s record only, no quad.
   */
  sortedSlots(m, slots) {
    const q = this.q;
    const b = m << 4;
    const K = q[b + LEN];
    if (K > 255) throw `vertex ${m} is in more than 255 faces`;
    const xs = K > INLINE ? this.big.get(m).s : null;
    for (let t = 0; t < K; t++) {
      const slot = t < INLINE ? q[b + AT + t] : xs[t - INLINE];
      let i = t;
      while (i > 0 && slots[i - 1] > slot) {
        slots[i] = slots[i - 1];
        i--;
      }
      slots[i] = slot;
    }
    return K;
  }

  /** Room for `nv` vertices and `nf` slots. */
  reserve(nv, nf) {
    const mv = this.maxV;
    const mf = this.maxF;
    if (16 * nv > this.q.length) this.q = ensure(this.q, 16 * nv, 16 * this.nv, 16 * mv);
    if (4 * nf > this.f.length) this.f = ensure(this.f, 4 * nf, 4 * this.nf, 4 * mf);
  }
}

/** A vertex record of `Frontier.q`: its list length at `+ LEN`, the first `INLINE` slots from `+ AT`. */
const LEN = 3;
const AT = 4;
const INLINE = 12;

/** The number of slots holding vertex `v` of frontier `st`. */
export function degree(st, v) {
  return st.q[(v << 4) + LEN];
}

/**
 * The corner (0..3) of the quad at `f[s4 .. s4 + 4)` that holds vertex `v`,
 * known to be one of its four (the slot lists are exact): from comparisons
 * as 0/1 values, with no branch on where `v` sits — it is anywhere, so such
 * branches mispredict on the hot paths (canonicalStar, the face split).
 */
export function cornerOf(f, s4, v) {
  return ((f[s4 + 1] === v) | 0) + 2 * ((f[s4 + 2] === v) | 0) + 3 * ((f[s4 + 3] === v) | 0);
}

/**
 * The corner of the quad at `f[s4 .. s4 + 4)` that holds vertex `v` (0..3),
 * or −1.
 */
export function cornerIn(f, s4, v) {
  if (f[s4] === v) return 0;
  if (f[s4 + 1] === v) return 1;
  if (f[s4 + 2] === v) return 2;
  if (f[s4 + 3] === v) return 3;
  return -1;
}

/**
 * Explicit records with undo data, structure-of-arrays (spec §7.1). Level
 * `k` has `vAt[k]` vertices and `fAt[k]` faces; record `k` (from level `k`
 * to `k + 1`) moved the entries `movedAt[k] .. movedAt[k+1]` of `moved`
 * (stride 4: vertex, code change xyz = new − old) and rewrote the entries
 * `rwAt[k] .. rwAt[k+1]` of `rw` (stride 2: corner index 4 · slot + c,
 * new XOR old of that corner — one entry per corner that changes, so the
 * split's one-corner rewrites take 8 bytes instead of a whole quad's 20;
 * a slot may have several entries in one record). Entries are applied in record order when refining and in
 * reverse when coarsening, so a change and its inverse are the same data
 * (add / subtract, XOR): half the memory of storing both states, and
 * memory traffic is what the decoder waits on. `newCodes` holds the first
 * code of every vertex after the base ones and `app` the first quad of
 * every slot after the base ones — for the first `nNew` / `nApp` of them:
 * they are not written while records decode but built from the frontier
 * when a move first needs them (PqmDecoder `_firstStates`): a move to the
 * deepest level copies the frontier and needs neither, and that is the
 * move a whole-file or streaming decode makes (bunny: 5.8 MB not written).
 */
export class RecordLog {
  /**
   * @param {boolean} [forward] one-way decoding (PqmDecoder's `forwardOnly`):
   * `moved` and `rw` hold only the entries of the chunk being decoded (the
   * decoder takes what the next change reports from them when the chunk
   * commits and then empties them), `newCodes`, `app` and `ops` stay empty
   * (the frontier holds the appended vertices and quads), and
   * `movedAt` / `rwAt` are not kept.
   */
  constructor(forward = false) {
    this.forward = forward;
    this.ops = new Uint8Array(0);
    this.nRecords = 0;
    this.vAt = new Uint32Array(0);
    this.fAt = new Uint32Array(0);
    this.movedAt = new Uint32Array(0);
    this.rwAt = new Uint32Array(0);
    this.moved = new Int32Array(0);
    this.nMoved = 0;
    this.rw = new Int32Array(0);
    this.nRw = 0;
    this.newCodes = new Uint32Array(0);
    this.nNew = 0;
    this.app = new Uint32Array(0);
    this.nApp = 0;
    /** `moved` / `rw` entries when `newCodes` / `app` were last built. */
    this.movedBuilt = 0;
    this.rwBuilt = 0;
  }

  /** Appends the counts of a new level (after the base or a record). */
  pushLevel(v, f) {
    const n = this.levels;
    if (n + 1 > this.vAt.length) {
      const max = this.maxLevels;
      this.vAt = ensure(this.vAt, n + 1, n, max);
      this.fAt = ensure(this.fAt, n + 1, n, max);
      if (!this.forward) {
        this.movedAt = ensure(this.movedAt, n + 1, n, max);
        this.rwAt = ensure(this.rwAt, n + 1, n, max);
      }
    }
    this.vAt[n] = v;
    this.fAt[n] = f;
    if (!this.forward) {
      this.movedAt[n] = this.nMoved;
      this.rwAt[n] = this.nRw;
    }
    this.levels = n + 1;
  }

  /** Room for `levels` levels in vAt, fAt (and movedAt, rwAt, ops unless one-way). */
  reserveLevels(levels) {
    const n = this.levels;
    const max = this.maxLevels;
    if (levels > this.vAt.length) {
      this.vAt = ensure(this.vAt, levels, n, max);
      this.fAt = ensure(this.fAt, levels, n, max);
    }
    if (this.forward) return;
    if (levels > this.movedAt.length) {
      this.movedAt = ensure(this.movedAt, levels, n, max);
      this.rwAt = ensure(this.rwAt, levels, n, max);
    }
    if (levels > this.ops.length) this.ops = ensure(this.ops, levels, this.nRecords, max);
  }

  /**
   * Room for `levels` levels and for the rewritten-slot entries of `nApp`
   * appended quads (the general log's whole `rw` holds every record's, the
   * one-way log's only the chunk's: `nApp` counts what `rw` will hold);
   * capacities grow past them as usual.
   */
  reserve(levels, nApp) {
    // Rewritten corners: about 3.3 per appended quad in the encoder's files
    // (loki and bunny; 1.9 rewritten slots, most of them with one changed
    // corner), so room for RW_PER_APP per quad — one allocation instead of
    // ×2 steps (bunny: 5.4 MB of entries, each step a copy into fresh
    // pages); a file with more grows ×2 from there.
    const nRw = Math.ceil(RW_PER_APP * nApp);
    if (2 * nRw > this.rw.length) this.rw = ensure(this.rw, 2 * nRw, 2 * this.nRw);
    this.reserveLevels(levels);
  }
}
RecordLog.prototype.levels = 0;
/** Levels of the file (record_count + 1): capacities never grow beyond. */
RecordLog.prototype.maxLevels = Infinity;
/** Rewritten-corner entries reserved per appended quad (RecordLog.reserve). */
const RW_PER_APP = 3.5;

/**
 * Decodes the base payload (spec §6) into a fresh frontier: the delta
 * layout in a file of version 3 or older; from version 4 a layout byte,
 * then the delta layout (0) or the traversal layout (1, §6.1).
 * @param {Uint8Array} payload
 * @param {number} nv base_vertex_count
 * @param {number} nf base_face_count
 * @param {number} qmax
 * @param {number} [capV=nv] vertices to make room for (≥ nv)
 * @param {number} [capF=nf] slots to make room for (≥ nf)
 * @param {number} [major=3] the file's version_major
 * @param {Frontier|null} [spare] a frontier of an earlier file whose arrays
 *   take the base when they are large enough (PqmDecoder `reset`): it is
 *   emptied and returned, the same frontier as a fresh one but for the
 *   capacity and the contents past the counts, which are never read
 * @returns {Frontier}
 */
export function decodeBase(payload, nv, nf, qmax, capV = nv, capF = nf, major = 3, spare = null) {
  return decodeBaseWith(payload, nv, nf, qmax, capV, capF, major, false, spare);
}

/**
 * decodeBase with the traversal layout decoded by decodeTraversalReference
 * (no shortcuts: every half-edge looked up), for tests: the same frontier
 * or the same error as decodeBase on any input.
 */
export function decodeBaseReference(payload, nv, nf, qmax, capV = nv, capF = nf, major = 3) {
  return decodeBaseWith(payload, nv, nf, qmax, capV, capF, major, true);
}

function decodeBaseWith(payload, nv, nf, qmax, capV, capF, major, reference, spare = null) {
  const section = 'base mesh';
  let traversal = false;
  let start = 0;
  if (major >= 4) {
    if (payload.length === 0) throw invalid(section, 'the base payload is empty (no layout byte)');
    const layout = payload[0];
    if (layout > LAYOUT_TRAVERSAL) throw invalid(section, `unknown base layout ${layout}`);
    traversal = layout === LAYOUT_TRAVERSAL;
    start = 1;
  }
  const len = payload.length - start;
  // Every corner and coordinate takes at least one byte (delta layout);
  // every face at least two corner bytes and every vertex three bytes of
  // `pos` (traversal layout): checked before allocating.
  const least = traversal ? 2 * nf + 3 * nv : 4 * nf + 3 * nv;
  if (least > len) {
    throw invalid(section, `${nf} faces and ${nv} vertices need at least ${least} bytes, the payload has ${len}`);
  }
  let st;
  if (spare !== null) {
    // An earlier file's frontier (its pages already mapped): emptied, each
    // array kept if it has the room a fresh one would get (else a fresh
    // one, as without a spare). Its old contents are never read: the base
    // decoders write every quad and every vertex's code before reading
    // them, rebuild() sets every base vertex's list length, appendVertex
    // each new one's, and a list is read only up to its length.
    st = spare;
    st.nv = 0;
    st.nf = 0;
    st.big.clear();
    st.maxV = Infinity;
    st.maxF = Infinity;
    const nq = 16 * Math.max(nv, capV);
    const nff = 4 * Math.max(nf, capF);
    if (st.q.length < nq) st.q = new Int32Array(nq);
    if (st.f.length < nff) st.f = new Uint32Array(nff);
  } else {
    st = new Frontier();
    st.q = new Int32Array(16 * Math.max(nv, capV));
    st.f = new Uint32Array(4 * Math.max(nf, capF));
  }
  try {
    if (traversal) (reference ? decodeTraversalReference : decodeTraversal)(payload, start, st, nv, nf, qmax);
    else decodeDelta(payload, start, st, nv, nf, qmax);
  } catch (e) {
    if (typeof e === 'string') throw invalid(section, e);
    throw e;
  }
  st.nv = nv;
  st.nf = nf;
  st.rebuild();
  return st;
}

/** Base layout byte (version ≥ 4, spec §6): the traversal layout follows (0: the delta layout). */
const LAYOUT_TRAVERSAL = 1;
/** Most faces a vertex may be in, in the traversal layout (spec §6.1). */
const MAX_FACES_PER_VERTEX = 255;

/** The delta layout (spec §6) from `payload[start ..]` into `st.f` / `st.q`; throws message strings. */
function decodeDelta(payload, start, st, nv, nf, qmax) {
  const r = new Reader(payload, start, payload.length, 'base');
  let prev = 0;
  const f = st.f;
  for (let i = 0; i < nf; i++) {
    for (let c = 0; c < 4; c++) {
      const v = prev + r.s();
      if (v < 0 || v >= nv) throw `face ${i} corner ${c} is vertex ${v}, outside 0..${nv}`;
      f[4 * i + c] = v;
      prev = v;
    }
    const a = f[4 * i], b = f[4 * i + 1], c = f[4 * i + 2], d = f[4 * i + 3];
    if (a === b || a === c || a === d || b === c || b === d || c === d) {
      throw `face ${i} repeats a vertex (${a} ${b} ${c} ${d})`;
    }
  }
  const q = st.q;
  let x = 0, y = 0, z = 0;
  for (let i = 0; i < nv; i++) {
    x += r.s();
    y += r.s();
    z += r.s();
    if (x < 0 || x > qmax || y < 0 || y > qmax || z < 0 || z > qmax) {
      throw `vertex ${i} code (${x}, ${y}, ${z}) outside 0..=${qmax}`;
    }
    q[16 * i] = x;
    q[16 * i + 1] = y;
    q[16 * i + 2] = z;
  }
  if (r.remaining() !== 0) throw `${r.remaining()} unused bytes after the last vertex`;
}

/**
 * The traversal layout (spec §6.1) from `payload[start ..]` into `st.f` /
 * `st.q`; throws message strings. Mirrors `decode_traversal` of the Rust
 * reference (pqm_format::base), and decodeTraversalReference below (the
 * same decoder looking every half-edge up: the same faces, codes and
 * errors, which a test holds it to).
 *
 * The decoded half-edges are kept per vertex as a list of its corners in
 * decode order (`cNext` links corner `4 g + k` of face `g` to the vertex's
 * next corner; `cNext[4 nf + v]` is the first of `v`'s, so an append needs
 * no test for an empty list): corner `c` of face `g` starts the half-edge
 * `g[k] → g[k+1]` (id `c`, outgoing at `g[k]`) and ends the half-edge
 * `g[k−1] → g[k]` (id `g·4 + (k+3) mod 4`, incoming: a face holds a vertex
 * once), so one list gives both the outgoing and the incoming half-edges in
 * decode order. `open[e]` says that the reverse of half-edge `e` is not
 * decoded. A vertex is in at most 255 faces, so every scan of a list is
 * short.
 *
 * A face coded across the open half-edge `a → b` (`g[r] = b`, `g[r+1] = a`,
 * `x = g[r+2]`, `y = g[r+3]`) takes what addFace would scan the lists for
 * from how `x` and `y` were named: `b → a` is no repeat (`a → b` is open)
 * and its reverse is `a → b`; a new `x` (`y`) is in no half-edge and is
 * none of the other corners; a candidate `x` (`x → a` open) is neither `a`
 * nor `b`, `a → x` is no repeat and its reverse is `x → a`; likewise a
 * candidate `y` (`b → y` open) for `y → b`; only `x → y`, when both are
 * candidates, is looked up (one scan of `x`'s corners), and only then may
 * two corners be equal (`x = y`, compared). An escape, a crowded corner, a
 * repeated vertex or half-edge goes to addFaceLists (the reference's
 * addFace on these lists), so that every error is the one it reports.
 *
 * Positions: `P(v)`'s parallelogram sum is over the faces at `v` whose
 * three other corners come before `v`: those whose largest corner is `v`,
 * which each vertex lists (`topHead` / `topNext`, built as faces are
 * added: a face across an edge with a new `y` has it as its largest
 * corner, else one with a new `x` has `x`); `v`'s other faces are walked
 * only when it has none of them. For 1, 2, 4 or 8 faces the floor of the
 * sum over 8 c is a shift.
 */
function decodeTraversal(payload, start, st, nv, nf, qmax) {
  // qmax as int32: the decoder passes 2 ** bits − 1, a heap number, and
  // compared and returned by clamp() it made every prediction and code a
  // double, each store into q a conversion. (bits ≤ 24 is checked with the
  // header; a caller with a wider qmax gets the reference decoder, whose
  // sums need not fit an int32.)
  if (!(qmax <= 0xffffff)) {
    decodeTraversalReference(payload, start, st, nv, nf, qmax);
    return;
  }
  qmax |= 0;
  const top = new Reader(payload, start, payload.length, 'base');
  const gates = baseStream(top, 'base gates');
  const corners = baseStream(top, 'base corners');
  const escapes = baseStream(top, 'base escapes');
  const pos = baseStream(top, 'base positions');
  if (top.remaining() !== 0) throw `${top.remaining()} bytes after the last base stream`;

  const f = st.f;
  const nc = 4 * nf;
  // cNext[nc + v]: v's first corner (−1: none); tail[v]: the slot its next
  // corner's id goes to; deg[v]: its faces; topHead / topNext: the faces
  // whose largest corner it is. All views of one zero-filled allocation.
  const words = nc + 4 * nv + nf;
  const mem = new ArrayBuffer(4 * words + nc);
  const cNext = new Int32Array(mem, 0, nc + nv).fill(-1, nc);
  const tail = new Int32Array(mem, 4 * (nc + nv), nv);
  for (let v = 0; v < nv; v++) tail[v] = nc + v;
  const deg = new Int32Array(mem, 4 * (nc + 2 * nv), nv);
  const topHead = new Int32Array(mem, 4 * (nc + 3 * nv), nv).fill(-1);
  const topNext = new Int32Array(mem, 4 * (nc + 4 * nv), nf);
  const open = new Uint8Array(mem, 4 * words, nc);
  // the gate and corner streams read in place (their cursors written back
  // for the rare paths that use the readers and for the checks at the end)
  const gb = gates.b;
  const gEnd = gates.end;
  let gp = gates.p;
  const cb = corners.b;
  const cEnd = corners.end;
  let cp = corners.p;
  let s = 0; // vertices seen
  let n = 0;
  let h = 0;
  while (n < nf) {
    const o = 4 * n;
    if (h === n) {
      // a component start: four corner symbols, no candidates
      corners.p = cp;
      for (let k = 0; k < 4; k++) {
        const v = startCorner(corners, escapes, s, nv, n);
        if (v === s) s++;
        f[o + k] = v;
      }
      cp = corners.p;
      addFaceLists(f, cNext, tail, deg, open, nc, n);
      addTop(f, topHead, topNext, n);
      n++;
      continue;
    }
    const g = 4 * h;
    h++;
    for (let k = 0; k < 4 && n < nf; k++) {
      // face h's half-edge a → b: b → a is decoded exactly when it is closed
      const ab = g + k;
      if (open[ab] === 0) continue;
      if (gp >= gEnd) throw `stream base gates ends early`;
      const gate = gb[gp++];
      if (gate === 0) continue;
      if (gate > 4) throw `gate byte ${gate} before face ${n} (spec §6.1)`;
      const a = f[ab];
      const b = f[g + ((k + 1) & 3)];
      const on = 4 * n;
      const r = gate - 1;
      const ta = on + ((r + 1) & 3);
      const tx = on + ((r + 2) & 3);
      const ty = on + ((r + 3) & 3);
      f[on + r] = b;
      f[ta] = a;
      // x: new, a candidate of X (the sources of the open half-edges into
      // a, in decode order: the incoming half-edge of each of a's corners)
      // or an escape; ex: the open half-edge x → a it names (−1: new, −2:
      // escape). The candidates are taken before face n's half-edges are
      // added.
      if (cp >= cEnd) throw `stream base corners ends early`;
      let sym = cb[cp++];
      let x;
      let ex = -1;
      if (sym === 0) {
        if (s >= nv) throw `face ${n} has a new vertex but all ${nv} vertices are seen`;
        x = s++;
      } else if (sym === 255) {
        x = escapeCorner(escapes, s, n);
        ex = -2;
      } else {
        let i = sym - 1;
        for (let c = cNext[nc + a]; c >= 0; c = cNext[c]) {
          const e = (c & ~3) | ((c + 3) & 3);
          if (open[e] !== 0) {
            if (i === 0) {
              ex = e;
              break;
            }
            i--;
          }
        }
        if (ex < 0) throw `face ${n} names candidate ${sym} of ${sym - 1 - i} (spec §6.1)`;
        x = f[ex];
      }
      f[tx] = x;
      // y: likewise from Y (the targets of the open half-edges out of b);
      // ey: the open half-edge b → y
      if (cp >= cEnd) throw `stream base corners ends early`;
      sym = cb[cp++];
      let y;
      let ey = -1;
      if (sym === 0) {
        if (s >= nv) throw `face ${n} has a new vertex but all ${nv} vertices are seen`;
        y = s++;
      } else if (sym === 255) {
        y = escapeCorner(escapes, s, n);
        ey = -2;
      } else {
        let i = sym - 1;
        for (let c = cNext[nc + b]; c >= 0; c = cNext[c]) {
          if (open[c] !== 0) {
            if (i === 0) {
              ey = c;
              break;
            }
            i--;
          }
        }
        if (ey < 0) throw `face ${n} names candidate ${sym} of ${sym - 1 - i} (spec §6.1)`;
        y = f[(ey & ~3) | ((ey + 1) & 3)];
      }
      f[ty] = y;
      // the face's half-edges from how x and y were named (see above), or
      // addFaceLists where that does not tell (or an error may be due)
      let fast = ex !== -2 && ey !== -2 && deg[a] < MAX_FACES_PER_VERTEX && deg[b] < MAX_FACES_PER_VERTEX;
      let exy = -1; // the reverse y → x of x → y
      if (fast && ex >= 0) {
        if (deg[x] >= MAX_FACES_PER_VERTEX) fast = false;
        else if (ey >= 0) {
          if (x === y) fast = false;
          else {
            // one scan of x's corners: a repeat x → y or the reverse y → x
            for (let c = cNext[nc + x]; c >= 0; c = cNext[c]) {
              const co = c & ~3;
              if (f[co | ((c + 1) & 3)] === y) {
                fast = false;
                break;
              }
              const e = co | ((c + 3) & 3);
              if (f[e] === y) exy = e;
            }
          }
        }
      }
      if (fast && ey >= 0 && deg[y] >= MAX_FACES_PER_VERTEX) fast = false;
      if (fast) {
        // b → a closes a → b
        open[ab] = 0;
        open[on + r] = 0;
        if (ex >= 0) {
          open[ex] = 0;
          open[ta] = 0;
        } else open[ta] = 1;
        if (exy >= 0) {
          open[exy] = 0;
          open[tx] = 0;
        } else open[tx] = 1;
        if (ey >= 0) {
          open[ey] = 0;
          open[ty] = 0;
        } else open[ty] = 1;
        // each corner appended to its vertex's list (a vertex gets one per
        // face, so the order within the face is free)
        cNext[tail[b]] = on + r;
        tail[b] = on + r;
        cNext[on + r] = -1;
        deg[b]++;
        cNext[tail[a]] = ta;
        tail[a] = ta;
        cNext[ta] = -1;
        deg[a]++;
        cNext[tail[x]] = tx;
        tail[x] = tx;
        cNext[tx] = -1;
        deg[x]++;
        cNext[tail[y]] = ty;
        tail[y] = ty;
        cNext[ty] = -1;
        deg[y]++;
        // the largest corner: a new y, else a new x, else compared
        if (ey === -1) {
          topNext[n] = topHead[y];
          topHead[y] = ty;
        } else if (ex === -1) {
          topNext[n] = topHead[x];
          topHead[x] = tx;
        } else addTop(f, topHead, topNext, n);
      } else {
        addFaceLists(f, cNext, tail, deg, open, nc, n);
        addTop(f, topHead, topNext, n);
      }
      n++;
    }
  }
  gates.p = gp;
  corners.p = cp;
  if (s !== nv) throw `the faces use ${s} of the ${nv} base vertices`;
  for (const r of [gates, corners, escapes]) {
    if (r.remaining() !== 0) throw `${r.remaining()} unused bytes in the ${r.name}`;
  }

  // Positions: P(v) over the faces whose largest corner is v (their other
  // corners come before v), else the mean of v's earlier edge neighbours
  // (spec §6.1; §7.6's version-4 stencil).
  const q = st.q;
  for (let v = 0; v < nv; v++) {
    let fk = topHead[v];
    if (fk >= 0) {
      let px, py, pz;
      let sx = 0, sy = 0, sz = 0, c = 0;
      do {
        const fo = fk & ~3;
        const n1 = 16 * f[fo | ((fk + 1) & 3)];
        const op = 16 * f[fo | ((fk + 2) & 3)];
        const n3 = 16 * f[fo | ((fk + 3) & 3)];
        sx += 5 * (q[n1] + q[n3]) - 2 * q[op];
        sy += 5 * (q[n1 + 1] + q[n3 + 1]) - 2 * q[op + 1];
        sz += 5 * (q[n1 + 2] + q[n3 + 2]) - 2 * q[op + 2];
        c++;
        fk = topNext[fk >> 2];
      } while (fk >= 0);
      if (c <= 8 && (c & (c - 1)) === 0) {
        // d = 8 c a power of two (one or two faces, the most common): the
        // floor is an arithmetic shift, the sums being int32 (|s| ≤ 8 · 10 ·
        // qmax < 2^31 for qmax < 2^24)
        const sh = 34 - Math.clz32(c);
        px = clamp(sx >> sh, qmax);
        py = clamp(sy >> sh, qmax);
        pz = clamp(sz >> sh, qmax);
      } else {
        // Math.floor(s / d) is exact here (as in the split form): d ≤ 8 ·
        // 255 and |s| ≤ 255 · 12 · 2^24, so the quotient's rounding error
        // is far below the 1/d a non-integer quotient keeps from the next
        // integer
        const d = 8 * c;
        px = clamp(Math.floor(sx / d), qmax);
        py = clamp(Math.floor(sy / d), qmax);
        pz = clamp(Math.floor(sz / d), qmax);
      }
      storeBaseCode(q, v, px, py, pz, pos, qmax);
    } else {
      let ex = 0, ey = 0, ez = 0, e = 0;
      for (let cr = cNext[nc + v]; cr >= 0; cr = cNext[cr]) {
        const fo = cr & ~3;
        const n1 = f[fo | ((cr + 1) & 3)];
        const n3 = f[fo | ((cr + 3) & 3)];
        if (n1 < v) {
          ex += q[16 * n1];
          ey += q[16 * n1 + 1];
          ez += q[16 * n1 + 2];
          e++;
        }
        if (n3 < v) {
          ex += q[16 * n3];
          ey += q[16 * n3 + 1];
          ez += q[16 * n3 + 2];
          e++;
        }
      }
      storeEdgeMeanCode(q, v, e, ex, ey, ez, pos, qmax);
    }
  }
  if (pos.remaining() !== 0) throw `${pos.remaining()} unused bytes in the base positions`;
}

/**
 * Base vertex `v`'s code: prediction (px, py, pz) plus its three residuals
 * from `pos`, checked against 0..=qmax, into `q` (both traversal decoders).
 */
function storeBaseCode(q, v, px, py, pz, pos, qmax) {
  const x = px + pos.s();
  const y = py + pos.s();
  const z = pz + pos.s();
  if (x < 0 || x > qmax || y < 0 || y > qmax || z < 0 || z > qmax) {
    throw `vertex ${v} code (${x}, ${y}, ${z}) outside 0..=${qmax}`;
  }
  q[16 * v] = x;
  q[16 * v + 1] = y;
  q[16 * v + 2] = z;
}

/**
 * Base vertex `v`'s code where no face has three earlier corners: the
 * mean of its `e` earlier edge neighbours (their sums ex, ey, ez), else
 * the previous vertex's code, else 0 (spec §6.1), plus its residuals.
 */
function storeEdgeMeanCode(q, v, e, ex, ey, ez, pos, qmax) {
  if (e > 0) {
    const px = clamp(Math.floor(ex / e), qmax);
    const py = clamp(Math.floor(ey / e), qmax);
    const pz = clamp(Math.floor(ez / e), qmax);
    storeBaseCode(q, v, px, py, pz, pos, qmax);
  } else if (v > 0) {
    storeBaseCode(q, v, q[16 * (v - 1)], q[16 * (v - 1) + 1], q[16 * (v - 1) + 2], pos, qmax);
  } else {
    storeBaseCode(q, v, 0, 0, 0, pos, qmax);
  }
}

/** A component start's corner symbol of face `n` (no candidates): cornerSymbol of kind 0. */
function startCorner(corners, escapes, s, nv, n) {
  const sym = corners.byte();
  if (sym === 0) {
    if (s >= nv) throw `face ${n} has a new vertex but all ${nv} vertices are seen`;
    return s;
  }
  if (sym === 255) return escapeCorner(escapes, s, n);
  throw `face ${n} names candidate ${sym} of 0 (spec §6.1)`;
}

/** An escape corner symbol of face `n` with `s` vertices seen (spec §6.1): the vertex it names. */
function escapeCorner(escapes, s, n) {
  const u = escapes.u();
  if (u >= s) throw `face ${n} escapes to vertex ${s - 1 - u} before vertex 0`;
  return s - 1 - u;
}

/**
 * Face `n` (its corners in `f`) into decodeTraversal's lists (`cNext[nc +
 * v]` the first of v's corners, `tail[v]` the slot for its next): the
 * checks of addFace (4 distinct corners, no half-edge decoded twice, at
 * most 255 faces per vertex) and their messages, the reverses it meets
 * closed. One scan of `u`'s corners per corner `u → v` finds both a repeat
 * (an outgoing `u → v`) and the reverse (an incoming `v → u`).
 */
function addFaceLists(f, cNext, tail, deg, open, nc, n) {
  const o = 4 * n;
  const a = f[o], b = f[o + 1], c = f[o + 2], d = f[o + 3];
  if (a === b || a === c || a === d || b === c || b === d || c === d) {
    throw `face ${n} repeats a vertex (${a} ${b} ${c} ${d})`;
  }
  for (let t = 0; t < 4; t++) {
    const u = f[o + t];
    const v = f[o + ((t + 1) & 3)];
    if (deg[u] >= MAX_FACES_PER_VERTEX) throw `face ${n}: vertex ${u} is in more than ${MAX_FACES_PER_VERTEX} faces`;
    let rev = -1;
    for (let cr = cNext[nc + u]; cr >= 0; cr = cNext[cr]) {
      const fo = cr & ~3;
      if (f[fo | ((cr + 1) & 3)] === v) throw `face ${n}: half-edge ${u} -> ${v} is in two faces`;
      const e = fo | ((cr + 3) & 3);
      if (f[e] === v) rev = e;
    }
    const id = o + t;
    if (rev >= 0) open[rev] = 0;
    open[id] = rev < 0 ? 1 : 0;
    cNext[id] = -1;
    cNext[tail[u]] = id;
    tail[u] = id;
    deg[u]++;
  }
}

/** Face `n` (4 distinct corners in `f`) into its largest corner's list of faces (`topHead` / `topNext`, as corner ids). */
function addTop(f, topHead, topNext, n) {
  const o = 4 * n;
  const k01 = f[o + 1] > f[o] ? 1 : 0;
  const k23 = f[o + 3] > f[o + 2] ? 3 : 2;
  const k = f[o + k23] > f[o + k01] ? k23 : k01;
  const v = f[o + k];
  topNext[n] = topHead[v];
  topHead[v] = o + k;
}

/**
 * decodeTraversal without its shortcuts (as `decode_reference` of the Rust
 * reference, pqm_format::base): every face's half-edges looked up in the
 * lists by addFace, every prediction over all the faces at its vertex. The
 * same faces, codes and errors as decodeTraversal on any input (a test
 * holds them to it); decodeBaseReference decodes with it. The decoded half-edges are kept per vertex
 * as a list of its corners in decode order (`cNext` links corner `4 g + k`
 * of face `g` to the vertex's next corner): corner `c` of face `g` starts
 * the half-edge `g[k] → g[k+1]` (id `c`, outgoing at `g[k]`) and ends the
 * half-edge `g[k−1] → g[k]` (id `g·4 + (k+3) mod 4`, incoming), so one list
 * gives both the outgoing and the incoming half-edges in decode order.
 * `open[e]` says that the reverse of half-edge `e` is not decoded. A
 * vertex is in at most 255 faces, so every scan of a list is short.
 */
function decodeTraversalReference(payload, start, st, nv, nf, qmax) {
  const top = new Reader(payload, start, payload.length, 'base');
  const gates = baseStream(top, 'base gates');
  const corners = baseStream(top, 'base corners');
  const escapes = baseStream(top, 'base escapes');
  const pos = baseStream(top, 'base positions');
  if (top.remaining() !== 0) throw `${top.remaining()} bytes after the last base stream`;

  const f = st.f;
  const head = new Int32Array(nv).fill(-1);
  const tail = new Int32Array(nv);
  const deg = new Int32Array(nv);
  const cNext = new Int32Array(4 * nf);
  const open = new Uint8Array(4 * nf);
  let s = 0; // vertices seen
  let n = 0;
  let h = 0;
  while (n < nf) {
    const o = 4 * n;
    if (h === n) {
      // a component start: four corner symbols, no candidates
      for (let k = 0; k < 4; k++) {
        const v = cornerSymbol(corners, escapes, f, head, cNext, open, 0, 0, s, nv, n);
        if (v === s) s++;
        f[o + k] = v;
      }
      addFace(f, head, tail, deg, cNext, open, n);
      n++;
      continue;
    }
    const g = 4 * h;
    h++;
    for (let k = 0; k < 4 && n < nf; k++) {
      // face h's half-edge a → b: b → a is decoded exactly when it is closed
      if (open[g + k] === 0) continue;
      const gate = gates.byte();
      if (gate === 0) continue;
      if (gate > 4) throw `gate byte ${gate} before face ${n} (spec §6.1)`;
      const a = f[g + k];
      const b = f[g + ((k + 1) & 3)];
      const on = 4 * n;
      const r = gate - 1;
      f[on + r] = b;
      f[on + ((r + 1) & 3)] = a;
      // the candidates are taken before face n's half-edges are added
      const x = cornerSymbol(corners, escapes, f, head, cNext, open, 1, a, s, nv, n);
      if (x === s) s++;
      f[on + ((r + 2) & 3)] = x;
      const y = cornerSymbol(corners, escapes, f, head, cNext, open, 2, b, s, nv, n);
      if (y === s) s++;
      f[on + ((r + 3) & 3)] = y;
      addFace(f, head, tail, deg, cNext, open, n);
      n++;
    }
  }
  if (s !== nv) throw `the faces use ${s} of the ${nv} base vertices`;
  for (const r of [gates, corners, escapes]) {
    if (r.remaining() !== 0) throw `${r.remaining()} unused bytes in the ${r.name}`;
  }

  // Positions: P(v) over the faces at v (its corner list) whose other
  // corners come before v (spec §6.1; §7.6's version-4 stencil).
  const q = st.q;
  for (let v = 0; v < nv; v++) {
    let sx = 0, sy = 0, sz = 0, c = 0;
    let ex = 0, ey = 0, ez = 0, e = 0;
    for (let cr = head[v]; cr >= 0; cr = cNext[cr]) {
      const o = cr & ~3;
      const n1 = f[o | ((cr + 1) & 3)];
      const op = f[o | ((cr + 2) & 3)];
      const n3 = f[o | ((cr + 3) & 3)];
      const k1 = n1 < v;
      const k3 = n3 < v;
      if (k1 && k3 && op < v) {
        sx += 5 * (q[16 * n1] + q[16 * n3]) - 2 * q[16 * op];
        sy += 5 * (q[16 * n1 + 1] + q[16 * n3 + 1]) - 2 * q[16 * op + 1];
        sz += 5 * (q[16 * n1 + 2] + q[16 * n3 + 2]) - 2 * q[16 * op + 2];
        c++;
      }
      if (k1) {
        ex += q[16 * n1];
        ey += q[16 * n1 + 1];
        ez += q[16 * n1 + 2];
        e++;
      }
      if (k3) {
        ex += q[16 * n3];
        ey += q[16 * n3 + 1];
        ez += q[16 * n3 + 2];
        e++;
      }
    }
    // Math.floor(s / d) is exact here (as in the split form): d ≤ 8 · 255
    // and |s| ≤ 255 · 12 · 2^24, so the quotient's rounding error is far
    // below the 1/d a non-integer quotient keeps from the next integer
    if (c > 0) {
      const d = 8 * c;
      const px = clamp(Math.floor(sx / d), qmax);
      const py = clamp(Math.floor(sy / d), qmax);
      const pz = clamp(Math.floor(sz / d), qmax);
      storeBaseCode(q, v, px, py, pz, pos, qmax);
    } else {
      storeEdgeMeanCode(q, v, e, ex, ey, ez, pos, qmax);
    }
  }
  if (pos.remaining() !== 0) throw `${pos.remaining()} unused bytes in the base positions`;
}

/** One length-prefixed stream of the traversal layout (spec §6.1) from `top`. */
function baseStream(top, name) {
  const n = top.u();
  if (n > top.remaining()) throw `stream ${name} claims ${n} bytes, ${top.remaining()} remain`;
  const r = new Reader(top.b, top.p, top.p + n, name);
  top.p += n;
  return r;
}

/**
 * A corner symbol of face `n` (spec §6.1) with `s` vertices seen: a new
 * vertex (returns `s`: the caller counts it), a candidate or an escape
 * (below `s`). Candidates: `kind` 1 — X, the sources of the open
 * half-edges into `at` (the incoming half-edge of each of its corners);
 * 2 — Y, the targets of the open half-edges out of `at`; 0 — none.
 */
function cornerSymbol(corners, escapes, f, head, cNext, open, kind, at, s, nv, n) {
  const sym = corners.byte();
  if (sym === 0) {
    if (s >= nv) throw `face ${n} has a new vertex but all ${nv} vertices are seen`;
    return s;
  }
  if (sym === 255) {
    const u = escapes.u();
    if (u >= s) throw `face ${n} escapes to vertex ${s - 1 - u} before vertex 0`;
    return s - 1 - u;
  }
  // entry sym − 1 of the list, in decode order
  let i = sym - 1;
  let len = 0;
  if (kind !== 0) {
    for (let c = head[at]; c >= 0; c = cNext[c]) {
      // X: corner c's incoming half-edge (id of the corner before it), its source;
      // Y: corner c's outgoing half-edge (id c), its target
      const e = kind === 1 ? (c & ~3) | ((c + 3) & 3) : c;
      if (open[e] === 0) continue;
      if (i === 0) return kind === 1 ? f[e] : f[(c & ~3) | ((c + 1) & 3)];
      i--;
      len++;
    }
  }
  throw `face ${n} names candidate ${sym} of ${len} (spec §6.1)`;
}

/**
 * Adds face `n` (its corners in `f`) to the per-vertex corner lists: checks
 * 4 distinct corners, no half-edge decoded twice and at most 255 faces per
 * vertex, and closes the reverses it meets. One scan of `u`'s corners per
 * corner `u → v` finds both a repeat (an outgoing `u → v`) and the reverse
 * (an incoming `v → u`). (A throw ends the decoding: no state is kept.)
 */
function addFace(f, head, tail, deg, cNext, open, n) {
  const o = 4 * n;
  const a = f[o], b = f[o + 1], c = f[o + 2], d = f[o + 3];
  if (a === b || a === c || a === d || b === c || b === d || c === d) {
    throw `face ${n} repeats a vertex (${a} ${b} ${c} ${d})`;
  }
  for (let t = 0; t < 4; t++) {
    const u = f[o + t];
    const v = f[o + ((t + 1) & 3)];
    if (deg[u] >= MAX_FACES_PER_VERTEX) throw `face ${n}: vertex ${u} is in more than ${MAX_FACES_PER_VERTEX} faces`;
    let rev = -1;
    for (let cr = head[u]; cr >= 0; cr = cNext[cr]) {
      const fo = cr & ~3;
      if (f[fo | ((cr + 1) & 3)] === v) throw `face ${n}: half-edge ${u} -> ${v} is in two faces`;
      const e = fo | ((cr + 3) & 3);
      if (f[e] === v) rev = e;
    }
    const id = o + t;
    if (rev >= 0) open[rev] = 0;
    open[id] = rev < 0 ? 1 : 0;
    cNext[id] = -1;
    if (head[u] < 0) head[u] = id;
    else cNext[tail[u]] = id;
    tail[u] = id;
    deg[u]++;
  }
}

/**
 * Decoding context of one chunk: the five streams, the two cursors, the
 * file's final counts and the quantization range.
 */
class ChunkContext {
  constructor(streams, st, log, finalV, finalF, bits, versionMajor) {
    this.ops = streams[0];
    this.conn = streams[1];
    this.refs = streams[2];
    this.slots = streams[3];
    this.pos = streams[4];
    this.st = st;
    this.log = log;
    this.VF = finalV;
    this.FF = finalF;
    // As int32 (bits ≤ 24, checked with the header): `2 ** bits` is a
    // heap number, and through clamp() and readCode it made the code
    // fields (cx … pz) double fields, each store a boxed float and each
    // read a conversion.
    this.qmax = (1 << bits) - 1;
    this.half = 1 << (bits - 1);
    this.vcur = 0;
    this.scur = 0;
    this.nExtra = 0; // entries of the general form's extra list
    this.lastOp = 0;
    this.cx = 0; // last code read by readCode
    this.cy = 0;
    this.cz = 0;
    this.px = 0; // last prediction of predictNew
    this.py = 0;
    this.pz = 0;
    this.versionMajor = versionMajor;
    /** Version-2 rules (spec §7.3 form 3, §7.6 multi-parallelogram). */
    this.v2 = versionMajor >= 2;
    /** Version-3 rules (spec §7.3 form 4, edge split). */
    this.v3 = versionMajor >= 3;
    /** Version-4 rules (spec §7.6 stencil). */
    this.v4 = versionMajor >= 4;
    // §7.6's per-quad term wN (Q[n1] + Q[n3]) − wO Q[o] and the divisor
    // div · c of its sum over c quads: 1, 1, 1 (versions 2 and 3: the
    // mean of parallelograms) or 5, 2, 8 (version 4: the stencil). Read
    // once per prediction, outside its loops: no branch per quad.
    this.wN = this.v4 ? 5 : 1;
    this.wO = this.v4 ? 2 : 1;
    this.div = this.v4 ? 8 : 1;
  }
}

/** Splits a chunk payload into its five streams (spec §7.2). */
function splitStreams(payload) {
  const names = ['ops', 'conn', 'refs', 'slots', 'pos'];
  const top = new Reader(payload, 0, payload.length, 'chunk payload');
  const out = [];
  for (const name of names) {
    const len = top.u();
    if (len > top.remaining()) {
      throw `stream ${name} claims ${len} bytes, ${top.remaining()} remain`;
    }
    out.push(new Reader(payload, top.p, top.p + len, name));
    top.p += len;
  }
  if (top.remaining() !== 0) throw `${top.remaining()} bytes after the fifth stream`;
  return out;
}

/**
 * Decodes record chunk `index` into the frontier and the log. On success the
 * log holds `info.recordCount` more levels; on failure the log is left as it
 * was before the chunk (a chunk's records are available only once the
 * whole chunk is, spec §7.2) and the frontier is unusable.
 * @param {Uint8Array} payload decompressed chunk
 * @param {number} index chunk index
 * @param {{recordCount:number, vertexCount:number, faceCount:number}} info chunk table entry
 * @param {Frontier} st
 * @param {RecordLog} log
 * @param {{finalVertexCount:number, finalFaceCount:number, quantBits:number, versionMajor:number}} h header
 */
export function decodeChunk(payload, index, info, st, log, h) {
  const section = `chunk ${index}`;
  let streams;
  try {
    streams = splitStreams(payload);
  } catch (e) {
    if (typeof e === 'string') throw invalid(section, e);
    throw e;
  }
  const ctx = new ChunkContext(streams, st, log, h.finalVertexCount, h.finalFaceCount, h.quantBits, h.versionMajor);
  const saved = {
    nRecords: log.nRecords,
    levels: log.levels,
    nMoved: log.nMoved,
    nRw: log.nRw,
    nNew: log.nNew,
    nApp: log.nApp,
  };
  const first = log.nRecords;
  const forward = log.forward;
  const nv0 = st.nv;
  const nf0 = st.nf;
  let t = 0;
  try {
    // Room for the chunk's levels once, then one store per array per
    // record, with no capacity test or call each. (The table's record
    // counts sum to the header's, so this stays within maxLevels; and
    // every record takes a byte of the ops stream, so no more than that
    // is reserved: memory follows the bytes delivered. A chunk that
    // claims more fails at the end of that stream.)
    const n0 = log.levels;
    const nEnd = n0 + info.recordCount;
    log.reserveLevels(n0 + Math.min(info.recordCount, ctx.ops.remaining()));
    const vAt = log.vAt;
    const fAt = log.fAt;
    const movedAt = log.movedAt;
    const rwAt = log.rwAt;
    const ops = log.ops;
    const r0 = log.nRecords;
    for (; t < info.recordCount; t++) {
      decodeRecord(ctx);
      const n = n0 + t;
      vAt[n] = st.nv;
      fAt[n] = st.nf;
      if (!forward) {
        ops[r0 + t] = ctx.lastOp;
        movedAt[n] = log.nMoved;
        rwAt[n] = log.nRw;
      }
    }
    log.levels = nEnd;
    log.nRecords = r0 + info.recordCount;
    for (const s of streams) {
      if (s.remaining() !== 0) {
        t = -1;
        throw `${s.remaining()} unused bytes in stream ${s.name}`;
      }
    }
    if (st.nv !== info.vertexCount || st.nf !== info.faceCount) {
      t = -1;
      throw `records reach ${st.nv} vertices and ${st.nf} faces, the chunk table says ${info.vertexCount} and ${info.faceCount}`;
    }
  } catch (e) {
    // The frontier goes back to the deepest committed level: one-way
    // decoding has no other copy of it, and the general decoder builds its
    // log's first states from it (RecordLog) and copies it for a move to
    // the deepest level.
    rollBack(st, log, saved.nMoved, saved.nRw, nv0, nf0);
    Object.assign(log, saved);
    if (typeof e !== 'string') throw e;
    if (t < 0) throw invalid(section, e);
    throw badRecord(index, first + t, e);
  } finally {
    anchorMaps(ctx);
  }
}

/**
 * Keeps the chunk context of the last decoded chunk alive, emptied: its
 * readers read an empty array and it holds a fresh empty frontier and
 * log, not the decoder's. Why: V8's optimized code of the record
 * functions checks the hidden classes (maps) of the context, its readers,
 * the frontier and the log, and a map lives only as long as an object
 * has it. After a full collection with no decoder alive (a page that
 * decodes a second mesh after an idle GC; `gc()` between decodes) the
 * maps died and all that code was dropped ("weak objects", --trace-deopt):
 * bunny then took 270–300 ms instead of 100–115 until V8 had compiled
 * again. With one emptied context alive the maps, and the code, survive.
 * Memory: a few empty objects. The empty frontier and log are created
 * here, after the real ones, so they have the real ones' current maps.
 */
function anchorMaps(ctx) {
  ctx.st = new Frontier();
  ctx.log = new RecordLog(ctx.log.forward);
  for (const r of [ctx.ops, ctx.conn, ctx.refs, ctx.slots, ctx.pos]) {
    r.b = ANCHOR_BYTES;
    r.p = 0;
    r.end = 0;
  }
  anchoredContext = ctx;
}
const ANCHOR_BYTES = new Uint8Array(0);
/** @type {ChunkContext|null} see anchorMaps */
let anchoredContext = null;

/**
 * Undoes on the frontier the log entries from `nMoved` / `nRw` on (those of
 * a chunk that failed; each entry is logged before its write, so they cover
 * every write made) and truncates it to `nv` vertices and `nf` slots, then
 * lists the slots afresh (O(mesh), once, on a failure).
 */
function rollBack(st, log, nMoved, nRw, nv, nf) {
  const q = st.q;
  const f = st.f;
  const M = log.moved;
  const R = log.rw;
  for (let e = log.nRw - 1; e >= nRw; e--) {
    f[R[2 * e]] ^= R[2 * e + 1];
  }
  for (let e = log.nMoved - 1; e >= nMoved; e--) {
    const o = 16 * M[4 * e];
    q[o] -= M[4 * e + 1];
    q[o + 1] -= M[4 * e + 2];
    q[o + 2] -= M[4 * e + 3];
  }
  st.nv = nv;
  st.nf = nf;
  st.rebuild();
}

/** Decodes one record and applies it to the frontier, logging undo data. */
function decodeRecord(ctx) {
  const sym = ctx.ops.byte();
  const op = sym & 3;
  const form = (sym >> 2) & 3;
  ctx.lastOp = op;
  if (form === 0) {
    // bits 4-7 select form 0 (general) or 4 (edge split), spec §7.3
    const high = sym >> 4;
    if (high === 0) decodeGeneral(ctx);
    else if (high === 1 && ctx.v3) decodeEdgeSplit(ctx);
    else if (high === 1) {
      throw `record form 4 (edge split, symbol 0x${sym.toString(16)}) is invalid in a version ${ctx.versionMajor} file`;
    } else throw `general-form symbol 0x${sym.toString(16)} has bits 4-7 set`;
  } else if (form === 1) {
    decodeSplit(ctx, sym);
  } else if (form === 2) {
    decodeLocal(ctx, sym);
  } else if (ctx.v2) {
    decodeFaceSplit(ctx, sym);
  } else {
    throw `record form ${form} is invalid in a version 1 file (symbol 0x${sym.toString(16)})`;
  }
}

/**
 * Reads three residuals and adds them to `(px, py, pz)`; checks the range.
 * The message names `${what} ${id}${suffix}`, built only on failure (this
 * runs once per new or moved vertex: no string work on the good path).
 */
export function readCode(ctx, px, py, pz, what, id, suffix) {
  const p = ctx.pos;
  const x = px + p.s();
  const y = py + p.s();
  const z = pz + p.s();
  const qmax = ctx.qmax;
  if (x < 0 || x > qmax || y < 0 || y > qmax || z < 0 || z > qmax) {
    throw `${what} ${id}${suffix} code (${x}, ${y}, ${z}) outside 0..=${qmax}`;
  }
  ctx.cx = x;
  ctx.cy = y;
  ctx.cz = z;
}

const clamp = (x, qmax) => (x < 0 ? 0 : x > qmax ? qmax : x);

/** Logs a move of `v` to the code in ctx.cx/cy/cz and applies it. */
export function logMove(ctx, v) {
  const log = ctx.log;
  const q = ctx.st.q;
  const n = log.nMoved;
  if (4 * (n + 1) > log.moved.length) log.moved = ensure(log.moved, 4 * (n + 1), 4 * n);
  const m = log.moved;
  const o = 4 * n;
  m[o] = v;
  m[o + 1] = ctx.cx - q[16 * v];
  m[o + 2] = ctx.cy - q[16 * v + 1];
  m[o + 3] = ctx.cz - q[16 * v + 2];
  log.nMoved = n + 1;
  q[16 * v] = ctx.cx;
  q[16 * v + 1] = ctx.cy;
  q[16 * v + 2] = ctx.cz;
}

/**
 * Logs the corners of the quad at `f[s4 .. s4 + 4)` that change, by their
 * new XOR old values `x0 .. x3`: one entry (corner index, XOR) per changed
 * corner, so a split's rewrite (one corner: m → c) is 8 bytes, not a whole
 * quad's 20 — the general log is written once and read rarely, and its
 * fresh pages are what it costs. Written without branches on which
 * corners change (data): all four at the cursor, which moves past the
 * nonzero ones only.
 */
function logQuad(log, s4, x0, x1, x2, x3) {
  const n = log.nRw;
  if (2 * (n + 4) > log.rw.length) log.rw = ensure(log.rw, 2 * (n + 4), 2 * n);
  const r = log.rw;
  let o = 2 * n;
  r[o] = s4;
  r[o + 1] = x0;
  o += 2 & -((x0 !== 0) | 0);
  r[o] = s4 + 1;
  r[o + 1] = x1;
  o += 2 & -((x1 !== 0) | 0);
  r[o] = s4 + 2;
  r[o + 1] = x2;
  o += 2 & -((x2 !== 0) | 0);
  r[o] = s4 + 3;
  r[o + 1] = x3;
  o += 2 & -((x3 !== 0) | 0);
  log.nRw = o >> 1;
}

/** Logs that `slot` becomes quad `a b c d`, updating quads and adjacency. */
export function rewriteSlot(ctx, slot, a, b, c, d) {
  const st = ctx.st;
  const log = ctx.log;
  const f = st.f;
  const s4 = 4 * slot;
  logQuad(log, s4, a ^ f[s4], b ^ f[s4 + 1], c ^ f[s4 + 2], d ^ f[s4 + 3]);
  const o0 = f[s4], o1 = f[s4 + 1], o2 = f[s4 + 2], o3 = f[s4 + 3];
  f[s4] = a;
  f[s4 + 1] = b;
  f[s4 + 2] = c;
  f[s4 + 3] = d;
  // the lists name slots: only vertices leaving or entering the slot
  // change one (a rotated quad changes none)
  if (o0 !== a && o0 !== b && o0 !== c && o0 !== d) st.remove(o0, slot);
  if (o1 !== a && o1 !== b && o1 !== c && o1 !== d) st.remove(o1, slot);
  if (o2 !== a && o2 !== b && o2 !== c && o2 !== d) st.remove(o2, slot);
  if (o3 !== a && o3 !== b && o3 !== c && o3 !== d) st.remove(o3, slot);
  if (a !== o0 && a !== o1 && a !== o2 && a !== o3) st.add(a, slot);
  if (b !== o0 && b !== o1 && b !== o2 && b !== o3) st.add(b, slot);
  if (c !== o0 && c !== o1 && c !== o2 && c !== o3) st.add(c, slot);
  if (d !== o0 && d !== o1 && d !== o2 && d !== o3) st.add(d, slot);
}

/** Appends quad `a b c d` at the next slot. */
export function appendQuad(ctx, a, b, c, d) {
  const st = ctx.st;
  const slot = st.nf;
  st.reserve(st.nv, slot + 1);
  const f = st.f;
  f[4 * slot] = a;
  f[4 * slot + 1] = b;
  f[4 * slot + 2] = c;
  f[4 * slot + 3] = d;
  st.nf = slot + 1;
  st.add(a, slot);
  st.add(b, slot);
  st.add(c, slot);
  st.add(d, slot);
}

/** Appends a vertex with the code in ctx.cx/cy/cz (to the frontier only: see RecordLog). */
export function appendVertex(ctx) {
  const st = ctx.st;
  const v = st.nv;
  st.reserve(v + 1, st.nf);
  const q = st.q;
  q[16 * v] = ctx.cx;
  q[16 * v + 1] = ctx.cy;
  q[16 * v + 2] = ctx.cz;
  q[16 * v + LEN] = 0;
  st.nv = v + 1;
}

// General-form scratch, grown on demand (sizes are bounded by the streams).
let gSlots = new Int32Array(64);
let gRw = new Int32Array(256);
let gApp = new Int32Array(256);
let gExtra = new Int32Array(64);

/**
 * Vertex `ctx.vcur + delta` read from `refs` (spec §7.2's vertex cursor),
 * which must be below `limit`; moves the cursor to it.
 */
export function vertexRef(ctx, limit, what) {
  const v = ctx.vcur + ctx.refs.s();
  if (v < 0 || v >= limit) throw `${what} ${v} outside 0..${limit}`;
  ctx.vcur = v;
  return v;
}

/** Resolves a corner code (spec §7.4) of the record being decoded. */
function cornerCode(ctx, V, nNew, nRw, f) {
  const x = ctx.conn.u();
  if (x === 0) {
    const v = vertexRef(ctx, V + nNew, 'explicit vertex');
    if (ctx.nExtra === gExtra.length) gExtra = ensure(gExtra, ctx.nExtra + 1);
    gExtra[ctx.nExtra++] = v;
    return v;
  }
  if (x <= nNew) return V + x - 1;
  if (x <= nNew + 4 * nRw) {
    const i = x - 1 - nNew;
    return f[4 * gSlots[i >> 2] + (i & 3)];
  }
  const e = x - 1 - nNew - 4 * nRw;
  if (e >= ctx.nExtra) throw `corner code ${x} names extra entry ${e}, only ${ctx.nExtra} exist`;
  return gExtra[e];
}

/** General form (spec §7.4). */
function decodeGeneral(ctx) {
  const st = ctx.st;
  const conn = ctx.conn;
  const V = st.nv;
  const NF = st.nf;
  const nNew = conn.u();
  if (nNew > ctx.VF - V) throw `${nNew} new vertices exceed the final count ${ctx.VF} (now ${V})`;
  const nMoved = conn.u();
  if (nMoved > V) throw `${nMoved} moved vertices, only ${V} exist`;
  const nRw = conn.u();
  if (nRw > NF) throw `${nRw} rewritten faces, only ${NF} exist`;
  const nApp = conn.u();
  if (nApp > ctx.FF - NF) throw `${nApp} appended faces exceed the final count ${ctx.FF} (now ${NF})`;
  // Each element takes at least one byte of its streams: check before
  // sizing any scratch buffer by these counts.
  if (nRw > ctx.slots.remaining() || nRw + 4 * nApp > conn.remaining() || 3 * (nNew + nMoved) > ctx.pos.remaining()) {
    throw `counts (${nNew} new, ${nMoved} moved, ${nRw} rewritten, ${nApp} appended) exceed what the streams hold`;
  }

  // 2. moved vertices: applied at once, so that predictions see them.
  let prevMoved = -1;
  for (let i = 0; i < nMoved; i++) {
    const v = vertexRef(ctx, V, 'moved vertex');
    if (v <= prevMoved) throw `moved vertex ${v} does not follow ${prevMoved}`;
    prevMoved = v;
    const q = st.q;
    readCode(ctx, q[16 * v], q[16 * v + 1], q[16 * v + 2], 'moved vertex', v, '');
    logMove(ctx, v);
  }

  // 3. rewritten slots.
  if (nRw > gSlots.length) gSlots = new Int32Array(2 * nRw);
  const slots = gSlots;
  if (nRw > 0) {
    let s = ctx.scur + ctx.slots.s();
    if (s < 0 || s >= NF) throw `rewritten slot ${s} outside 0..${NF}`;
    slots[0] = s;
    for (let i = 1; i < nRw; i++) {
      const gap = ctx.slots.u();
      if (gap > NF) throw `slot gap ${gap} exceeds the face count ${NF}`;
      s = s + 1 + gap;
      if (s >= NF) throw `rewritten slot ${s} outside 0..${NF}`;
      slots[i] = s;
    }
    ctx.scur = s;
  }

  // 4.–5. quads. Old quads of rewritten slots stay in st.f until applied.
  ctx.nExtra = 0;
  const f = st.f;
  if (4 * nRw > gRw.length) gRw = new Int32Array(8 * nRw);
  if (4 * nApp > gApp.length) gApp = new Int32Array(8 * nApp);
  const rwNew = gRw;
  const app = gApp;
  for (let i = 0; i < nRw; i++) {
    const mask = conn.u();
    if (mask > 15) throw `corner mask ${mask} of slot ${slots[i]} exceeds 15`;
    const s4 = 4 * slots[i];
    for (let c = 0; c < 4; c++) {
      rwNew[4 * i + c] = mask & (1 << c) ? cornerCode(ctx, V, nNew, nRw, f) : f[s4 + c];
    }
    checkDistinct(rwNew, 4 * i, 'rewritten slot', slots[i]);
  }
  for (let i = 0; i < nApp; i++) {
    for (let c = 0; c < 4; c++) app[4 * i + c] = cornerCode(ctx, V, nNew, nRw, f);
    checkDistinct(app, 4 * i, 'appended quad', i);
  }

  finishRecord(ctx, V, NF, nNew, slots, nRw, rwNew, nApp, app);
}

// Corners of the record's quads grouped by new vertex (counting sort):
// the corners of new vertex V + k are gOcc[gOccAt[k] .. gOccAt[k + 1]), in
// the order of spec §7.6 (appended quads, then rewritten quads by ascending
// slot). A corner index i < 4 nApp is corner i of the appended quads,
// larger ones are corner i − 4 nApp of the rewritten quads. One pass over
// the quads for every new vertex together: a hostile record with many new
// vertices and many quads costs linear time, not their product.
let gOcc = new Int32Array(64);
let gOccAt = new Int32Array(64);

/** Fills gOcc / gOccAt for the new vertices V .. V + nNew. */
export function groupCorners(V, nNew, rwNew, nRw, app, nApp) {
  if (nNew + 2 > gOccAt.length) gOccAt = new Int32Array(2 * nNew + 2);
  const at = gOccAt;
  at.fill(0, 0, nNew + 2);
  const na = 4 * nApp;
  const nr = 4 * nRw;
  // count per vertex into at[k + 2], prefix sums, then place with at[k + 1]
  // as the running cursor: afterwards at[k] is the start of vertex k
  for (let i = 0; i < na; i++) {
    const v = app[i] - V;
    if (v >= 0) at[v + 2]++;
  }
  for (let i = 0; i < nr; i++) {
    const v = rwNew[i] - V;
    if (v >= 0) at[v + 2]++;
  }
  for (let k = 2; k < nNew + 2; k++) at[k] += at[k - 1];
  const total = at[nNew + 1];
  if (total > gOcc.length) gOcc = new Int32Array(2 * total);
  const occ = gOcc;
  for (let i = 0; i < na; i++) {
    const v = app[i] - V;
    if (v >= 0) occ[at[v + 1]++] = i;
  }
  for (let i = 0; i < nr; i++) {
    const v = rwNew[i] - V;
    if (v >= 0) occ[at[v + 1]++] = na + i;
  }
}

/**
 * Records with at most this many new vertices (a qeMerge inverse has 4)
 * bucket their corners by new vertex in one pass and predict from the
 * buckets (finishRecord, predictScan): cheaper than the counting sort's two
 * passes, prefix sums and clearing for so few.
 */
const SCAN_NEW = 4;

/** The grouping gOcc / gOccAt as arrays (for tests): per new vertex, its corner indices. */
export function groupedCorners(nNew) {
  return Array.from({ length: nNew }, (_, k) => [...gOcc.subarray(gOccAt[k], gOccAt[k + 1])]);
}

/** ⌊s / c⌋ for integers s and c > 0, exact whatever the rounding of s / c. */
export function floorDiv(s, c) {
  let q = Math.floor(s / c);
  if (q * c > s) q--;
  else if ((q + 1) * c <= s) q++;
  return q;
}

/**
 * The prediction of new vertex `x` (spec §7.6) into ctx.px/py/pz, from the
 * corners gOcc groups for it (groupCorners). Versions 2 and 3: the floored
 * mean of the parallelograms of every quad holding `x` whose three other
 * corners are known (ids < x); version 4: of their stencils 5 (n1 + n3) −
 * 2 o, divided by 8 c; version 1, and 2–4 when no quad qualifies: the
 * first quad's parallelogram, mean of its known corners, else the previous
 * new vertex or the grid centre.
 */
function predictNew(ctx, x, V, nApp, app, rwNew) {
  const q = ctx.st.q;
  const qmax = ctx.qmax;
  const k = x - V;
  const from = gOccAt[k];
  const to = gOccAt[k + 1];
  const na = 4 * nApp;
  if (ctx.v2) {
    const wN = ctx.wN;
    const wO = ctx.wO;
    let sx = 0, sy = 0, sz = 0, n = 0;
    for (let j = from; j < to; j++) {
      const i = gOcc[j];
      const arr = i < na ? app : rwNew;
      const ci = i < na ? i : i - na;
      const o = ci & ~3;
      const c = ci & 3;
      const n1 = arr[o + ((c + 1) & 3)];
      const op = arr[o + ((c + 2) & 3)];
      const n3 = arr[o + ((c + 3) & 3)];
      if (n1 < x && op < x && n3 < x) {
        sx += wN * (q[16 * n1] + q[16 * n3]) - wO * q[16 * op];
        sy += wN * (q[16 * n1 + 1] + q[16 * n3 + 1]) - wO * q[16 * op + 1];
        sz += wN * (q[16 * n1 + 2] + q[16 * n3 + 2]) - wO * q[16 * op + 2];
        n++;
      }
    }
    if (n > 0) {
      const d = ctx.div * n;
      ctx.px = clamp(d === 1 ? sx : floorDiv(sx, d), qmax);
      ctx.py = clamp(d === 1 ? sy : floorDiv(sy, d), qmax);
      ctx.pz = clamp(d === 1 ? sz : floorDiv(sz, d), qmax);
      return;
    }
  }
  if (from < to) {
    const i = gOcc[from];
    predictFallback(ctx, x, V, i < na ? app : rwNew, i < na ? i : i - na);
  } else {
    predictFallback(ctx, x, V, null, -1);
  }
}

/**
 * §7.6's rule when no parallelogram counts (version 1: always): the first
 * quad holding `x` — corner `ci` of `arr` (null: none) — gives its
 * parallelogram if its three other corners are known (ids < x), else the
 * floored mean of the known ones, else the previous new vertex's code (x >
 * V) or the grid centre. Into ctx.px/py/pz.
 */
function predictFallback(ctx, x, V, arr, ci) {
  const q = ctx.st.q;
  const qmax = ctx.qmax;
  if (arr !== null) {
    const o = ci & ~3;
    const c = ci & 3;
    const n1 = arr[o + ((c + 1) & 3)];
    const op = arr[o + ((c + 2) & 3)];
    const n3 = arr[o + ((c + 3) & 3)];
    const k1 = n1 < x;
    const ko = op < x;
    const k3 = n3 < x;
    if (k1 && ko && k3) {
      // parallelogram
      ctx.px = clamp(q[16 * n1] + q[16 * n3] - q[16 * op], qmax);
      ctx.py = clamp(q[16 * n1 + 1] + q[16 * n3 + 1] - q[16 * op + 1], qmax);
      ctx.pz = clamp(q[16 * n1 + 2] + q[16 * n3 + 2] - q[16 * op + 2], qmax);
      return;
    }
    if (k1 || ko || k3) {
      // mean of the known ones (codes are ≥ 0: floor = truncation)
      let sx = 0, sy = 0, sz = 0, n = 0;
      if (k1) {
        sx += q[16 * n1];
        sy += q[16 * n1 + 1];
        sz += q[16 * n1 + 2];
        n++;
      }
      if (ko) {
        sx += q[16 * op];
        sy += q[16 * op + 1];
        sz += q[16 * op + 2];
        n++;
      }
      if (k3) {
        sx += q[16 * n3];
        sy += q[16 * n3 + 1];
        sz += q[16 * n3 + 2];
        n++;
      }
      ctx.px = Math.floor(sx / n);
      ctx.py = Math.floor(sy / n);
      ctx.pz = Math.floor(sz / n);
      return;
    }
  }
  if (x > V) {
    ctx.px = q[16 * (x - 1)];
    ctx.py = q[16 * (x - 1) + 1];
    ctx.pz = q[16 * (x - 1) + 2];
  } else {
    ctx.px = ctx.py = ctx.pz = ctx.half;
  }
}

/**
 * predictNew for a record with one new vertex `V` (no grouping pass): every
 * other corner of the record's quads is an existing vertex, so every quad
 * holding `V` has its parallelogram — versions 2 and 3 average them all,
 * version 4 their stencils, version 1 takes the first (appended quads
 * first, spec §7.6).
 */
function predictOnly(ctx, V, nApp, app, nRw, rwNew) {
  const q = ctx.st.q;
  const qmax = ctx.qmax;
  const all = ctx.v2;
  const wN = ctx.wN;
  const wO = ctx.wO;
  let sx = 0, sy = 0, sz = 0, n = 0;
  for (let pass = 0; pass < 2; pass++) {
    const arr = pass === 0 ? app : rwNew;
    const len = 4 * (pass === 0 ? nApp : nRw);
    for (let i = 0; i < len; i++) {
      if (arr[i] !== V) continue;
      const o = i & ~3;
      const c = i & 3;
      const n1 = 16 * arr[o + ((c + 1) & 3)];
      const op = 16 * arr[o + ((c + 2) & 3)];
      const n3 = 16 * arr[o + ((c + 3) & 3)];
      sx += wN * (q[n1] + q[n3]) - wO * q[op];
      sy += wN * (q[n1 + 1] + q[n3 + 1]) - wO * q[op + 1];
      sz += wN * (q[n1 + 2] + q[n3 + 2]) - wO * q[op + 2];
      n++;
      if (!all) break;
    }
    if (n > 0 && !all) break;
  }
  if (n === 0) {
    ctx.px = ctx.py = ctx.pz = ctx.half;
  } else {
    const d = ctx.div * n;
    ctx.px = clamp(d === 1 ? sx : floorDiv(sx, d), qmax);
    ctx.py = clamp(d === 1 ? sy : floorDiv(sy, d), qmax);
    ctx.pz = clamp(d === 1 ? sz : floorDiv(sz, d), qmax);
  }
}

// predictScan's corner buckets (see there), grown on demand, and their fill
let gNewA = new Int32Array(256);
let gNewR = new Int32Array(1024);
const gCntA = new Int32Array(SCAN_NEW + 1);
const gCntR = new Int32Array(SCAN_NEW + 1);

/**
 * predictNew for records with few new vertices (at most SCAN_NEW: an edge
 * split has 4), from buckets instead of the counting sort: finishRecord
 * puts each corner holding a new vertex into that vertex's bucket in one
 * pass (`gNewA` / `gNewR`, appended and rewritten corners apart,
 * ascending), and `x` reads its `nA` appended corners from `aFrom` and
 * `nR` rewritten ones from `rFrom` — appended first, then rewritten by
 * ascending slot: the order of spec §7.6 (and of groupCorners), so the
 * first one is the fallback's first quad and the sums are the same.
 */
function predictScan(ctx, x, V, app, aFrom, nA, rwNew, rFrom, nR) {
  const q = ctx.st.q;
  const qmax = ctx.qmax;
  if (ctx.v2) {
    const wN = ctx.wN;
    const wO = ctx.wO;
    let sx = 0, sy = 0, sz = 0, n = 0;
    // the appended corners, then the rewritten ones (one loop body for both).
    // The same parallelogram sum as predictNew's and decodeEdgeSplit's,
    // kept inline with local sums: through a shared helper adding into
    // module-level sums this, then also the edge split's prediction,
    // measured 2–5 % slower (same-run A/B).
    for (let part = 0; part < 2; part++) {
      const quads = part === 0 ? app : rwNew;
      const idx = part === 0 ? gNewA : gNewR;
      const from = part === 0 ? aFrom : rFrom;
      const to = part === 0 ? aFrom + nA : rFrom + nR;
      for (let t = from; t < to; t++) {
        const i = idx[t];
        const o = i & ~3;
        const c = i & 3;
        const n1 = quads[o + ((c + 1) & 3)];
        const op = quads[o + ((c + 2) & 3)];
        const n3 = quads[o + ((c + 3) & 3)];
        if (n1 < x && op < x && n3 < x) {
          sx += wN * (q[16 * n1] + q[16 * n3]) - wO * q[16 * op];
          sy += wN * (q[16 * n1 + 1] + q[16 * n3 + 1]) - wO * q[16 * op + 1];
          sz += wN * (q[16 * n1 + 2] + q[16 * n3 + 2]) - wO * q[16 * op + 2];
          n++;
        }
      }
    }
    if (n > 0) {
      const d = ctx.div * n;
      ctx.px = clamp(d === 1 ? sx : floorDiv(sx, d), qmax);
      ctx.py = clamp(d === 1 ? sy : floorDiv(sy, d), qmax);
      ctx.pz = clamp(d === 1 ? sz : floorDiv(sz, d), qmax);
      return;
    }
  }
  // the first quad holding x (fallback): appended ones come first
  if (nA > 0) predictFallback(ctx, x, V, app, gNewA[aFrom]);
  else if (nR > 0) predictFallback(ctx, x, V, rwNew, gNewR[rFrom]);
  else predictFallback(ctx, x, V, null, -1);
}

/**
 * The end of a general- or local-form record (spec §7.4 steps 6 and the
 * apply of §7.1): new vertex codes against the §7.6 prediction, then the
 * rewritten slots (`slots`, ascending) and the appended quads.
 */
export function finishRecord(ctx, V, NF, nNew, slots, nRw, rwNew, nApp, app) {
  const st = ctx.st;
  if (nNew === 1) {
    // the common case: one new vertex, every other corner known
    st.reserve(V + 1, NF);
    predictOnly(ctx, V, nApp, app, nRw, rwNew);
    readCode(ctx, ctx.px, ctx.py, ctx.pz, 'new vertex', V, '');
    appendVertex(ctx);
  } else if (nNew <= SCAN_NEW && nNew > 0) {
    st.reserve(V + nNew, NF);
    // the corners holding each new vertex k, ascending, in bucket k
    // (stride na / nr: room for any record), appended and rewritten apart;
    // an edge split has ≈ one per rewritten quad, three or four per
    // appended one
    const na = 4 * nApp;
    const nr = 4 * nRw;
    if ((SCAN_NEW + 1) * na > gNewA.length) gNewA = new Int32Array(2 * (SCAN_NEW + 1) * na);
    if ((SCAN_NEW + 1) * nr > gNewR.length) gNewR = new Int32Array(2 * (SCAN_NEW + 1) * nr);
    const ai = gNewA;
    const ri = gNewR;
    const ca = gCntA;
    const cr = gCntR;
    for (let k = 0; k < nNew; k++) {
      ca[k] = 0;
      cr[k] = 0;
    }
    ca[SCAN_NEW] = 0;
    cr[SCAN_NEW] = 0;
    // every corner is below V + nNew (corner codes resolve there); a
    // corner of an old vertex (k < 0) goes to the unread bucket SCAN_NEW,
    // by masks: which corners hold new vertices is data, so a branch on it
    // mispredicts
    for (let i = 0; i < na; i++) {
      const k = app[i] - V;
      const neg = k >> 31;
      const b = (k & ~neg) | (SCAN_NEW & neg);
      ai[b * na + ca[b]++] = i;
    }
    for (let i = 0; i < nr; i++) {
      const k = rwNew[i] - V;
      const neg = k >> 31;
      const b = (k & ~neg) | (SCAN_NEW & neg);
      ri[b * nr + cr[b]++] = i;
    }
    for (let k = 0; k < nNew; k++) {
      predictScan(ctx, V + k, V, app, k * na, ca[k], rwNew, k * nr, cr[k]);
      readCode(ctx, ctx.px, ctx.py, ctx.pz, 'new vertex', V + k, '');
      appendVertex(ctx);
    }
  } else if (nNew > 0) {
    st.reserve(V + nNew, NF);
    groupCorners(V, nNew, rwNew, nRw, app, nApp);
    for (let k = 0; k < nNew; k++) {
      predictNew(ctx, V + k, V, nApp, app, rwNew);
      readCode(ctx, ctx.px, ctx.py, ctx.pz, 'new vertex', V + k, '');
      appendVertex(ctx);
    }
  }

  // Apply the connectivity.
  for (let i = 0; i < nRw; i++) {
    rewriteSlot(ctx, slots[i], rwNew[4 * i], rwNew[4 * i + 1], rwNew[4 * i + 2], rwNew[4 * i + 3]);
  }
  for (let i = 0; i < nApp; i++) {
    appendQuad(ctx, app[4 * i], app[4 * i + 1], app[4 * i + 2], app[4 * i + 3]);
  }
}

/** Throws unless quad `a[o .. o+4)` has four distinct vertices (message: `${what} ${id}`). */
export function checkDistinct(a, o, what, id) {
  const x = a[o], y = a[o + 1], z = a[o + 2], w = a[o + 3];
  if (x === y || x === z || x === w || y === z || y === w || z === w) {
    throw `${what} ${id} repeats a vertex (${x} ${y} ${z} ${w})`;
  }
}

/**
 * Scratch of one canonical star (spec §7.5 step 2; K ≤ 255): `S` the slots
 * holding the centre, ascending, `C` the centre's corner in each, `N`,
 * `O`, `P` the corners after, opposite and before it (n(f), the opposite
 * corner, p(f)); `list` the walk order (indices into `S`), so that link
 * entry `t` is `N[list[t]]` (and, on the boundary, `P[list[K − 1]]` last).
 * Typed arrays allocated once: no allocation per record.
 */
class StarScratch {
  constructor() {
    this.S = new Int32Array(256);
    this.C = new Int32Array(256);
    this.N = new Int32Array(256);
    this.O = new Int32Array(256);
    this.P = new Int32Array(256);
    this.list = new Int32Array(256);
    // inWalk[t] === gen marks star face t as walked (a stamp per walk: no clearing)
    this.inWalk = new Int32Array(256);
    this.gen = 0;
    this.K = 0;
    this.boundary = false;
  }
}

/**
 * The canonical star of `m` (spec §7.5 step 2) into `sc`: rewind to the
 * start face, walk counter-clockwise, check that the walk holds every face
 * and that the link has at least 2 entries; returns K. Throws a message
 * string on every reject of that step.
 * @param {Frontier} st
 * @param {number} m
 * @param {StarScratch} sc
 */
function canonicalStar(st, m, sc) {
  const f = st.f;
  const S = sc.S;
  const sK = sc.C;
  const sN = sc.N;
  const sO = sc.O;
  const sP = sc.P;
  // Frontier.star fused with the corner reads: the slots ascending first
  // (the list is in m's record, in cache), then one read of each quad for
  // its corner and neighbours — the K quad reads are the record's first
  // touches of scattered memory, so they go out back to back with no
  // dependent work between them.
  const K = st.sortedSlots(m, S);
  if (K < 1) throw `vertex ${m} is in no face`;
  for (let i = 0; i < K; i++) {
    const s4 = 4 * S[i];
    // m's corner, then the three others by index
    const k = cornerOf(f, s4, m);
    sK[i] = k;
    sN[i] = f[s4 + ((k + 1) & 3)];
    sO[i] = f[s4 + ((k + 2) & 3)];
    sP[i] = f[s4 + ((k + 3) & 3)];
  }
  // succ(i): the smallest other slot g with n(g) = p(i); pred(i): the
  // smallest other g with p(g) = n(i). S is sorted, so "smallest" is the
  // first index found.
  //
  // Fast path (interior vertices, most of them): walk succ from face 0. If
  // that walk comes back to face 0 through all K faces, succ is a cyclic
  // permutation, so no two faces share an n (only the smallest of them
  // could be a succ: a frontier quad's four corners are distinct, so n(i)
  // ≠ p(i) and "other" never skips one) nor a p (two faces with one p
  // have one succ): pred is
  // succ's inverse, the rewind from 0 comes back to 0, and the star is
  // interior with start 0 — exactly what the rewind and walk below give.
  // Otherwise (a boundary, or a reject) they run as specified.
  const sList = sc.list;
  if (K <= INLINE) {
    // The same fast path with succ from a table instead of a scan of the
    // K faces per step (K² / 2 compares, each step's exit a mispredict):
    // face j under the hash of n(j), stamped with this walk's generation.
    // Two faces under one hash (a shared n, or a collision: ≈ 6 % of
    // stars of 6 faces) leave the table incomplete: the scan below runs
    // instead. Small stars only (K ≤ INLINE: 256 buckets hold them with
    // few collisions). Same-window A/B, separate processes, B / A time by
    // median (minimum): bunny 0.963 (0.954) and 0.994 (0.967), loki 0.946
    // (0.982), makehuman 0.964 (0.978), spot 0.957 (0.966).
    if (++sc.gen === 0x7fffffff) {
      sc.gen = 1;
      sc.inWalk.fill(0);
      succGen.fill(0);
    }
    const gen = sc.gen;
    let ok = true;
    for (let j = 0; j < K; j++) {
      const n = sN[j];
      const h = Math.imul(n, 0x9e3779b1) >>> 24;
      ok = ok && succGen[h] !== gen;
      succGen[h] = gen;
      succKey[h] = n;
      succFace[h] = j;
    }
    if (ok) {
      let last = 0;
      let len = 1;
      sList[0] = 0;
      for (;;) {
        const p = sP[last];
        const h = Math.imul(p, 0x9e3779b1) >>> 24;
        if (succGen[h] !== gen || succKey[h] !== p) break;
        const g = succFace[h];
        if (g === 0) {
          if (len === K) {
            sc.K = K;
            sc.boundary = false;
            return K;
          }
          break;
        }
        if (len === K) break;
        sList[len++] = g;
        last = g;
      }
    }
  }
  {
    // succ is a function, so a walk from 0 that comes back to 0 is a cycle
    // of distinct faces: back to 0 after exactly K steps means all K faces
    let last = 0;
    let len = 1;
    let g = -1;
    sList[0] = 0;
    for (;;) {
      const p = sP[last];
      g = -1;
      for (let j = 0; j < K; j++) {
        if (j !== last && sN[j] === p) {
          g = j;
          break;
        }
      }
      if (g <= 0 || len === K) break;
      sList[len++] = g;
      last = g;
    }
    if (g === 0 && len === K) {
      sc.K = K;
      sc.boundary = false;
      return K;
    }
  }
  // Rewind.
  let start = -1;
  let boundary = false;
  for (let it = 0, g = 0; it < K; it++) {
    const n = sN[g];
    let pr = -1;
    for (let j = 0; j < K; j++) {
      if (j !== g && sP[j] === n) {
        pr = j;
        break;
      }
    }
    if (pr < 0) {
      start = g;
      boundary = true;
      break;
    }
    if (pr === 0) {
      start = 0;
      break;
    }
    g = pr;
  }
  if (start < 0) throw `the faces around vertex ${m} do not form a fan`;
  // Walk.
  const sIn = sc.inWalk;
  if (++sc.gen === 0x7fffffff) {
    sc.gen = 1;
    sIn.fill(0);
  }
  const gen = sc.gen;
  let len = 0;
  sList[len++] = start;
  sIn[start] = gen;
  for (;;) {
    const last = sList[len - 1];
    const p = sP[last];
    let g = -1;
    for (let j = 0; j < K; j++) {
      if (j !== last && sN[j] === p) {
        g = j;
        break;
      }
    }
    if (boundary ? g < 0 : g === start) break;
    if (g < 0 || sIn[g] === gen || len >= K) {
      throw `the faces around vertex ${m} do not form a single fan`;
    }
    sList[len++] = g;
    sIn[g] = gen;
  }
  if (len !== K) throw `the fan around vertex ${m} holds ${len} of its ${K} faces`;
  const L = boundary ? K + 1 : K;
  if (L < 2) throw `vertex ${m} has a link of ${L} vertex`;
  sc.K = K;
  sc.boundary = boundary;
  return K;
}

// canonicalStar's succ table: per hash of a vertex id, the walk generation
// that wrote it, the id and the face of the star whose n(f) it is
const succGen = new Int32Array(256);
const succKey = new Int32Array(256);
const succFace = new Int32Array(256);

// Star scratch of the split, face-split and edge-split forms (the edge
// split needs two stars at once).
const starA = new StarScratch();
const starB = new StarScratch();

/** Split form (spec §7.5). */
function decodeSplit(ctx, sym) {
  const st = ctx.st;
  const V = st.nv;
  const NF = st.nf;
  if (V >= ctx.VF || NF >= ctx.FF) {
    throw `a vertex split needs a new vertex and face, the file's final counts are reached (${V}, ${NF})`;
  }
  const m = vertexRef(ctx, V, 'split vertex');

  // 2. canonical star of m.
  const sc = starA;
  const K = canonicalStar(st, m, sc);
  const S = sc.S;
  const sN = sc.N;
  const sO = sc.O;
  const sP = sc.P;
  const sList = sc.list;
  // The link is N of the faces in walk order, then (boundary) P of the last.
  const L = sc.boundary ? K + 1 : K;

  // 3. wings.
  const i = ctx.conn.u();
  if (i > L - 1) throw `wing index ${i} exceeds ${L - 1}`;
  const e = ctx.conn.u();
  if (e > L - 2) throw `wing offset ${e} exceeds ${L - 2}`;
  // (i + 1 + e) mod L, with i + 1 + e < 2L: a subtraction, not a division
  let j = i + 1 + e;
  j -= L & -((j >= L) | 0);
  const b = i < K ? sN[sList[i]] : sP[sList[K - 1]];
  const d = j < K ? sN[sList[j]] : sP[sList[K - 1]];
  if (b === d) throw `wings ${i} and ${j} of vertex ${m} are the same vertex ${b}`;

  // 4. sides, as ranges of walk positions: side A is i ≤ t < j
  // (cyclically), side C the rest, so side C is [c1, c2) ∪ [c3, c4) — the
  // loops below run over the ranges, with no per-face side test (where a
  // side ends is data, so such tests mispredict). The side means of step
  // 6 only when a moves (each is a random read of a code; most records
  // skip them).
  let c1, c2, c3, c4;
  if (i < j) {
    c1 = 0;
    c2 = i;
    c3 = j < K ? j : K;
    c4 = K;
  } else {
    c1 = j;
    c2 = i < K ? i : K;
    c3 = K;
    c4 = K;
  }
  const nC = c2 - c1 + (c4 - c3);
  const nA = K - nC;
  const q = st.q;
  const moves = (sym & 0x40) !== 0;
  let sax = 0, say = 0, saz = 0;
  let scx = 0, scy = 0, scz = 0;
  if (moves) {
    for (let t = 0; t < K; t++) {
      const o = 16 * sO[sList[t]];
      if ((t >= c1 && t < c2) || t >= c3) {
        scx += q[o];
        scy += q[o + 1];
        scz += q[o + 2];
      } else {
        sax += q[o];
        say += q[o + 1];
        saz += q[o + 2];
      }
    }
  }

  // 6. positions. a (moved m) first, then c.
  const qmax = ctx.qmax;
  const mx = q[16 * m], my = q[16 * m + 1], mz = q[16 * m + 2];
  let ax = mx, ay = my, az = mz;
  if (moves) {
    // side means (m's own code for an empty side), without temporaries
    const max = nA === 0 ? mx : Math.floor(sax / nA);
    const may = nA === 0 ? my : Math.floor(say / nA);
    const maz = nA === 0 ? mz : Math.floor(saz / nA);
    const mcx = nC === 0 ? mx : Math.floor(scx / nC);
    const mcy = nC === 0 ? my : Math.floor(scy / nC);
    const mcz = nC === 0 ? mz : Math.floor(scz / nC);
    readCode(
      ctx,
      clamp(mx + Math.floor((max - mcx) / 4), qmax),
      clamp(my + Math.floor((may - mcy) / 4), qmax),
      clamp(mz + Math.floor((maz - mcz) / 4), qmax),
      'split vertex',
      m,
      ' (a)',
    );
    ax = ctx.cx;
    ay = ctx.cy;
    az = ctx.cz;
    logMove(ctx, m);
  }
  const c = V;
  let px, py, pz;
  if (sym & 0x80) {
    // reflection of a through the old position of m
    px = clamp(2 * mx - ax, qmax);
    py = clamp(2 * my - ay, qmax);
    pz = clamp(2 * mz - az, qmax);
  } else if (ctx.v2 && (nC > 0 || ctx.v4)) {
    // §7.6 versions 2–4: c's quads are the appended (m, d, c, b) rotated —
    // neighbours b and d, opposite m (code a) — and every side-C face with
    // m replaced by c — neighbours n and p, opposite o, none of them m (a
    // quad's corners are distinct), all existing: every quad counts, with
    // the term wN (n1 + n3) − wO o (the parallelogram in versions 2 and 3,
    // where one quad alone is the version-1 rule below; version 4's
    // stencil even for the appended quad alone).
    const wN = ctx.wN;
    const wO = ctx.wO;
    let sx = wN * (q[16 * b] + q[16 * d]) - wO * ax;
    let sy = wN * (q[16 * b + 1] + q[16 * d + 1]) - wO * ay;
    let sz = wN * (q[16 * b + 2] + q[16 * d + 2]) - wO * az;
    for (let part = 0; part < 2; part++) {
      const to = part === 0 ? c2 : c4;
      for (let t = part === 0 ? c1 : c3; t < to; t++) {
        const idx = sList[t];
        const n = 16 * sN[idx];
        const p = 16 * sP[idx];
        const o = 16 * sO[idx];
        sx += wN * (q[n] + q[p]) - wO * q[o];
        sy += wN * (q[n + 1] + q[p + 1]) - wO * q[o + 1];
        sz += wN * (q[n + 2] + q[p + 2]) - wO * q[o + 2];
      }
    }
    const n = ctx.div * (nC + 1);
    // Math.floor(s / n) is exact here (floorDiv's correction never fires):
    // n ≤ 8 · 256 and |s| ≤ 256 · 12 · 2^24, so the quotient's rounding
    // error (< 2^-19) is below the 1/n a non-integer quotient keeps from
    // the next integer — and it inlines, where floorDiv is a call
    px = clamp(Math.floor(sx / n), qmax);
    py = clamp(Math.floor(sy / n), qmax);
    pz = clamp(Math.floor(sz / n), qmax);
  } else {
    // §7.6 (version 1; versions 2 and 3 with side C empty): the appended quad
    // (m, d, c, b) rotated is the first quad holding c; its neighbours
    // there are b and d, its opposite corner m (code a).
    px = clamp(q[16 * b] + q[16 * d] - ax, qmax);
    py = clamp(q[16 * b + 1] + q[16 * d + 1] - ay, qmax);
    pz = clamp(q[16 * b + 2] + q[16 * d + 2] - az, qmax);
  }
  readCode(ctx, px, py, pz, 'split vertex', m, ' (c)');
  appendVertex(ctx);

  // 5. the explicit record — the side-C slots, m → c — written straight
  // into the frontier: one corner per slot (m's, known from the star), its
  // log entry (the XOR is m ^ c at that corner; a record's entries name
  // distinct slots, so their order is free: walk order here), and the lists
  // whole when m's is inline: m keeps its side-A slots, the new c takes the
  // side-C ones (what rewriteSlot's per-slot remove and add would leave,
  // without a scan of m's list each; the lists are unordered sets).
  const log = ctx.log;
  let n = log.nRw;
  if (2 * (n + nC) > log.rw.length) log.rw = ensure(log.rw, 2 * (n + nC), 2 * n);
  const r = log.rw;
  const fq = st.f;
  const qs = st.q; // appendVertex may have grown it
  const sC = sc.C;
  const x = m ^ c;
  const whole = K <= INLINE;
  const bc = (c << 4) + AT;
  let nCk = 0;
  for (let part = 0; part < 2; part++) {
    const to = part === 0 ? c2 : c4;
    for (let t = part === 0 ? c1 : c3; t < to; t++) {
      const idx = sList[t];
      const s = S[idx];
      const k = sC[idx];
      const o = 2 * n++;
      // one corner changes: m → c at corner k
      r[o] = 4 * s + k;
      r[o + 1] = x;
      fq[4 * s + k] = c;
      if (whole) {
        qs[bc + nCk] = s;
      } else {
        st.remove(m, s);
        st.add(c, s);
      }
      nCk++;
    }
  }
  log.nRw = n;
  if (whole) {
    // side A: walk positions [0, c1) ∪ [c2, c3), around the side-C ranges
    const bm = (m << 4) + AT;
    let nAk = 0;
    for (let t = 0; t < c1; t++) qs[bm + nAk++] = S[sList[t]];
    for (let t = c2; t < c3; t++) qs[bm + nAk++] = S[sList[t]];
    qs[(m << 4) + LEN] = nAk;
    qs[(c << 4) + LEN] = nCk;
  }
  // Q'[t] = B[(t + rot) mod 4] with B = (m, d, c, b)
  // (indexed, not a branch per rotation: the rotation is data)
  const rot = (sym >> 4) & 3;
  const B = splitQuad;
  B[0] = m;
  B[1] = d;
  B[2] = c;
  B[3] = b;
  appendQuad(ctx, B[rot], B[(rot + 1) & 3], B[(rot + 2) & 3], B[(rot + 3) & 3]);
}
const splitQuad = new Int32Array(4);

/**
 * Face-split form (spec §7.9, version 2): vertex `m`, the `t`-th slot of
 * its star by ascending slot, split along its diagonal through `m` by a
 * new vertex `c` — the inverse of a doublet removal.
 */
function decodeFaceSplit(ctx, sym) {
  const st = ctx.st;
  const V = st.nv;
  const NF = st.nf;
  if (V >= ctx.VF || NF >= ctx.FF) {
    throw `a face split needs a new vertex and face, the file's final counts are reached (${V}, ${NF})`;
  }
  const m = vertexRef(ctx, V, 'face-split vertex');
  // 2. S ascending, no walk: only the slot list is sorted, and only the
  // split quad is read (the others' corners are not needed, and each quad
  // read is a first touch of scattered memory).
  const sS = starA.S;
  const K = st.sortedSlots(m, sS);
  if (K < 1) throw `vertex ${m} is in no face`;
  // 3. the split slot
  const x = ctx.conn.u();
  if (x >= 2 * K) throw `face index ${Math.floor(x / 2)} of vertex ${m} outside 0..${K}`;
  // x < 2K ≤ 510: shifts, not a float division and remainder
  const t = x >> 1;
  const swap = x & 1;
  const s = sS[t];
  const f = st.f;
  const k = cornerOf(f, 4 * s, m);
  // 4. the halves A = (m, p, o, c) and B = (m, c, o, q)
  const s4 = 4 * s;
  const p = f[s4 + ((k + 1) & 3)];
  const o = f[s4 + ((k + 2) & 3)];
  const qv = f[s4 + ((k + 3) & 3)];
  const c = V;
  // 7. c against §7.6 (versions 2–4): it is in both halves with all three
  // other corners known — A: n1 = m, o = p, n3 = o; B: n1 = o, o = q, n3 = m.
  // Versions 2 and 3: ⌊(2 (m + o) − p − q) / 2⌋; version 4 (the stencil of
  // both): ⌊(10 (m + o) − 2 (p + q)) / 16⌋.
  const q = st.q;
  const qmax = ctx.qmax;
  const m3 = 16 * m, p3 = 16 * p, o3 = 16 * o, q3 = 16 * qv;
  // ⌊s / 2^k⌋ as s >> k: codes are below 2^24, so s is an int32
  if (ctx.v4) {
    readCode(
      ctx,
      clamp((10 * (q[m3] + q[o3]) - 2 * (q[p3] + q[q3])) >> 4, qmax),
      clamp((10 * (q[m3 + 1] + q[o3 + 1]) - 2 * (q[p3 + 1] + q[q3 + 1])) >> 4, qmax),
      clamp((10 * (q[m3 + 2] + q[o3 + 2]) - 2 * (q[p3 + 2] + q[q3 + 2])) >> 4, qmax),
      'face-split vertex',
      m,
      ' (c)',
    );
  } else {
    readCode(
      ctx,
      clamp((2 * q[m3] + 2 * q[o3] - q[p3] - q[q3]) >> 1, qmax),
      clamp((2 * q[m3 + 1] + 2 * q[o3 + 1] - q[p3 + 1] - q[q3 + 1]) >> 1, qmax),
      clamp((2 * q[m3 + 2] + 2 * q[o3 + 2] - q[p3 + 2] - q[q3 + 2]) >> 1, qmax),
      'face-split vertex',
      m,
      ' (c)',
    );
  }
  appendVertex(ctx);
  // 5.–6. X' rewrites slot s, Y' is appended; rotations from symbol bits 4-7
  const rotX = (sym >> 4) & 3;
  const rotY = sym >> 6;
  // fH: half A (m, p, o, c), half B (m, c, o, q), then the vertex that
  // leaves slot s when X is A (q) or B (p)
  const fH = fsH;
  fH[0] = m; fH[1] = p; fH[2] = o; fH[3] = c;
  fH[4] = m; fH[5] = c; fH[6] = o; fH[7] = qv;
  fH[8] = qv; fH[9] = p;
  // X is half `swap` (0: A, 1: B), Y the other, read by index (swap is
  // data: a select between the halves would branch)
  const X = 4 * swap;
  const Y = 4 - X;
  // X keeps m and o and one of p / q, and takes c: exactly one vertex
  // leaves slot s (q for A, p for B) and c enters it — what rewriteSlot's
  // set comparison would find, without its 32 compares
  rewriteSwap(ctx, s, fH[X + rotX], fH[X + ((rotX + 1) & 3)], fH[X + ((rotX + 2) & 3)], fH[X + ((rotX + 3) & 3)], fH[8 + swap], c);
  appendQuad(ctx, fH[Y + rotY], fH[Y + ((rotY + 1) & 3)], fH[Y + ((rotY + 2) & 3)], fH[Y + ((rotY + 3) & 3)]);
}

/**
 * rewriteSlot for a rewrite that the caller knows replaces vertex `out` of
 * the slot by `inV` (which is not in it) and permutes the rest: the same
 * log entry, quad and lists, with one list removal and one addition.
 */
function rewriteSwap(ctx, slot, a, b, c, d, out, inV) {
  const st = ctx.st;
  const log = ctx.log;
  const f = st.f;
  const s4 = 4 * slot;
  logQuad(log, s4, a ^ f[s4], b ^ f[s4 + 1], c ^ f[s4 + 2], d ^ f[s4 + 3]);
  f[s4] = a;
  f[s4 + 1] = b;
  f[s4 + 2] = c;
  f[s4 + 3] = d;
  st.remove(out, slot);
  st.add(inV, slot);
}
const fsH = new Int32Array(10);

/**
 * The 24 permutations of 0..3 in lexicographic order (spec §7.10 step 5):
 * permutation number t is PERM4[4t .. 4t + 4).
 */
const PERM4 = (() => {
  const out = new Uint8Array(96);
  let n = 0;
  for (let a = 0; a < 4; a++) {
    for (let b = 0; b < 4; b++) {
      for (let c = 0; c < 4; c++) {
        if (b === a || c === a || c === b) continue;
        out[n++] = a;
        out[n++] = b;
        out[n++] = c;
        out[n++] = 6 - a - b - c;
      }
    }
  }
  return out;
})();

// Edge-split scratch: the rewritten faces of both stars (≤ 2 × 255), their
// new quads, whether each is a fan quad, and per endpoint its fan
// rotations; the entry of each face of X0's star by its index in S.
const eSlot = new Int32Array(512);
const eQuad = new Int32Array(4 * 512);
const eFan = new Uint8Array(512);
const eOfS0 = new Int32Array(256);
const eRot = [new Int32Array(256), new Int32Array(256)];
const eUid = new Int32Array(4);
const eApp = new Int32Array(16);
const eC = new Int32Array(16);
// Per entry: how many swaps it took (a sector face: X → u, a shared face
// of both stars two such; a fan quad one, see there), and for one swap the
// vertex that left (`eOut`) and the one that entered (`eIn`): such an
// entry is applied as a swap, with one list removal and one addition and
// no set comparison.
const eSwaps = new Uint8Array(512);
const eOut = new Int32Array(512);
const eIn = new Int32Array(512);
// Per new vertex k (V + k), the rewritten corners holding it, as indices
// 4 e + corner into eQuad (at most K ≤ 255 sector faces and one fan quad
// per endpoint): filled while step 8 writes them, so no pass over every
// corner of the record looks for them.
const E_BUCKET = 512;
const eNewR = new Int32Array(4 * E_BUCKET);
const eCntR = new Int32Array(4);

/**
 * Edge-split form (spec §7.10, version 3): the inverse of a qeMerge, named
 * by the anchor `A`, the index of `D` in A's link, per endpoint (smaller id
 * first) the first-sector length and the fan length, the orders of the new
 * vertices and appended quads and the rotations. Every field is read first
 * (steps 1–7), then the record is built in scratch (step 8) while the old
 * quads stay in the frontier, then its new vertices are read against §7.6
 * from its own corner buckets and it is applied (steps 9–10).
 */
function decodeEdgeSplit(ctx) {
  const st = ctx.st;
  const V = st.nv;
  const NF = st.nf;
  if (V + 4 > ctx.VF || NF + 4 > ctx.FF) {
    throw `an edge split needs 4 new vertices and 4 faces, the file's final counts allow ${ctx.VF - V} and ${ctx.FF - NF}`;
  }
  // 1.–3. the endpoints and their stars
  const A = vertexRef(ctx, V, 'edge-split anchor');
  const conn = ctx.conn;
  const sa = starA;
  const KA = canonicalStar(st, A, sa);
  if (sa.boundary) throw `edge-split endpoint ${A} is on the boundary`;
  const r = conn.u();
  if (r > KA - 1) throw `edge index ${r} of vertex ${A} exceeds ${KA - 1}`;
  const D = sa.N[sa.list[r]];
  const sd = starB;
  const KD = canonicalStar(st, D, sd);
  if (sd.boundary) throw `edge-split endpoint ${D} is on the boundary`;
  let rhoD = -1;
  for (let t = 0; t < KD; t++) {
    if (sd.N[sd.list[t]] === A) {
      rhoD = t;
      break;
    }
  }
  if (rhoD < 0) throw `vertex ${A} is not in the link of vertex ${D}`;
  // X0 = the smaller id; every later field is by X0, X1
  const aFirst = A < D;
  const s0 = aFirst ? sa : sd;
  const s1 = aFirst ? sd : sa;
  const X0 = aFirst ? A : D;
  const X1 = aFirst ? D : A;
  const rho0 = aFirst ? r : rhoD;
  const rho1 = aFirst ? rhoD : r;
  const K0 = s0.K;
  const K1 = s1.K;
  // 4. sectors and fans
  const n10 = conn.u();
  if (n10 > K0 - 3) throw `first-sector length ${n10} at vertex ${X0} exceeds ${K0 - 3}`;
  const e0 = conn.u();
  if (e0 > K0 - 3 - n10) throw `fan length ${e0 + 1} at vertex ${X0} exceeds ${K0 - 2 - n10}`;
  const n11 = conn.u();
  if (n11 > K1 - 3) throw `first-sector length ${n11} at vertex ${X1} exceeds ${K1 - 3}`;
  const e1 = conn.u();
  if (e1 > K1 - 3 - n11) throw `fan length ${e1 + 1} at vertex ${X1} exceeds ${K1 - 2 - n11}`;
  const m0 = e0 + 1;
  const m1 = e1 + 1;
  // 5.–7. orders and rotations
  const p = conn.u();
  if (p > 575) throw `permutation code ${p} exceeds 575`;
  const pv = 4 * Math.floor(p / 24);
  const pf = 4 * (p % 24);
  const ra = conn.u();
  if (ra > 255) throw `appended rotations ${ra} exceed 255`;
  for (let x = 0; x < 2; x++) {
    const rot = eRot[x];
    const m = x === 0 ? m0 : m1;
    for (let j = 0; j < m; j++) {
      const t = conn.u();
      if (t > 3) throw `rotation ${t} of fan quad ${j} at vertex ${x === 0 ? X0 : X1} exceeds 3`;
      rot[j] = t;
    }
  }
  for (let i = 0; i < 4; i++) eUid[i] = V + PERM4[pv + i];

  // 8. build: the faces of X0's star are entries 0 .. K0 (by walk index
  // from ρ), X1's faces that are not in X0's star follow.
  const f = st.f;
  let nE = 0;
  eCntR[0] = 0;
  eCntR[1] = 0;
  eCntR[2] = 0;
  eCntR[3] = 0;
  for (let x = 0; x < 2; x++) {
    const sc = x === 0 ? s0 : s1;
    const K = sc.K;
    const rho = x === 0 ? rho0 : rho1;
    const n1 = x === 0 ? n10 : n11;
    const m = x === 0 ? m0 : m1;
    const X = x === 0 ? X0 : X1;
    const u1 = eUid[2 * x];
    const u2 = eUid[2 * x + 1];
    const S = sc.S;
    const list = sc.list;
    const rot = eRot[x];
    // w = (rho + i) mod K, stepped (a division per face otherwise)
    for (let i = 0, w = rho % K; i < K; i++, w = w + 1 === K ? 0 : w + 1) {
      const idx = list[w];
      const slot = S[idx];
      const fan = i > n1 && i <= n1 + m;
      let e;
      if (x === 0) {
        e = nE++;
        eOfS0[idx] = e;
        eSlot[e] = slot;
        eSwaps[e] = 0;
        eFan[e] = fan ? 1 : 0;
        const s4 = 4 * slot;
        const e4 = 4 * e;
        eQuad[e4] = f[s4];
        eQuad[e4 + 1] = f[s4 + 1];
        eQuad[e4 + 2] = f[s4 + 2];
        eQuad[e4 + 3] = f[s4 + 3];
      } else {
        // is the slot in X0's star? The lists are exact: if and only if X0
        // is one of its corners (X1 is at C; N, O, P are the others), and
        // then S ascending finds its index (binary search) — most faces
        // of X1's star skip the search
        const S0 = s0.S;
        let lo = K0;
        if (sc.N[idx] === X0 || sc.O[idx] === X0 || sc.P[idx] === X0) {
          lo = 0;
          let hi = K0;
          while (lo < hi) {
            const mid = (lo + hi) >> 1;
            if (S0[mid] < slot) lo = mid + 1;
            else hi = mid;
          }
        }
        if (lo < K0 && S0[lo] === slot) {
          e = eOfS0[lo];
          if (fan || eFan[e]) throw `face ${slot} is in the fan of one endpoint and in the star of the other`;
        } else {
          e = nE++;
          eSlot[e] = slot;
          eSwaps[e] = 0;
          eFan[e] = fan ? 1 : 0;
          const s4 = 4 * slot;
          const e4 = 4 * e;
          eQuad[e4] = f[s4];
          eQuad[e4 + 1] = f[s4 + 1];
          eQuad[e4 + 2] = f[s4 + 2];
          eQuad[e4 + 3] = f[s4 + 3];
        }
      }
      if (!fan) {
        // sector: X (at corner C[idx]) becomes u1 or u2
        const u = i <= n1 ? u1 : u2;
        const ci = 4 * e + sc.C[idx];
        eQuad[ci] = u;
        const k = u - V;
        eNewR[k * E_BUCKET + eCntR[k]++] = ci;
        eOut[e] = X;
        eIn[e] = u;
        eSwaps[e]++;
        continue;
      }
      // fan quad j = i − n1 − 1: G_j = (X, P_2j+1, P_2j+2, P_2j+3), the last
      // (X, P_2m−1, P_2m, u2), with P_2j = N and P_2j+1 = O of h_j and
      // P_2m = the link entry of the first second-sector face
      const j = i - n1 - 1;
      const next = list[w + 1 === K ? 0 : w + 1];
      const g1 = sc.O[idx];
      const g2 = sc.N[next];
      const g3 = j < m - 1 ? sc.O[next] : u2;
      const t = rot[j];
      const e4 = 4 * e;
      // G'[k] = G[(k + t) mod 4] with G = (X, g1, g2, g3)
      eQuad[e4 + ((4 - t) & 3)] = X;
      eQuad[e4 + ((5 - t) & 3)] = g1;
      eQuad[e4 + ((6 - t) & 3)] = g2;
      eQuad[e4 + ((7 - t) & 3)] = g3;
      // the last one holds u2 (g3); its other corners are old vertices
      if (j === m - 1) {
        const k = u2 - V;
        eNewR[k * E_BUCKET + eCntR[k]++] = e4 + ((7 - t) & 3);
      }
      // a fan quad is built from link entries: they may repeat a vertex
      // (a sector quad is an old quad with X, or X0 and X1, replaced by
      // new vertices, distinct by construction)
      checkDistinct(eQuad, e4, 'rewritten slot', slot);
      // and it is a swap too: h_j = (X, N, O, P) with P = N of the next
      // face (the walk's succ), so G_j keeps X, O and P, N leaves and g3
      // enters (when g3 is N itself, the swap leaves the lists as they are)
      eOut[e] = sc.N[idx];
      eIn[e] = g3;
      eSwaps[e] = 1;
    }
    // corner quad T_X = (X, u1, P_0, P_1), P_0 / P_1 = N / O of the first fan face
    const h0 = list[(rho + n1 + 1) % K];
    const c4 = 4 * (2 + x);
    eC[c4] = X;
    eC[c4 + 1] = u1;
    eC[c4 + 2] = sc.N[h0];
    eC[c4 + 3] = sc.O[h0];
  }
  // C_0 = (X0, u2(X0), u1(X1), X1), C_1 = (X0, X1, u2(X1), u1(X0))
  eC[0] = X0;
  eC[1] = eUid[1];
  eC[2] = eUid[2];
  eC[3] = X1;
  eC[4] = X0;
  eC[5] = X1;
  eC[6] = eUid[3];
  eC[7] = eUid[0];
  // C_i rotated by (ra >> 2i) & 3, at slot NF + π_f(i)
  for (let i = 0; i < 4; i++) {
    const t = (ra >> (2 * i)) & 3;
    const o = 4 * PERM4[pf + i];
    for (let k = 0; k < 4; k++) eApp[o + k] = eC[4 * i + ((k + t) & 3)];
  }

  // The appended quads are distinct by construction: C_0, C_1 hold X0, X1
  // and two distinct new vertices, T_X an old quad's X, N, O with a new
  // vertex. Of the rewritten ones the fan quads were checked above, the
  // sector quads are distinct by construction.

  // 9.–10. positions of V .. V+3 against §7.6 (versions 2 and 3: the
  // floored mean of the parallelograms of every quad holding the vertex
  // whose three other corners are known; version 4: of their stencils),
  // then the apply. The sums do not depend on
  // the quads' order, and every new vertex is in an appended quad, so the
  // fallback's first quad (appended ones first, by slot) is always an
  // appended one: the rewritten slots need no sorting (their log entries
  // name distinct slots, in any order, and the lists are sets). The sums
  // are predictScan's, written out here over this record's own buckets
  // (eC through E_APP_AT, eNewR) rather than filling predictScan's.
  st.reserve(V + 4, NF);
  const q = st.q;
  const qmax = ctx.qmax;
  const wN = ctx.wN;
  const wO = ctx.wO;
  const div = ctx.div;
  for (let k = 0; k < 4; k++) {
    const x = V + k;
    let sx = 0, sy = 0, sz = 0, n = 0;
    // appended corners: eC's quads hold the new vertex eUid[a] at a fixed
    // corner (C_0: u2(X0) at 1, u1(X1) at 2; C_1: u2(X1) at 2, u1(X0) at
    // 3; T_X: u1(X) at 1), and a rotation keeps a corner's neighbours
    for (let a = 0; a < 4; a++) {
      if (eUid[a] !== x) continue;
      for (let h = 0; h < 2; h++) {
        const at = E_APP_AT[2 * a + h];
        if (at < 0) continue;
        const o = at & ~3;
        const c = at & 3;
        const n1 = eC[o + ((c + 1) & 3)];
        const op = eC[o + ((c + 2) & 3)];
        const n3 = eC[o + ((c + 3) & 3)];
        if (n1 < x && op < x && n3 < x) {
          sx += wN * (q[16 * n1] + q[16 * n3]) - wO * q[16 * op];
          sy += wN * (q[16 * n1 + 1] + q[16 * n3 + 1]) - wO * q[16 * op + 1];
          sz += wN * (q[16 * n1 + 2] + q[16 * n3 + 2]) - wO * q[16 * op + 2];
          n++;
        }
      }
    }
    const from = k * E_BUCKET;
    const to = from + eCntR[k];
    for (let t = from; t < to; t++) {
      const i = eNewR[t];
      const o = i & ~3;
      const c = i & 3;
      const n1 = eQuad[o + ((c + 1) & 3)];
      const op = eQuad[o + ((c + 2) & 3)];
      const n3 = eQuad[o + ((c + 3) & 3)];
      if (n1 < x && op < x && n3 < x) {
        sx += wN * (q[16 * n1] + q[16 * n3]) - wO * q[16 * op];
        sy += wN * (q[16 * n1 + 1] + q[16 * n3 + 1]) - wO * q[16 * op + 1];
        sz += wN * (q[16 * n1 + 2] + q[16 * n3 + 2]) - wO * q[16 * op + 2];
        n++;
      }
    }
    if (n > 0) {
      // Math.floor(s / d) is exact here, as in the split form: d = div · n
      // ≤ 8 · 512 and |s| ≤ 512 · 12 · 2^24, so the quotient's rounding
      // error is far below the 1/d a non-integer quotient keeps from the
      // next integer (and it inlines, where floorDiv is a call)
      const d = div * n;
      ctx.px = clamp(Math.floor(sx / d), qmax);
      ctx.py = clamp(Math.floor(sy / d), qmax);
      ctx.pz = clamp(Math.floor(sz / d), qmax);
    } else {
      // the first appended quad (by slot) holding x
      let i = 0;
      while (eApp[i] !== x) i++;
      predictFallback(ctx, x, V, eApp, i);
    }
    readCode(ctx, ctx.px, ctx.py, ctx.pz, 'new vertex', x, '');
    appendVertex(ctx);
  }
  for (let e = 0; e < nE; e++) {
    const e4 = 4 * e;
    if (eSwaps[e] === 1) {
      rewriteSwap(ctx, eSlot[e], eQuad[e4], eQuad[e4 + 1], eQuad[e4 + 2], eQuad[e4 + 3], eOut[e], eIn[e]);
    } else {
      rewriteSlot(ctx, eSlot[e], eQuad[e4], eQuad[e4 + 1], eQuad[e4 + 2], eQuad[e4 + 3]);
    }
  }
  for (let i = 0; i < 4; i++) appendQuad(ctx, eApp[4 * i], eApp[4 * i + 1], eApp[4 * i + 2], eApp[4 * i + 3]);
}
/**
 * Where eC (C_0, C_1, T_X0, T_X1 unrotated, 4 corners each) holds new
 * vertex eUid[a]: corner indices 4 i + j, two per a (−1: none).
 */
const E_APP_AT = Int32Array.of(7, 9, 1, -1, 2, 13, 6, -1);
