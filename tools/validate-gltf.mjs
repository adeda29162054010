// Validate a glTF/GLB file with the Khronos glTF validator; print its JSON report.
// Usage: node tools/validate-gltf.mjs FILE.glb   (set up first: npm ci in tools/)
// Exit code 0 when the report could be made (whatever its issues), 2 on a usage or
// read error: the caller judges the report (issues.numErrors).
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");
const file = process.argv[2];
if (!file) {
  console.error("usage: node validate-gltf.mjs FILE.glb|FILE.gltf");
  process.exit(2);
}
try {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, { uri: file, maxIssues: 100 });
  console.log(JSON.stringify(report, null, 1));
} catch (error) {
  console.error(`${file}: ${error && error.message ? error.message : error}`);
  process.exit(2);
}
