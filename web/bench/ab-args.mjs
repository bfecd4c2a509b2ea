// The arguments both A/B scripts share (`ab.mjs` in one process,
// `ab-proc.mjs` in separate ones): `--forward` (B one-way),
// `--forward-both` (both one-way), then one or two source directories
// (A, and B = this checkout's pqm-decoder/src by default) before the files.
import { existsSync, statSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));

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
