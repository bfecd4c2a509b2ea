// `pqm view` in a real browser (Debian chromium driven by playwright-core):
// a real shared mesh is encoded, served, streamed into the page and drawn.
// Fails (never skips) when chromium or the pqm binary is missing, with a
// message saying how to get them.
import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import {
  ARTIFACTS,
  SHARED_MESHES,
  countDrawnPixels,
  findChromium,
  findPqm,
  launchChromium,
  runPqm,
  startView,
  tempDir,
} from './harness.mjs';

/** The page's background (viewer.js BACKGROUND = 0x1d2026). */
const BACKGROUND = [0x1d, 0x20, 0x26];
/** The mesh must cover at least this fraction of the canvas (the cow covers ~15 %). */
const MIN_DRAWN = 0.03;

const number = (text) => Number(text.replace(/[^0-9]/g, ''));

// One encoded file and one browser for both tests.
let pqm;
let info;
let file;
let browser;
let tmp;
after(async () => {
  await browser?.close();
  tmp?.remove();
});
before(async () => {
  findChromium(); // fail first, and clearly, when the browser is missing
  pqm = findPqm();
  const mesh = path.join(SHARED_MESHES, 'quad', 'spot_quadrangulated.obj');
  assert.ok(existsSync(mesh), `shared mesh missing: ${mesh} (set PQM_SHARED_MESHES)`);
  tmp = tempDir('pqm-view-test-');
  file = path.join(tmp.dir, 'spot.pqm');
  runPqm(pqm, ['-q', 'encode', mesh, '-o', file]);
  info = JSON.parse(runPqm(pqm, ['--json', 'info', file]));
  assert.ok(info.final_faces > info.base_faces, 'the file refines');
  browser = await launchChromium();
});

/**
 * Opens the viewer on a fresh page (at `query`, waiting until `ready` holds
 * or the page failed: by default, the finest level drawn); collects page
 * errors and any request outside the server.
 */
async function openViewer(t, server, query = '', ready = () => window.pqmViewer.fullMs !== null, viewport = { width: 800, height: 600 }) {
  const page = await browser.newPage({ viewport });
  t.after(() => page.close());
  const problems = [];
  page.on('pageerror', (e) => problems.push(e.message));
  page.on('requestfailed', (r) => problems.push(`request failed: ${r.url()}: ${r.failure()?.errorText}`));
  // Offline: nothing but the local server may be asked for anything.
  const origin = new URL(server.url).origin;
  page.on('request', (r) => {
    if (!r.url().startsWith(origin) && !r.url().startsWith('data:')) problems.push(`external request: ${r.url()}`);
  });
  await page.goto(server.url + query);
  await page.waitForFunction(`window.pqmViewer && (window.pqmViewer.failed || (${ready})())`, null, {
    timeout: 120_000,
  });
  const state = await page.evaluate(() => ({ ...window.pqmViewer }));
  assert.equal(state.failed, null, `the page failed: ${state.failed}`);
  assert.deepEqual(problems, []);
  return { page, state, problems };
}

