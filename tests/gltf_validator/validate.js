// Validates each .glb given on the command line with the Khronos glTF validator; exits 1 if any
// has an error or a warning, printing the first messages.
const validator = require('gltf-validator');
const fs = require('fs');

(async () => {
  let failed = false;
  for (const file of process.argv.slice(2)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)));
    const { numErrors, numWarnings } = report.issues;
    console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings`);
    for (const m of report.issues.messages.slice(0, 10)) {
      console.log(`  ${m.code}: ${m.message} ${m.pointer || ''}`);
    }
    failed = failed || numErrors > 0 || numWarnings > 0;
  }
  process.exit(failed ? 1 : 0);
})();
