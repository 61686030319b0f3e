// Run the Khronos glTF-Validator (npm `gltf-validator`) over every .gltf and .glb under
// the folders given; print each file's error, warning and info counts and its errors,
// and exit non-zero when any file has an error.
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(process.env.GLTF_VALIDATOR_DIR
  ? path.join(process.env.GLTF_VALIDATOR_DIR, 'package.json') : import.meta.url);
const validator = require('gltf-validator');

function* files(dir) {
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const full = path.join(dir, entry.name);
    if (entry.isDirectory()) yield* files(full);
    else if (/\.(gltf|glb)$/i.test(entry.name)) yield full;
  }
}

let failed = 0, checked = 0;
for (const dir of process.argv.slice(2)) {
  for (const file of files(dir)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file),
      maxIssues: 50,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
          (err, data) => err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
    });
    const { numErrors, numWarnings, numInfos } = report.issues;
    checked += 1;
    console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos`);
    for (const m of report.issues.messages.filter((m) => m.severity === 0)) {
      console.log(`  ${m.code} ${m.pointer ?? ''}: ${m.message}`);
    }
    if (numErrors > 0) failed += 1;
  }
}
console.log(`${checked} files validated, ${failed} with errors`);
if (checked === 0 || failed > 0) process.exit(1);
