/**
 * Local record form (spec §7.7): a general-form record whose moved
 * vertices, rewritten slots and explicit corners are named by small indices
 * into the neighbourhood of one *anchor* vertex instead of by global deltas.
 *
 * Neighbourhood of anchor `m`: `A` = the corners of the faces at `m`
 * (1..=255 faces); `R` = every slot with a corner in `A`, ascending (at most
 * 4096 corners visited while collecting, else the record is invalid);
 * `U` = the corners of the faces of `R`, ascending.
 *
 * Written from the spec; shares only the apply/log primitives with the
 * general form (codec.js).
 */
import { readCode, logMove, checkDistinct, finishRecord, degree, vertexRef } from './codec.js';

const MAX_STAR = 255;
const MAX_CORNERS = 4096;

// Scratch, sized by the limits above (no allocation per record).
const lA = new Int32Array(4 * MAX_STAR);
const lR = new Int32Array(MAX_CORNERS);
const lU = new Int32Array(4 * MAX_CORNERS);
const lW = new Int32Array(4 * MAX_CORNERS);
// one vertex's slots (Frontier.slotsOf)
const lTmp = new Int32Array(MAX_CORNERS);
// Per-record lists, grown on demand (bounded by |R| and the streams).
let lSlots = new Int32Array(64);
let lRw = new Int32Array(256);
let lApp = new Int32Array(256);
let lExtra = new Int32Array(64);
const lQuad = new Int32Array(4);

// Generation stamps (spec order is by id; stamps drop repeats so that only
// the distinct faces and vertices get sorted): stampV[v] === gen marks
// vertex v as seen in the current pass, stampF likewise for slots. 16-bit:
// half the cache footprint of 32-bit stamps (they are read at random ids),
// for a clearing pass every 16,383 records.
let stampV = new Uint16Array(0);
let stampF = new Uint16Array(0);
let gen = 0;

/**
 * Fresh stamps for `nv` vertices and `nf` slots; returns `g`, reserving
 * `g .. g+3`: vertices use g (in A), g+2 (in U), g+3 (in the head of W);
 * slots use g+1 (in R).
 */
function nextGen(nv, nf) {
  if (stampV.length < nv) {
    const g = new Uint16Array(Math.max(nv, 2 * stampV.length));
    g.set(stampV);
    stampV = g;
  }
  if (stampF.length < nf) {
    const g = new Uint16Array(Math.max(nf, 2 * stampF.length));
    g.set(stampF);
    stampF = g;
  }
  if (gen > 0xfffb) {
    gen = 0;
    stampV.fill(0);
    stampF.fill(0);
  }
  gen += 4;
  return gen - 3;
}

/**
 * Sorts a[0..n) ascending in place. Insertion sort: the lists are short
 * (|R| is 16 around a regular interior vertex, |U| 25; on bunny's records
 * 19.6 and 30.4 on average), where it beats TypedArray.prototype.sort (a
 * subarray view and a generic sort per call). Falls back to the built-in
 * sort for long lists.
 */
function sortInts(a, n) {
  if (n > 64) {
    a.subarray(0, n).sort();
    return;
  }
  for (let i = 1; i < n; i++) {
    const x = a[i];
    let j = i - 1;
    while (j >= 0 && a[j] > x) {
      a[j + 1] = a[j];
      j--;
    }
    a[j + 1] = x;
  }
}

// Sizes of the neighbourhood of the record being decoded: |R|, and |U| or
// −1 while U is not collected yet (U is needed only by moved vertices and
// explicit corners — 96 % of bunny's local records move a vertex, so this
// saves little, but costs nothing; U is a function of the quads before the
// record, which stay in st.f until the record is applied, so collecting it
// later gives the same list).
let curR = 0;
let curU = -1;
// Vertex stamp of U for the current record (see nextGen).
let curGu = 0;
// Whether lU[0..curU) is sorted yet (see collectU).
let uSorted = false;

