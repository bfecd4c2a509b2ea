/**
 * three.js integration of `pqm-decoder`.
 *
 * - `PQMProgressiveMesh`: a `BufferGeometry` (positions + a triangle index,
 *   quad slot `f` = triangles `2f`, `2f + 1`) and a line geometry of the quad
 *   edges (a wireframe without the diagonals, sharing the position
 *   attribute), kept equal to a `PqmDecoder`'s current level. Moving between
 *   levels touches only the changed ranges: each `Change` becomes
 *   `BufferAttribute.addUpdateRange` calls (in array elements), so the
 *   renderer uploads just those bytes with `bufferSubData`. Buffers are
 *   allocated once at the file's final counts (from the header, checked
 *   against the decoder's limits), so GPU buffers are never reallocated.
 * - `PQMLoader`: a three.js `Loader` that streams a URL with `fetch()`,
 *   calls `onLoad` as soon as the base mesh is decoded and keeps refining as
 *   chunks arrive (or stops reading once a target face count / error is
 *   reached); with `setRangeRequests(true)` it asks the server for only
 *   the bytes the target needs (HTTP Range, via `PqmRangeLoader`) and the
 *   mesh can `fetchMore(target)` later.
 * - View-dependent level of detail (3D Tiles' screen-space error):
 *   `PQMProgressiveMesh.updateForView(object, camera, viewportHeight)` goes
 *   to the coarsest level whose geometric error is drawn at most
 *   `maxScreenError` pixels tall, and says how many bytes of the file a
 *   finer level still needs; `pixelsPerWorldUnit` is its projection rule.
 *
 * Materials: by default the geometry has no normals (they change with every
 * level): use `flatShading: true`. With `normals: true` it keeps a smooth
 * `normal` attribute, each vertex the area-weighted mean of its quads' normals, updated
 * through update ranges like the rest: only the vertices of the quads a
 * change touches are written.
 */
import { Box3, BufferAttribute, BufferGeometry, DynamicDrawUsage, Loader, MathUtils, Sphere, Vector3 } from 'three';
import { PqmDecoder, PqmError, PqmRangeLoader } from 'pqm-decoder';

/**
 * Merges sorted runs `{start, end}` whose gap is at most `maxGap` (fewer
 * `bufferSubData` calls for a few re-sent unchanged elements).
 */
export function coalesce(runs, maxGap) {
  const out = [];
  for (const r of runs) {
    const last = out[out.length - 1];
    if (last && r.start - last.end <= maxGap) last.end = Math.max(last.end, r.end);
    else out.push({ start: r.start, end: r.end });
  }
  return out;
}

/**
 * Slot `f`'s two triangles into `out` (6 indices at `6f`), split along the
 * shorter diagonal of its quad (`quads`, 4 ids per slot), measured on the
 * quantization codes `codes` scaled by the grid's `step` per axis (on the
 * cube grid, one step: integers, exact). The rule of the Rust glTF export
 * (`quad_split_diagonal`): v1–v3 only when strictly shorter, the fan then
 * starting at v1 (a tie that its f64 positions round apart aside).
 */
export function splitShorter(out, f, quads, codes, step) {
  const a = quads[4 * f];
  const b = quads[4 * f + 1];
  const c = quads[4 * f + 2];
  const d = quads[4 * f + 3];
  const cube = step[0] === step[1] && step[1] === step[2];
  const dist2 = (u, v) => {
    let s = 0;
    for (let k = 0; k < 3; k++) {
      const t = cube ? codes[3 * u + k] - codes[3 * v + k] : (codes[3 * u + k] - codes[3 * v + k]) * step[k];
      s += t * t;
    }
    return s;
  };
  // the fan's corners: from v1 when v1–v3 is the shorter diagonal
  const [p, q, r, t] = dist2(b, d) < dist2(a, c) ? [b, c, d, a] : [a, b, c, d];
  out.set([p, q, r, p, r, t], 6 * f);
}

