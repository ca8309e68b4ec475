// Milliseconds per VGA frame of the WebAssembly build (pkg/, from scripts/build-web.sh)
// in Node's V8, the engine of Chromium: the browser's per-frame cost without the page.
// A benchmark, not a test: run it on a quiet machine. After the simulator's sphere, the
// end-to-end test's stored frame (the textured scene) as the page's fake webcam gives it:
// through 4:2:0 chroma and back (y4m), the frame whose rate the end-to-end test reports.
//
//   node scripts/bench-wasm.mjs
//
// With --browser, the end-to-end test's frame is scanned instead by the page's own
// decoding worker in headless Chromium (scripts/serve.py's cross-origin isolated page),
// once with pkg/ (`?threads=0`: the worker's one thread) and once with pkg-threads/
// (WebAssembly threads, a pool of two): the only way to measure the threads, which
// Node's V8 cannot start without web workers.
//
//   node scripts/bench-wasm.mjs --browser
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { dirname, join } from 'node:path';

const root = join(dirname(fileURLToPath(import.meta.url)), '..');
if (process.argv.includes('--browser')) {
  await benchBrowser();
  process.exit(0);
}
const wasm = await import(join(root, 'pkg/stripelight.js'));
wasm.initSync({ module: readFileSync(join(root, 'pkg/stripelight_bg.wasm')) });

const { decodePng } = await import(join(root, 'tests/e2e/png.mjs'));
const { decodeY4m, encodeY4m } = await import(join(root, 'tests/e2e/y4m.mjs'));

const calib = wasm.defaultCalibration();
const crosstalk = new Float32Array(wasm.simulatorCrosstalk());
console.log('| directions | filter | ms per frame (median of 21) | fastest of 21 |');
console.log('|---|---|---|---|');
for (const directions of [1, 2, 3]) {
  const spec = wasm.generatePattern(directions, 1024, 768);
  const frame = wasm.renderScene('sphere', spec, calib, 1);
  for (const filter of ['direct', 'loggrad']) {
    bench(`| ${directions} | ${filter} |`, spec, filter, frame.rgba(), frame.width, frame.height);
  }
}
const stored = decodePng(readFileSync(join(root, 'tests/e2e/fixtures/textured-2dir.png')));
const webcam = decodeY4m(encodeY4m(stored));
bench('| 2, the end-to-end test\'s frame through 4:2:0 | loggrad |', wasm.generatePattern(2, 1024, 768), 'loggrad',
  new Uint8Array(webcam.rgba.buffer, webcam.rgba.byteOffset, webcam.rgba.byteLength), webcam.width, webcam.height);

/** One table row: the median and fastest of 21 frames, each stage's fastest to stderr. */
function bench(row, spec, filter, rgba, width, height) {
  const scanner = new wasm.Scanner(spec, calib, filter, crosstalk);
  scanner.scan(rgba, width, height); // warm up
  // The median frame (a shared machine's load comes in bursts), and each stage's
  // fastest time over the frames (load only ever adds time).
  const times = [];
  let fastest = null;
  for (let i = 0; i < 21; i++) {
    const start = performance.now();
    const stats = scanner.scan(rgba, width, height);
    times.push(performance.now() - start);
    const stages = JSON.parse(stats).stage_ms;
    fastest = fastest === null ? stages : fastest.map(([n, ms], k) => [n, Math.min(ms, stages[k][1])]);
  }
  times.sort((a, b) => a - b);
  const ms = times[times.length >> 1];
  console.log(`${row} ${ms.toFixed(1)} | ${times[0].toFixed(1)} |`);
  console.error(`  fastest by stage (ms): ${fastest.map(([n, t]) => `${n} ${t.toFixed(1)}`).join(', ')}`);
  scanner.free();
}

/** The end-to-end test's frame through 4:2:0, scanned by the page's worker in Chromium. */
async function benchBrowser() {
  const { startServer, launch, openPage } = await import(join(root, 'tests/e2e/harness.mjs'));
  const { decodePng } = await import(join(root, 'tests/e2e/png.mjs'));
  const { decodeY4m, encodeY4m } = await import(join(root, 'tests/e2e/y4m.mjs'));
  const stored = decodePng(readFileSync(join(root, 'tests/e2e/fixtures/textured-2dir.png')));
  const webcam = decodeY4m(encodeY4m(stored));
  const frame = { width: webcam.width, height: webcam.height, base64: Buffer.from(webcam.rgba).toString('base64') };
  const server = await startServer();
  const browser = await launch();
  try {
    console.log('| build | threads | ms per frame (median of 21) | fastest of 21 |');
    console.log('|---|---|---|---|');
    for (const [build, query] of [['pkg/', '?threads=0'], ['pkg-threads/', '']]) {
      const { context, page } = await openPage(browser, `${server.url}${query}`);
      await page.waitForFunction(() => window.stripelight?.state.specJson && window.stripelight.state.simulatorCrosstalk);
      const r = await page.evaluate(async ({ width, height, base64 }) => {
        const { bridge, state } = window.stripelight;
        await bridge.ready();
        const pixels = Uint8Array.from(atob(base64), (c) => c.charCodeAt(0));
        const scan = () => bridge.request('scan', {
          specJson: state.specJson, calibJson: state.calibJson, filter: 'loggrad',
          crosstalk: state.simulatorCrosstalk, width, height, rgba: pixels.slice(),
        });
        let reply = await scan(); // warm up
        const times = [];
        let fastest = null;
        for (let i = 0; i < 21; i++) {
          reply = await scan();
          times.push(reply.ms);
          const stages = reply.stats.stage_ms;
          fastest = fastest === null ? stages : fastest.map(([n, ms], k) => [n, Math.min(ms, stages[k][1])]);
        }
        return { times, fastest, threads: reply.threads };
      }, frame);
      const times = r.times.sort((a, b) => a - b);
      console.log(`| ${build} | ${r.threads} | ${times[10].toFixed(1)} | ${times[0].toFixed(1)} |`);
      console.error(`  fastest by stage (ms): ${r.fastest.map(([n, t]) => `${n} ${t.toFixed(1)}`).join(', ')}`);
      await context.close();
    }
  } finally {
    await browser.close();
    server.stop();
  }
}
