/**
 * Shared by the real-browser test (`view.test.mjs`) and the slow-link
 * benchmark (`../bench/slow-link.mjs`): finding the Debian chromium and the
 * `pqm` binary, starting `pqm view`, launching chromium through
 * `playwright-core`, counting drawn pixels of a screenshot.
 *
 * Never a downloaded browser build: chromium is the distribution's
 * `/usr/bin/chromium` (installed by `scripts/install-browser.sh`, which
 * `scripts/test-all.sh` runs), or `$PQM_CHROMIUM`.
 */
import { spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { createInterface } from 'node:readline';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

/** The repository root (web/..). */
export const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');

/** Where tests leave artefacts (screenshots): `target/test-artifacts/` (gitignored). */
export const ARTIFACTS = path.join(process.env.CARGO_TARGET_DIR || path.join(REPO, 'target'), 'test-artifacts');

/** The shared real meshes: `../shared/meshes` beside the repository (as in CI), or `$PQM_SHARED_MESHES`. */
export const SHARED_MESHES = process.env.PQM_SHARED_MESHES || path.join(REPO, '..', 'shared', 'meshes');

/** The chromium executable, or an Error saying how to install it. */
export function findChromium() {
  const exe = process.env.PQM_CHROMIUM || '/usr/bin/chromium';
  if (!existsSync(exe)) {
    throw new Error(
      `chromium not found at ${exe}: install the Debian package with scripts/install-browser.sh ` +
        '(apt-get install -y chromium; scripts/test-all.sh does it) or set PQM_CHROMIUM',
    );
  }
  return exe;
}

/**
 * The `pqm` binary: `$PQM_BIN`, else `target/<profile>/pqm` (`debug` unless
 * `profile` says otherwise). Checks that it has the `view` command, so a stale
 * binary fails clearly instead of timing out.
 */
export function findPqm(profile = 'debug') {
  const target = process.env.CARGO_TARGET_DIR || path.join(REPO, 'target');
  const exe = process.env.PQM_BIN || path.join(target, profile, 'pqm');
  const build = profile === 'release' ? 'cargo build --release -p pqm-cli' : 'cargo build -p pqm-cli';
  if (!existsSync(exe)) {
    throw new Error(`the pqm binary is missing (${exe}): run \`${build}\` first (scripts/test-all.sh builds it), or set PQM_BIN`);
  }
  const help = spawnSync(exe, ['view', '--help'], { encoding: 'utf8' });
  if (help.status !== 0) {
    throw new Error(`${exe} has no working \`view\` command (stale build?): run \`${build}\``);
  }
  return exe;
}

/** Runs `pqm ARGS` to completion; returns stdout, throws with stderr on failure. */
export function runPqm(pqm, args) {
  const r = spawnSync(pqm, args, { encoding: 'utf8', maxBuffer: 64 << 20 });
  if (r.status !== 0) throw new Error(`pqm ${args.join(' ')} failed (exit ${r.status}): ${r.stderr}`);
  return r.stdout;
}

/** A fresh temporary directory, removed by the returned function. */
export function tempDir(prefix) {
  const dir = mkdtempSync(path.join(tmpdir(), prefix));
  return { dir, remove: () => rmSync(dir, { recursive: true, force: true }) };
}

/**
 * Starts `pqm view FILE --port 0 --json ...extra` and resolves with
 * `{url, stop}` once it printed its URL.
 */
export function startView(pqm, file, extra = []) {
  const child = spawn(pqm, ['--json', 'view', file, '--port', '0', ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
  let stderr = '';
  child.stderr.on('data', (d) => {
    stderr += d;
  });
  return new Promise((resolve, reject) => {
    const lines = createInterface({ input: child.stdout });
    const timer = setTimeout(() => {
      child.kill();
      reject(new Error(`pqm view printed no URL within 30 s: ${stderr}`));
    }, 30000);
    child.on('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`pqm view exited (${code}) before printing its URL: ${stderr}`));
    });
    lines.once('line', (line) => {
      clearTimeout(timer);
      const { url } = JSON.parse(line);
      const stop = () =>
        new Promise((done) => {
          if (child.exitCode !== null) return done();
          child.once('exit', () => done());
          child.kill();
        });
      resolve({ url, stop });
    });
  });
}

/**
 * Launches headless chromium with flags that work as root on a machine
 * without network or GPU: no sandbox, no background traffic, WebGL through
 * SwiftShader (software), a fresh profile directory.
 */
export async function launchChromium() {
  const executablePath = findChromium();
  // playwright-core gives every launch() a fresh temporary profile
  // (--user-data-dir) and removes it on close; it refuses the flag in args.
  return chromium.launch({
    executablePath,
    headless: true,
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
}

/**
 * Counts the pixels of a PNG screenshot that differ from `background`
 * (`[r, g, b]`) by more than `tolerance` in any channel, decoding it in the
 * page (a 2D canvas), so no PNG library is needed. Returns `{differ, total}`.
 */
export async function countDrawnPixels(page, png, background, tolerance = 24) {
  return page.evaluate(
    async ({ b64, bg, tol }) => {
      const img = new Image();
      img.src = `data:image/png;base64,${b64}`;
      await img.decode();
      const c = document.createElement('canvas');
      c.width = img.width;
      c.height = img.height;
      const g = c.getContext('2d');
      g.drawImage(img, 0, 0);
      const d = g.getImageData(0, 0, c.width, c.height).data;
      let differ = 0;
      for (let i = 0; i < d.length; i += 4) {
        if (Math.abs(d[i] - bg[0]) > tol || Math.abs(d[i + 1] - bg[1]) > tol || Math.abs(d[i + 2] - bg[2]) > tol) differ++;
      }
      return { differ, total: d.length / 4 };
    },
    { b64: png.toString('base64'), bg: background, tol: tolerance },
  );
}
