// Differential fuzzing of the JavaScript decoder against the Rust reference
// decoder: mutates the decompressed payloads, header fields (flag bits 0
// and 2, the 3.2 bounds included; flag bit 3 and the reserved bits, which
// change no level but must read alike), chunk table entries, optional sections (dropped, duplicated,
// renamed) and the zstd framing of one section (trailing bytes or frames,
// skippable frames, no content size, a checksum) of the test files, repacks
// them (raw zstd frames, CRCs recomputed, so the mutations reach the
// structural checks), decodes each with both decoders and reports every file
// where they disagree (one accepts, the other rejects, or both accept with
// different finest meshes), and every file where the forward-only JS
// decoder (`forwardOnly: true`) differs from the general one, in its
// outcome or in the deepest level it keeps after an error.
//
//   cargo build --release --manifest-path tools/make-pqm/Cargo.toml
//   node tools/diff-fuzz.mjs [COUNT] [SEED]          (from web/)
import { mkdtempSync, writeFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { execFileSync } from 'node:child_process';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { PqmDecoder, PqmError } from '../pqm-decoder/src/index.js';
import { testFiles, levelDigests, rng } from '../pqm-decoder/test/helpers.mjs';
import { unpack, pack, rawZstdFrame, concat } from '../pqm-decoder/test/repack.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const tool = path.join(here, 'make-pqm/target/release/make-pqm');
const count = Number(process.argv[2] ?? 2000);
const rand = rng(Number(process.argv[3] ?? 7));
const pick = (n) => Math.floor(rand() * n);

/** Framings of one payload that break or bend spec §1's one-frame rule. */
const framings = [
  ['trailing empty frame', (p) => concat([rawZstdFrame(p), rawZstdFrame(new Uint8Array(0))])],
  ['trailing bytes', (p) => concat([rawZstdFrame(p), new Uint8Array(1 + pick(4))])],
  ['two half frames', (p) => concat([rawZstdFrame(p.subarray(0, p.length >> 1)), rawZstdFrame(p.subarray(p.length >> 1))])],
  ['leading skippable frame', (p) => concat([Uint8Array.of(0x50 + pick(16), 0x2a, 0x4d, 0x18, 2, 0, 0, 0, 0, 0), rawZstdFrame(p)])],
  ['no content size', (p) => {
    const f = rawZstdFrame(p, { windowDescriptor: 15 << 3 });
    return concat([Uint8Array.of(0x28, 0xb5, 0x2f, 0xfd, 0x00, f[5]), f.subarray(10)]);
  }],
  ['content size + 1', (p) => rawZstdFrame(concat([p, Uint8Array.of(0)]))],
  // windows of 1 KiB .. 2^25 (spec §1 lets readers refuse larger ones, so
  // the decoders need not agree there)
  ['window descriptor', (p) => {
    const e = pick(16);
    return rawZstdFrame(p, { windowDescriptor: (e << 3) | (e === 15 ? 0 : pick(8)) });
  }],
  ['cut short', (p) => rawZstdFrame(p).subarray(0, -1 - pick(3))],
];

/** Toggles a section list change and fixes section_count. */
function mutateSections(parts) {
  const how = pick(3);
  const hv = new DataView(parts.header.buffer);
  if (how === 0 && parts.sections.length) parts.sections.pop();
  else if (how === 1 && parts.sections.length) parts.sections.push({ ...parts.sections[0] });
  else if (parts.sections.length) parts.sections[0] = { ...parts.sections[0], tag: 'XORD' };
  else parts.sections.push({ tag: 'XTRA', payload: Uint8Array.of(1, 2, 3) });
  hv.setUint32(48, parts.sections.length, true);
  return `sections ${['drop last', 'duplicate first', 'rename first / add unknown'][how]} → ${parts.sections.map((x) => x.tag).join(',')}`;
}

function mutate(parts) {
  const what = pick(16);
  if (what === 15) {
    // spec §3: bit 3 (4.1's finest diagonals) changes no level; reserved
    // bits are ignored. Both decoders must decode as before and report
    // the same flag
    const dv = new DataView(parts.header.buffer);
    const bit = pick(2) ? 3 : 4 + pick(28);
    dv.setUint32(16, (dv.getUint32(16, true) ^ (1 << bit)) >>> 0, true);
    return { what: `header flag bit ${bit} toggled` };
  }
  if (what === 13) {
    // spec §3 (3.2): flag bit 2 says the header holds bounds; both
    // decoders must refuse it on a 120-byte header and ignore a 168-byte
    // header's bounds without it
    const dv = new DataView(parts.header.buffer);
    dv.setUint32(16, dv.getUint32(16, true) ^ 4, true);
    return { what: `header flag bit 2 toggled (header_len ${parts.header.length})` };
  }
  if (what === 14 && parts.header.length >= 168) {
    // one bounds value: NaN, infinite, past the other end, or one ulp off
    const dv = new DataView(parts.header.buffer);
    const off = 116 + 8 * pick(6);
    const v = dv.getFloat64(off, true);
    const other = dv.getFloat64(off < 140 ? off + 24 : off - 24, true);
    const how = pick(4);
    const bad = [NaN, (how & 1 ? -1 : 1) * Infinity, off < 140 ? other + Math.abs(other) + 1 : other - Math.abs(other) - 1, v * (1 + Number.EPSILON)][how];
    dv.setFloat64(off, bad, true);
    return { what: `bounds value at ${off} → ${bad}` };
  }
  if (what === 10) {
    const dv = new DataView(parts.header.buffer);
    dv.setUint32(16, dv.getUint32(16, true) ^ 1, true);
    return { what: 'header flag bit 0 toggled' };
  }
  if (what === 11) return { what: mutateSections(parts) };
  if (what === 12) {
    const all = [parts.base, ...parts.chunks, ...parts.sections.map((x) => x.payload)];
    const target = all[pick(all.length)];
    const [name, bad] = framings[pick(framings.length)];
    return {
      what: `framing of payload ${all.indexOf(target)}: ${name}`,
      frame: (p) => (p === target ? bad(p) : rawZstdFrame(p)),
    };
  }
  const bytesOf = (arr) => arr;
  if (what < 7) {
    // a payload: base or a chunk
    const all = [parts.base, ...parts.chunks];
    const i = pick(all.length);
    let p = bytesOf(all[i]);
    if (p.length === 0) return 'nothing';
    const k = pick(p.length);
    const how = pick(4);
    if (how === 0) p[k] = pick(256);
    else if (how === 1) p[k] = (p[k] + 1) & 0xff;
    else if (how === 2) p[k] = (p[k] + 255) & 0xff;
    else {
      // delete a byte
      const q = new Uint8Array(p.length - 1);
      q.set(p.subarray(0, k));
      q.set(p.subarray(k + 1), k);
      p = q;
    }
    if (i === 0) parts.base = p;
    else parts.chunks[i - 1] = p;
    return `payload ${i === 0 ? 'base' : `chunk ${i - 1}`} byte ${k} how ${how}`;
  }
  if (what < 9 && parts.entries.length) {
    // a chunk table field: record, vertex, face count or error (offsets,
    // lengths and CRCs are recomputed by pack)
    const i = pick(parts.entries.length);
    const off = [16, 20, 24, 28][pick(4)];
    const dv = new DataView(parts.entries[i].buffer);
    const delta = [1, -1, 2][pick(3)];
    dv.setUint32(off, (dv.getUint32(off, true) + delta) >>> 0, true);
    return `entry ${i} field ${off} ${delta}`;
  }
  // a header field
  const off = [20, 24, 28, 32, 36, 40, 112][pick(7)];
  const dv = new DataView(parts.header.buffer);
  if (off === 20) dv.setUint8(20, dv.getUint8(20) + [1, -1][pick(2)]);
  else dv.setUint32(off, (dv.getUint32(off, true) + [1, -1][pick(2)]) >>> 0, true);
  return `header field ${off}`;
}

/**
 * What the JS decoder makes of a file: `ok LEVEL DIGESTS` or `err MESSAGE`
 * (compared with the Rust decoder's), then after ` | ` the deepest level it
 * keeps after an error (compared between the general and the forward-only
 * decoder, which must roll its frontier back to it).
 */
function jsOutcome(bytes, forwardOnly = false) {
  const d = new PqmDecoder({ forwardOnly });
  let out;
  try {
    d.push(bytes);
    d.end();
    d.setLevel({ level: d.deepestLevel });
    const g = levelDigests(d);
    return `ok ${d.deepestLevel} ${g.positions} ${g.quads} diagonals ${d.header.finestDiagonals}`;
  } catch (e) {
    if (!(e instanceof PqmError)) return `CRASH ${e && e.stack}`;
    out = `err ${e.message}`;
  }
  try {
    if (d.deepestLevel === null) return out;
    d.setLevel({ level: d.deepestLevel });
    const g = levelDigests(d);
    return `${out} | kept ${d.deepestLevel} ${g.positions} ${g.quads}`;
  } catch (e) {
    return `CRASH after the error: ${e && e.stack}`;
  }
}

const dir = mkdtempSync(path.join(tmpdir(), 'pqm-fuzz-'));
const files = testFiles();
const cases = [];
for (let n = 0; n < count; n++) {
  const f = files[pick(files.length)];
  const parts = unpack(f.bytes);
  const m = mutate(parts);
  const what = typeof m === 'string' ? m : m.what;
  const bytes = pack(parts, m.frame ? { frame: m.frame } : {});
  const file = path.join(dir, `${n}.pqm`);
  writeFileSync(file, bytes);
  cases.push({ n, name: f.name, what, file, js: jsOutcome(bytes), fwd: jsOutcome(bytes, true) });
}
// The unmodified files, repacked, must decode identically too.
for (const f of files) {
  const file = path.join(dir, `${f.name}.repacked.pqm`);
  const bytes = pack(unpack(f.bytes));
  writeFileSync(file, bytes);
  cases.push({ n: f.name, name: f.name, what: 'repacked', file, js: jsOutcome(bytes), fwd: jsOutcome(bytes, true) });
}
const out = execFileSync(tool, ['check', ...cases.map((c) => c.file)], { maxBuffer: 1 << 28 }).toString();
const rust = new Map();
for (const line of out.split('\n')) {
  if (!line) continue;
  const sp = line.indexOf(' ');
  rust.set(line.slice(0, sp), line.slice(sp + 1));
}
let agree = 0;
let bothErr = 0;
const mismatches = [];
for (const c of cases) {
  const r = rust.get(c.file);
  const jsOk = c.js.startsWith('ok');
  const rOk = r.startsWith('ok');
  if (c.js.includes('CRASH') || jsOk !== rOk || (jsOk && c.js !== r) || c.fwd !== c.js) mismatches.push({ ...c, rust: r });
  else {
    agree++;
    if (!jsOk) bothErr++;
  }
}
console.log(`${cases.length} files: ${agree} agree (${bothErr} rejected by both), ${mismatches.length} disagree`);
for (const m of mismatches.slice(0, Number(process.env.SHOW ?? 30))) {
  console.log(`- ${m.name} #${m.n} (${m.what})\n    js:   ${m.js}\n    fwd:  ${m.fwd}\n    rust: ${m.rust}`);
}
rmSync(dir, { recursive: true, force: true });
process.exitCode = mismatches.length ? 1 : 0;
