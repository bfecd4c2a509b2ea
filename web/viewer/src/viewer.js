/**
 * The page `pqm view` serves: streams `mesh.pqm` with `fetch()` and a
 * `ReadableStream` reader into a `PQMProgressiveMesh`, refining as chunks
 * complete, and draws it with three.js.
 *
 * Controls: a level slider (moving it left coarsens; while it sits at the
 * right end the mesh follows the stream), orbit controls (drag / wheel), a
 * wireframe toggle (the quad edges from `pqm-three`, no diagonals), smooth
 * or flat shading (smooth: `pqm-three`'s normals, kept per level), and
 * "level by view": each frame draws the coarsest level whose error
 * spans at most one pixel on screen (`PQMProgressiveMesh.updateForView`,
 * 3D Tiles' screen-space error), so zooming out coarsens and zooming in
 * refines. Live figures: faces, level, bytes received, geometric error of the
 * current level (a fraction of the bounding-box diagonal, from the chunk
 * table) and, by view, the pixels it spans.
 *
 * Opened as `/?view` (or `/?view=PX`), the page downloads by view instead of
 * streaming the whole file: HTTP Range requests for the header and chunk
 * table, then the base mesh, then — level by view on, at most PX pixels
 * (default 1) — only the chunks the view's level needs, one request more
 * each time zooming in asks for a finer level than the bytes hold (the
 * chunk table's offsets, `PqmRangeLoader`, `fetchMore`).
 *
 * Opened as `/?glb`, the page instead loads `/compare.glb` (served with
 * `pqm view --compare`) with three's `GLTFLoader` — the baseline of the
 * slow-link benchmark, drawn with the same camera, lights and material.
 *
 * State for tests and benchmarks is `window.pqmViewer` (see `state` below);
 * times are `performance.now()` milliseconds since navigation start.
 *
 * Built into `../dist/viewer.js` by `npm run build:viewer` (esbuild, see
 * `../build.mjs`); the Rust binary embeds that file.
 */
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { PqmDecoder, PqmRangeLoader } from 'pqm-decoder';
import { PQMProgressiveMesh } from 'pqm-three';

/** Background colour; the browser test counts pixels that differ from it. */
const BACKGROUND = 0x1d2026;

const params = new URLSearchParams(location.search);
const state = {
  /** 'pqm' (streaming), 'view' (Range requests by view) or 'glb' (baseline). */
  mode: params.has('glb') ? 'glb' : params.has('view') ? 'view' : 'pqm',
  /** The largest error drawn by view, in pixels. */
  maxScreenError: Number(params.get('view')) > 0 ? Number(params.get('view')) : 1,
  /** Range requests made ('view' mode), and whether one is in flight. */
  requests: 0,
  fetching: false,
  /** Faces drawn now (quads; triangles in glb mode). */
  faces: 0,
  baseFaces: null,
  finalFaces: null,
  /** Current level and the file's finest level (records). */
  level: null,
  levels: null,
  /** Deepest level decoded so far. */
  deepestLevel: null,
  /** Bytes received so far and the Content-Length. */
  bytes: 0,
  totalBytes: null,
  /** Error bound of the current level (fraction of the bbox diagonal). */
  error: null,
  wireframe: false,
  /** Smooth shading (the progressive mesh's normals) or flat. */
  smooth: true,
  /** "Level by view" is on; the pixels the current level's error spans then. */
  byView: false,
  screenError: null,
  /** The whole file arrived and was decoded. */
  done: false,
  /** An error message if loading failed. */
  failed: null,
  /** When the first frame with the mesh was drawn, and the first at the finest level. */
  firstPixelsMs: null,
  fullMs: null,
  frames: 0,
  /** While streaming: `{ms, bytes, level, faces}` after each read that changed the level. */
  timeline: [],
};
window.pqmViewer = state;

const $ = (id) => document.getElementById(id);
const fmt = (n) => n.toLocaleString('en-US');

// ---- scene -------------------------------------------------------------------

