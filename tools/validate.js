// Validates glTF files with the Khronos glTF-Validator. Prints one line per issue and a summary per
// file; exit 1 if any file has errors. Usage: node tools/validate.js FILE...
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
  const result = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      fs.promises.readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  for (const m of result.issues.messages) {
    console.log(`${file}: ${['ERROR', 'WARN', 'INFO', 'HINT'][m.severity]} ${m.code} ${m.pointer || ''} ${m.message}`);
  }
  console.log(`${file}: ${result.issues.numErrors} errors, ${result.issues.numWarnings} warnings`);
  return result.issues.numErrors;
}

(async () => {
  let failed = 0;
  for (const file of process.argv.slice(2)) {
    try {
      if ((await validate(file)) > 0) failed++;
    } catch (e) {
      console.log(`${file}: validator failed: ${e}`);
      failed++;
    }
  }
  process.exitCode = failed > 0 ? 1 : 0;
})();
