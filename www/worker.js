// The decoding worker: loads the wasm package once and answers typed messages.
//
// Protocol (the page talks to it only through bridge.js):
//   worker -> page  {type: 'ready'}                         wasm is loaded
//                   {type: 'startup-error', message}        wasm could not be loaded
//                   {type: 'progress', id, message}         a request is under way
//                   {type: 'reply', id, ok: true, value}    a request succeeded
//                   {type: 'reply', id, ok: false, error, fatal}
//                                                            it failed; `fatal` means the
//                                                            wasm instance panicked and this
//                                                            worker must be replaced
//   page -> worker  {type, id, ...payload}                  one of the request types in
//                                                            `handlers` below
// Messages that arrive while wasm is loading wait in a queue and run in order once it
// has loaded. Result buffers are transferred, never copied.

import init, * as wasm from '../pkg/stripelight.js';

/** Scanners kept alive, keyed by spec and calibration (the size comes with the calibration). */
const MAX_SCANNERS = 3;
const scanners = new Map();

let state = 'loading'; // 'loading' | 'ready' | 'failed'
let startupError = '';
const queue = [];

function scannerFor(specJson, calibJson, filter, crosstalk, id) {
  const key = [specJson, calibJson, crosstalk ? crosstalk.join(',') : 'none'].join('\u0000');
  let scanner = scanners.get(key);
  if (scanner) {
    scanners.delete(key); // re-insert as most recently used
  } else {
    progress(id, 'building the scanner (FFT plans and buffers)');
    scanner = new wasm.Scanner(specJson, calibJson, filter, crosstalk ? Float32Array.from(crosstalk) : undefined);
    while (scanners.size >= MAX_SCANNERS) {
      const [oldKey, old] = scanners.entries().next().value;
      scanners.delete(oldKey);
      old.free();
    }
  }
  scanners.set(key, scanner);
  return scanner;
}

function image(img) {
  try {
    const rgba = img.rgba();
    return { value: { width: img.width, height: img.height, rgba }, transfer: [rgba.buffer] };
  } finally {
    img.free();
  }
}

function buffersOf(cloud) {
  return [cloud.positions, cloud.colors, cloud.pixels, cloud.families].map((a) => a.buffer);
}

/** Each handler takes the message and returns {value, transfer}. */
const handlers = {
  generatePattern({ directions, width, height }) {
    return { value: wasm.generatePattern(directions, width, height) };
  },
  parseSpec({ json }) {
    return { value: wasm.parseSpec(json) };
  },
  renderPattern({ specJson }) {
    return image(wasm.renderPattern(specJson));
  },
  defaultCalibration() {
    return { value: wasm.defaultCalibration() };
  },
  parseCalibration({ json }) {
    return { value: wasm.parseCalibration(json) };
  },
  calibrationFromRig({ rig }) {
    return { value: wasm.calibrationFromRig(JSON.stringify(rig)) };
  },
  sceneNames() {
    return { value: wasm.sceneNames() };
  },
  saturationLevel() {
    return { value: wasm.saturationLevel() };
  },
  simulatorCrosstalk() {
    return { value: [...wasm.simulatorCrosstalk()] };
  },
  estimateCrosstalk({ frames, width, height }) {
    const [r, g, b, k] = frames.map(bytesOf);
    return { value: [...wasm.estimateCrosstalk(r, g, b, k, width, height, 2.2)] };
  },
  renderScene({ name, specJson, calibJson, seed }, id) {
    progress(id, `simulating the ${name} scene`);
    return image(wasm.renderScene(name, specJson, calibJson, seed >>> 0));
  },
  decodeImage({ bytes }) {
    return image(wasm.decodeImage(bytesOf(bytes)));
  },
  scan({ specJson, calibJson, filter, crosstalk, width, height, rgba, stages }, id) {
    const scanner = scannerFor(specJson, calibJson, filter, crosstalk, id);
    scanner.setFilter(filter);
    progress(id, `decoding a ${width}x${height} frame (${filter})`);
    const t0 = performance.now();
    const stats = JSON.parse(scanner.scan(bytesOf(rgba), width, height));
    const ms = performance.now() - t0;
    // The results stay in the scanner until its next frame; each array is copied out
    // once and then transferred.
    const merged = scanner.cloud();
    const families = [];
    for (let k = 0; k < scanner.familyCount; k++) families.push(scanner.cloud(k));
    const depth = scanner.depth();
    const value = {
      merged,
      families,
      depth,
      width: scanner.width,
      height: scanner.height,
      stats,
      ms,
      stages: stages ? stagesOf(scanner) : [],
    };
    const transfer = [merged, ...families].flatMap(buffersOf);
    transfer.push(depth.buffer, ...value.stages.map((s) => s.rgba.buffer));
    return { value, transfer };
  },
  parseCrosstalk({ text }) {
    return { value: [...wasm.parseCrosstalk(text)] };
  },
  encodePly({ positions, colors, pixels, families, ascii }) {
    const bytes = wasm.encodePly(positions, colors, pixels, families, Boolean(ascii));
    return { value: bytes, transfer: [bytes.buffer] };
  },
  encodePfm({ depth, width, height }) {
    const bytes = wasm.encodePfm(depth, width, height);
    return { value: bytes, transfer: [bytes.buffer] };
  },
  panicForTest() {
    wasm.panicForTest();
    return { value: null };
  },
};

function stagesOf(scanner) {
  return scanner.stages().map((s) => {
    try {
      return { name: s.name, caption: s.caption, width: s.width, height: s.height, rgba: s.rgba() };
    } finally {
      s.free();
    }
  });
}

/** A Uint8Array view (no copy) of an ArrayBuffer or any typed array. */
function bytesOf(data) {
  return data instanceof ArrayBuffer ? new Uint8Array(data) : new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
}

function progress(id, message) {
  if (id !== undefined) postMessage({ type: 'progress', id, message });
}

function handle(msg) {
  const { type, id } = msg;
  const handler = Object.hasOwn(handlers, type) ? handlers[type] : null;
  if (!handler) {
    postMessage({ type: 'reply', id, ok: false, error: `unknown request type ${JSON.stringify(type)}`, fatal: false });
    return;
  }
  if (state === 'failed') {
    postMessage({ type: 'reply', id, ok: false, error: `the decoder did not start: ${startupError}`, fatal: false });
    return;
  }
  try {
    const { value, transfer = [] } = handler(msg, id);
    postMessage({ type: 'reply', id, ok: true, value }, transfer);
  } catch (e) {
    // A Rust panic surfaces as a WebAssembly.RuntimeError ("unreachable"); the instance
    // may be inconsistent afterwards, so this worker asks to be replaced.
    const fatal = e instanceof WebAssembly.RuntimeError;
    const error = fatal ? `The decoder crashed (${e.message})` : messageOf(e);
    postMessage({ type: 'reply', id, ok: false, error, fatal });
    if (fatal) close();
  }
}

function messageOf(e) {
  return e instanceof Error ? e.message : String(e);
}

self.onmessage = (event) => {
  if (state === 'loading') queue.push(event.data);
  else handle(event.data);
};

init()
  .then(() => {
    state = 'ready';
    postMessage({ type: 'ready' });
  })
  .catch((e) => {
    state = 'failed';
    startupError = messageOf(e);
    postMessage({ type: 'startup-error', message: startupError });
  })
  .finally(() => {
    while (queue.length) handle(queue.shift());
  });
