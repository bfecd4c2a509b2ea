// What both A/B scripts share (`ab.mjs` in one process, `ab-proc.mjs` in
// separate ones), so that their figures are measured the same way: the
// arguments — `--runs N`, `--forward` (B one-way), `--forward-both` (both
// one-way), then one or two source directories (A, and B = this
// checkout's pqm-decoder/src by default) before the files — and the timed
// decode with its warm-up.
import { execFileSync } from 'node:child_process';
import { existsSync, statSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));

/** Removes `flag N` from `args` and returns N as a number (`dflt` when the flag is absent). */
export function takeNumber(args, flag, dflt) {
  const at = args.indexOf(flag);
  return at >= 0 ? Number(args.splice(at, 2)[1]) : dflt;
}

/** Removes the shared flags and directories from `args` (the files stay); exits with `usage` when either part is missing. */
export function abArgs(args, usage) {
  const bothAt = args.indexOf('--forward-both');
  const forwardBoth = bothAt >= 0 && args.splice(bothAt, 1).length > 0;
  const forwardAt = args.indexOf('--forward');
  const forward = forwardBoth || (forwardAt >= 0 && args.splice(forwardAt, 1).length > 0);
  const dirs = [];
  while (args.length && existsSync(args[0]) && statSync(args[0]).isDirectory()) dirs.push(path.resolve(args.shift()));
  if (dirs.length === 0 || args.length === 0) {
    console.error(`usage: ${usage}`);
    process.exit(2);
  }
  if (dirs.length === 1) dirs.push(path.join(here, '../pqm-decoder/src'));
  return { forward, forwardBoth, dirs };
}

export const median = (xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];

const cpuMs = (c) => (c.user + c.system) / 1000;

/**
 * One timed run: push the whole file into a new decoder and go to the
 * finest level. CPU time (process.cpuUsage), not wall time: other
 * processes on a shared machine count less.
 */
export function timeDecode(PqmDecoder, bytes, forwardOnly) {
  const c0 = process.cpuUsage();
  const d = new PqmDecoder(forwardOnly ? { forwardOnly: true } : {});
  d.push(bytes);
  d.setLevel({ level: d.deepestLevel });
  const ms = cpuMs(process.cpuUsage(c0));
  return { ms, faces: d.faceCount };
}

/**
 * Warm-up (JIT tiers): `run` at least 3 times and until WARM_UP_MS of CPU
 * have gone by. No cap on the number of runs: a small file (spot decodes in
 * ≈ 1.2 ms) needs a few hundred runs before V8's optimizing tier has
 * compiled everything it will, and a cap of 50 runs stopped it at 60 ms.
 * 1 s, not 300 ms: `process.cpuUsage` counts the compiler threads too, and
 * a fresh process's first makehuman decodes take ≈ 75 ms of CPU each, so
 * 300 ms were only 4 decodes. The timed decodes that followed were still
 * being compiled (9–13 ms each, with 450–950 page faults per decode —
 * not glibc trimming the heap: they stayed with its trim and mmap
 * thresholds at 1 GB, so most likely the compiler threads' memory), against
 * 6.6 ms and 0–2 faults after 1 s (≈ 100 decodes). Session 12 measured this; bench:draco's makehuman figure
 * moved from ≈ 1.9 to ≈ 2.8 M faces/s with it.
 */
export const WARM_UP_MS = 1000;
export function warmUp(run) {
  for (let w = 0, c0 = process.cpuUsage(); w < 3 || cpuMs(process.cpuUsage(c0)) < WARM_UP_MS; w++) run();
}

/**
 * Cold figures: runs `node SCRIPT ...childArgs` `n` times, each a fresh
 * process (nothing compiled yet, no warmed heap) that times its first
 * decode and prints one JSON line; returns the parsed lines.
 */
export function freshProcesses(script, childArgs, n) {
  const out = [];
  for (let i = 0; i < n; i++) {
    out.push(JSON.parse(execFileSync(process.execPath, [script, ...childArgs], { encoding: 'utf8' })));
  }
  return out;
}
