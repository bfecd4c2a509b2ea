// Test-only writer of the base section's traversal layout (spec §6.1),
// mirroring `encode_traversal` of the Rust reference (pqm_format::base),
// the walk order the coarsener numbers a base in (`traversal_order`,
// pqm-core/src/coarsen/record.rs), and quad meshes to try them on.
import { varint, svarint } from './helpers.mjs';

/** Most faces a vertex may be in, in the traversal layout (spec §6.1). */
export const MAX_FACES_PER_VERTEX = 255;

/**
 * Decoded half-edges around each vertex, each with an "open" flag (its
 * reverse is not decoded), in decode order: `HalfEdges` of base.rs.
 */
class HalfEdges {
  constructor(nv) {
    this.out = Array.from({ length: nv }, () => []); // [target, open]
    this.inc = Array.from({ length: nv }, () => []); // [source, open]
  }

  has(u, v) {
    return this.out[u].some((e) => e[0] === v);
  }

  /** Adds face `g`; returns an error message or null. `maxFaces` bounds the faces per vertex. */
  addFace(g, maxFaces = MAX_FACES_PER_VERTEX) {
    for (let t = 0; t < 4; t++) {
      const [u, v] = [g[t], g[(t + 1) & 3]];
      if (this.has(u, v)) return `half-edge ${u} -> ${v} is in two faces`;
      if (this.out[u].length >= maxFaces) return `vertex ${u} is in more than ${maxFaces} faces`;
    }
    for (let t = 0; t < 4; t++) {
      const [u, v] = [g[t], g[(t + 1) & 3]];
      const reverse = this.has(v, u);
      if (reverse) {
        for (const e of this.out[v]) if (e[0] === u) e[1] = false;
        for (const e of this.inc[u]) if (e[0] === v) e[1] = false;
      }
      this.out[u].push([v, !reverse]);
      this.inc[v].push([u, !reverse]);
    }
    return null;
  }

  /** X of §6.1: sources w of open half-edges w → a, in decode order. */
  openIn(a) {
    return this.inc[a].filter((e) => e[1]).map((e) => e[0]);
  }

  /** Y of §6.1: targets z of open half-edges b → z, in decode order. */
  openOut(b) {
    return this.out[b].filter((e) => e[1]).map((e) => e[0]);
  }
}

/** The rotation r with g[r] = b and g[r + 1] = a, or −1. */
function across(g, a, b) {
  for (let r = 0; r < 4; r++) if (g[r] === b && g[(r + 1) & 3] === a) return r;
  return -1;
}

/** `P(v)` of §6.1 from the codes of the vertices before `v` (`around`: the faces holding v). */
export function predictBase(v, codes, quads, around, qmax) {
  const sum = [0, 0, 0];
  const esum = [0, 0, 0];
  let c = 0;
  let e = 0;
  for (const fi of around) {
    const g = quads[fi];
    const k = g.indexOf(v);
    if (k < 0) continue;
    const [n1, o, n3] = [g[(k + 1) & 3], g[(k + 2) & 3], g[(k + 3) & 3]];
    if (n1 < v && o < v && n3 < v) {
      for (let t = 0; t < 3; t++) sum[t] += 5 * (codes[n1][t] + codes[n3][t]) - 2 * codes[o][t];
      c++;
    }
    for (const u of [n1, n3]) {
      if (u < v) {
        for (let t = 0; t < 3; t++) esum[t] += codes[u][t];
        e++;
      }
    }
  }
  const clamp = (x) => Math.min(Math.max(x, 0), qmax);
  if (c > 0) return sum.map((x) => clamp(Math.floor(x / (8 * c))));
  if (e > 0) return esum.map((x) => clamp(Math.floor(x / e)));
  if (v > 0) return codes[v - 1].slice();
  return [0, 0, 0];
}

