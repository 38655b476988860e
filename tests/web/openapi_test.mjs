// The OpenAPI document checked by a real validator (@seriousme/openapi-schema-validator from web/node_modules, the
// OpenAPI 3.x JSON schemas), not by panelbass's own code:
//   node tests/web/openapi_test.mjs api/openapi.json
// Fails when the document is not JSON, does not match the schema of its `openapi` version, or has a $ref that
// resolves to nothing. Exit 0 on success; 1 with "openapi_test: FAIL: <reason>" (every schema error listed); 2 on
// bad usage.

import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const webPackage = path.resolve(here, '../../web/package.json');

function fail(message) {
  console.error(`openapi_test: FAIL: ${message}`);
  process.exit(1);
}

if (process.argv.length !== 3) {
  console.error('usage: node tests/web/openapi_test.mjs OPENAPI.json');
  process.exit(2);
}
const file = path.resolve(process.argv[2]);

let Validator;
try {
  // An ESM-only package: resolved from web/ (where npm installed it), then imported.
  const entry = createRequire(webPackage).resolve('@seriousme/openapi-schema-validator');
  ({ Validator } = await import(pathToFileURL(entry).href));
} catch (e) {
  fail(`@seriousme/openapi-schema-validator not usable from ${webPackage} (run scripts/web_setup.sh): ${e.message}`);
}

let document;
try {
  document = JSON.parse(fs.readFileSync(file, 'utf8'));
} catch (e) {
  fail(`${file}: ${e.message}`);
}

const validator = new Validator();
const result = await validator.validate(document);
if (!result.valid) {
  const errors = (Array.isArray(result.errors) ? result.errors : [result.errors])
    .map((e) => (typeof e === 'string' ? e : `${e.instancePath || '/'}: ${e.message}${e.params ? ` ${JSON.stringify(e.params)}` : ''}`));
  fail(`${file} is not a valid OpenAPI ${document.openapi ?? '(no "openapi" field)'} document:\n  ${errors.join('\n  ')}`);
}
try {
  validator.resolveRefs();
} catch (e) {
  fail(`${file}: a $ref resolves to nothing: ${e.message}`);
}
const operations = Object.values(document.paths ?? {}).flatMap((p) => Object.keys(p).filter((k) => k !== 'parameters'));
console.log(`openapi_test: ${file} is a valid OpenAPI ${validator.version} document (${Object.keys(document.paths ?? {}).length} paths, `
            + `${operations.length} operations); PASS`);
