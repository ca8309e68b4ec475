// What every panel of the scanner page shares: the page's state, the decoding workers,
// the status line and the corner messages, and two small helpers (drawing RGBA pixels
// into a canvas, saving bytes as a download). Nothing here knows about any one panel.

import { WorkerBridge } from './bridge.js';

const params = new URLSearchParams(location.search);

/**
 * Threads per decoding worker: where the page is cross-origin isolated (scripts/serve.py
 * sends the headers), each worker loads pkg-threads/ and scans a frame on a pool of this
 * many threads, one a core (at most 4); `?threads=0` in the page's address, or no
 * isolation, gives 0: pkg/, one thread a worker.
 */
export const THREADS = self.crossOriginIsolated && params.get('threads') !== '0'
  ? Math.min(4, Math.max(2, navigator.hardwareConcurrency || 2)) : 0;

/**
 * Decoding workers: the target machine has two cores, so two frames decode at once, with
 * threads too (on the end-to-end test's page one threaded worker gave 5 frames per second
 * and 240 ms latency, two gave 7 and 280 ms).
 */
export const WORKERS = 2;

/** The element with this id (every element the panels touch has one). */
export const $ = (id) => document.getElementById(id);

/**
 * The page's state: one object, so that the console and the end-to-end test can read it
 * as `stripelight.state`. Each group of fields is written by the module named above it.
 */
export const state = {
  // panel-pattern.js
  directions: 2,
  specJson: '',
  spec: null,
  specSource: 'generated', // 'generated' | file name
  patternPixels: null, // {width, height, rgba} of the spec, for the projector window
  // panel-calibration.js
  calibJson: '',
  calib: null,
  calibSource: 'demo', // 'demo' | 'rig' | file name
  // The camera's colour mixing for camera and dropped frames: 'none', 'simulator' or
  // 'measured'. Simulated frames always use the simulator's, which is known exactly.
  crosstalk: 'none',
  simulatorCrosstalk: null, // 9 numbers, row-major (set once at start-up by app.js)
  measuredCrosstalk: null, // 9 numbers, row-major, typed by the user or measured
  // The camera's response for camera and dropped frames: null for the power law, or
  // {values: 256 linear values, departure, source: 'measured' | file name}.
  response: null,
  // panel-results.js (the teaching view's filter choice)
  filter: 'loggrad',
  // panel-frames.js
  frames: [],
  current: null,
  // panel-camera.js
  continuous: false,
  live: null, // figures of the latest run of continuous scanning (live.js)
  // projector-link.js
  projectorWindow: null,
  // busy() below
  busy: 0,
};

/** The decoding workers (worker.js) behind one promise queue; a crash shows as a message. */
export const bridge = new WorkerBridge(new URL(`./worker.js?threads=${THREADS}`, import.meta.url), {
  count: WORKERS,
  onEvent: ({ kind, message }) => showMessage(message, kind === 'note' ? 'info' : 'error'),
});

/** Show a message in the corner; errors stay until dismissed, notes fade. */
export function showMessage(text, kind = 'info') {
  const box = $('messages');
  // The same message twice (both workers failing alike) is shown once.
  for (const old of [...box.children]) if (old.firstChild.textContent === text) old.remove();
  const item = document.createElement('div');
  item.className = `message ${kind}`;
  item.setAttribute('role', kind === 'error' ? 'alert' : 'status');
  const span = document.createElement('span');
  span.textContent = text;
  const close = document.createElement('button');
  close.className = 'close';
  close.type = 'button';
  close.setAttribute('aria-label', 'dismiss');
  close.textContent = '×';
  close.onclick = () => item.remove();
  item.append(span, close);
  box.prepend(item);
  while (box.children.length > 4) box.lastElementChild.remove();
  if (kind !== 'error') setTimeout(() => item.remove(), 12_000);
  if (kind === 'error') console.warn('stripelight:', text);
}

/** The one-line status at the top of the page. */
export function setStatus(text) {
  $('status').textContent = text;
}

/** Run `task` with `label` as the status and the page marked busy until it settles. */
export async function busy(label, task) {
  state.busy++;
  document.body.classList.add('busy');
  setStatus(label);
  try {
    return await task();
  } finally {
    state.busy--;
    if (!state.busy) document.body.classList.remove('busy');
  }
}

/** Draw an RGBA image into a canvas, scaled down to `maxWidth` CSS pixels if given. */
export function drawImage(canvas, img, maxWidth) {
  const data = new ImageData(new Uint8ClampedArray(img.rgba.buffer, img.rgba.byteOffset, img.rgba.byteLength), img.width, img.height);
  if (!maxWidth) {
    canvas.width = img.width;
    canvas.height = img.height;
    canvas.getContext('2d').putImageData(data, 0, 0);
    return;
  }
  const scale = Math.min(1, maxWidth / img.width);
  canvas.width = Math.round(img.width * scale);
  canvas.height = Math.round(img.height * scale);
  const full = new OffscreenCanvas(img.width, img.height);
  full.getContext('2d').putImageData(data, 0, 0);
  canvas.getContext('2d').drawImage(full, 0, 0, canvas.width, canvas.height);
}

/** Save bytes (or a string) as a file the browser downloads. */
export function download(bytes, name, type) {
  const url = URL.createObjectURL(new Blob([bytes], { type }));
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}
