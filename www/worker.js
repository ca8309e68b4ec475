// The decoding worker: loads the wasm package once and answers typed messages.
//
// Protocol (the page talks to it only through bridge.js):
//   worker -> page  {type: 'ready', threads, note}          wasm is loaded; a scan runs on
//                                                            `threads` threads; `note`
//                                                            says why not on more, if asked
//                   {type: 'startup-error', message}        wasm could not be loaded
//                   {type: 'progress', id, message}         a request is under way
//                   {type: 'reply', id, ok: true, value}    a request succeeded
//                   {type: 'reply', id, ok: false, error, fatal}
//                                                            it failed; `fatal` means the
//                                                            wasm instance panicked or ran
//                                                            out of memory, and this worker
//                                                            closes and must be replaced
//   page -> worker  {type, id, ...payload}                  one of the request types in
//                                                            `handlers` below
// Messages that arrive while wasm is loading wait in a queue and run in order once it
// has loaded. Result buffers are transferred, never copied. Frames larger than
// MAX_FRAME_PIXELS (frame-size.js) are refused before they are decoded or scanned.
// Scanning, and which results a scan reply carries (`want`), is worker-scan.js.
// `panicForTest` and `outOfMemoryForTest` exist only for the end-to-end test.

import { imageSize } from './frame-size.js';
import { bytesOf, refuseLargeFrame, scanFrame } from './worker-scan.js';

let state = 'loading'; // 'loading' | 'ready' | 'failed'
let startupError = '';
/** The wasm package's module (set once it has loaded): pkg-threads/ or pkg/. */
let wasm = null;
/** The instance's WebAssembly.Memory (set once wasm has loaded). */
let memory = null;
const queue = [];

/** The gammas the page assumes for a camera's codes and a projector's levels (the
 * command line's defaults). */
const CAMERA_GAMMA = 2.2;
const PROJECTOR_GAMMA = 2.2;

/**
 * A camera response (256 linear values) with how far it departs from the power law and
 * whether that is more than a measurement's own noise (`powerLaw`: read it as the power
 * law).
 */
function describeResponse(values) {
  const departure = wasm.responseDeparture(Float32Array.from(values), CAMERA_GAMMA);
  return { values, departure, powerLaw: departure <= wasm.powerLawTolerance() };
}

/**
 * How many threads the page asks for (`?threads=N` on this script's URL, bridge.js):
 * 0 or none loads pkg/, which scans on this worker's one thread; N > 0 loads
 * pkg-threads/ (WebAssembly threads: shared memory and a pool of N web workers, on which
 * a frame's families and tiles run at once). That needs cross-origin isolation; where it
 * is missing, or pkg-threads/ fails to load or start its pool, pkg/ is loaded instead.
 */
const THREADS_ASKED = Math.max(0, Math.min(16, Number(new URL(self.location.href).searchParams.get('threads')) || 0));

/** Load a package; resolves to {module, memory, threads, note}. */
async function loadWasm() {
  let note = '';
  if (THREADS_ASKED > 0 && !self.crossOriginIsolated) {
    note = 'the page is not cross-origin isolated, so WebAssembly threads are off';
  } else if (THREADS_ASKED > 0) {
    try {
      const module = await import('../pkg-threads/stripelight.js');
      const exports = await module.default();
      await module.initThreadPool(THREADS_ASKED);
      return { module, memory: exports.memory, threads: module.threadCount(), note };
    } catch (e) {
      note = `WebAssembly threads did not start (${messageOf(e)})`;
    }
  }
  if (note) console.warn(`stripelight: ${note}; scanning on one thread`);
  const module = await import('../pkg/stripelight.js');
  const exports = await module.default();
  return { module, memory: exports.memory, threads: 1, note };
}