/**
 * The traversal-layout base payload (layout byte 1 and the four streams)
 * of `codes` (per vertex [x, y, z]) and `quads` (per face 4 ids), or null
 * when the base cannot be written in it. Options for hostile tests:
 * `maxFaces` (the per-vertex bound the writer keeps, default 255) and
 * `parts` (returns the streams apart instead of the payload).
 */
export function encodeTraversal(codes, quads, qmax, { maxFaces = MAX_FACES_PER_VERTEX, parts = false } = {}) {
  const nv = codes.length;
  const nf = quads.length;
  const he = new HalfEdges(nv);
  const gates = [];
  const corners = [];
  const escapes = [];
  let s = 0;
  const corner = (v, cands) => {
    if (v === s) {
      corners.push(0);
      s++;
    } else if (v > s) {
      return false;
    } else {
      const i = cands.indexOf(v);
      if (i >= 0 && i < 254) corners.push(1 + i);
      else {
        corners.push(255);
        escapes.push(...varint(s - 1 - v));
      }
    }
    return true;
  };
  let n = 0;
  let h = 0;
  while (n < nf) {
    if (h === n) {
      const g = quads[n];
      for (const v of g) if (!corner(v, [])) return null;
      if (he.addFace(g, maxFaces) !== null) return null;
      n++;
      continue;
    }
    const f = quads[h];
    h++;
    for (let k = 0; k < 4; k++) {
      if (n >= nf) break;
      const [a, b] = [f[k], f[(k + 1) & 3]];
      if (he.has(b, a)) continue;
      const g = quads[n];
      const r = across(g, a, b);
      if (r < 0) {
        gates.push(0);
        continue;
      }
      gates.push(1 + r);
      if (!corner(g[(r + 2) & 3], he.openIn(a))) return null;
      if (!corner(g[(r + 3) & 3], he.openOut(b))) return null;
      if (he.addFace(g, maxFaces) !== null) return null;
      n++;
    }
  }
  if (s !== nv) return null;
  const around = Array.from({ length: nv }, () => []);
  quads.forEach((g, i) => g.forEach((v) => around[v].push(i)));
  const pos = [];
  for (let v = 0; v < nv; v++) {
    const p = predictBase(v, codes, quads, around[v], qmax);
    for (let t = 0; t < 3; t++) pos.push(...svarint(codes[v][t] - p[t]));
  }
  if (parts) return { gates, corners, escapes, pos };
  return joinStreams({ gates, corners, escapes, pos });
}

/** The payload (layout byte 1, then each stream with its varint length) of `{gates, corners, escapes, pos}`. */
export function joinStreams({ gates, corners, escapes, pos }, layout = 1) {
  const out = [layout];
  for (const p of [gates, corners, escapes, pos]) out.push(...varint(p.length), ...p);
  return Uint8Array.from(out);
}

/**
 * The faces and vertices of a quad mesh in the walk's order (the Rust
 * `traversal_order`): faces breadth first across edges from each not yet
 * reached face in input order, vertices by first appearance (a start
 * face's four corners, then each face across an edge its two corners
 * off that edge); vertices in no face last. Returns the mesh renumbered:
 * `{codes, quads}` (each face keeps its rotation).
 */
export function walkOrder(codes, quads) {
  const byHalfEdge = new Map();
  quads.forEach((g, i) => {
    for (let t = 0; t < 4; t++) byHalfEdge.set(`${g[t]},${g[(t + 1) & 3]}`, i);
  });
  const queued = new Uint8Array(quads.length);
  const newId = new Int32Array(codes.length).fill(-1);
  const vertices = [];
  const number = (v) => {
    if (newId[v] < 0) {
      newId[v] = vertices.length;
      vertices.push(v);
    }
  };
  const faces = [];
  let head = 0;
  for (let start = 0; start < quads.length; start++) {
    if (queued[start]) continue;
    queued[start] = 1;
    faces.push(start);
    quads[start].forEach(number);
    while (head < faces.length) {
      const f = quads[faces[head++]];
      for (let k = 0; k < 4; k++) {
        const [a, b] = [f[k], f[(k + 1) & 3]];
        const g = byHalfEdge.get(`${b},${a}`);
        if (g === undefined || queued[g]) continue;
        queued[g] = 1;
        faces.push(g);
        const gv = quads[g];
        const r = gv.indexOf(b);
        number(gv[(r + 2) & 3]);
        number(gv[(r + 3) & 3]);
      }
    }
  }
  for (let v = 0; v < codes.length; v++) number(v);
  return {
    codes: vertices.map((v) => codes[v].slice()),
    quads: faces.map((fi) => quads[fi].map((v) => newId[v])),
  };
}

