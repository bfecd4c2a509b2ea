// Size and decode speed of .pqm against Draco (npm `draco3d`, its WASM
// encoder and decoder) on the same meshes, in node:
//
//   bash bench/make-data.sh        # once: bench/data/*.pqm from shared/meshes
//   npm run bench:draco            # or: node bench/draco.mjs [FILE.pqm ...] [--runs N] [--procs N] [--cold N]
//
// For each .pqm file, the mesh compared is its finest level as pqm-decoder
// decodes it (the input mesh with positions on the 14-bit grid), each quad
// split into two triangles along its shorter diagonal, as `pqm decode`'s
// glTF export splits it (what a pipeline would hand Draco; until session
// 22 the two the decoder draws, v0 v1 v2 and v0 v2 v3, whose diagonal
// follows where the .pqm writer starts each quad: Draco's makehuman took
// 21.5 bits per vertex with the input's starts, 23.5 with the canonical).
// Draco encodes those triangles with positions only: 14-bit position
// quantization, edgebreaker, speed 3/3 (= `draco_encoder -cl 7`).
//
// Columns:
// - V, quads: vertices and quads of the finest level (Draco gets 2 × quads
//   triangles, and drops the few that are degenerate on its grid: printed);
// - bits/vertex: 8 × bytes / V for the whole .pqm file (every level, the
//   chunk table and the VORD / VNBR section included); for the .pqm file
//   without its optional sections, i.e. header, chunk table, base mesh and
//   records only ("pos+conn": positions and connectivity, the figure issue 4
//   asks for — Draco's edgebreaker reorders vertices and keeps no input
//   order, so this is the like-for-like size); for the Draco buffer; and a
//   plain GLB's buffers computed as 12 bytes per vertex (float32 xyz) + 24
//   per quad (6 uint32 indices), without the JSON chunk;
// - decode, warm: million faces per second, CPU time (process.cpuUsage,
//   median of --runs after warm-up runs — at least 3 and 1 s of CPU —, so
//   other processes on the machine count less), each decoder in node
//   processes of its own that load only it (the parent encodes with Draco);
//   the median of --procs N such processes (default 3). One process's
//   median is not enough: in node a process lands in one of two glibc heap
//   states (web/README.md, session 12: the heap top trimmed after a
//   collection, or not), and a small file's decodes then take 0 or several
//   hundred fresh pages each, which moves its figure by up to 30 %;
// - decode, cold: the first decode in a fresh node process (pqm: its module
//   loaded, nothing run yet; Draco: its WASM module instantiated, nothing
//   decoded yet), CPU time, median of --cold N processes (default 3, 0 to
//   skip). The cold CPU time includes V8's compiler threads.
//   pqm: push the whole file into a new PqmDecoder (CRC, zstd, records) and
//   go to the finest level (positions + triangle indices ready), faces =
//   quads of the finest level; also with `forwardOnly: true` (the one-way
//   decoder of a streaming client). Draco: DecodeArrayToMesh, then the triangle
//   indices and float positions copied out of the WASM heap (what three's
//   DRACOLoader does); faces = triangles / 2, a quad-equivalent count (the
//   same surface, the same triangles). Draco's triangles/s is twice that.
// Ratios are pqm / Draco for size (below 1: pqm smaller) and for speed
// (above 1: pqm faster).
import { readFileSync, readdirSync, existsSync, statSync, writeFileSync, mkdtempSync, rmSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { PqmDecoder } from '../pqm-decoder/src/index.js';
import { freshProcesses, median, warmUp } from './ab-common.mjs';

const require = createRequire(import.meta.url);
const draco3d = require('draco3d');

const here = path.dirname(fileURLToPath(import.meta.url));
const self = fileURLToPath(import.meta.url);
const args = process.argv.slice(2);
const runsAt = args.indexOf('--runs');
const runs = runsAt >= 0 ? Number(args.splice(runsAt, 2)[1]) : 7;
const procsAt = args.indexOf('--procs');
const procs = procsAt >= 0 ? Number(args.splice(procsAt, 2)[1]) : 3;
if (!(Number.isInteger(procs) && procs >= 1)) {
  console.error(`--procs wants a whole number ≥ 1`);
  process.exit(2);
}
const coldAt = args.indexOf('--cold');
const coldRuns = coldAt >= 0 ? Number(args.splice(coldAt, 2)[1]) : 3;
let files = args;
if (files.length === 0) {
  const dir = path.join(here, 'data');
  files = existsSync(dir)
    ? readdirSync(dir)
        .filter((f) => f.endsWith('.pqm'))
        .map((f) => path.join(dir, f))
    : [];
  files.sort((a, b) => statSync(a).size - statSync(b).size);
  if (files.length === 0) {
    console.error('no .pqm files in bench/data: run `bash bench/make-data.sh` first (needs the pqm binary)');
    process.exit(1);
  }
}

const cpuMs = (c) => (c.user + c.system) / 1000;

/** Median CPU milliseconds of `fn` over `runs` runs after warm-up runs (JIT tiers). */
function timeCpu(fn, runs) {
  warmUp(fn);
  const t = [];
  for (let r = 0; r < runs; r++) {
    const c0 = process.cpuUsage();
    fn();
    t.push(cpuMs(process.cpuUsage(c0)));
  }
  return median(t);
}

/**
 * Child process: `--child pqm FILE FORWARD RUNS` or `--child draco
 * FILE.drc - RUNS` decodes in this fresh process, which loads only that
 * decoder: RUNS = 0 times the first decode (cold), else the median of RUNS
 * after the warm-up (warm); prints one JSON line and exits. Each decoder
 * is timed in a process of its own: in the parent, which has run Draco's
 * encoder, pqm's decodes took ≈ 10 % more CPU (bunny, 122 against 107–112
 * ms in a process that never loaded Draco).
 */
async function child([kind, file, fwd, runsArg]) {
  const bytes = new Uint8Array(readFileSync(file));
  let fn;
  if (kind === 'pqm') {
    fn = () => pqmDecode(bytes, fwd === '1');
  } else {
    decoderModule = await draco3d.createDecoderModule({});
    fn = () => dracoDecode(bytes);
  }
  let ms;
  if (Number(runsArg) === 0) {
    const c0 = process.cpuUsage();
    fn();
    ms = cpuMs(process.cpuUsage(c0));
  } else {
    ms = timeCpu(fn, Number(runsArg));
  }
  console.log(JSON.stringify({ ms }));
  process.exit(0);
}

let decoderModule = null;
if (args[0] === '--child') await child(args.slice(1));
const encoderModule = await draco3d.createEncoderModule({});
decoderModule = await draco3d.createDecoderModule({});

/**
 * Each quad of `quads` (4 ids each) as two triangles split along its
 * shorter diagonal in `positions` (x, y, z per vertex), `q[0]–q[2]` on a
 * tie: pqm_core::io::quad_split_diagonal, which the glTF export uses.
 */
function shorterDiagonalTriangles(positions, quads) {
  const d2 = (a, b) => {
    let s = 0;
    for (let k = 0; k < 3; k++) {
      const t = positions[3 * a + k] - positions[3 * b + k];
      s += t * t;
    }
    return s;
  };
  const out = new Uint32Array((quads.length / 4) * 6);
  for (let f = 0, o = 0; f < quads.length; f += 4, o += 6) {
    let q = [quads[f], quads[f + 1], quads[f + 2], quads[f + 3]];
    if (d2(q[1], q[3]) < d2(q[0], q[2])) q = [q[1], q[2], q[3], q[0]];
    out.set([q[0], q[1], q[2], q[0], q[2], q[3]], o);
  }
  return out;
}

/** Draco bytes of the triangle mesh (positions only). */
function dracoEncode(positions, triangles) {
  const E = encoderModule;
  const encoder = new E.Encoder();
  const builder = new E.MeshBuilder();
  const mesh = new E.Mesh();
  builder.AddFacesToMesh(mesh, triangles.length / 3, triangles);
  builder.AddFloatAttributeToMesh(mesh, E.POSITION, positions.length / 3, 3, positions);
  encoder.SetAttributeQuantization(E.POSITION, 14);
  encoder.SetSpeedOptions(3, 3); // compression level 7
  encoder.SetEncodingMethod(E.MESH_EDGEBREAKER_ENCODING);
  const out = new E.DracoInt8Array();
  const n = encoder.EncodeMeshToDracoBuffer(mesh, out);
  if (n <= 0) throw new Error('Draco encoding failed');
  const bytes = new Uint8Array(n);
  for (let i = 0; i < n; i++) bytes[i] = out.GetValue(i) & 0xff;
  for (const o of [out, mesh, builder, encoder]) E.destroy(o);
  return bytes;
}

/** Decodes Draco bytes to {positions, indices} as three's DRACOLoader does. */
function dracoDecode(bytes) {
  const D = decoderModule;
  const decoder = new D.Decoder();
  const mesh = new D.Mesh();
  const status = decoder.DecodeArrayToMesh(bytes, bytes.byteLength, mesh);
  if (!status.ok()) throw new Error(`Draco decoding failed: ${status.error_msg()}`);
  const nIdx = mesh.num_faces() * 3;
  const ip = D._malloc(nIdx * 4);
  decoder.GetTrianglesUInt32Array(mesh, nIdx * 4, ip);
  const indices = new Uint32Array(D.HEAPF32.buffer, ip, nIdx).slice();
  D._free(ip);
  const attr = decoder.GetAttribute(mesh, decoder.GetAttributeId(mesh, D.POSITION));
  const nPos = mesh.num_points() * 3;
  const pp = D._malloc(nPos * 4);
  decoder.GetAttributeDataArrayForAllPoints(mesh, attr, D.DT_FLOAT32, nPos * 4, pp);
  const positions = new Float32Array(D.HEAPF32.buffer, pp, nPos).slice();
  D._free(pp);
  D.destroy(mesh);
  D.destroy(decoder);
  return { positions, indices };
}

function pqmDecode(bytes, forwardOnly = false) {
  const d = new PqmDecoder({ forwardOnly });
  d.push(bytes);
  d.setLevel({ level: d.deepestLevel });
  return d;
}

const tmp = mkdtempSync(path.join(os.tmpdir(), 'pqm-draco-'));
const rows = [];
for (const file of files) {
  const bytes = new Uint8Array(readFileSync(file));
  const dec = pqmDecode(bytes);
  const V = dec.vertexCount;
  const F = dec.faceCount;
  const positions = dec.positions.slice();
  const triangles = shorterDiagonalTriangles(positions, dec.quads);
  const drc = dracoEncode(positions, triangles);
  const check = dracoDecode(drc);
  // Draco drops triangles that are degenerate on its grid (a handful on the
  // split bunny); more than 0.1 % would mean the comparison is off.
  const dracoTris = check.indices.length / 3;
  if (Math.abs(dracoTris - 2 * F) > 0.001 * 2 * F) {
    throw new Error(`${file}: Draco returned ${dracoTris} triangles, expected ${2 * F}`);
  }
  const glb = 12 * V + 24 * F;
  // cold: fresh processes, before this one has decoded the file warm
  const drcFile = path.join(tmp, `${path.basename(file, '.pqm')}.drc`);
  writeFileSync(drcFile, drc);
  const cold = (childArgs) => (coldRuns > 0 ? median(freshProcesses(self, ['--child', ...childArgs, '0'], coldRuns).map((x) => x.ms)) : NaN);
  const warm = (childArgs) => median(freshProcesses(self, ['--child', ...childArgs, String(runs)], procs).map((x) => x.ms));
  const pqmCold = cold(['pqm', file, '0']);
  const fwdCold = cold(['pqm', file, '1']);
  const drcCold = cold(['draco', drcFile, '-']);
  const pqmMs = warm(['pqm', file, '0']);
  // the one-way decoder a streaming client uses (no way back to coarser
  // levels, so no undo log): the same faces and positions
  const fwdMs = warm(['pqm', file, '1']);
  const drcMs = warm(['draco', drcFile, '-']);
  rows.push({
    mesh: path.basename(file, '.pqm'),
    V,
    F,
    pqmBpv: (8 * bytes.length) / V,
    // the records end where the optional sections (vertex order) begin
    pqmPcBpv: (8 * (dec.chunks.length ? dec.chunks[dec.chunks.length - 1].end : bytes.length)) / V,
    drcBpv: (8 * drc.length) / V,
    glbBpv: (8 * glb) / V,
    pqmMfs: F / pqmMs / 1000,
    fwdMfs: F / fwdMs / 1000,
    drcMfs: dracoTris / 2 / drcMs / 1000, // quad-equivalent: triangles / 2
    dropped: 2 * F - dracoTris,
    pqmMs,
    drcMs,
    pqmColdMfs: F / pqmCold / 1000,
    fwdColdMfs: F / fwdCold / 1000,
    drcColdMfs: dracoTris / 2 / drcCold / 1000,
  });
}
rmSync(tmp, { recursive: true, force: true });

const f1 = (x) => x.toFixed(1);
const f2 = (x) => x.toFixed(2);
const header = [
  'mesh', 'V', 'quads', 'pqm b/v', 'pqm pos+conn b/v', 'Draco b/v', 'GLB b/v', 'size pqm/Draco', 'pos+conn pqm/Draco',
  'pqm Mf/s', 'pqm forward-only Mf/s', 'Draco Mf/s', 'speed pqm/Draco', 'pqm ms', 'Draco ms',
  'cold pqm Mf/s', 'cold pqm forward-only Mf/s', 'cold Draco Mf/s',
];
const table = rows.map((r) => [
  r.mesh, String(r.V), String(r.F), f1(r.pqmBpv), f1(r.pqmPcBpv), f1(r.drcBpv), f1(r.glbBpv), f2(r.pqmBpv / r.drcBpv), f2(r.pqmPcBpv / r.drcBpv),
  f2(r.pqmMfs), f2(r.fwdMfs), f2(r.drcMfs), f2(r.pqmMfs / r.drcMfs), f1(r.pqmMs), f1(r.drcMs),
  f2(r.pqmColdMfs), f2(r.fwdColdMfs), f2(r.drcColdMfs),
]);
console.log(`node ${process.version}, warm: CPU-time medians of ${runs} runs after ≥ 1 s of warm-up, median of ${procs} processes; cold: first decode in a fresh process, median of ${coldRuns} processes; Draco: draco3d ${require('draco3d/package.json').version} (WASM), qp 14, speed 3/3, edgebreaker`);
console.log(`| ${header.join(' | ')} |`);
console.log(`|${header.map(() => '---').join('|')}|`);
for (const t of table) console.log(`| ${t.join(' | ')} |`);
for (const r of rows) {
  if (r.dropped) console.log(`${r.mesh}: Draco dropped ${r.dropped} degenerate triangles of ${2 * r.F}`);
}
console.log('Mf/s = million quad-equivalent faces per second (Draco: triangles / 2). b/v = bits per vertex.');
