// A/B decode speed of two pqm-decoder source trees in *separate processes*,
// alternating A, B, A, B, … for --rounds rounds: each process loads one
// tree, warms up (at least 3 runs and 1 s of CPU) and reports the median
// and minimum CPU time (process.cpuUsage) of --runs whole-file decodes to
// the finest level. In one process (bench/ab.mjs) both trees share one heap
// and one JIT, so one tree's garbage, page reuse and deopts land on the
// other's runs; here they do not, and the load drift is shared by the
// alternation. Prints per file the median over rounds of the per-process
// medians and the minimum of the minima, as million faces/s, and B / A.
//
// --verbose also prints each process's median and its minor page faults
// per decode (fresh pages from the kernel: see README, session 11).
//
//   node bench/ab-proc.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N] [--rounds R] [--forward | --forward-both] [--verbose]
import { execFileSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { abArgs, median, takeNumber, timeDecode, warmUp } from './ab-common.mjs';

const args = process.argv.slice(2);
if (args[0] === '--child') {
  // child: --child SRC_DIR FILE RUNS FORWARD
  const [, dir, file, runsArg, fwd] = args;
  const { PqmDecoder } = await import(pathToFileURL(path.join(dir, 'index.js')).href);
  const bytes = new Uint8Array(readFileSync(file));
  // A push-only decode first, as bench/decode.mjs's probe: without it
  // most of these processes decoded the small files with ≈ 600–800 fresh
  // pages from the kernel per decode (glibc returning and re-mapping the
  // freed arrays' memory, ≈ 3 µs a page on this VM; README, sessions 11
  // and 12), with it ≈ 0–300: makehuman's per-process medians went from
  // 1.35–2.02 to 2.34–2.57 M faces/s, same code and window.
  new PqmDecoder().push(bytes);
  let faces = 0;
  const run = () => {
    const r = timeDecode(PqmDecoder, bytes, fwd === '1');
    faces = r.faces;
    return r.ms;
  };
  warmUp(run);
  const t = [];
  // minor page faults: fresh pages from the kernel (README, session 11)
  const pf0 = process.resourceUsage().minorPageFault;
  for (let r = 0; r < Number(runsArg); r++) t.push(run());
  const faults = (process.resourceUsage().minorPageFault - pf0) / Number(runsArg);
  t.sort((a, b) => a - b);
  console.log(JSON.stringify({ faces, median: t[t.length >> 1], min: t[0], faults }));
  process.exit(0);
}
const runs = takeNumber(args, '--runs', 11);
const rounds = takeNumber(args, '--rounds', 6);
const verboseAt = args.indexOf('--verbose');
const verbose = verboseAt >= 0 && args.splice(verboseAt, 1).length > 0;
const { forward, forwardBoth, dirs } = abArgs(args, 'node bench/ab-proc.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N] [--rounds R] [--forward | --forward-both]');
const self = fileURLToPath(import.meta.url);
for (const file of args) {
  const med = [[], []];
  const min = [[], []];
  const faults = [[], []];
  let faces = 0;
  for (let r = 0; r < rounds; r++) {
    for (let k = 0; k < 2; k++) {
      const fwd = forward && (k === 1 || forwardBoth) ? '1' : '0';
      const out = JSON.parse(execFileSync(process.execPath, [self, '--child', dirs[k], file, String(runs), fwd], { encoding: 'utf8' }));
      faces = out.faces;
      med[k].push(out.median);
      min[k].push(out.min);
      faults[k].push(out.faults);
    }
  }
  const [a, b] = med.map(median);
  const [ma, mb] = min.map((x) => Math.min(...x));
  const mfs = (ms) => (faces / ms / 1e3).toFixed(2);
  console.log(
    `${path.basename(file)}: ${faces} faces; A ${mfs(a)} M faces/s, B ${mfs(b)} M faces/s, B / A ${(b / a).toFixed(3)} ` +
      `(median of ${rounds} process medians of ${runs}); minima A ${mfs(ma)}, B ${mfs(mb)}, B / A ${(mb / ma).toFixed(3)}`,
  );
  if (verbose) {
    // per process: median M faces/s and minor page faults per decode
    for (let k = 0; k < 2; k++) {
      console.log(`  ${'AB'[k]}: ${med[k].map((m, r) => `${mfs(m)}/${faults[k][r].toFixed(0)}`).join(' ')}`);
    }
  }
}