/**
 * How many pixels one world unit spans on screen, across the view, at
 * `distance` world units in front of `camera` — the scale 3D Tiles'
 * screen-space error uses. A `PerspectiveCamera` (`fov` in degrees, `zoom`)
 * gives `viewportHeight / (2 distance tan(fov / 2) / zoom)`, larger as the
 * object comes closer; an `OrthographicCamera` (`top`, `bottom`, `zoom`)
 * gives `viewportHeight zoom / (top − bottom)` at any distance. A distance
 * of 0 or less (the camera inside the object) gives `Infinity`: every
 * error is too large to see through.
 * @param {import('three').Camera} camera
 * @param {number} viewportHeight height of the drawing buffer, in pixels
 * @param {number} distance from the camera to the nearest point of the object, world units (unused for orthographic cameras)
 * @returns {number}
 */
export function pixelsPerWorldUnit(camera, viewportHeight, distance) {
  const zoom = camera.zoom ?? 1;
  if (camera.isOrthographicCamera) return (viewportHeight * zoom) / (camera.top - camera.bottom);
  if (!camera.isPerspectiveCamera) {
    throw new PqmError('parameter', 'pixelsPerWorldUnit needs a PerspectiveCamera or an OrthographicCamera');
  }
  if (!(distance > 0)) return Infinity;
  return viewportHeight / ((2 * distance * Math.tan(MathUtils.degToRad(camera.fov) / 2)) / zoom);
}

const viewScratch = { sphere: new Sphere(), eye: new Vector3() };

/** Pixels an error spans at `scale` pixels per unit; an error of 0 spans none even up close. */
function screenPixels(error, scale) {
  return error === 0 ? 0 : error * scale;
}

/**
 * A progressive mesh bound to a decoder (see the module docs).
 */
export class PQMProgressiveMesh {
  /**
   * @param {PqmDecoder} [decoder] a decoder (a new one if omitted); its
   *   header may arrive later through `push`
   * @param {object} [options]
   * @param {boolean} [options.autoRefine=true] go to the deepest level each
   *   time a chunk completes (within `maxFaces`)
   * @param {number} [options.maxFaces=Infinity] auto-refinement stops at the
   *   finest level with at most this many faces
   * @param {number} [options.maxGap=32] merge update ranges closer than this
   *   many vertices / slots
   * @param {'file'|'shorter'|'auto'} [options.quadSplit='file'] the diagonal
   *   each quad is drawn along: `file`, its v0–v2 as the decoder lists it
   *   (the decoder's `triangleIndices`); `shorter`, the shorter one, as
   *   modelling tools split (chosen when the slot is written: where records
   *   move vertices, files written with `--placement qem`, a slot keeps the
   *   split of its last write); `auto`, `file` for a file whose header says
   *   its diagonals are meant (flag bit 3, `finestDiagonals`: a triangle
   *   mesh paired into quads, whose finest level is then drawn as its own
   *   triangles), else `shorter`
   * @param {boolean} [options.normals=false] keep a smooth `normal`
   *   attribute: per vertex, the normalized sum of its quads' vector areas
   *   (`(p2 − p0) × (p3 − p1) / 2`), summed on the integer position codes so
   *   that adding and removing quads is exact and any path to a level gives
   *   the same normals as computing them at that level; a change writes
   *   only the corners of the quads it adds, removes or moves a vertex of
   */
  constructor(decoder = new PqmDecoder(), options = {}) {
    this.decoder = decoder;
    this.autoRefine = options.autoRefine ?? true;
    this.maxFaces = options.maxFaces ?? Infinity;
    this.maxGap = options.maxGap ?? 32;
    /** Whether the geometry keeps a `normal` attribute. */
    this.normals = options.normals ?? false;
    const split = options.quadSplit ?? 'file';
    if (!['file', 'shorter', 'auto'].includes(split)) {
      throw new PqmError('parameter', `quadSplit must be 'file', 'shorter' or 'auto', not ${split}`);
    }
    /** `quadSplit` as asked; `auto` is resolved with the header (`drawnSplit`). */
    this.quadSplit = split;
    /** The split in use once the header is known: `file` or `shorter`. */
    this.drawnSplit = null;
    /** Triangle geometry: `position` and an index, 6 indices per quad slot. */
    this.geometry = null;
    /** Quad-edge geometry: the same `position`, 8 line indices per quad slot. */
    this.wireframeGeometry = null;
    /** Elements written through update ranges since creation, per attribute. */
    this.uploaded = { position: 0, index: 0, lines: 0, normal: 0 };
    /** The last `Change` applied. */
    this.lastChange = null;
    /** The `PqmRangeLoader` that feeds it (meshes from `PQMLoader` Range loads), else null. */
    this.source = null;
    if (decoder.header) this._allocate();
    if (decoder.deepestLevel !== null) this.apply(decoder.fullUpload());
  }

