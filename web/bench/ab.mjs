// A/B decode speed of two pqm-decoder source trees in one process: runs
// alternate (A, B, A, B, …) so that both see the same machine load — on a
// shared VM the load drifts by more than most changes are worth, and two
// separate `bench/decode.mjs` runs minutes apart cannot tell 5 % apart.
//
//   node bench/ab.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N] [--pairs] [--forward | --forward-both]
//
// SRC_DIR is a copy of pqm-decoder/src (e.g. `git archive` of an older
// commit, with `fzstd` resolvable from it); NEW_SRC_DIR defaults to this
// checkout's. Per file: the median CPU time (process.cpuUsage) of "push the
// whole file into a new decoder and go to the finest level" over N runs
// after warm-up runs (at least 3 and 1 s of CPU per tree), as million
// faces/s, and B / A (below 1: B is faster); the same for the minima, which
// drift less than medians on a loaded machine. Both trees must read the
// file's version; with --pairs the files come in pairs (A's, then B's),
// e.g. a mesh as a 2.0 file for an old tree and as a 3.0 file for this one;
// with --forward B's decoder is one-way (`forwardOnly: true`), with
// --forward-both both are.
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { abArgs, median, takeNumber, timeDecode, warmUp } from './ab-common.mjs';

const args = process.argv.slice(2);
const runs = takeNumber(args, '--runs', 7);
// --forward: B decodes with `forwardOnly: true` (A stays the general decoder);
// --forward-both: both do (an old forward-only decoder against this one)
const { forward, forwardBoth, dirs } = abArgs(args, 'node bench/ab.mjs OLD_SRC_DIR [NEW_SRC_DIR] FILE.pqm ... [--runs N] [--pairs] [--forward | --forward-both]');
const trees = await Promise.all(dirs.map((d) => import(pathToFileURL(path.join(d, 'index.js')).href)));

// --pairs: the files come in pairs, A's file then B's (e.g. the same mesh
// as a 2.0 file for an old tree and a 3.0 file for the new one)
const pairsAt = args.indexOf('--pairs');
const pairs = pairsAt >= 0 && args.splice(pairsAt, 1).length > 0;
if (pairs && args.length % 2 !== 0) {
  console.error('--pairs needs an even number of files');
  process.exit(2);
}
const jobs = pairs ? args.filter((_, i) => i % 2 === 0).map((f, i) => [f, args[2 * i + 1]]) : args.map((f) => [f, f]);

for (const files of jobs) {
  const bytes = files.map((f) => new Uint8Array(readFileSync(f)));
  const t = [[], []];
  const faces = [0, 0];
  const run = (k) => {
    const r = timeDecode(trees[k].PqmDecoder, bytes[k], forward && (k === 1 || forwardBoth));
    faces[k] = r.faces;
    return r.ms;
  };
  // warm-up: each tree on its own
  for (let k = 0; k < 2; k++) warmUp(() => run(k));
  for (let r = 0; r < runs; r++) for (let k = 0; k < 2; k++) t[k].push(run(k));
  const [a, b] = t.map(median);
  const [ma, mb] = t.map((x) => Math.min(...x));
  const mfs = (k, ms) => (faces[k] / ms / 1e3).toFixed(2);
  const name = files[0] === files[1] ? path.basename(files[0]) : `${path.basename(files[0])} / ${path.basename(files[1])}`;
  console.log(
    `${name}: ${faces[1]} faces; A ${a.toFixed(1)} ms = ${mfs(0, a)} M faces/s, B ${b.toFixed(1)} ms = ${mfs(1, b)} M faces/s; ` +
      `B / A ${(b / a).toFixed(3)} (CPU medians of ${runs}); minima A ${mfs(0, ma)}, B ${mfs(1, mb)} M faces/s, B / A ${(mb / ma).toFixed(3)}`,
  );
}
