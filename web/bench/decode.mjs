// Decode throughput of pqm-decoder in node: faces reconstructed per second,
// zstd included (push the whole file into a new decoder, then go to the
// finest level: positions and triangle indices ready), on the biggest .pqm
// available — bench/data/*.pqm (written by `bash bench/make-data.sh` or
// tools/make-pqm, see README) or else the test files — with where the time
// goes: zstd (every frame), CRC-32 (every section), the records
// (the rest of the push) and the move to the finest level.
//
//   node bench/decode.mjs [FILE.pqm ...] [--runs N] [--cold N] [--forward] [--reuse]
//
// --forward: the one-way decoder (`forwardOnly: true`).
// --reuse: every warm decode of a file (warm-up, timed, 64 KiB pieces) in
// one decoder, `reset(options)` before each (timed with the push), instead
// of a new decoder each: the next file decoded into the previous one's
// arrays, as a client decoding asset after asset would. The cold figure is
// a fresh process's first decode either way. Compare runs with and without
// it in separate processes, alternating (a shared machine drifts).
//
// Warm (steady state): medians over --runs runs after warm-up runs (at
// least 3, and until 1 s of CPU however many runs that takes, see
// ab-common.mjs's WARM_UP_MS: a small file decodes in a few ms, far from
// enough for the JIT's optimizing tier after one run), as CPU time (process.cpuUsage: what this process used,
// so other processes on a busy machine count less) and as wall time.
// Cold: the first decode in a fresh node process (the decoder's module
// loaded, nothing run yet: interpreter and baseline tiers, a new heap) —
// what a page that decodes one file sees —, median of --cold N processes
// (default 3, 0 to skip). faces = quads of the finest level.
import { readFileSync, readdirSync, existsSync, statSync } from 'node:fs';
import { freshProcesses, warmUp } from './ab-common.mjs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { PqmDecoder, crc32 } from '../pqm-decoder/src/index.js';
import { decompressFrame } from '../pqm-decoder/src/zstd.js';

const here = path.dirname(fileURLToPath(import.meta.url));
const self = fileURLToPath(import.meta.url);
const args = process.argv.slice(2);
if (args.includes('--help') || args.includes('-h')) {
  // the header comment above is the manual
  const text = readFileSync(self, 'utf8').split('\n');
  const end = text.findIndex((l) => !l.startsWith('//'));
  console.log(text.slice(0, end).map((l) => l.replace(/^\/\/ ?/, '')).join('\n'));
  process.exit(0);
}
if (args[0] === '--cold-child') {
  // child: --cold-child FILE FORWARD — one decode in this fresh process
  const bytes = new Uint8Array(readFileSync(args[1]));
  const c0 = process.cpuUsage();
  const t0 = performance.now();
  const d = new PqmDecoder(args[2] === '1' ? { forwardOnly: true } : {});
  d.push(bytes);
  d.setLevel({ level: d.deepestLevel });
  const wall = performance.now() - t0;
  const c = process.cpuUsage(c0);
  console.log(JSON.stringify({ faces: d.faceCount, cpu: (c.user + c.system) / 1000, wall }));
  process.exit(0);
}
const runsAt = args.indexOf('--runs');
const runs = runsAt >= 0 ? Number(args.splice(runsAt, 2)[1]) : 7;
const coldAt = args.indexOf('--cold');
const coldRuns = coldAt >= 0 ? Number(args.splice(coldAt, 2)[1]) : 3;
const forwardAt = args.indexOf('--forward');
const options = forwardAt >= 0 && args.splice(forwardAt, 1).length > 0 ? { forwardOnly: true } : {};
const reuseAt = args.indexOf('--reuse');
const reuse = reuseAt >= 0 && args.splice(reuseAt, 1).length > 0;
let files = args;
if (files.length === 0) {
  const dirs = [path.join(here, 'data'), path.join(here, '../pqm-decoder/test/data'), path.join(here, '../../spec/vectors')];
  const all = dirs.filter(existsSync).flatMap((d) => readdirSync(d).filter((f) => f.endsWith('.pqm')).map((f) => path.join(d, f)));
  all.sort((a, b) => statSync(b).size - statSync(a).size);
  files = all.slice(0, 1);
}