  /** Faces of the current level. */
  get faceCount() {
    return this.decoder.faceCount;
  }

  /** The current level. */
  get level() {
    return this.decoder.level;
  }

  /**
   * Pushes bytes into the decoder; allocates the buffers when the header is
   * complete, uploads the base mesh, and (with `autoRefine`) refines as
   * chunks complete. Returns the decoder's events.
   * @param {Uint8Array} bytes
   */
  push(bytes) {
    const events = this.decoder.push(bytes);
    for (const ev of events) {
      if (ev.type === 'headerReady') this._allocate();
      else if (ev.type === 'baseMeshReady') this.apply(this.decoder.fullUpload());
    }
    if (this.autoRefine && events.some((e) => e.type === 'chunkReady')) {
      this.refineTo({ faces: this.maxFaces === Infinity ? Number.MAX_SAFE_INTEGER : this.maxFaces });
    }
    return events;
  }

  /**
   * Range-loaded meshes: downloads what `target` needs beyond the bytes
   * already here (one more HTTP Range request; null = the rest of the file)
   * and refines to it. Resolves to this mesh.
   * @param {object|null} [target] `{faces}`, `{error}`, `{level}` or null
   */
  async fetchMore(target = null) {
    if (!this.source) throw new PqmError('parameter', 'fetchMore() needs a mesh loaded with Range requests');
    this.maxFaces = target && target.faces !== undefined ? Math.max(this.maxFaces, target.faces) : Infinity;
    await this.source.load(target);
    this.refineTo(target ?? { level: this.decoder.deepestLevel });
    return this;
  }

  /** Goes to a target (`{level}`, `{faces}`, `{error}` or a level number). */
  setLevel(target) {
    return this.apply(this.decoder.setLevel(target));
  }

  /** Refines to a target (never coarsens). */
  refineTo(target) {
    return this.apply(this.decoder.refineTo(target));
  }

  /** Coarsens to a target (never refines). */
  coarsenTo(target) {
    return this.apply(this.decoder.coarsenTo(target));
  }

  _allocate() {
    if (this.geometry) return;
    const h = this.decoder.header;
    this.drawnSplit = this.quadSplit === 'auto' ? (h.finestDiagonals ? 'file' : 'shorter') : this.quadSplit;
    const pos = new BufferAttribute(new Float32Array(3 * h.finalVertexCount), 3);
    pos.setUsage(DynamicDrawUsage);
    const index = new BufferAttribute(new Uint32Array(6 * h.finalFaceCount), 1);
    index.setUsage(DynamicDrawUsage);
    const lines = new BufferAttribute(new Uint32Array(8 * h.finalFaceCount), 1);
    lines.setUsage(DynamicDrawUsage);
    // The header's bounds: the exact box of every position of every level
    // (spec §3, flag bit 2); without them the decoder gives the quantization
    // grid, which holds every level too. The grid itself need not be tight
    // (the cube grid of spec §5), so it is not used when bounds are present.
    const box = new Box3(new Vector3(...h.boundsMin), new Vector3(...h.boundsMax));
    const sphere = box.getBoundingSphere(new Sphere());
    const g = new BufferGeometry();
    g.setAttribute('position', pos);
    if (this.normals) {
      const normal = new BufferAttribute(new Float32Array(3 * h.finalVertexCount), 3);
      normal.setUsage(DynamicDrawUsage);
      g.setAttribute('normal', normal);
      // per vertex, the sum of its quads' vector areas, and per slot the
      // vector area it added: integers (doubled areas in code units), so
      // that removing a quad takes back exactly what adding it put in
      this._normalSum = new Float64Array(3 * h.finalVertexCount);
      this._slotArea = new Float64Array(3 * h.finalFaceCount);
      this._touched = new Uint8Array(h.finalVertexCount);
      // each vertex's quad slots, for the quads around a moved vertex
      this._slotsOf = Array.from({ length: h.finalVertexCount }, () => []);
      this._slotSeen = new Uint8Array(h.finalFaceCount);
    }
    g.setIndex(index);
    g.setDrawRange(0, 0);
    g.boundingBox = box;
    g.boundingSphere = sphere;
    const w = new BufferGeometry();
    w.setAttribute('position', pos);
    w.setIndex(lines);
    w.setDrawRange(0, 0);
    w.boundingBox = box.clone();
    w.boundingSphere = sphere.clone();
    this.geometry = g;
    this.wireframeGeometry = w;
  }

