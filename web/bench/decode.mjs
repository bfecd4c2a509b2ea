// Decode throughput of pqm-decoder in node: faces reconstructed per second,
// zstd included (push the whole file, then go to the finest level), on the
// biggest .pqm available — bench/data/*.pqm (written by tools/make-pqm, see
// README) or else the test files.
//
//   node bench/decode.mjs [FILE.pqm ...] [--runs N]
import { readFileSync, readdirSync, existsSync, statSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { PqmDecoder } from '../pqm-decoder/src/index.js';
import { decompressFrame } from '../pqm-decoder/src/zstd.js';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const runsAt = args.indexOf('--runs');
const runs = runsAt >= 0 ? Number(args.splice(runsAt, 2)[1]) : 7;
let files = args;
if (files.length === 0) {
  const dirs = [path.join(here, 'data'), path.join(here, '../pqm-decoder/test/data'), path.join(here, '../../spec/vectors')];
  const all = dirs.filter(existsSync).flatMap((d) => readdirSync(d).filter((f) => f.endsWith('.pqm')).map((f) => path.join(d, f)));
  all.sort((a, b) => statSync(b).size - statSync(a).size);
  files = all.slice(0, 1);
}

const median = (xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];

for (const file of files) {
  const bytes = new Uint8Array(readFileSync(file));
  let faces = 0;
  let info = '';
  const wall = [];
  const cpu = [];
  const zstd = [];
  const stream = [];
  for (let r = 0; r < runs + 1; r++) {
    const c0 = process.cpuUsage();
    const t0 = performance.now();
    const d = new PqmDecoder();
    d.push(bytes);
    d.setLevel({ level: d.deepestLevel });
    const t1 = performance.now();
    const c1 = process.cpuUsage(c0);
    faces = d.faceCount;
    info = `${d.header.baseFaceCount} → ${d.faceCount} faces, ${d.header.recordCount} records, ${d.header.chunkCount} chunks`;
    // zstd alone: every chunk's frame
    const t2 = performance.now();
    for (const c of d.chunks) decompressFrame(bytes.subarray(c.offset, c.end), c.uncompressedLen);
    const t3 = performance.now();
    // streamed in 64 KiB pieces
    const t4 = performance.now();
    const s = new PqmDecoder();
    for (let o = 0; o < bytes.length; o += 65536) s.push(bytes.subarray(o, o + 65536));
    s.setLevel({ level: s.deepestLevel });
    const t5 = performance.now();
    if (r === 0) continue; // warm-up
    wall.push(t1 - t0);
    cpu.push((c1.user + c1.system) / 1000);
    zstd.push(t3 - t2);
    stream.push(t5 - t4);
  }
  const w = median(wall);
  console.log(`${path.relative(process.cwd(), file)}: ${(bytes.length / 1024).toFixed(0)} KiB, ${info}`);
  console.log(`  decode + refine to the finest level: ${w.toFixed(1)} ms (median of ${runs}; CPU ${median(cpu).toFixed(1)} ms)`);
  console.log(`  ${((faces / w) * 1000 / 1e6).toFixed(2)} million faces/s wall (${((faces / median(cpu)) * 1000 / 1e6).toFixed(2)} million/s CPU), zstd alone ${median(zstd).toFixed(1)} ms`);
  console.log(`  pushed in 64 KiB pieces: ${median(stream).toFixed(1)} ms`);
}