const container = $('view');
const renderer = new THREE.WebGLRenderer({ antialias: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
renderer.setSize(container.clientWidth, container.clientHeight);
container.appendChild(renderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color(BACKGROUND);
const camera = new THREE.PerspectiveCamera(40, container.clientWidth / container.clientHeight, 0.001, 1000);
scene.add(camera);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.2));
const key = new THREE.DirectionalLight(0xffffff, 1.6);
key.position.set(1, 2, 3);
camera.add(key); // the light follows the view, so every side is lit when orbiting

const controls = new OrbitControls(camera, renderer.domElement);
controls.addEventListener('change', () => requestRender());

const surfaceMaterial = new THREE.MeshStandardMaterial({
  color: 0xd8c7a8,
  roughness: 0.75,
  metalness: 0.0,
  flatShading: false, // smooth: pqm-three keeps the normals of every level (the "smooth shading" toggle)
  side: THREE.DoubleSide,
  polygonOffset: true, // keeps the wireframe in front of the faces it outlines
  polygonOffsetFactor: 1,
  polygonOffsetUnits: 1,
});
const wireMaterial = new THREE.LineBasicMaterial({ color: 0x10131a });

/** Points the camera at a box (the header's bounds, which hold every level). */
function frame(box) {
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const r = sphere.radius || 1;
  const dist = (1.15 * r) / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
  camera.position.copy(sphere.center).add(new THREE.Vector3(-0.6, 0.3, -1).normalize().multiplyScalar(dist));
  camera.near = dist / 100;
  camera.far = dist * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(sphere.center);
  controls.update();
}

let renderQueued = false;
/** Draws one frame on the next animation frame (rendering is on demand). */
function requestRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => {
    renderQueued = false;
    if (state.byView) viewLevel();
    renderer.render(scene, camera);
    state.frames++;
    const now = performance.now();
    if (state.faces > 0 && state.firstPixelsMs === null) state.firstPixelsMs = now;
    if (state.done && state.fullMs === null && state.level === state.levels) state.fullMs = now;
  });
}

window.addEventListener('resize', () => {
  camera.aspect = container.clientWidth / container.clientHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(container.clientWidth, container.clientHeight);
  requestRender();
});

function setStatus(text, failed = false) {
  const el = $('status');
  el.textContent = text;
  el.className = failed ? 'failed' : '';
}

function fail(e) {
  state.failed = String(e && e.message ? e.message : e);
  setStatus(`failed: ${state.failed}`, true);
  console.error(e);
}

// ---- .pqm streaming ------------------------------------------------------------

let pm = null;
let surface = null;
let lines = null;
/** True while the slider sits at the deepest level: new chunks refine the mesh. */
let follow = true;
const slider = $('level-slider');
const wireToggle = $('wireframe');
const viewToggle = $('by-view');
const drawingBuffer = new THREE.Vector2();

/** "Level by view": the coarsest level whose error the camera draws at most a pixel tall. */
function viewLevel() {
  if (!pm || !surface) return;
  camera.updateMatrixWorld();
  surface.updateMatrixWorld();
  const v = pm.updateForView(surface, camera, renderer.getDrawingBufferSize(drawingBuffer).y, {
    maxScreenError: state.maxScreenError,
  });
  if (!v) return;
  state.screenError = v.screenError;
  updatePanel();
  // 'view' mode: the bytes the view's level needs, one request at a time
  if (pm.source && v.bytesNeeded > 0 && !fetching) {
    state.fetching = true;
    fetching = pm
      .fetchMore({ error: v.targetError })
      .then(() => {
        fetching = null;
        state.fetching = false;
        state.bytes = pm.source.loaded;
        state.requests = pm.source.requests.length;
        if (pm.source.complete) state.done = true;
        updatePanel();
        requestRender();
      })
      .catch(fail);
  }
}
/** The Range request in flight ('view' mode), if any. */
let fetching = null;

function updatePanel() {
  const dec = pm && pm.decoder;
  if (dec && dec.deepestLevel !== null) {
    state.faces = dec.faceCount;
    state.level = dec.level;
    state.deepestLevel = dec.deepestLevel;
    state.error = pm.levelError(dec.level);
    slider.max = String(dec.deepestLevel);
    slider.value = String(dec.level);
    slider.disabled = false;
  }
  $('faces').textContent = state.faces ? fmt(state.faces) : '–';
  $('level').textContent = state.level === null ? '–' : `${fmt(state.level)} / ${fmt(state.levels ?? 0)}`;
  const pct = state.totalBytes ? ` (${Math.round((100 * state.bytes) / state.totalBytes)}%)` : '';
  $('bytes').textContent = `${fmt(state.bytes)}${state.totalBytes ? ` / ${fmt(state.totalBytes)}` : ''}${pct}`;
  $('error').textContent = state.error === null ? '–' : state.error === 0 ? '0' : `${state.error.toExponential(2)} × diag`;
  $('screen-error').textContent =
    state.byView && state.screenError !== null ? `${state.screenError < 10 ? state.screenError.toFixed(2) : fmt(Math.round(state.screenError))} px` : '–';
}

/** Sets the scene up as the header and the base mesh arrive. */
function onEvents(events) {
  const dec = pm.decoder;
  for (const ev of events) {
    if (ev.type === 'headerReady') {
      const h = dec.header;
      state.baseFaces = h.baseFaceCount;
      state.finalFaces = h.finalFaceCount;
      state.levels = dec.finalLevel;
      frame(pm.geometry.boundingBox);
    } else if (ev.type === 'baseMeshReady') {
      surface = new THREE.Mesh(pm.geometry, surfaceMaterial);
      scene.add(surface);
      lines = new THREE.LineSegments(pm.wireframeGeometry, wireMaterial);
      lines.visible = wireToggle.checked;
      scene.add(lines);
    }
  }
}