const median = (xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];
const cpuMs = (c) => (c.user + c.system) / 1000;

/** CPU and wall milliseconds of fn(). */
function measure(fn) {
  const c0 = process.cpuUsage();
  const t0 = performance.now();
  fn();
  return { wall: performance.now() - t0, cpu: cpuMs(process.cpuUsage(c0)) };
}

const summary = [];
for (const file of files) {
  // cold first, in fresh processes, before this process warms anything
  const cold = freshProcesses(self, ['--cold-child', file, options.forwardOnly ? '1' : '0'], coldRuns);
  const bytes = new Uint8Array(readFileSync(file));
  const probe = new PqmDecoder();
  probe.push(bytes);
  const h = probe.header;
  const sections = [[h.headerLen + h.chunkCount * h.chunkEntryLen + 4, h.baseCompressedLen, h.baseUncompressedLen]];
  for (const c of probe.chunks) sections.push([c.offset, c.compressedLen, c.uncompressedLen]);
  const uncompressed = sections.reduce((s, x) => s + x[2], 0);
  let faces = 0;
  const m = { total: [], totalWall: [], push: [], level: [], zstd: [], crc: [], pieces: [] };
  // The timed decodes run back to back (nothing else allocating between
  // them), so the collections their garbage triggers land in them, as in
  // any process that decodes file after file; zstd, CRC-32 and the
  // 64 KiB-pieces decode are timed in loops of their own afterwards (when
  // they ran between the timed decodes, a major GC fell outside the timed
  // part every other run: bunny read 2.19 M faces/s instead of 1.84).
  // --reuse: one decoder per file, reset before each decode
  let kept = null;
  const decoder = () => {
    if (!reuse) return new PqmDecoder(options);
    if (kept === null) kept = new PqmDecoder(options);
    else kept.reset(options);
    return kept;
  };
  const decodeOnce = () => {
    let d = null;
    const push = measure(() => {
      d = decoder();
      d.push(bytes);
    });
    const level = measure(() => d.setLevel({ level: d.deepestLevel }));
    faces = d.faceCount;
    return { push, level };
  };
  warmUp(decodeOnce);
  // minor page faults of the timed decodes: fresh pages from the kernel,
  // ≈ 3 µs each on this VM, whose count depends on glibc's state more
  // than on the decoder (README, sessions 11 and 12)
  const pf0 = process.resourceUsage().minorPageFault;
  for (let r = 0; r < runs; r++) {
    const { push, level } = decodeOnce();
    m.total.push(push.cpu + level.cpu);
    m.totalWall.push(push.wall + level.wall);
    m.push.push(push.cpu);
    m.level.push(level.cpu);
  }
  const faults = (process.resourceUsage().minorPageFault - pf0) / runs;
  for (let r = 0; r < runs; r++) {
    m.zstd.push(
      measure(() => {
        for (const [o, n, u] of sections) decompressFrame(bytes.subarray(o, o + n), u);
      }).cpu,
    );
    m.crc.push(
      measure(() => {
        for (const [o, n] of sections) crc32(bytes, o, o + n);
      }).cpu,
    );
  }
  for (let r = 0; r < runs; r++) {
    m.pieces.push(
      measure(() => {
        const s = decoder();
        for (let o = 0; o < bytes.length; o += 65536) s.push(bytes.subarray(o, o + 65536));
        s.setLevel({ level: s.deepestLevel });
      }).wall,
    );
  }
  const cpu = median(m.total);
  const mean = m.total.reduce((a, b) => a + b, 0) / m.total.length;
  const wall = median(m.totalWall);
  const zstd = median(m.zstd);
  const crc = median(m.crc);
  const push = median(m.push);
  const pct = (x) => `${((100 * x) / cpu).toFixed(0)} %`;
  const mfs = (ms) => ((faces / ms) * 1000) / 1e6;
  console.log(
    `${path.relative(process.cwd(), file)}${options.forwardOnly ? ' (forward-only)' : ''}${reuse ? ' (one decoder, reset)' : ''}: ${(bytes.length / 1024).toFixed(0)} KiB (${(uncompressed / 1024).toFixed(0)} KiB uncompressed), ` +
      `${h.baseFaceCount} → ${faces} faces, ${h.recordCount} records, ${h.chunkCount} chunks`,
  );
  console.log(
    `  decode + refine to the finest level: ${cpu.toFixed(1)} ms CPU = ${mfs(cpu).toFixed(2)} million faces/s ` +
      `(wall ${wall.toFixed(1)} ms = ${mfs(wall).toFixed(2)} M/s; medians of ${runs}; CPU mean ${mean.toFixed(1)} ms = ${mfs(mean).toFixed(2)} M/s)`,
  );
  console.log(
    `  push ${push.toFixed(1)} ms: zstd ${zstd.toFixed(1)} ms (${pct(zstd)}, ${(uncompressed / 1e3 / zstd).toFixed(0)} MB/s out), ` +
      `CRC ${crc.toFixed(1)} ms (${pct(crc)}), records ${(push - zstd - crc).toFixed(1)} ms (${pct(push - zstd - crc)}); ` +
      `level move ${median(m.level).toFixed(1)} ms (${pct(median(m.level))})`,
  );
  if (cold.length > 0) {
    const cc = median(cold.map((x) => x.cpu));
    const cw = median(cold.map((x) => x.wall));
    console.log(
      `  cold (first decode in a fresh process, median of ${cold.length}): ${cc.toFixed(1)} ms CPU = ${mfs(cc).toFixed(2)} million faces/s ` +
        `(wall ${cw.toFixed(1)} ms = ${mfs(cw).toFixed(2)} M/s; ${(cc / cpu).toFixed(1)}× the warm time)`,
    );
  }
  console.log(`  without zstd: ${mfs(cpu - zstd).toFixed(2)} million faces/s CPU`);
  console.log(`  pushed in 64 KiB pieces: ${median(m.pieces).toFixed(1)} ms wall`);
  const cc = cold.length > 0 ? median(cold.map((x) => x.cpu)) : NaN;
  summary.push([path.basename(file, '.pqm'), String(faces), mfs(cpu), Math.min(...m.total), mfs(mean), mfs(cc), 100 * (zstd / cpu), 100 * (median(m.level) / cpu), faults]);
}
// one row per file: warm (median, best, mean of the back-to-back decodes)
// and cold, million faces/s by CPU time
const f2 = (x) => (Number.isFinite(x) ? x.toFixed(2) : '–');
const head = ['mesh', 'faces', 'warm median', 'warm best', 'warm mean', 'cold', 'zstd %', 'level move %', 'page faults / decode'];
console.log(`\n${options.forwardOnly ? 'forward-only' : 'general'} decoder${reuse ? ' (warm: one decoder, reset before each decode)' : ''}, million faces/s by CPU time (node ${process.version}; warm: ${runs} runs after ≥ 1 s of warm-up; cold: first decode in a fresh process, median of ${coldRuns})`);
console.log(`| ${head.join(' | ')} |`);
console.log(`|${head.map(() => '---').join('|')}|`);
for (const [name, faces, med, best, mean, cold, z, l, pf] of summary) {
  const mf = (ms) => (Number(faces) / ms / 1e3);
  console.log(`| ${name} | ${faces} | ${f2(med)} | ${f2(mf(best))} | ${f2(mean)} | ${f2(cold)} | ${z.toFixed(0)} | ${l.toFixed(0)} | ${pf.toFixed(0)} |`);
}
