// Decode time of the base section alone (spec §6; the traversal layout of
// §6.1 in a 4.0 file): the decompressed base payload of each file decoded
// again and again by decodeBase (positions and faces into a fresh
// frontier, its rebuild included) — and, if the codec module exports it,
// by decodeTraversal alone —, as CPU time per decode (medians of --runs
// rounds of enough decodes for ~50 ms each, after a warm-up second).
//
//   node bench/base.mjs [FILE.pqm ...] [--runs N] [--src DIR]
//
// --src: a pqm-decoder/src directory to load codec.js from (default this
// tree's), to compare two versions in one machine state.
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { unpack } from '../pqm-decoder/test/repack.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const take = (flag, dflt) => {
  const i = args.indexOf(flag);
  return i >= 0 ? args.splice(i, 2)[1] : dflt;
};
const runs = Number(take('--runs', 11));
const src = take('--src', path.join(here, '../pqm-decoder/src'));
const codec = await import(pathToFileURL(path.join(path.resolve(src), 'codec.js')).href);
const files = args.length ? args : ['makehuman_base', 'loki', 'spot_quadrangulated'].map((f) => path.join(here, 'data', `${f}.pqm`));

const cpu = () => {
  const c = process.cpuUsage();
  return (c.user + c.system) / 1000;
};
const median = (xs) => xs.slice().sort((a, b) => a - b)[xs.length >> 1];

function time(fn) {
  // warm-up: 1 s of CPU
  const w = cpu();
  let k = 0;
  while (cpu() - w < 1000) {
    fn();
    k++;
  }
  const reps = Math.max(1, Math.round((k * 50) / 1000));
  const per = [];
  for (let r = 0; r < runs; r++) {
    const t = cpu();
    for (let i = 0; i < reps; i++) fn();
    per.push((cpu() - t) / reps);
  }
  return median(per);
}

for (const file of files) {
  const bytes = new Uint8Array(readFileSync(file));
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const major = dv.getUint16(4, true);
  const qmax = 2 ** bytes[20] - 1;
  const nv = dv.getUint32(24, true);
  const nf = dv.getUint32(28, true);
  const payload = unpack(bytes).base;
  const line = [`${path.basename(file)}: ${nf} base faces, ${nv} vertices, layout ${major >= 4 ? payload[0] : '-'}`];
  const base = time(() => codec.decodeBase(payload, nv, nf, qmax, nv, nf, major));
  line.push(`decodeBase ${(base * 1000).toFixed(1)} µs (${(nf / base / 1000).toFixed(2)} M faces/s)`);
  if (codec.decodeTraversal && major >= 4 && payload[0] === 1) {
    const st = { q: new Int32Array(16 * nv), f: new Uint32Array(4 * nf) };
    const t = time(() => codec.decodeTraversal(payload, 1, st, nv, nf, qmax));
    line.push(`decodeTraversal ${(t * 1000).toFixed(1)} µs (${(nf / t / 1000).toFixed(2)} M faces/s)`);
  }
  console.log(line.join('; '));
}
