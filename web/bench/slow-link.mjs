// Slow-link benchmark (not a test): time until a mesh is on screen when it
// comes over a slow link, progressive .pqm against the same mesh as a plain
// GLB. Both are served by `pqm view --throttle KIB_PER_S` (the GLB through
// `--compare`, same throttle, same page, camera and material) and loaded in
// headless Debian chromium: the .pqm streamed with fetch + ReadableStream
// into pqm-three, the GLB with three's GLTFLoader.
//
//   npm run bench:slow-link --prefix web -- [--throttle 32,128] [--runs 3] [--mesh FILE.obj]
//
// Default mesh: ../shared/meshes/quad/spot_quadrangulated.obj. The GLB is
// `pqm decode FILE.pqm -o x.glb` (the finest level: the same surface the
// .pqm ends at). Times are milliseconds from the start of the mesh request
// (resource timing), median of the runs; "mesh requested at" is that start
// since navigation (the page and its script are served unthrottled, the
// same for both). "first pixels" = first frame with the mesh drawn (the base mesh
// for .pqm); "full" = first frame at the finest level. Uses
// target/release/pqm when built (else target/debug/pqm, or $PQM_BIN).
import { statSync } from 'node:fs';
import path from 'node:path';
import { SHARED_MESHES, findPqm, launchChromium, runPqm, startView, tempDir } from '../browser-test/harness.mjs';

const args = process.argv.slice(2);
const opt = (name, dflt) => {
  const i = args.indexOf(name);
  return i >= 0 ? args[i + 1] : dflt;
};
const throttles = opt('--throttle', '32,128').split(',').map(Number);
const runs = Number(opt('--runs', '3'));
const mesh = opt('--mesh', path.join(SHARED_MESHES, 'quad', 'spot_quadrangulated.obj'));

let pqm;
try {
  pqm = findPqm('release');
} catch {
  pqm = findPqm('debug');
}
const median = (xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];
const fmt = (n) => Math.round(n).toLocaleString('en-US');

const tmp = tempDir('pqm-slow-link-');
const file = path.join(tmp.dir, 'mesh.pqm');
const glb = path.join(tmp.dir, 'mesh.glb');
runPqm(pqm, ['-q', 'encode', mesh, '-o', file]);
runPqm(pqm, ['-q', 'decode', file, '-o', glb]);
const info = JSON.parse(runPqm(pqm, ['--json', 'info', file]));
const baseBytes = info.levels[0].bytes;

console.log(`mesh: ${mesh}`);
console.log(
  `.pqm ${fmt(statSync(file).size)} bytes (base mesh ${fmt(info.base_faces)} quads in the first ${fmt(baseBytes)} bytes, ` +
    `full ${fmt(info.final_faces)} quads); .glb ${fmt(statSync(glb).size)} bytes (finest level, pqm decode)`,
);
console.log(`binary: ${pqm}; ${runs} run(s) each, median\n`);
console.log('| link (KiB/s) | file | bytes | mesh requested at (ms) | first pixels (ms after request) | full (ms after request) |');
console.log('|---|---|---|---|---|---|');

const browser = await launchChromium();
const ratios = [];
try {
  for (const kib of throttles) {
    const server = await startView(pqm, file, ['--throttle', String(kib), '--compare', glb]);
    try {
      const measure = async (query) => {
        const first = [];
        const full = [];
        const request = [];
        let bytes = 0;
        for (let r = 0; r < runs; r++) {
          const context = await browser.newContext({ viewport: { width: 800, height: 600 } });
          const page = await context.newPage();
          await page.goto(server.url + query);
          await page.waitForFunction(() => window.pqmViewer && (window.pqmViewer.failed || window.pqmViewer.fullMs !== null), null, {
            timeout: 600_000,
          });
          const s = await page.evaluate(() => ({
            ...window.pqmViewer,
            // when the mesh request started (after the page and its script loaded)
            requestMs: performance.getEntriesByType('resource').find((e) => /mesh\.pqm|compare\.glb/.test(e.name))?.startTime,
          }));
          await context.close();
          if (s.failed) throw new Error(`${query || 'pqm'}: ${s.failed}`);
          // measured from the mesh request, so page start-up (unthrottled,
          // the same script for both) does not blur the comparison
          first.push(s.firstPixelsMs - s.requestMs);
          full.push(s.fullMs - s.requestMs);
          request.push(s.requestMs);
          bytes = s.bytes;
        }
        return { first: median(first), full: median(full), request: median(request), bytes };
      };
      const p = await measure('');
      const g = await measure('?glb');
      console.log(`| ${kib} | .pqm (progressive) | ${fmt(p.bytes)} | ${fmt(p.request)} | ${fmt(p.first)} | ${fmt(p.full)} |`);
      console.log(`| ${kib} | .glb (GLTFLoader) | ${fmt(g.bytes)} | ${fmt(g.request)} | ${fmt(g.first)} | ${fmt(g.full)} |`);
      ratios.push({ kib, first: g.first / p.first, full: g.full / p.full });
    } finally {
      await server.stop();
    }
  }
} finally {
  await browser.close();
  tmp.remove();
}
console.log('\n| link (KiB/s) | first pixels: glb / pqm | full: glb / pqm |');
console.log('|---|---|---|');
for (const r of ratios) console.log(`| ${r.kib} | ${r.first.toFixed(2)}× | ${r.full.toFixed(2)}× |`);
