// Milliseconds per VGA frame of the WebAssembly build (pkg/, from scripts/build-web.sh)
// in Node's V8, the engine of Chromium: the browser's per-frame cost without the page.
// A benchmark, not a test: run it on a quiet machine.
//
//   node scripts/bench-wasm.mjs
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { dirname, join } from 'node:path';

const root = join(dirname(fileURLToPath(import.meta.url)), '..');
const wasm = await import(join(root, 'pkg/stripelight.js'));
wasm.initSync({ module: readFileSync(join(root, 'pkg/stripelight_bg.wasm')) });

const calib = wasm.defaultCalibration();
const crosstalk = new Float32Array(wasm.simulatorCrosstalk());
console.log('| directions | filter | ms per frame |');
console.log('|---|---|---|');
for (const directions of [1, 2, 3]) {
  const spec = wasm.generatePattern(directions, 1024, 768);
  const frame = wasm.renderScene('sphere', spec, calib, 1);
  const rgba = frame.rgba();
  for (const filter of ['direct', 'loggrad']) {
    const scanner = new wasm.Scanner(spec, calib, filter, crosstalk);
    const first = scanner.scan(rgba, frame.width, frame.height); // warm up
    const stages = JSON.parse(first.statsJson).stage_ms.map(([n, ms]) => `${n} ${ms.toFixed(0)}`);
    first.free();
    const runs = 10;
    const start = performance.now();
    for (let i = 0; i < runs; i++) scanner.scan(rgba, frame.width, frame.height).free();
    const ms = (performance.now() - start) / runs;
    console.log(`| ${directions} | ${filter} | ${ms.toFixed(1)} |`);
    console.error(`  stages (ms): ${stages.join(', ')}`);
    scanner.free();
  }
}