  /**
   * Applies a decoder `Change` to the buffers: copies the changed ranges,
   * registers them as update ranges and sets the draw ranges. Returns it.
   */
  apply(change) {
    const dec = this.decoder;
    this._allocate();
    const posAttr = this.geometry.attributes.position;
    const idxAttr = this.geometry.index;
    const lineAttr = this.wireframeGeometry.index;
    const gap = this.maxGap;

    // vertices: moved runs and the appended range
    const vRuns = change.movedRanges();
    const va = change.verticesAppended;
    if (va.end > va.start) vRuns.push({ start: va.start, end: va.end });
    const pos = dec.positions;
    for (const r of coalesce(vRuns, gap)) {
      posAttr.array.set(pos.subarray(3 * r.start, 3 * r.end), 3 * r.start);
      posAttr.addUpdateRange(3 * r.start, 3 * (r.end - r.start));
      this.uploaded.position += 3 * (r.end - r.start);
    }
    if (vRuns.length) posAttr.needsUpdate = true;

    // faces: rewritten runs and the appended range
    const fRuns = change.rewrittenRanges();
    const fa = change.facesAppended;
    if (fa.end > fa.start) fRuns.push({ start: fa.start, end: fa.end });
    // normals, before the line index (which still holds each slot's old
    // quad) is overwritten: take back what the old quads put in
    const touched = this.normals ? [] : null;
    if (this.normals) {
      const ft = change.facesTruncated;
      for (let f = ft.start; f < ft.end; f++) this._unaddSlot(f, touched);
      for (const r of fRuns) for (let f = r.start; f < r.end; f++) this._unaddSlot(f, touched);
    }
    const tris = dec.triangleIndices;
    const quads = dec.quads;
    const L = lineAttr.array;
    const shorter = this.drawnSplit === 'shorter' && fRuns.length > 0;
    const codes = shorter ? dec.positionCodes : null;
    const step = shorter ? dec.grid.step : null;
    for (const r of coalesce(fRuns, gap)) {
      if (shorter) {
        for (let f = r.start; f < r.end; f++) splitShorter(idxAttr.array, f, quads, codes, step);
      } else {
        idxAttr.array.set(tris.subarray(6 * r.start, 6 * r.end), 6 * r.start);
      }
      idxAttr.addUpdateRange(6 * r.start, 6 * (r.end - r.start));
      for (let f = r.start; f < r.end; f++) {
        const a = quads[4 * f];
        const b = quads[4 * f + 1];
        const c = quads[4 * f + 2];
        const d = quads[4 * f + 3];
        const o = 8 * f;
        L[o] = a;
        L[o + 1] = b;
        L[o + 2] = b;
        L[o + 3] = c;
        L[o + 4] = c;
        L[o + 5] = d;
        L[o + 6] = d;
        L[o + 7] = a;
      }
      lineAttr.addUpdateRange(8 * r.start, 8 * (r.end - r.start));
      this.uploaded.index += 6 * (r.end - r.start);
      this.uploaded.lines += 8 * (r.end - r.start);
    }
    if (fRuns.length) {
      idxAttr.needsUpdate = true;
      lineAttr.needsUpdate = true;
    }
    if (this.normals) {
      const seen = this._slotSeen;
      const done = [];
      for (const r of fRuns) {
        for (let f = r.start; f < r.end; f++) {
          this._addSlot(f, touched);
          seen[f] = 1;
          done.push(f);
        }
      }
      // the other quads around a moved vertex: same corners, new area
      for (const v of change.verticesMoved) {
        // a copy: taking a slot out and back in reorders the list
        for (const f of this._slotsOf[v].slice()) {
          if (seen[f]) continue;
          seen[f] = 1;
          done.push(f);
          this._unaddSlot(f, touched);
          this._addSlot(f, touched);
        }
      }
      for (const f of done) seen[f] = 0;
      this._writeNormals(touched);
    }
    this.geometry.setDrawRange(0, 6 * dec.faceCount);
    this.wireframeGeometry.setDrawRange(0, 8 * dec.faceCount);
    this.lastChange = change;
    return change;
  }

