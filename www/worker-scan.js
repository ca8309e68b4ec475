// The decoding worker's scanners and its scan replies (the protocol is in worker.js).
//
// A scan reply always carries the frame's figures (`stats`, the time taken, which worker
// answered and the size of its wasm memory) and the merged cloud. Everything else is a
// frame-sized array or more, so it crosses only when the request's `want` names it:
// 'families' (one cloud per stripe family), 'depth' (Z in mm per pixel), 'correspondence'
// (three projector coordinates per pixel: 3.7 MB for a VGA frame) and 'stages' (a dozen
// pictures for the teaching view). What is sent is copied out of the scanner once and
// transferred; what is not stays in the scanner until its next frame.

import { MAX_FRAME_PIXELS, frameSizeProblem } from './frame-size.js';

/**
 * Scanners kept alive, keyed by spec and calibration (the size comes with the
 * calibration): at most MAX_SCANNERS, and together at most MAX_FRAME_PIXELS pixels, so
 * that a worker holds the buffers of one largest frame at most (a scanner's buffers are
 * many times its frame's size; a 12-megapixel one takes about 2.5 GB).
 */
const MAX_SCANNERS = 3;
const scanners = new Map(); // key -> {scanner, pixels}, least recently used first

/** What a scan reply may carry besides the merged cloud and the figures. */
export const OPTIONAL_RESULTS = ['families', 'depth', 'correspondence', 'stages'];

/**
 * Scan one frame: the request's fields as in worker.js; `progress(message)` tells the page
 * what is under way; `wasm` is the loaded package's module and `memory` its instance's
 * WebAssembly.Memory. Returns {value, transfer}.
 */
export function scanFrame({ specJson, calibJson, filter, crosstalk, response, width, height, rgba, want = [] }, progress, wasm, memory) {
  const started = performance.now();
  const wanted = wantedResults(want);
  refuseLargeFrame(width, height);
  const scanner = scannerFor(wasm, { specJson, calibJson, filter, crosstalk, response }, width * height, progress);
  scanner.setFilter(filter);
  progress(`decoding a ${width}x${height} frame (${filter})`);
  const t0 = performance.now();
  const stats = JSON.parse(scanner.scan(bytesOf(rgba), width, height));
  const ms = performance.now() - t0;
  const reply = resultsOf(scanner, wanted);
  // workerMs: the whole request, copies out of the scanner included; ms: the scan alone.
  Object.assign(reply.value, {
    stats, ms, workerMs: performance.now() - started, worker: self.name, threads: wasm.threadCount(), memoryBytes: memory.buffer.byteLength,
  });
  return reply;
}

/** Refuse a frame over the page's size limit, with the message frame-size.js words. */
export function refuseLargeFrame(width, height) {
  const problem = frameSizeProblem(width, height);
  if (problem) throw new Error(problem);
}

/** A Uint8Array view (no copy) of an ArrayBuffer or any typed array. */
export function bytesOf(data) {
  return data instanceof ArrayBuffer ? new Uint8Array(data) : new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
}

function scannerFor(wasm, { specJson, calibJson, filter, crosstalk, response }, pixels, progress) {
  const key = [specJson, calibJson, crosstalk ? crosstalk.join(',') : 'none', response ? response.join(',') : 'power law'].join('\u0000');
  let entry = scanners.get(key);
  if (entry) {
    scanners.delete(key); // re-insert as most recently used
  } else {
    // Room first, so that the allocator reuses the old scanners' memory for the new one.
    const held = () => [...scanners.values()].reduce((n, e) => n + e.pixels, 0);
    while (scanners.size && (scanners.size >= MAX_SCANNERS || held() + pixels > MAX_FRAME_PIXELS)) {
      const [oldKey, old] = scanners.entries().next().value;
      scanners.delete(oldKey);
      old.scanner.free();
    }
    progress('building the scanner (FFT plans and buffers)');
    const table = (values) => (values ? Float32Array.from(values) : undefined);
    entry = { scanner: new wasm.Scanner(specJson, calibJson, filter, table(crosstalk), table(response)), pixels };
  }
  scanners.set(key, entry);
  return entry.scanner;
}

function wantedResults(want) {
  if (!Array.isArray(want)) throw new Error(`a scan's \`want\` must be a list of ${OPTIONAL_RESULTS.join(', ')}`);
  const unknown = want.filter((w) => !OPTIONAL_RESULTS.includes(w));
  if (unknown.length) throw new Error(`unknown scan results ${unknown.join(', ')}: the choices are ${OPTIONAL_RESULTS.join(', ')}`);
  return new Set(want);
}

/** The reply's arrays: the merged cloud, and those of OPTIONAL_RESULTS in `wanted`. */
function resultsOf(scanner, wanted) {
  const value = { merged: scanner.cloud(), familyCount: scanner.familyCount, width: scanner.width, height: scanner.height };
  const transfer = buffersOf(value.merged);
  if (wanted.has('families')) {
    value.families = [];
    for (let k = 0; k < scanner.familyCount; k++) value.families.push(scanner.cloud(k));
    transfer.push(...value.families.flatMap(buffersOf));
  }
  for (const name of ['depth', 'correspondence']) {
    if (!wanted.has(name)) continue;
    value[name] = scanner[name]();
    transfer.push(value[name].buffer);
  }
  if (wanted.has('stages')) {
    value.stages = stagesOf(scanner);
    transfer.push(...value.stages.map((s) => s.rgba.buffer));
  }
  return { value, transfer };
}

function buffersOf(cloud) {
  return [cloud.positions, cloud.colors, cloud.pixels, cloud.families].map((a) => a.buffer);
}

function stagesOf(scanner) {
  return scanner.stages().map((s) => {
    try {
      return { name: s.name, caption: s.caption, width: s.width, height: s.height, rgba: s.rgba() };
    } finally {
      s.free();
    }
  });
}
