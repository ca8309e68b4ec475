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
console.log('| directions | filter | ms per frame (median of 21) |');
console.log('|---|---|---|');
for (const directions of [1, 2, 3]) {
  const spec = wasm.generatePattern(directions, 1024, 768);
  const frame = wasm.renderScene('sphere', spec, calib, 1);
  const rgba = frame.rgba();
  for (const filter of ['direct', 'loggrad']) {
    const scanner = new wasm.Scanner(spec, calib, filter, crosstalk);
    const first = scanner.scan(rgba, frame.width, frame.height); // warm up
    const stages = JSON.parse(first).stage_ms.map(([n, ms]) => `${n} ${ms.toFixed(0)}`);
    // The median frame: a shared machine's load comes in bursts.
    const times = [];
    for (let i = 0; i < 21; i++) {
      const start = performance.now();
      scanner.scan(rgba, frame.width, frame.height);
      times.push(performance.now() - start);
    }
    times.sort((a, b) => a - b);
    const ms = times[times.length >> 1];
    console.log(`| ${directions} | ${filter} | ${ms.toFixed(1)} |`);
    console.error(`  stages (ms): ${stages.join(', ')}`);
    scanner.free();
  }
}
