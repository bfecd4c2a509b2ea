// View-dependent level of detail (`updateForView`, `pixelsPerWorldUnit`):
// the projection rule agrees with three's own projection matrices; the level
// drawn is the coarsest whose error the view cannot see, so approaching
// refines and receding coarsens; scaling the whole scene changes nothing;
// the hysteresis keeps a jittering view on one level; a streamed file says
// how many bytes a finer level still needs.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Mesh, OrthographicCamera, PerspectiveCamera, Vector3 } from 'three';
import { PqmDecoder, PqmError } from 'pqm-decoder';
import { PQMProgressiveMesh, pixelsPerWorldUnit } from '../src/index.js';
import { testFiles, rng } from '../../pqm-decoder/test/helpers.mjs';

const files = testFiles();
const many = files.filter((f) => ['local_form', 'spot', 'box_vnbr'].includes(f.name));

/** Pixels between two world points projected by `camera` (vertical). */
function projectedHeight(camera, a, b, height) {
  camera.updateMatrixWorld();
  const pa = a.clone().project(camera);
  const pb = b.clone().project(camera);
  return (Math.abs(pb.y - pa.y) / 2) * height;
}

test('pixelsPerWorldUnit is the scale three projects with', () => {
  const r = rng(27);
  for (let i = 0; i < 200; i++) {
    const height = 200 + Math.floor(r() * 2000);
    const d = 0.1 + r() * 50;
    const len = 0.01 + r() * 2;
    const cam = new PerspectiveCamera(10 + r() * 100, 0.5 + r() * 2, 0.01, 1000);
    cam.zoom = 0.5 + r() * 3;
    cam.updateProjectionMatrix();
    // a vertical segment on the view axis, d in front of the camera
    const want = projectedHeight(cam, new Vector3(0, -len / 2, -d), new Vector3(0, len / 2, -d), height);
    const got = len * pixelsPerWorldUnit(cam, height, d);
    assert.ok(Math.abs(got - want) <= 1e-9 * want, `perspective ${got} vs ${want}`);

    const half = 0.5 + r() * 10;
    const ortho = new OrthographicCamera(-half, half, half, -half, 0.01, 1000);
    ortho.zoom = 0.5 + r() * 3;
    ortho.updateProjectionMatrix();
    const o = projectedHeight(ortho, new Vector3(0, -len / 2, -d), new Vector3(0, len / 2, -d), height);
    const og = len * pixelsPerWorldUnit(ortho, height, d);
    assert.ok(Math.abs(og - o) <= 1e-9 * o, `orthographic ${og} vs ${o}`);
    assert.equal(pixelsPerWorldUnit(ortho, height, -1), pixelsPerWorldUnit(ortho, height, d), 'orthographic: no distance');
  }
  const cam = new PerspectiveCamera(50, 1, 0.1, 100);
  assert.equal(pixelsPerWorldUnit(cam, 800, 0), Infinity, 'camera inside the object');
  assert.equal(pixelsPerWorldUnit(cam, 800, -3), Infinity);
  assert.throws(() => pixelsPerWorldUnit({}, 800, 1), PqmError);
});

/** A fully decoded progressive mesh drawn by a Mesh placed at random. */
function scene(f, r, options = {}) {
  const dec = new PqmDecoder();
  const pm = new PQMProgressiveMesh(dec, { autoRefine: false });
  pm.push(f.bytes);
  dec.end();
  pm.setLevel({ level: 0 });
  const object = new Mesh(pm.geometry);
  object.position.set(r() * 10 - 5, r() * 10 - 5, r() * 10 - 5);
  object.rotation.set(r() * 6, r() * 6, r() * 6);
  object.scale.setScalar(options.scale ?? 0.2 + r() * 5);
  object.updateMatrixWorld();
  const camera = new PerspectiveCamera(30 + r() * 60, 1.5, 0.01, 1e6);
  return { dec, pm, object, camera };
}

/** Puts the camera `distance` world units from the object's sphere, looking at it along `dir`. */
function place(camera, object, pm, dir, distance) {
  const s = pm.geometry.boundingSphere.clone().applyMatrix4(object.matrixWorld);
  camera.position.copy(s.center).addScaledVector(dir, s.radius + distance);
  camera.lookAt(s.center);
  camera.updateMatrixWorld();
}

/** The error bounds of the levels `updateForView` can pick: level 0 and the chunk boundaries. */
function boundaries(dec) {
  return [{ level: 0, error: dec.header.baseError }, ...dec.chunks.map((c) => ({ level: c.level, error: c.error }))];
}

