// Validate a glTF/GLB file with the Khronos glTF validator; print its JSON report.
// Usage: node tools/validate-gltf.mjs FILE.glb
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");
const file = process.argv[2];
const bytes = new Uint8Array(await readFile(file));
const report = await validator.validateBytes(bytes, { uri: file, maxIssues: 100 });
console.log(JSON.stringify(report, null, 1));
