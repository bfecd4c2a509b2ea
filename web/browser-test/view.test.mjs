// `pqm view` in a real browser (Debian chromium driven by playwright-core):
// a real shared mesh is encoded, served, streamed into the page and drawn.
// Fails (never skips) when chromium or the pqm binary is missing, with a
// message saying how to get them.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, mkdirSync, writeFileSync } from 'node:fs';
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

test('pqm view streams a real mesh to its full level, draws it, and the slider coarsens to the base', { timeout: 240_000 }, async (t) => {
  findChromium(); // fail first, and clearly, when the browser is missing
  const pqm = findPqm();
  const mesh = path.join(SHARED_MESHES, 'quad', 'spot_quadrangulated.obj');
  assert.ok(existsSync(mesh), `shared mesh missing: ${mesh} (set PQM_SHARED_MESHES)`);

  const tmp = tempDir('pqm-view-test-');
  t.after(tmp.remove);
  const file = path.join(tmp.dir, 'spot.pqm');
  runPqm(pqm, ['-q', 'encode', mesh, '-o', file]);
  const info = JSON.parse(runPqm(pqm, ['--json', 'info', file]));
  assert.ok(info.final_faces > info.base_faces, 'the file refines');

  const server = await startView(pqm, file);
  t.after(server.stop);
  const browser = await launchChromium();
  t.after(() => browser.close());
  const page = await browser.newPage({ viewport: { width: 800, height: 600 } });
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  page.on('requestfailed', (r) => pageErrors.push(`request failed: ${r.url()}`));
  // Offline: nothing but the local server may be asked for anything.
  const origin = new URL(server.url).origin;
  page.on('request', (r) => {
    if (!r.url().startsWith(origin) && !r.url().startsWith('data:')) pageErrors.push(`external request: ${r.url()}`);
  });

  await page.goto(server.url);
  await page.waitForFunction(() => window.pqmViewer && (window.pqmViewer.failed || window.pqmViewer.fullMs !== null), null, {
    timeout: 120_000,
  });
  const s = await page.evaluate(() => ({ ...window.pqmViewer }));
  assert.equal(s.failed, null, `the page failed: ${s.failed}`);
  assert.deepEqual(pageErrors, []);

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

  // slider to the start (keyboard Home, as a user would): the base mesh
  const frames2 = await page.evaluate(() => window.pqmViewer.frames);
  await page.focus('#level-slider');
  await page.keyboard.press('Home');
  await page.waitForFunction(() => window.pqmViewer.level === 0);
  assert.equal(number(await page.textContent('#faces')), info.base_faces);
  assert.equal(await page.evaluate(() => window.pqmViewer.faces), info.base_faces);
  const baseError = Number((await page.textContent('#error')).split(' ')[0]);
  assert.ok(baseError > 0, 'the base level has a positive error bound');
  await page.waitForFunction((f) => window.pqmViewer.frames > f, frames2);
  const base = await drawn('view-base.png');
  assert.ok(base.differ / base.total > MIN_DRAWN, `base mesh canvas looks blank: ${base.differ} of ${base.total}`);

  // and back to the end refines again (hiding the panel for the screenshot
  // took the focus away)
  await page.focus('#level-slider');
  await page.keyboard.press('End');
  await page.waitForFunction((n) => window.pqmViewer.faces === n, info.final_faces);
  assert.deepEqual(pageErrors, []);
});
