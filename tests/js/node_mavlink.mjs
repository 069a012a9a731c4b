// node-mavlink (npm, installed into tests/js by tools/test): a MAVLink
// implementation nobody on this project wrote, with the registry of every message
// set zonemap meets. Without it a test is skipped with the reason (exit 77),
// never passed.
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
let loaded;
try {
  loaded = require('node-mavlink');
} catch (e) {
  console.log('SKIP: node-mavlink is not installed (npm unreachable when tools/test set up tests/js)');
  process.exit(77);
}
export const mavlink = loaded;
export const REGISTRY = {
  ...loaded.minimal.REGISTRY, ...loaded.common.REGISTRY, ...loaded.ardupilotmega.REGISTRY,
};
