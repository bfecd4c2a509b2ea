#!/usr/bin/env node
// Runs the Khronos glTF-Validator (npm `gltf-validator`, pinned in package-lock.json)
// on each FILE (.gltf or .glb) and prints one JSON object:
//
//   {"file.glb": {"errors": 0, "warnings": 1, "infos": 2, "hints": 0,
//                 "messages": [{"code": ..., "severity": ..., "message": ..., "pointer": ...}]}, ...}
//
// Exits 0 when no file has an error, 1 when any file has at least one error,
// 2 on usage errors or when a file cannot be read or its format is not recognized.
// External resources (.bin, images) are resolved relative to the file's directory.
//
// usage: node validate.mjs FILE...
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node validate.mjs FILE...");
  process.exit(2);
}

const severityName = ["error", "warning", "info", "hint"];
const results = {};
let anyError = false;
let failed = false;

for (const file of files) {
  try {
    const data = await readFile(file);
    const report = await validator.validateBytes(new Uint8Array(data), {
      uri: path.basename(file),
      maxIssues: 100,
      externalResourceFunction: (uri) =>
        readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then(
          (buf) => new Uint8Array(buf),
        ),
    });
    const issues = report.issues;
    results[file] = {
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      infos: issues.numInfos,
      hints: issues.numHints,
      messages: issues.messages.map((m) => ({
        code: m.code,
        severity: severityName[m.severity] ?? String(m.severity),
        message: m.message,
        pointer: m.pointer,
      })),
    };
    if (issues.numErrors > 0) anyError = true;
  } catch (err) {
    results[file] = { errors: 1, fatal: String(err) };
    failed = true;
  }
}

console.log(JSON.stringify(results, null, 2));
// exitCode, not process.exit(): writes to a pipe are asynchronous, and
// exit() cut the report at the pipe's 64 KiB (spot control's levels, once
// curves could be shortened and it coarsened further)
process.exitCode = failed ? 2 : anyError ? 1 : 0;
