#!/usr/bin/env node
// Checks glTF files (.glb or .gltf) with Khronos' glTF-Validator, the npm package
// gltf-validator that scripts/setup.sh unpacks into .deps/gltf-validator (or the folder in
// GLYPTIC_GLTF_VALIDATOR).
//
//   node scripts/validate-gltf.js FILE...          one summary line a file, then its issues
//   node scripts/validate-gltf.js --json FILE      the validator's whole report (JSON) on stdout
//
// Exit codes: 0 no file has an error; 1 some file has errors (or cannot be read or parsed);
// 2 bad usage or the validator is missing.
'use strict';
const fs = require('fs');
const path = require('path');

const args = process.argv.slice(2);
const json = args[0] === '--json';
const files = json ? args.slice(1) : args;
if (files.length === 0 || (json && files.length !== 1)) {
  console.error('usage: node scripts/validate-gltf.js [--json] FILE.glb...  (--json takes one file)');
  process.exit(2);
}
const where = process.env.GLYPTIC_GLTF_VALIDATOR
  || path.join(__dirname, '..', '.deps', 'gltf-validator');
let validator;
try {
  validator = require(path.resolve(where));
} catch (e) {
  console.error(`gltf-validator not found in ${where} (bash scripts/setup.sh installs it): ${e.message}`);
  process.exit(2);
}

async function check(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, { uri: path.basename(file) });
  if (json) {
    process.stdout.write(JSON.stringify(report, null, 2) + '\n');
  } else {
    const i = report.issues;
    const info = report.info || {};
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, `
      + `${i.numHints} hints (glTF-Validator ${report.validatorVersion}); `
      + `${info.totalTriangleCount} triangles, ${info.totalVertexCount} vertices, `
      + `${info.materialCount} materials, ${info.drawCallCount} draw calls`);
    for (const m of i.messages) {
      const severity = ['error', 'warning', 'info', 'hint'][m.severity] || m.severity;
      console.log(`  ${severity} ${m.code} ${m.pointer || ''}: ${m.message}`);
    }
  }
  return report.issues.numErrors;
}

(async () => {
  let failed = false;
  for (const file of files) {
    try {
      if ((await check(file)) > 0) failed = true;
    } catch (e) {
      console.error(`${file}: ${e.message || e}`);
      failed = true;
    }
  }
  process.exit(failed ? 1 : 0);
})();