  /** Adds slot `f`'s quad (the decoder's now) to its corners' sums. */
  _addSlot(f, touched) {
    const dec = this.decoder;
    const q = dec.quads;
    const c = dec.positionCodes;
    const a = q[4 * f];
    const b = q[4 * f + 1];
    const cc = q[4 * f + 2];
    const d = q[4 * f + 3];
    // doubled vector area (p2 − p0) × (p3 − p1), on the codes
    const ux = c[3 * cc] - c[3 * a];
    const uy = c[3 * cc + 1] - c[3 * a + 1];
    const uz = c[3 * cc + 2] - c[3 * a + 2];
    const vx = c[3 * d] - c[3 * b];
    const vy = c[3 * d + 1] - c[3 * b + 1];
    const vz = c[3 * d + 2] - c[3 * b + 2];
    const nx = uy * vz - uz * vy;
    const ny = uz * vx - ux * vz;
    const nz = ux * vy - uy * vx;
    const A = this._slotArea;
    A[3 * f] = nx;
    A[3 * f + 1] = ny;
    A[3 * f + 2] = nz;
    const S = this._normalSum;
    for (const v of [a, b, cc, d]) {
      S[3 * v] += nx;
      S[3 * v + 1] += ny;
      S[3 * v + 2] += nz;
      this._slotsOf[v].push(f);
      this._touch(v, touched);
    }
  }

  /**
   * Takes slot `f`'s quad back out of its corners' sums and slot lists:
   * the area it last added, from the corners it went to (the line index's
   * quad, the slot's before this change's writes). Slots never written
   * (past every level drawn so far) are in no list.
   */
  _unaddSlot(f, touched) {
    const L = this.wireframeGeometry.index.array;
    const A = this._slotArea;
    const nx = A[3 * f];
    const ny = A[3 * f + 1];
    const nz = A[3 * f + 2];
    const S = this._normalSum;
    for (let k = 0; k < 8; k += 2) {
      const v = L[8 * f + k];
      const list = this._slotsOf[v];
      const i = list.indexOf(f);
      if (i < 0) return; // not in the sums (each corner lists it, or none does)
      list[i] = list[list.length - 1];
      list.pop();
      S[3 * v] -= nx;
      S[3 * v + 1] -= ny;
      S[3 * v + 2] -= nz;
      this._touch(v, touched);
    }
    A[3 * f] = A[3 * f + 1] = A[3 * f + 2] = 0;
  }

  _touch(v, touched) {
    if (this._touched[v]) return;
    this._touched[v] = 1;
    touched.push(v);
  }

  /** Normalizes the touched vertices' sums into the `normal` attribute (update ranges, merged within `maxGap`). */
  _writeNormals(touched) {
    const attr = this.geometry.attributes.normal;
    const nv = this.decoder.vertexCount;
    touched.sort((x, y) => x - y);
    const runs = [];
    for (const v of touched) {
      this._touched[v] = 0;
      if (v >= nv) continue; // a removed vertex: not drawn
      const last = runs[runs.length - 1];
      if (last && last.end === v) last.end = v + 1;
      else runs.push({ start: v, end: v + 1 });
    }
    const k = this._axisScale();
    for (const r of coalesce(runs, this.maxGap)) {
      for (let v = r.start; v < r.end; v++) this._normalOf(v, attr.array, k);
      attr.addUpdateRange(3 * r.start, 3 * (r.end - r.start));
      this.uploaded.normal += 3 * (r.end - r.start);
    }
    if (runs.length) attr.needsUpdate = true;
  }

  /**
   * The sums are in code units: a grid step of its own per axis (files
   * before 3.1's cube grid) scales a normal by (sy sz, sx sz, sx sy).
   */
  _axisScale() {
    const [sx, sy, sz] = this.decoder.grid.step;
    return [sy * sz, sx * sz, sx * sy];
  }