// Quad meshes (counter-clockwise seen from outside), as {nv, quads}.

/** A w × h grid of quads (a disk: boundary all around). */
export function gridMesh(w, h) {
  const id = (i, j) => i + (w + 1) * j;
  const quads = [];
  for (let j = 0; j < h; j++) for (let i = 0; i < w; i++) quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
  return { nv: (w + 1) * (h + 1), quads };
}

/** A closed torus of n × m quads. */
export function torusMesh(n, m) {
  const id = (i, j) => (i % n) + n * (j % m);
  const quads = [];
  for (let j = 0; j < m; j++) for (let i = 0; i < n; i++) quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
  return { nv: n * m, quads };
}

/** The surface of a cube, each side cut into k × k quads (closed, genus 0). */
export function boxMesh(k) {
  const ids = new Map();
  const id = (x) => {
    const key = x.join();
    if (!ids.has(key)) ids.set(key, ids.size);
    return ids.get(key);
  };
  const quads = [];
  // each side: p(u, v) on it; its quads (u, v) (u+1, v) (u+1, v+1) (u, v+1)
  // are counter-clockwise about du × dv, reversed where that points inward
  const sides = [
    (u, v) => [u, v, 0],
    (u, v) => [u, v, k],
    (u, v) => [u, 0, v],
    (u, v) => [u, k, v],
    (u, v) => [0, u, v],
    (u, v) => [k, u, v],
  ];
  for (const p of sides) {
    const o = p(0, 0);
    const du = p(1, 0).map((x, t) => x - o[t]);
    const dv = p(0, 1).map((x, t) => x - o[t]);
    const n = [du[1] * dv[2] - du[2] * dv[1], du[2] * dv[0] - du[0] * dv[2], du[0] * dv[1] - du[1] * dv[0]];
    const mid = p(k / 2, k / 2).map((x) => x - k / 2);
    const outward = n[0] * mid[0] + n[1] * mid[1] + n[2] * mid[2] > 0;
    for (let v = 0; v < k; v++) {
      for (let u = 0; u < k; u++) {
        const g = [id(p(u, v)), id(p(u + 1, v)), id(p(u + 1, v + 1)), id(p(u, v + 1))];
        quads.push(outward ? g : [g[0], g[3], g[2], g[1]]);
      }
    }
  }
  return { nv: ids.size, quads };
}

/** Several meshes side by side (ids offset). */
export function unionMesh(...meshes) {
  let off = 0;
  const quads = [];
  for (const m of meshes) {
    for (const g of m.quads) quads.push(g.map((v) => v + off));
    off += m.nv;
  }
  return { nv: off, quads };
}

/** A disk of `k` quads around vertex 0 (its valence is k): (0, r_i, o_i, r_{i+1}), closed fan. */
export function fanMesh(k) {
  const quads = [];
  for (let i = 0; i < k; i++) quads.push([0, 1 + 2 * i, 2 + 2 * i, 1 + 2 * ((i + 1) % k)]);
  return { nv: 1 + 2 * k, quads };
}

/** Codes for `nv` vertices from `rand` (0..qmax), some at the extremes. */
export function randomCodes(nv, qmax, rand) {
  return Array.from({ length: nv }, (_, v) =>
    [0, 1, 2].map((t) => (v % 17 === 3 ? (t === 0 ? 0 : qmax) : Math.floor(rand() * (qmax + 1)))),
  );
}
