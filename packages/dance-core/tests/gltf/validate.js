// Validate a glTF/GLB file with the Khronos glTF-Validator (npm `gltf-validator`) and print its report's
// issue counts and messages as one JSON object. Run: NODE_PATH=.tools/node_modules node validate.js FILE
"use strict";
const fs = require("fs");
const validator = require("gltf-validator");

const file = process.argv[2];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), { maxIssues: 100 }).then((report) => {
  const issues = report.issues;
  console.log(JSON.stringify({
    errors: issues.numErrors, warnings: issues.numWarnings, infos: issues.numInfos, hints: issues.numHints,
    messages: issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ""}: ${m.message}`),
    info: report.info,
  }));
}, (error) => {
  console.error(String(error));
  process.exit(2);
});