function image(img) {
  try {
    const rgba = img.rgba();
    return { value: { width: img.width, height: img.height, rgba }, transfer: [rgba.buffer] };
  } finally {
    img.free();
  }
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
  estimateCrosstalk({ frames, width, height, response }) {
    const [r, g, b, k] = frames.map(bytesOf);
    const table = response ? Float32Array.from(response) : undefined;
    return { value: [...wasm.estimateCrosstalk(r, g, b, k, width, height, CAMERA_GAMMA, table)] };
  },
  // The mixing read from the stripes of one scanned frame (`stripelight scan --crosstalk
  // frame`): the frame is scanned a few times on a scanner of its own, not kept.
  estimateCrosstalkFromFrame({ specJson, calibJson, filter, response, rgba, width, height }, id) {
    refuseLargeFrame(width, height);
    progress(id, `estimating the colour mixing from a ${width}x${height} frame`);
    const table = response ? Float32Array.from(response) : undefined;
    return { value: [...wasm.estimateCrosstalkFromFrame(specJson, calibJson, filter, table, bytesOf(rgba), width, height)] };
  },
  estimateResponse({ frames, width, height, greyLevel }) {
    const [white, grey, black] = frames.map(bytesOf);
    const values = [...wasm.estimateResponse(white, grey, black, width, height, greyLevel, CAMERA_GAMMA, PROJECTOR_GAMMA)];
    return { value: describeResponse(values) };
  },
  parseResponse({ text }) {
    return { value: describeResponse([...wasm.parseResponse(text)]) };
  },
  responseJson({ values }) {
    return { value: wasm.responseJson(Float32Array.from(values)) };
  },
  renderScene({ name, specJson, calibJson, seed }, id) {
    progress(id, `simulating the ${name} scene`);
    return image(wasm.renderScene(name, specJson, calibJson, seed >>> 0));
  },
  decodeImage({ bytes }) {
    const data = bytesOf(bytes);
    const size = imageSize(data);
    if (size) refuseLargeFrame(size.width, size.height);
    return image(wasm.decodeImage(data));
  },
  scan(msg, id) {
    return scanFrame(msg, (message) => progress(id, message), wasm, memory);
  },
  parseCrosstalk({ text }) {
    return { value: [...wasm.parseCrosstalk(text)] };
  },
  encodePly({ positions, colors, pixels, families, ascii }) {
    const bytes = wasm.encodePly(positions, colors, pixels, families, Boolean(ascii));
    return { value: bytes, transfer: [bytes.buffer] };
  },
  encodePfmRgb({ values, width, height }) {
    const bytes = wasm.encodePfmRgb(values, width, height);
    return { value: bytes, transfer: [bytes.buffer] };
  },
  encodePfm({ depth, width, height }) {
    const bytes = wasm.encodePfm(depth, width, height);
    return { value: bytes, transfer: [bytes.buffer] };
  },
  panicForTest({ inPool }) {
    wasm.panicForTest(Boolean(inPool));
    return { value: null };
  },
  // Runs out of memory the way a huge frame does: the instance's memory is grown to the
  // most the engine allows (as earlier huge frames leave it), then bytes that fit in no
  // free block are handed to the decoder, whose allocator then fails for real.
  outOfMemoryForTest() {
    const held = memory.buffer.byteLength;
    for (let pages = 32768; pages >= 1; pages >>= 1) {
      try {
        for (;;) memory.grow(pages);
      } catch {
        // at most `pages` short of the maximum: try a smaller step
      }
    }
    wasm.decodeImage(new Uint8Array(held + 2 ** 20));
    return { value: null };
  },
};

/**
 * Whether an error means memory ran out. An allocation that fails inside the decoder
 * aborts, which surfaces as a trap (a RuntimeError, like a panic) whose stack names the
 * allocator's failure path (the package keeps its function names); memory that the engine
 * cannot grow or allocate for JavaScript arrays is a RangeError.
 */
function isOutOfMemory(e) {
  if (e instanceof WebAssembly.RuntimeError) return OOM_FRAMES.test(e.stack ?? '');
  return e instanceof RangeError && /memory|alloc/i.test(e.message);
}

/** Rust's allocation-failure handler, and wasm-bindgen's allocator for arguments. */
const OOM_FRAMES = /handle_alloc_error|__rust_alloc_error_handler|rust_oom|__wbindgen_malloc/;

/** The memory the instance holds, in MB, for crash messages. */
function memoryInUse() {
  return memory ? `${Math.round(memory.buffer.byteLength / 2 ** 20).toLocaleString('en')} MB` : 'an unknown amount';
}

/** The size a request's frame has, where it carries one, for crash messages. */
function frameOf(msg) {
  return msg.width && msg.height ? ` on a ${msg.width}x${msg.height} frame` : '';
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
    // A Rust panic (or an allocation failing inside Rust) surfaces as a
    // WebAssembly.RuntimeError ("unreachable"), memory that runs out in the engine as a
    // RangeError. Either way the instance may be inconsistent afterwards, and its memory
    // never shrinks again, so this worker closes and asks to be replaced.
    const oom = isOutOfMemory(e);
    const fatal = oom || e instanceof WebAssembly.RuntimeError;
    let error = messageOf(e);
    if (oom) {
      const how = e instanceof RangeError ? e.message : 'an allocation failed';
      error = `The decoder ran out of memory${frameOf(msg)} (${how} with ${memoryInUse()} in use; WebAssembly gives a worker at most 4 GB)`;
    } else if (fatal) {
      error = `The decoder crashed${frameOf(msg)} (${e.message}, with ${memoryInUse()} in use)`;
    }
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

loadWasm()
  .then((loaded) => {
    ({ module: wasm, memory } = loaded);
    state = 'ready';
    postMessage({ type: 'ready', threads: loaded.threads, note: loaded.note });
  })
  .catch((e) => {
    state = 'failed';
    startupError = messageOf(e);
    postMessage({ type: 'startup-error', message: startupError });
  })
  .finally(() => {
    while (queue.length) handle(queue.shift());
  });