test('pqm view streams a real mesh to its full level, draws it, and the slider coarsens to the base', { timeout: 240_000 }, async (t) => {
  const server = await startView(pqm, file);
  t.after(server.stop);
  const { page, state: s, problems: pageErrors } = await openViewer(t, server);

  // full level reached: the figures shown agree with `pqm info`
  assert.equal(s.level, s.levels);
  assert.equal(s.levels, info.records);
  assert.equal(s.faces, info.final_faces);
  assert.equal(number(await page.textContent('#faces')), info.final_faces);
  assert.equal(s.bytes, info.file_bytes);
  assert.match(await page.textContent('#bytes'), new RegExp(info.file_bytes.toLocaleString('en-US')));
  assert.equal(await page.textContent('#error'), '0'); // the full level is exact (up to quantization)

  mkdirSync(ARTIFACTS, { recursive: true });
  writeFileSync(path.join(ARTIFACTS, 'view.png'), await page.screenshot());
  const drawn = async (name) => {
    // count on a screenshot without the panel, so only the mesh differs from the background
    await page.evaluate(() => (document.getElementById('panel').style.visibility = 'hidden'));
    const png = await page.screenshot();
    await page.evaluate(() => (document.getElementById('panel').style.visibility = ''));
    writeFileSync(path.join(ARTIFACTS, name), png);
    return countDrawnPixels(page, png, BACKGROUND);
  };
  const full = await drawn('view-full-mesh.png');
  assert.ok(full.differ / full.total > MIN_DRAWN, `canvas looks blank: ${full.differ} of ${full.total} pixels drawn`);

  // the wireframe toggle shows the quad edges
  const frames = await page.evaluate(() => window.pqmViewer.frames);
  await page.click('#wireframe');
  assert.equal(await page.evaluate(() => window.pqmViewer.wireframe), true);
  await page.waitForFunction((f) => window.pqmViewer.frames > f, frames);
  writeFileSync(path.join(ARTIFACTS, 'view-wireframe.png'), await page.screenshot());
  await page.click('#wireframe');

  // smooth shading (the progressive mesh's normals) is the default; flat
  // shading draws the same surface with other pixels
  assert.equal(s.smooth, true);
  const flatFrames = await page.evaluate(() => window.pqmViewer.frames);
  await page.click('#smooth');
  assert.equal(await page.evaluate(() => window.pqmViewer.smooth), false);
  await page.waitForFunction((f) => window.pqmViewer.frames > f, flatFrames);
  const flat = await drawn('view-flat.png');
  assert.ok(flat.differ / flat.total > MIN_DRAWN, `flat-shaded canvas looks blank: ${flat.differ} of ${flat.total}`);
  const shot = (name) => readFileSync(path.join(ARTIFACTS, name));
  assert.ok(!shot('view-flat.png').equals(shot('view-full-mesh.png')), 'flat and smooth shading draw other pixels');
  await page.click('#smooth');
  assert.equal(await page.evaluate(() => window.pqmViewer.smooth), true);

  // slider to the start (keyboard Home, as a user would): the base mesh
  const frames2 = await page.evaluate(() => window.pqmViewer.frames);
  await page.focus('#level-slider');
  await page.keyboard.press('Home');
  await page.waitForFunction(() => window.pqmViewer.level === 0);
  assert.equal(number(await page.textContent('#faces')), info.base_faces);
  assert.equal(await page.evaluate(() => window.pqmViewer.faces), info.base_faces);
  const baseError = Number((await page.textContent('#error')).split(' ')[0]);
  assert.ok(baseError > 0, 'the base level has a positive error');
  await page.waitForFunction((f) => window.pqmViewer.frames > f, frames2);
  const base = await drawn('view-base.png');
  assert.ok(base.differ / base.total > MIN_DRAWN, `base mesh canvas looks blank: ${base.differ} of ${base.total}`);

  // and back to the end refines again (hiding the panel for the screenshot
  // took the focus away)
  await page.focus('#level-slider');
  await page.keyboard.press('End');
  await page.waitForFunction((n) => window.pqmViewer.faces === n, info.final_faces);

  // level by view: the coarsest level whose error spans at most a pixel;
  // zooming out (the wheel, as a user would) coarsens, zooming in refines
  const viewed = async () => {
    // one more frame after the input so far (rendering is on demand; a
    // resize event asks for one)
    const f = await page.evaluate(() => {
      window.dispatchEvent(new Event('resize'));
      return window.pqmViewer.frames;
    });
    await page.waitForFunction((n) => window.pqmViewer.frames > n, f);
    return page.evaluate(() => ({ ...window.pqmViewer }));
  };
  await page.click('#by-view');
  await page.waitForFunction(() => window.pqmViewer.byView && window.pqmViewer.screenError !== null);
  const framed = await viewed();
  assert.ok(framed.screenError <= 1 || framed.level === framed.levels, `framed: ${framed.screenError} px at level ${framed.level}`);
  assert.match(await page.textContent('#screen-error'), / px$/);
  await page.mouse.move(400, 300);
  for (let i = 0; i < 40; i++) await page.mouse.wheel(0, 200);
  const far = await viewed();
  assert.ok(far.level < framed.level, `zooming out coarsens: level ${framed.level} → ${far.level}`);
  assert.ok(far.screenError <= 1, `far: ${far.screenError} px`);
  for (let i = 0; i < 60; i++) await page.mouse.wheel(0, -200);
  const near = await viewed();
  assert.ok(near.level > far.level, `zooming in refines: level ${far.level} → ${near.level}`);
  assert.ok(near.screenError <= 1 || near.level === near.levels, `near: ${near.screenError} px`);
  // the slider takes the level back
  await page.focus('#level-slider');
  await page.keyboard.press('Home');
  await page.waitForFunction(() => window.pqmViewer.level === 0 && !window.pqmViewer.byView);
  assert.equal(await page.isChecked('#by-view'), false);
  assert.deepEqual(pageErrors, []);
});