/** 'view' mode: the header and table, the base mesh, then what the view asks for. */
async function loadByView() {
  pm = new PQMProgressiveMesh(new PqmDecoder(), { autoRefine: false, quadSplit: 'auto', normals: true });
  const src = new PqmRangeLoader('mesh.pqm', {
    decoder: pm.decoder,
    push: (bytes) => {
      const events = pm.push(bytes);
      onEvents(events);
      return events;
    },
  });
  pm.source = src;
  state.byView = viewToggle.checked = true;
  setStatus('loading by view…');
  await src.load({ level: 0 });
  state.totalBytes = src.size;
  state.bytes = src.loaded;
  state.requests = src.requests.length;
  pm.setLevel({ level: 0 });
  updatePanel();
  setStatus(`by view (≤ ${state.maxScreenError} px): Range requests for what the view needs`);
  requestRender();
}

async function streamPqm() {
  const res = await fetch('mesh.pqm');
  if (!res.ok || !res.body) throw new Error(`mesh.pqm: HTTP ${res.status}`);
  state.totalBytes = Number(res.headers.get('Content-Length')) || null;
  // quads along their shorter diagonal, or as the file means them (a paired
  // triangle mesh: its own triangles at the finest level)
  pm = new PQMProgressiveMesh(new PqmDecoder(), { autoRefine: false, quadSplit: 'auto', normals: true });
  const dec = pm.decoder;
  const reader = res.body.getReader();
  setStatus('streaming…');
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    state.bytes += value.length;
    const events = pm.push(value);
    onEvents(events);
    if (follow && !state.byView && events.some((e) => e.type === 'chunkReady')) pm.refineTo({ level: dec.deepestLevel });
    const before = state.level;
    updatePanel();
    if (state.level !== before) {
      state.timeline.push({ ms: performance.now(), bytes: state.bytes, level: state.level, faces: state.faces });
    }
    requestRender();
  }
  dec.end(); // throws 'truncated' naming the missing section if the file ended early
  state.done = true;
  updatePanel();
  setStatus(`complete: ${fmt(state.finalFaces)} faces in ${fmt(state.bytes)} bytes`);
  requestRender();
}

slider.addEventListener('input', () => {
  if (!pm || pm.decoder.deepestLevel === null) return;
  const v = Number(slider.value);
  follow = v >= pm.decoder.deepestLevel;
  if (state.byView) {
    // the slider takes the level back
    state.byView = viewToggle.checked = false;
  }
  pm.setLevel({ level: v });
  updatePanel();
  requestRender();
});

viewToggle.addEventListener('change', () => {
  state.byView = viewToggle.checked;
  if (!state.byView && pm && pm.decoder.deepestLevel !== null) {
    // back to following the stream from the deepest level
    follow = true;
    pm.setLevel({ level: pm.decoder.deepestLevel });
  }
  updatePanel();
  requestRender();
});

const smoothToggle = $('smooth');
smoothToggle.addEventListener('change', () => {
  state.smooth = smoothToggle.checked;
  surfaceMaterial.flatShading = !state.smooth;
  surfaceMaterial.needsUpdate = true;
  requestRender();
});

wireToggle.addEventListener('change', () => {
  state.wireframe = wireToggle.checked;
  if (lines) lines.visible = wireToggle.checked;
  requestRender();
});

// ---- baseline: the finest level as a plain GLB --------------------------------

async function loadGlb() {
  slider.disabled = true;
  wireToggle.disabled = true;
  viewToggle.disabled = true;
  // the baseline GLB holds positions only: flat shading, as before normals
  state.smooth = smoothToggle.checked = false;
  smoothToggle.disabled = true;
  surfaceMaterial.flatShading = true;
  setStatus('loading compare.glb…');
  const gltf = await new GLTFLoader().loadAsync('compare.glb', (p) => {
    state.bytes = p.loaded;
    if (p.total) state.totalBytes = p.total;
    updatePanel();
  });
  let triangles = 0;
  gltf.scene.traverse((o) => {
    if (o.isMesh) {
      o.material = surfaceMaterial;
      const g = o.geometry;
      triangles += (g.index ? g.index.count : g.attributes.position.count) / 3;
    }
  });
  scene.add(gltf.scene);
  frame(new THREE.Box3().setFromObject(gltf.scene));
  state.faces = triangles;
  state.finalFaces = triangles;
  state.level = state.levels = 0;
  state.done = true;
  updatePanel();
  $('level').textContent = 'GLB (triangles)';
  setStatus(`compare.glb: ${fmt(triangles)} triangles in ${fmt(state.bytes)} bytes`);
  requestRender();
}

updatePanel();
requestRender();
(state.mode === 'glb' ? loadGlb() : state.mode === 'view' ? loadByView() : streamPqm()).catch(fail);
