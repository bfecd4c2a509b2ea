// The checked-in viewer bundle (web/viewer/dist, embedded by `pqm view`)
// must be what the sources build to today.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import { fileURLToPath } from 'node:url';
import path from 'node:path';
import { buildViewer } from '../build.mjs';

const dist = path.join(path.dirname(fileURLToPath(import.meta.url)), '..', 'dist');

test('web/viewer/dist is up to date with web/viewer/src (run `npm run build:viewer --prefix web`)', async () => {
  const built = await buildViewer();
  for (const [name, text] of Object.entries(built)) {
    const checkedIn = await readFile(path.join(dist, name), 'utf8').catch(() => null);
    assert.ok(checkedIn !== null, `web/viewer/dist/${name} is missing: run \`npm run build:viewer --prefix web\``);
    assert.ok(
      checkedIn === text,
      `web/viewer/dist/${name} is stale (${checkedIn.length} bytes checked in, ${text.length} built): run \`npm run build:viewer --prefix web\` and commit it`,
    );
  }
});

test('the bundle needs no network: no absolute http(s) URLs are loaded', async () => {
  const html = await readFile(path.join(dist, 'index.html'), 'utf8');
  assert.doesNotMatch(html, /<script[^>]+src="https?:/);
  assert.doesNotMatch(html, /<link[^>]+href="https?:/);
  assert.match(html, /<script src="viewer.js">/);
});