  /** Writes vertex `v`'s unit normal (zero where its quads' areas cancel) into `out`. */
  _normalOf(v, out, k) {
    const S = this._normalSum;
    const x = S[3 * v] * k[0];
    const y = S[3 * v + 1] * k[1];
    const z = S[3 * v + 2] * k[2];
    // the arithmetic of pqm_format::normals (a division, not a reciprocal)
    const len = Math.sqrt(x * x + y * y + z * z);
    if (len > 0 && Number.isFinite(len)) {
      out[3 * v] = x / len;
      out[3 * v + 1] = y / len;
      out[3 * v + 2] = z / len;
    } else {
      out[3 * v] = out[3 * v + 1] = out[3 * v + 2] = 0;
    }
  }

  /**
   * The geometric error of a decoded level, in the file's units
   * (fractions of its bounding-box diagonal, spec §3): the header's base
   * error at level 0, else the error of the last chunk boundary at or
   * before the level (errors never grow with the level, so a level between
   * two boundaries is at least as fine as the one before it).
   * @param {number} level
   */
  levelError(level) {
    const dec = this.decoder;
    let e = dec.header.baseError;
    for (const c of dec.chunks) {
      if (c.level > level) break;
      e = c.error;
    }
    return e;
  }

  /**
   * View-dependent level of detail, as 3D Tiles picks tiles by their
   * screen-space error: goes to the coarsest decoded level whose geometric
   * error, drawn by `camera` on `object`, is at most `maxScreenError`
   * pixels (the finest decoded one if none is), and reports what a finer
   * level would need. Call it once a frame, after the matrices are updated;
   * moves touch only the changed buffer ranges, as `setLevel` does. Give
   * the mesh `autoRefine: false` so that arriving chunks do not refine it
   * behind the view's back.
   *
   * The error is measured at the object's bounding sphere nearest the
   * camera (the header's bounds, which hold every level, through
   * `object.matrixWorld`; its largest scale scales the file's diagonal).
   * A camera inside the sphere asks for the finest level. To keep a level
   * from flickering while the view moves around a boundary, the mesh
   * refines as soon as the view asks for it but coarsens only as far as
   * `maxScreenError / hysteresis` allows.
   *
   * @param {import('three').Object3D} object the mesh that draws this geometry
   * @param {import('three').Camera} camera a PerspectiveCamera or OrthographicCamera
   * @param {number} viewportHeight drawing-buffer height in pixels (`renderer.getDrawingBufferSize(v).y`)
   * @param {object} [options]
   * @param {number} [options.maxScreenError=1] pixels
   * @param {number} [options.hysteresis=1.5] ≥ 1
   * @returns {null|{level: number, change: object|null, targetError: number,
   *   screenError: number, bytesFor: number, bytesNeeded: number}} null
   *   before the base mesh; else the level now drawn, the decoder `Change`
   *   applied (null when the level stayed), the error the view asks for
   *   (file units), the pixels the drawn level's error spans, the file
   *   bytes that reach the target (`decoder.bytesFor`) and how many of them
   *   have not been pushed yet (0 when the decoded levels suffice; with a
   *   Range-loaded mesh, `fetchMore({error: targetError})` gets them)
   */
  updateForView(object, camera, viewportHeight, options = {}) {
    const maxScreenError = options.maxScreenError ?? 1;
    const hysteresis = options.hysteresis ?? 1.5;
    if (!(maxScreenError > 0) || !(hysteresis >= 1)) {
      throw new PqmError('parameter', `updateForView needs maxScreenError > 0 and hysteresis ≥ 1, got ${maxScreenError} and ${hysteresis}`);
    }
    const dec = this.decoder;
    if (dec.deepestLevel === null) return null;
    this._allocate();
    const { sphere, eye } = viewScratch;
    sphere.copy(this.geometry.boundingSphere).applyMatrix4(object.matrixWorld);
    eye.setFromMatrixPosition(camera.matrixWorld);
    const distance = eye.distanceTo(sphere.center) - sphere.radius;
    const h = dec.header;
    const diagonal = Math.hypot(h.boundsMax[0] - h.boundsMin[0], h.boundsMax[1] - h.boundsMin[1], h.boundsMax[2] - h.boundsMin[2]);
    // pixels per unit of the file's error
    const scale = pixelsPerWorldUnit(camera, viewportHeight, distance) * diagonal * object.matrixWorld.getMaxScaleOnAxis();
    const targetError = maxScreenError / scale;
    const want = dec.resolve({ error: targetError });
    let level = dec.level;
    if (want > level) level = want;
    else if (want < level) level = Math.min(level, dec.resolve({ error: targetError / hysteresis }));
    const change = level === dec.level ? null : this.setLevel({ level });
    const bytesFor = dec.bytesFor({ error: targetError });
    const s = dec.status();
    return {
      level: dec.level,
      change,
      targetError,
      screenError: screenPixels(this.levelError(dec.level), scale),
      bytesFor,
      bytesNeeded: Math.max(0, bytesFor - s.bytesConsumed - s.bytesBuffered),
    };
  }