/** Fills lR for anchor `m` (and lA); sets curR, resets curU. */
function neighbourhood(st, m) {
  const f = st.f;
  const gv = nextGen(st.nv, st.nf);
  const gf = gv + 1;
  const sv = stampV;
  const sf = stampF;
  // S, the anchor's faces (the frontier's lists are exact: one entry per
  // slot). S is listed in R at once; R is sorted at the end, so the star
  // needs no order.
  const K = degree(st, m);
  if (K > MAX_STAR) throw `vertex ${m} is in more than ${MAX_STAR} faces`;
  if (K === 0) throw `anchor ${m} has no face`;
  st.slotsOf(m, lR, K);
  let nr = K;
  for (let i = 0; i < K; i++) sf[lR[i]] = gf;
  // A: the distinct corners of S.
  let na = 0;
  for (let i = 0; i < K; i++) {
    const s4 = 4 * lR[i];
    for (let k = 0; k < 4; k++) {
      const u = f[s4 + k];
      if (sv[u] !== gv) {
        sv[u] = gv;
        lA[na++] = u;
      }
    }
  }
  // The entries: every corner of the A vertices once (a corner is one
  // (vertex, slot) pair; the anchor's are its K faces), counted from the
  // list lengths before any list is read.
  let entries = K;
  for (let i = 0; i < na; i++) {
    const u = lA[i];
    if (u !== m) entries += degree(st, u);
  }
  if (entries > MAX_CORNERS) throw `the faces around anchor ${m} have more than ${MAX_CORNERS} corners`;
  for (let i = 0; i < na; i++) {
    const u = lA[i];
    if (u === m) continue;
    const n = st.slotsOf(u, lTmp, MAX_CORNERS);
    for (let j = 0; j < n; j++) {
      const s = lTmp[j];
      if (sf[s] !== gf) {
        sf[s] = gf;
        lR[nr++] = s;
      }
    }
  }
  sortInts(lR, nr);
  curR = nr;
  curU = -1;
  curGu = gv + 2;
}

/**
 * Collects U (once per record) from lR into lU, in collection order;
 * returns |U|. Sorting waits for sortedU: most records need only |U| (the
 * moved vertices they name are usually in the head of W).
 */
function collectU(f) {
  if (curU >= 0) return curU;
  const gu = curGu;
  const sv = stampV;
  let nu = 0;
  for (let i = 0; i < curR; i++) {
    const s4 = 4 * lR[i];
    for (let k = 0; k < 4; k++) {
      const u = f[s4 + k];
      if (sv[u] !== gu) {
        sv[u] = gu;
        lU[nu++] = u;
      }
    }
  }
  curU = nu;
  uSorted = false;
  return nu;
}

/** Sorts lU[0..|U|) once per record (U is collected). */
function sortedU() {
  if (!uSorted) {
    sortInts(lU, curU);
    uSorted = true;
  }
}

/** The `t`-th ascending local index (first as is, then gaps after `next`). */
function localIndex(ctx, t, next, len, what) {
  const i = t === 0 ? ctx.slots.u() : next + ctx.slots.u();
  if (i >= len) throw `${what} local index ${i} outside 0..${len}`;
  return i;
}

/**
 * Fills the head of lW (spec §7.7: moved-vertex vocabulary), the distinct
 * old corners of the rewritten slots lSlots[0..nRw]; returns its length.
 * The rewritten slots are in R, so their corners are in U: the head is
 * marked with a vertex stamp (U's stamp is no longer needed once U is
 * collected) instead of being looked up in U. W's length is |U|; its tail
 * (vocabularyTail) is built only when an index reaches it.
 */
function vocabularyHead(f, nRw) {
  const gh = curGu + 1;
  const sv = stampV;
  let n = 0;
  for (let t = 0; t < nRw; t++) {
    const s4 = 4 * lSlots[t];
    for (let k = 0; k < 4; k++) {
      const v = f[s4 + k];
      if (sv[v] !== gh) {
        sv[v] = gh;
        lW[n++] = v;
      }
    }
  }
  return n;
}

/** Appends to lW[0..h) the vertices of U not in the head, ascending; returns |W| (= |U|). */
function vocabularyTail(h) {
  sortedU();
  const gh = curGu + 1;
  const sv = stampV;
  const nU = curU;
  let n = h;
  for (let j = 0; j < nU; j++) {
    const v = lU[j];
    if (sv[v] !== gh) lW[n++] = v;
  }
  return n;
}

/** Resolves a corner code (spec §7.4, explicit corners as in §7.7). */
function cornerCode(ctx, V, nNew, nRw, f) {
  const x = ctx.conn.u();
  if (x === 0) {
    const nU = collectU(f);
    sortedU();
    const i = ctx.slots.u();
    if (i >= nU) throw `local corner index ${i} outside 0..${nU}`;
    const v = lU[i];
    if (ctx.nExtra === lExtra.length) {
      const g = new Int32Array(2 * lExtra.length);
      g.set(lExtra);
      lExtra = g;
    }
    lExtra[ctx.nExtra++] = v;
    return v;
  }
  if (x <= nNew) return V + x - 1;
  if (x <= nNew + 4 * nRw) {
    const i = x - 1 - nNew;
    return f[4 * lSlots[i >> 2] + (i & 3)];
  }
  const e = x - 1 - nNew - 4 * nRw;
  if (e >= ctx.nExtra) throw `corner code ${x} names extra entry ${e}, only ${ctx.nExtra} exist`;
  return lExtra[e];
}