test('over a slow link the page refines while the file streams', { timeout: 240_000 }, async (t) => {
  // The same mesh in small chunks (≈ 2 KiB of records each, about ten of
  // them) at 16 KiB/s: about 1.3 s of streaming. With the default two
  // chunks a loaded machine could deliver both in one read and show no
  // intermediate level, which is not what this test is about.
  const small = path.join(tmp.dir, 'spot-small-chunks.pqm');
  runPqm(pqm, ['-q', 'encode', path.join(SHARED_MESHES, 'quad', 'spot_quadrangulated.obj'), '-o', small, '--chunk-bytes', '2048']);
  const info = JSON.parse(runPqm(pqm, ['--json', 'info', small])); // this file's, not the shared one
  assert.ok(info.chunks >= 6, `only ${info.chunks} chunks`);
  const server = await startView(pqm, small, ['--throttle', '16']);
  t.after(server.stop);
  const { state } = await openViewer(t, server);
  const tl = state.timeline;
  assert.ok(tl.length >= 3, `only ${tl.length} level changes while streaming`);
  assert.equal(tl[0].faces, info.base_faces, 'the base mesh is shown first');
  assert.equal(tl[0].level, 0);
  assert.ok(tl[0].bytes < info.file_bytes / 2, `the base mesh waited for ${tl[0].bytes} bytes`);
  for (let i = 1; i < tl.length; i++) {
    assert.ok(tl[i].level > tl[i - 1].level, 'levels only go up while following the stream');
    assert.ok(tl[i].faces >= tl[i - 1].faces);
  }
  assert.ok(
    tl.some((e) => e.faces > info.base_faces && e.faces < info.final_faces && e.bytes < info.file_bytes),
    'an intermediate level was shown before the file ended',
  );
  assert.equal(tl[tl.length - 1].faces, info.final_faces);
  assert.ok(state.firstPixelsMs < state.fullMs, 'first pixels came before the full mesh');
});

test('by view, the page asks only for the bytes the view needs (HTTP Range)', { timeout: 240_000 }, async (t) => {
  // many small chunks, so that a level between the base and the finest
  // ends well before the file does
  const small = path.join(tmp.dir, 'spot-by-view.pqm');
  runPqm(pqm, ['-q', 'encode', path.join(SHARED_MESHES, 'quad', 'spot_quadrangulated.obj'), '-o', small, '--chunk-bytes', '1024', '--chunk-growth', '0']);
  const info = JSON.parse(runPqm(pqm, ['--json', 'info', small]));
  const server = await startView(pqm, small);
  t.after(server.stop);
  const settled = () => {
    const s = window.pqmViewer;
    return s.screenError !== null && !s.fetching && (s.screenError <= s.maxScreenError || s.level === s.levels);
  };
  // 8 pixels: with the measured errors `pqm encode` writes, a level near
  // the middle of the file (the coarsener's bounds would need every
  // record at 8 px; at 48 px the first 4 KiB request would already do)
  const { page, state: s1, problems } = await openViewer(t, server, '?view=8', settled);
  assert.equal(s1.mode, 'view');
  assert.equal(s1.byView, true);
  assert.ok(s1.screenError <= 8, `${s1.screenError} px`);
  assert.ok(s1.level > 0 && s1.level < s1.levels, `level ${s1.level} of ${s1.levels}`);
  assert.ok(s1.bytes < info.file_bytes, `${s1.bytes} of ${info.file_bytes} bytes fetched for level ${s1.level}`);
  assert.ok(s1.requests >= 2, `${s1.requests} requests`);
  // zooming in asks for a finer level: one more request, more bytes
  await page.mouse.move(500, 400); // on the canvas, clear of the panel
  for (let i = 0; i < 30; i++) await page.mouse.wheel(0, -200);
  await page.evaluate(() => window.dispatchEvent(new Event('resize')));
  await page.waitForFunction(`(${settled})() && window.pqmViewer.requests > ${s1.requests}`, null, { timeout: 60_000 });
  const s2 = await page.evaluate(() => ({ ...window.pqmViewer }));
  assert.ok(s2.level > s1.level, `zooming in refines: ${s1.level} → ${s2.level}`);
  assert.ok(s2.bytes > s1.bytes && s2.bytes <= info.file_bytes, `${s1.bytes} → ${s2.bytes} bytes`);
  assert.ok(s2.screenError <= 8 || s2.level === s2.levels, `${s2.screenError} px`);
  assert.deepEqual(problems, []);
});
