// A GPU stand-in for the three.js tests: it uploads only what
// `updateRanges` name, as three's WebGLAttributes does, so a copy that
// stays equal to the decoder proves the ranges were complete.
import assert from 'node:assert/strict';

/** A GPU stand-in: per attribute a copy updated like WebGLAttributes.update. */
export class FakeGpu {
  constructor() {
    this.buffers = new Map();
    this.elementsUploaded = 0;
  }

  upload(attr) {
    let b = this.buffers.get(attr);
    if (!b) {
      b = { data: attr.array.slice(), version: attr.version };
      this.buffers.set(attr, b);
      attr.clearUpdateRanges();
      return;
    }
    if (b.version === attr.version) return;
    if (attr.updateRanges.length === 0) {
      b.data.set(attr.array);
      this.elementsUploaded += attr.array.length;
    } else {
      for (const r of attr.updateRanges) {
        b.data.set(attr.array.subarray(r.start, r.start + r.count), r.start);
        this.elementsUploaded += r.count;
      }
      attr.clearUpdateRanges();
    }
    b.version = attr.version;
  }

  render(pm) {
    this.upload(pm.geometry.attributes.position);
    if (pm.geometry.attributes.normal) this.upload(pm.geometry.attributes.normal);
    this.upload(pm.geometry.index);
    this.upload(pm.wireframeGeometry.index);
  }

  /** Asserts that what the GPU holds within the draw ranges is the decoder's level. */
  check(pm, where) {
    const dec = pm.decoder;
    const pos = this.buffers.get(pm.geometry.attributes.position).data;
    const idx = this.buffers.get(pm.geometry.index).data;
    const lines = this.buffers.get(pm.wireframeGeometry.index).data;
    assert.equal(pm.geometry.drawRange.count, 6 * dec.faceCount, where);
    assert.equal(pm.wireframeGeometry.drawRange.count, 8 * dec.faceCount, where);
    assert.deepEqual(pos.subarray(0, 3 * dec.vertexCount), dec.positions, `${where}: positions`);
    assert.deepEqual(idx.subarray(0, 6 * dec.faceCount), dec.triangleIndices, `${where}: triangles`);
    const q = dec.quads;
    for (let f = 0; f < dec.faceCount; f++) {
      const [a, b, c, d] = q.subarray(4 * f, 4 * f + 4);
      const l = lines.subarray(8 * f, 8 * f + 8);
      // the four quad edges, no diagonal (a–c or b–d)
      if (l.join() !== [a, b, b, c, c, d, d, a].join()) assert.fail(`${where}: slot ${f} lines ${l}`);
    }
  }
}
