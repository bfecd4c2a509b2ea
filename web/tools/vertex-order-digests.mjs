// Prints the FNV-1a 64 digest (spec §11) of the vertex order the JS decoder
// reads from each given .pqm file (VORD or VNBR section), to compare with
// the Rust decoder's: `cargo run --release -p pqm-format --example
// vertex_order -- FILE.pqm...` prints the same digests.
//
// node web/tools/vertex-order-digests.mjs FILE.pqm...
import { readFileSync } from 'node:fs';
import { decodeAll } from '../pqm-decoder/src/index.js';
import { fnv1a64 } from '../pqm-decoder/test/helpers.mjs';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node web/tools/vertex-order-digests.mjs FILE.pqm...');
  process.exit(2);
}
for (const f of files) {
  const bytes = new Uint8Array(readFileSync(f));
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const t0 = performance.now();
  const d = decodeAll(bytes);
  const t1 = performance.now();
  // the section is decoded on this first read (spec §8: lazily)
  const o = d.vertexOrder;
  const orderMs = performance.now() - t1;
  const ms = t1 - t0;
  const tag = (dv.getUint32(16, true) & 2) !== 0 ? 'VNBR' : 'VORD';
  const digest = o ? fnv1a64(new Uint8Array(o.buffer, o.byteOffset, o.byteLength)) : '-';
  console.log(`${f} ${tag} ${o ? o.length : 0} ${digest} (levels decoded in ${ms.toFixed(0)} ms, then the order in ${orderMs.toFixed(0)} ms)`);
}
