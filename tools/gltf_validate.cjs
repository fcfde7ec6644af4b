// Validate a .glb/.gltf with the Khronos glTF validator (npm gltf-validator).
// Prints one JSON line {errors, warnings, messages}; exit 0 only with no errors.
// Usage: node tools/gltf_validate.cjs FILE
const fs = require('fs');
const validator = require('gltf-validator');

const file = process.argv[2];
validator
  .validateBytes(new Uint8Array(fs.readFileSync(file)))
  .then((report) => {
    const issues = report.issues;
    const errors = issues.messages.filter((m) => m.severity === 0).slice(0, 20);
    console.log(JSON.stringify({ errors: issues.numErrors, warnings: issues.numWarnings, messages: errors }));
    process.exit(issues.numErrors === 0 ? 0 : 1);
  })
  .catch((e) => {
    console.log(JSON.stringify({ errors: -1, fatal: String(e) }));
    process.exit(2);
  });
