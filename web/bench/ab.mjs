// A/B decode speed of two pqm-decoder source trees in one process: runs
// alternate (A, B, A, B, …) so that both see the same machine load — on a
// shared VM the load drifts by more than most changes are worth, and two
// separate `bench/decode.mjs` runs minutes apart cannot tell 5 % apart.
//
//   node bench/ab.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N]
//
// SRC_DIR is a copy of pqm-decoder/src (e.g. `git archive` of an older
// commit, with `fzstd` resolvable from it); NEW_SRC_DIR defaults to this
// checkout's. Per file: the median CPU time (process.cpuUsage) of "push the
// whole file into a new decoder and go to the finest level" over N runs
// after one warm-up run each, as million faces/s, and B / A (below 1: B is
// faster). Both trees must read the file's version.
import { readFileSync, existsSync, statSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const runsAt = args.indexOf('--runs');
const runs = runsAt >= 0 ? Number(args.splice(runsAt, 2)[1]) : 7;
const dirs = [];
while (args.length && existsSync(args[0]) && statSync(args[0]).isDirectory()) dirs.push(path.resolve(args.shift()));
if (dirs.length === 0 || args.length === 0) {
  console.error('usage: node bench/ab.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N]');
  process.exit(2);
}
if (dirs.length === 1) dirs.push(path.join(here, '../pqm-decoder/src'));
const trees = await Promise.all(dirs.map((d) => import(pathToFileURL(path.join(d, 'index.js')).href)));
const median = (xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];

for (const file of args) {
  const bytes = new Uint8Array(readFileSync(file));
  const t = [[], []];
  let faces = 0;
  for (let r = 0; r <= runs; r++) {
    for (let k = 0; k < 2; k++) {
      const c0 = process.cpuUsage();
      const d = new trees[k].PqmDecoder();
      d.push(bytes);
      d.setLevel({ level: d.deepestLevel });
      const c = process.cpuUsage(c0);
      faces = d.faceCount;
      if (r > 0) t[k].push((c.user + c.system) / 1000);
    }
  }
  const [a, b] = t.map(median);
  const mfs = (ms) => (faces / ms / 1e3).toFixed(2);
  console.log(
    `${path.basename(file)}: ${faces} faces; A ${a.toFixed(1)} ms = ${mfs(a)} M faces/s, B ${b.toFixed(1)} ms = ${mfs(b)} M faces/s; ` +
      `B / A ${(b / a).toFixed(3)} (CPU medians of ${runs})`,
  );
}
