// Writes pqm-decoder/test/data/zstd/NAME.LEVEL.zst: the inputs of
// pqm-decoder/test/zstd-inputs.mjs compressed by the zstd command line
// tool (content size stated, no checksum, as .pqm sections are), for the
// zstd decoder test. Run once; the outputs are committed.
//
//   node tools/make-zstd-fixtures.mjs      # needs `zstd` on PATH
import { writeFileSync, readFileSync, mkdtempSync, rmSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import path from 'node:path';
import os from 'node:os';
import { fileURLToPath } from 'node:url';
import { zstdInputs, ZSTD_LEVELS, levelsOf } from '../pqm-decoder/test/zstd-inputs.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const dir = path.join(here, '../pqm-decoder/test/data/zstd');
const tmp = mkdtempSync(path.join(os.tmpdir(), 'zstd-fix-'));
let total = 0;
for (const [name, bytes] of Object.entries(zstdInputs())) {
  const src = path.join(tmp, name);
  writeFileSync(src, bytes);
  for (const suffix of levelsOf(name)) {
    const args = ZSTD_LEVELS[suffix];
    const dst = path.join(dir, `${name}.${suffix}.zst`);
    execFileSync('zstd', ['-q', '-f', '--no-check', '--content-size', ...args, src, '-o', dst]);
    total += readFileSync(dst).length;
  }
}
rmSync(tmp, { recursive: true });
console.log(`${total} bytes of fixtures in ${dir}`);