  /** Frees the geometries' GPU resources. */
  dispose() {
    this.geometry?.dispose();
    this.wireframeGeometry?.dispose();
  }
}

/**
 * three.js loader of `.pqm` files, streaming.
 *
 * ```js
 * const loader = new PQMLoader();
 * loader.load('bunny.pqm', (pm) => {
 *   scene.add(new THREE.Mesh(pm.geometry, new THREE.MeshStandardMaterial({ flatShading: true })));
 *   scene.add(new THREE.LineSegments(pm.wireframeGeometry, new THREE.LineBasicMaterial()));
 * }, (p) => console.log(p.faces, p.loaded));
 * ```
 *
 * `onLoad(progressiveMesh)` runs once the base mesh is decoded; the mesh
 * keeps refining while the rest streams in. `onProgress({loaded, total,
 * level, faces, events, mesh})` runs after every network read that completed
 * something; `onError(error)` on a network or format error (a `PqmError`
 * after `onLoad` leaves the mesh at the deepest level decoded before it).
 */
export class PQMLoader extends Loader {
  constructor(manager) {
    super(manager);
    this.limits = undefined;
    this.target = null;
    this.maxGap = 32;
    this.rangeRequests = false;
    this.rangeOptions = {};
    this.meshOptions = {};
  }

  /**
   * Options of the `PQMProgressiveMesh`es this loader makes: `normals`
   * (smooth normals, kept per level) and `quadSplit` (see its constructor).
   * `maxGap` and the face cap come from the loader's own settings.
   */
  setMeshOptions(options = {}) {
    const known = ['normals', 'quadSplit'];
    const unknown = Object.keys(options).filter((k) => !known.includes(k));
    if (unknown.length) throw new PqmError('parameter', `setMeshOptions takes ${known.join(', ')}, not ${unknown.join(', ')}`);
    this.meshOptions = { ...options };
    return this;
  }

  /** Decoder limits (`{maxVertices, maxFaces, maxMemoryBytes}`). */
  setLimits(limits) {
    this.limits = limits;
    return this;
  }

  /**
   * Stop reading once this target is reachable: `{faces: n}` (the finest
   * level with at most n faces) or `{error: e}`; `null` reads everything.
   */
  setTarget(target) {
    this.target = target;
    return this;
  }

  /**
   * Use HTTP Range requests (default off): `load` first asks for the header
   * and chunk table (`bytes=0-4095`, more if the table is longer), then for
   * exactly the bytes up to the chunk that reaches the target
   * (`decoder.bytesFor`), and the mesh can fetch more later with
   * `mesh.fetchMore(target)`. A server that answers 200 is read as one
   * stream cut at the target. Without a target the rest of the file is
   * requested after the table. See `PqmRangeLoader` in `pqm-decoder`.
   * @param {boolean} [on=true]
   * @param {{firstBytes?: number}} [options]
   */
  setRangeRequests(on = true, options = {}) {
    this.rangeRequests = on;
    this.rangeOptions = options;
    return this;
  }

