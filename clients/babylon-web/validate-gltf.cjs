// The Khronos glTF validator (npm `gltf-validator`, pinned in package.json) on one .gltf and the
// files it refers to (resolved beside it): `node validate-gltf.cjs FILE.gltf` prints the
// validator's report as JSON (`issues.numErrors`, `numWarnings`, `numInfos`, `numHints`,
// `messages`); tests/gltf_render.rs runs it on hdrflow's glTF bake and asserts no errors.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const file = process.argv[2];
if (!file) {
    console.error('usage: node validate-gltf.cjs FILE.gltf');
    process.exit(2);
}
const dir = path.dirname(file);
const externalResourceFunction = (uri) =>
    new Promise((resolve, reject) => {
        fs.readFile(path.resolve(dir, decodeURIComponent(uri)), (err, data) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(data)));
    });
validator
    .validateBytes(new Uint8Array(fs.readFileSync(file)), { uri: path.basename(file), externalResourceFunction, maxIssues: 0 })
    .then((report) => console.log(JSON.stringify(report, null, 1)))
    .catch((e) => {
        console.error(`the validator failed: ${e}`);
        process.exit(2);
    });