/** Local form (spec §7.7); `sym` is the record's symbol byte. */
export function decodeLocal(ctx, sym) {
  if (sym >> 4) throw `local-form symbol 0x${sym.toString(16)} has bits 4-7 set`;
  const st = ctx.st;
  const conn = ctx.conn;
  const V = st.nv;
  const NF = st.nf;
  const m = vertexRef(ctx, V, 'local-form anchor');
  neighbourhood(st, m);
  const nR = curR;

  const nNew = conn.u();
  if (nNew > ctx.VF - V) throw `${nNew} new vertices exceed the final count ${ctx.VF} (now ${V})`;
  const nMoved = conn.u();
  const nU = nMoved > 0 ? collectU(st.f) : 0;
  if (nMoved > nU) throw `${nMoved} moved vertices, the neighbourhood holds ${nU}`;
  const nRw = conn.u();
  if (nRw > nR) throw `${nRw} rewritten faces, the neighbourhood holds ${nR}`;
  const nApp = conn.u();
  if (nApp > ctx.FF - NF) throw `${nApp} appended faces exceed the final count ${ctx.FF} (now ${NF})`;
  // Each element takes at least one byte of its streams: check before
  // sizing any scratch buffer by these counts.
  if (nMoved + nRw > ctx.slots.remaining() || nRw + 4 * nApp > conn.remaining() || 3 * (nNew + nMoved) > ctx.pos.remaining()) {
    throw `counts (${nNew} new, ${nMoved} moved, ${nRw} rewritten, ${nApp} appended) exceed what the streams hold`;
  }

  // Rewritten slots (the slot cursor is not used by this form).
  if (nRw > lSlots.length) lSlots = new Int32Array(2 * nRw);
  let next = 0;
  for (let t = 0; t < nRw; t++) {
    const i = localIndex(ctx, t, next, nR, 'rewritten face');
    next = i + 1;
    lSlots[t] = lR[i];
  }

  // Moved vertices, as indices into W: the distinct old corners of the
  // rewritten slots (slot order, corners 0..3), then the rest of U
  // ascending. Applied at once, so that predictions see them.
  if (nMoved > 0) {
    // nU = |W|; the tail of W is built when an index first reaches it.
    const h = vocabularyHead(st.f, nRw);
    let tail = false;
    next = 0;
    for (let t = 0; t < nMoved; t++) {
      const i = localIndex(ctx, t, next, nU, 'moved vertex');
      next = i + 1;
      if (i >= h && !tail) {
        vocabularyTail(h);
        tail = true;
      }
      const v = lW[i];
      const q = st.q;
      readCode(ctx, q[16 * v], q[16 * v + 1], q[16 * v + 2], "moved vertex", v, "");
      logMove(ctx, v);
    }
  }

  // Quads. Old quads of rewritten slots stay in st.f until applied.
  ctx.nExtra = 0;
  const f = st.f;
  if (4 * nRw > lRw.length) lRw = new Int32Array(8 * nRw);
  if (4 * nApp > lApp.length) lApp = new Int32Array(8 * nApp);
  const rwNew = lRw;
  const app = lApp;
  for (let i = 0; i < nRw; i++) {
    // bits 0-3: replaced corners of the old quad; bits 4-5: rotation
    const mask = conn.u();
    if (mask > 63) throw `corner mask ${mask} of slot ${lSlots[i]} exceeds 63`;
    const s4 = 4 * lSlots[i];
    for (let c = 0; c < 4; c++) {
      lQuad[c] = mask & (1 << c) ? cornerCode(ctx, V, nNew, nRw, f) : f[s4 + c];
    }
    const rot = mask >> 4;
    for (let k = 0; k < 4; k++) rwNew[4 * i + k] = lQuad[(k + rot) & 3];
    checkDistinct(rwNew, 4 * i, "rewritten slot", lSlots[i]);
  }
  for (let i = 0; i < nApp; i++) {
    for (let c = 0; c < 4; c++) app[4 * i + c] = cornerCode(ctx, V, nNew, nRw, f);
    checkDistinct(app, 4 * i, "appended quad", i);
  }

  finishRecord(ctx, V, NF, nNew, lSlots, nRw, rwNew, nApp, app);
}

/**
 * The neighbourhood lists R and U (spec §7.7 step 2) of anchor `m` in
 * frontier `st`, ascending, as fresh arrays; throws a message string where
 * a local-form record with this anchor would be invalid (no face, more than
 * 255 faces, more than 4096 entries). For tests: the decoder uses the
 * scratch lists directly.
 * @param {import('./codec.js').Frontier} st
 * @param {number} m
 * @returns {{R: number[], U: number[]}}
 */
export function neighbourhoodLists(st, m) {
  neighbourhood(st, m);
  const nU = collectU(st.f);
  sortedU();
  return { R: [...lR.subarray(0, curR)], U: [...lU.subarray(0, nU)] };
}