  /**
   * Promise form of a Range load: resolves to the mesh once the bytes for
   * `target` (default: the loader's target) are decoded and the mesh has
   * refined to it; `mesh.fetchMore(t)` continues later.
   * @param {string} url
   * @param {object|null} [target]
   * @param {(p: object) => void} [onProgress]
   */
  async loadRange(url, target = this.target, onProgress) {
    const fullUrl = this.manager.resolveURL((this.path ?? '') + url);
    return this._rangeLoad(fullUrl, null, onProgress, target);
  }

  load(url, onLoad, onProgress, onError) {
    const fullUrl = this.manager.resolveURL((this.path ?? '') + url);
    this.manager.itemStart(fullUrl);
    const run = this.rangeRequests
      ? this._rangeLoad(fullUrl, onLoad, onProgress, this.target)
      : this._stream(fullUrl, onLoad, onProgress);
    run.then(
      () => this.manager.itemEnd(fullUrl),
      (e) => {
        if (onError) onError(e);
        else console.error(e);
        this.manager.itemError(fullUrl);
        this.manager.itemEnd(fullUrl);
      },
    );
  }

  async _stream(url, onLoad, onProgress) {
    const res = await fetch(url, {
      headers: new Headers(this.requestHeader ?? {}),
      credentials: this.withCredentials ? 'include' : 'same-origin',
    });
    if (!res.ok || !res.body) throw new Error(`PQMLoader: ${url}: HTTP ${res.status}`);
    const total = Number(res.headers.get('Content-Length')) || 0;
    const pm = this._newMesh();
    const reader = res.body.getReader();
    let loaded = 0;
    let stopAt = Infinity;
    let delivered = false;
    try {
      for (;;) {
        const { done, value } = await reader.read();
        if (done) break;
        loaded += value.length;
        const piece = loaded > stopAt ? value.subarray(0, value.length - (loaded - stopAt)) : value;
        const events = pm.push(piece);
        if (events.some((e) => e.type === 'headerReady') && this.target) {
          stopAt = pm.decoder.bytesFor(this.target);
        }
        if (!delivered && pm.decoder.deepestLevel !== null) {
          delivered = true;
          onLoad(pm);
        }
        if (events.length && onProgress) {
          onProgress({ loaded: Math.min(loaded, stopAt), total, level: pm.level, faces: pm.faceCount, events, mesh: pm });
        }
        if (loaded >= stopAt) {
          await reader.cancel();
          break;
        }
      }
    } finally {
      reader.releaseLock?.();
    }
    if (!delivered) {
      throw new PqmError('truncated', `PQMLoader: ${url} ended before its base mesh (${loaded} bytes)`);
    }
    if (stopAt === Infinity) pm.decoder.end();
    return pm;
  }

  async _rangeLoad(url, onLoad, onProgress, target) {
    const pm = this._newMesh(target);
    let delivered = false;
    const src = new PqmRangeLoader(url, {
      decoder: pm.decoder,
      push: (bytes) => pm.push(bytes),
      init: {
        headers: this.requestHeader ?? {},
        credentials: this.withCredentials ? 'include' : 'same-origin',
      },
      firstBytes: this.rangeOptions?.firstBytes,
      onEvents: (events) => {
        if (!delivered && pm.decoder.deepestLevel !== null) {
          delivered = true;
          if (onLoad) onLoad(pm);
        }
        if (onProgress) {
          onProgress({ loaded: src.loaded, total: src.size ?? 0, level: pm.level, faces: pm.faceCount, events, mesh: pm });
        }
      },
    });
    pm.source = src;
    await src.load(target ?? null);
    pm.refineTo(target ?? { level: pm.decoder.deepestLevel });
    return pm;
  }

  _newMesh(target = this.target) {
    const pm = new PQMProgressiveMesh(new PqmDecoder({ limits: this.limits }), {
      ...this.meshOptions,
      maxGap: this.maxGap,
      maxFaces: target && target.faces !== undefined ? target.faces : Infinity,
    });
    return pm;
  }

  /**
   * Decodes a whole file held in memory; the mesh is at the finest level
   * (or at the target's level).
   * @param {ArrayBuffer|Uint8Array} data
   */
  parse(data) {
    const bytes = data instanceof Uint8Array ? data : new Uint8Array(data);
    const pm = this._newMesh();
    pm.push(bytes);
    pm.decoder.end();
    if (this.target && this.target.error !== undefined) pm.setLevel(this.target);
    return pm;
  }
}