test('updateForView draws the coarsest level whose error the view cannot see', () => {
  const r = rng(7);
  for (const f of many) {
    for (let round = 0; round < 4; round++) {
      const { dec, pm, object, camera } = scene(f, r);
      const dir = new Vector3(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
      const height = 300 + Math.floor(r() * 1500);
      const maxScreenError = 0.5 + r() * 4;
      const radius = pm.geometry.boundingSphere.radius * object.scale.x;
      const far = radius * 1e5;
      const levels = [];
      // approach from far away, then recede (no hysteresis: exactly the rule)
      const ds = [];
      for (let d = far; d > radius * 1e-4; d /= 1.3) ds.push(d);
      for (const d of [...ds, ...ds.slice().reverse()]) {
        place(camera, object, pm, dir, d);
        const v = pm.updateForView(object, camera, height, { maxScreenError, hysteresis: 1 });
        assert.equal(v.level, dec.level);
        const pxPerError = v.targetError > 0 ? maxScreenError / v.targetError : Infinity;
        // what the drawn level's error spans, measured independently
        const diag = new Vector3(...dec.header.boundsMax).sub(new Vector3(...dec.header.boundsMin)).length();
        const expectPx = pixelsPerWorldUnit(camera, height, d) * diag * object.scale.x;
        assert.ok(Math.abs(pxPerError - expectPx) <= 1e-6 * expectPx, `${f.name}: scale ${pxPerError} vs ${expectPx}`);
        const drawn = boundaries(dec).filter((b) => b.level <= v.level).pop();
        assert.ok(v.screenError <= maxScreenError * (1 + 1e-9) || v.level === dec.deepestLevel, `${f.name} d=${d}: ${v.screenError} px at level ${v.level}`);
        if (drawn.error > 0) assert.ok(Math.abs(v.screenError - drawn.error * expectPx) <= 1e-6 * v.screenError);
        // no coarser boundary would do
        const coarser = boundaries(dec).filter((b) => b.level < v.level);
        for (const b of coarser) assert.ok(b.error * expectPx > maxScreenError, `${f.name}: level ${b.level} would do at d=${d}`);
        assert.equal(v.bytesNeeded, 0, 'the whole file is here');
        levels.push(v.level);
      }
      const n = ds.length;
      for (let i = 1; i < n; i++) assert.ok(levels[i] >= levels[i - 1], `${f.name}: approaching refines`);
      for (let i = n + 1; i < 2 * n; i++) assert.ok(levels[i] <= levels[i - 1], `${f.name}: receding coarsens`);
      assert.equal(levels[0], 0, `${f.name}: far away, the base mesh`);
      assert.equal(levels[n - 1], dec.deepestLevel, `${f.name}: up close, the finest level`);
    }
  }
});

test('updateForView: scaling the whole scene changes nothing; orthographic views ignore distance', () => {
  const r = rng(11);
  for (const f of many) {
    const a = scene(f, r, { scale: 1 });
    const b = scene(f, () => 0.5, { scale: 1 });
    const dir = new Vector3(0.3, 0.4, -0.8).normalize();
    for (let i = 0; i < 30; i++) {
      const d = Math.exp(r() * 12 - 4);
      const k = Math.exp(r() * 6 - 3);
      // b is a with everything scaled by k about the origin
      b.object.position.copy(a.object.position).multiplyScalar(k);
      b.object.quaternion.copy(a.object.quaternion);
      b.object.scale.setScalar(k);
      b.object.updateMatrixWorld();
      b.camera.fov = a.camera.fov;
      b.camera.updateProjectionMatrix();
      place(a.camera, a.object, a.pm, dir, d);
      place(b.camera, b.object, b.pm, dir, d * k);
      const va = a.pm.updateForView(a.object, a.camera, 900, { hysteresis: 1 });
      const vb = b.pm.updateForView(b.object, b.camera, 900, { hysteresis: 1 });
      assert.equal(vb.level, va.level, f.name);
      assert.ok(Math.abs(vb.targetError - va.targetError) <= 1e-9 * va.targetError, f.name);
    }
    // orthographic: the level follows the zoom, not the distance
    const o = new OrthographicCamera(-1, 1, 1, -1, 0.01, 1e6);
    const levels = new Set();
    for (const d of [1, 10, 1000]) {
      place(o, a.object, a.pm, dir, d);
      o.updateProjectionMatrix();
      levels.add(a.pm.updateForView(a.object, o, 600, { hysteresis: 1 }).level);
    }
    assert.equal(levels.size, 1, `${f.name}: orthographic distance`);
    let last = -1;
    for (let zoom = 1e-3; zoom < 1e6; zoom *= 3) {
      o.zoom = zoom;
      o.updateProjectionMatrix();
      const v = a.pm.updateForView(a.object, o, 600, { hysteresis: 1 });
      assert.ok(v.level >= last, `${f.name}: zooming in refines`);
      last = v.level;
    }
    assert.equal(last, a.dec.deepestLevel);
  }
});

test('updateForView: the hysteresis keeps a jittering view on one level, and moves only when it must', () => {
  const r = rng(5);
  for (const f of many) {
    const { dec, pm, object, camera } = scene(f, r);
    const dir = new Vector3(-0.2, 1, 0.1).normalize();
    const h = 1.5;
    const radius = pm.geometry.boundingSphere.radius * object.scale.x;
    let changes = 0;
    for (let i = 0; i < 300; i++) {
      // a random walk in log distance, with jitter
      const d = radius * Math.exp(r() * 14 - 9);
      place(camera, object, pm, dir, d);
      const before = dec.level;
      const v = pm.updateForView(object, camera, 1000, { hysteresis: h });
      const want = dec.resolve({ error: v.targetError });
      const keep = dec.resolve({ error: v.targetError / h });
      assert.ok(want <= v.level && v.level <= keep, `${f.name}: ${want} ≤ ${v.level} ≤ ${keep}`);
      if (want <= before && before <= keep) assert.equal(v.change, null, 'no needless move');
      else {
        assert.notEqual(v.change, null);
        changes++;
      }
      // a ±10 % jitter (a factor 1.22 < h): the level never turns back
      const seen = [dec.level];
      for (let j = 0; j < 20; j++) {
        place(camera, object, pm, dir, d * (0.9 + 0.2 * r()));
        seen.push(pm.updateForView(object, camera, 1000, { hysteresis: h }).level);
      }
      const steps = seen.slice(1).map((l, j) => Math.sign(l - seen[j])).filter((x) => x !== 0);
      assert.ok(steps.every((x) => x === steps[0]), `${f.name}: jitter flickered ${seen.join(' ')}`);
      // refined from the base at the jitter's nearest point: it stays put
      pm.setLevel({ level: 0 });
      place(camera, object, pm, dir, d * 0.9);
      pm.updateForView(object, camera, 1000, { hysteresis: h });
      const settled = dec.level;
      for (let j = 0; j < 10; j++) {
        place(camera, object, pm, dir, d * (0.9 + 0.2 * r()));
        const w = pm.updateForView(object, camera, 1000, { hysteresis: h });
        assert.equal(w.change, null, `${f.name}: jitter moved ${settled} → ${w.level}`);
      }
    }
    assert.ok(changes > 5, `${f.name}: the walk moved the level (${changes})`);
  }
});

test('updateForView on a stream: bytesNeeded is what the view still lacks', () => {
  const r = rng(3);
  for (const f of many) {
    const whole = scene(f, r);
    const dec = new PqmDecoder();
    const pm = new PQMProgressiveMesh(dec, { autoRefine: false });
    const object = whole.object;
    const camera = whole.camera;
    assert.equal(pm.updateForView(object, camera, 800), null, 'nothing before the base mesh');
    const baseEnd = whole.dec.bytesFor({ level: 0 });
    pm.push(f.bytes.subarray(0, baseEnd));
    const dir = new Vector3(1, 0, 0);
    const radius = pm.geometry.boundingSphere.radius * object.scale.x;
    let pushed = baseEnd;
    for (let d = radius * 1e4; d > radius * 1e-3; d /= 2) {
      place(camera, object, pm, dir, d);
      const v = pm.updateForView(object, camera, 800);
      assert.equal(v.bytesFor, whole.dec.bytesFor({ error: v.targetError }));
      assert.equal(v.bytesNeeded, Math.max(0, v.bytesFor - pushed));
      if (v.bytesNeeded > 0) {
        assert.ok(v.screenError > 1, `${f.name}: more bytes only when the drawn level shows`);
        // all but the target chunk's last byte: buffered, not yet a level
        pm.push(f.bytes.subarray(pushed, v.bytesFor - 1));
        const u = pm.updateForView(object, camera, 800);
        assert.equal(u.bytesNeeded, 1, `${f.name}: one byte short`);
        assert.ok(u.level >= v.level, 'chunks completed on the way are drawn');
        pm.push(f.bytes.subarray(v.bytesFor - 1, v.bytesFor));
        pushed = v.bytesFor;
        const w = pm.updateForView(object, camera, 800);
        assert.equal(w.bytesNeeded, 0);
        assert.ok(w.screenError <= 1 + 1e-9 || w.level === dec.finalLevel, `${f.name}: ${w.screenError} px`);
        assert.ok(w.level > u.level, 'the last byte completes the level the view asks for');
      }
    }
    assert.equal(dec.level, whole.dec.deepestLevel, `${f.name}: up close, the whole file`);
  }
  const { pm, object, camera } = scene(many[0], r);
  assert.throws(() => pm.updateForView(object, camera, 800, { maxScreenError: 0 }), PqmError);
  assert.throws(() => pm.updateForView(object, camera, 800, { maxScreenError: NaN }), PqmError);
  assert.throws(() => pm.updateForView(object, camera, 800, { hysteresis: 0.5 }), PqmError);
});
