// The page's one way to talk to the decoding workers (protocol: worker.js).
//
// `request(type, payload, transfer)` returns a promise for the worker's reply. Requests
// go to the worker with the fewest outstanding requests, so with two workers two frames
// decode at once (the target machine has two cores). A worker that crashes (a Rust
// panic, or an uncaught error) or leaves a request unanswered too long (hung) fails its
// outstanding requests with the reason and is replaced by a fresh one; the page keeps
// working.

/** A worker that fails this many times within RESTART_WINDOW_MS is not restarted again. */
const MAX_RESTARTS = 5;
const RESTART_WINDOW_MS = 60_000;

/**
 * How long a request may go unanswered before its worker is taken for hung, replaced, and
 * its requests failed: REPLY_LIMIT_MS, plus REPLY_MS_PER_PIXEL for each pixel of a frame
 * the request carries (a 12-megapixel scan gets about 2.5 minutes, a VGA one 23 s). A
 * worker hangs where a thread of its pool (pkg-threads/) panics: the pool thread stops,
 * and the worker waits for its part of the frame for ever.
 */
const REPLY_LIMIT_MS = 20_000;
const REPLY_MS_PER_PIXEL = 0.01;

export class WorkerBridge {
  /**
   * @param {URL} url module worker script
   * @param {{count?: number, onEvent?: (event: {kind: string, message: string}) => void}} options
   *   `onEvent` hears 'startup-error', 'crash' and 'note' events for the page to show
   *   ('note': threads were asked for and did not start).
   */
  constructor(url, { count = 1, onEvent = () => {} } = {}) {
    this.url = url;
    this.onEvent = onEvent;
    this.nextId = 1;
    this.restarts = [];
    this.slots = Array.from({ length: count }, (_, i) => this.#spawn(i));
  }

  /** Resolves once every worker has loaded wasm; rejects with the first start-up error. */
  ready() {
    return Promise.all(this.slots.map((s) => s.ready));
  }

  /** Threads a worker scans a frame on (1 until the workers are ready, or without threads). */
  get threads() {
    return Math.max(1, ...this.slots.map((s) => s.threads ?? 1));
  }

  /** Number of requests waiting for a reply, over all workers. */
  get pending() {
    return this.slots.reduce((n, s) => n + s.pending.size, 0);
  }

  /**
   * Send `{type, id, ...payload}` to the least busy worker.
   * @param {string} type request type (see worker.js)
   * @param {object} payload fields of the request
   * @param {Transferable[]} transfer buffers to move to the worker (they become unusable here)
   * @param {{onProgress?: (message: string) => void, limitMs?: number, scans?: number}} options
   *   `limitMs`: how long to wait for the reply before the worker is taken for hung
   *   (default: REPLY_LIMIT_MS and the frame's size, see there, times `scans`: how many
   *   times the request scans its frame, 1 unless said)
   */
  request(type, payload = {}, transfer = [], { onProgress, limitMs, scans = 1 } = {}) {
    const slot = this.slots.reduce((a, b) => (b.pending.size < a.pending.size ? b : a));
    const id = this.nextId++;
    const pixels = (payload.width * payload.height) || 0;
    const limit = limitMs ?? REPLY_LIMIT_MS + REPLY_MS_PER_PIXEL * pixels * scans;
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        const seconds = (limit / 1000).toFixed(limit < 10_000 ? 1 : 0);
        this.#crashed(slot, `The decoder stopped answering (no reply to ${type} in ${seconds} s)`);
      }, limit);
      const settle = (fn) => (value) => {
        clearTimeout(timer);
        fn(value);
      };
      slot.pending.set(id, { resolve: settle(resolve), reject: settle(reject), onProgress });
      try {
        slot.worker.postMessage({ ...payload, type, id }, transfer);
      } catch (e) {
        slot.pending.delete(id);
        settle(reject)(e);
      }
    });
  }

  /** Stop every worker; outstanding requests fail. */
  terminate() {
    for (const slot of this.slots) this.#fail(slot, 'the page stopped the decoder');
    for (const slot of this.slots) slot.worker.terminate();
  }

  #spawn(index) {
    const worker = new Worker(this.url, { type: 'module', name: `stripelight-decoder-${index}` });
    const slot = { index, worker, pending: new Map(), started: false };
    slot.ready = new Promise((resolve, reject) => {
      slot.onReady = resolve;
      slot.onStartupError = reject;
    });
    slot.ready.catch(() => {}); // reported through onEvent; callers may also await ready()
    worker.onmessage = (event) => this.#receive(slot, event.data);
    worker.onerror = (event) => {
      event.preventDefault();
      const reason = event.message || 'the worker script failed to load (is pkg/ built? run scripts/build-web.sh)';
      if (!slot.started) {
        this.#startupFailed(slot, reason);
      } else {
        this.#crashed(slot, `the decoder stopped: ${reason}`);
      }
    };
    worker.onmessageerror = () => this.#crashed(slot, 'a message from the decoder could not be read');
    return slot;
  }

  #receive(slot, msg) {
    switch (msg.type) {
      case 'ready':
        slot.started = true;
        slot.threads = msg.threads;
        if (msg.note && !this.noted) {
          this.noted = true;
          this.onEvent({ kind: 'note', message: `The decoder scans on one thread: ${msg.note}.` });
        }
        slot.onReady();
        break;
      case 'startup-error':
        this.#startupFailed(slot, msg.message);
        break;
      case 'progress':
        slot.pending.get(msg.id)?.onProgress?.(msg.message);
        break;
      case 'reply': {
        const entry = slot.pending.get(msg.id);
        if (!entry) break;
        slot.pending.delete(msg.id);
        if (msg.ok) entry.resolve(msg.value);
        else entry.reject(new Error(msg.error));
        if (msg.fatal) this.#crashed(slot, msg.error);
        break;
      }
      default:
        console.warn('stripelight: unknown message from the worker', msg);
    }
  }

  #startupFailed(slot, reason) {
    slot.onStartupError(new Error(reason));
    this.#fail(slot, `the decoder did not start: ${reason}`);
    this.onEvent({ kind: 'startup-error', message: `The decoder could not start: ${reason}` });
  }

  #crashed(slot, reason) {
    if (slot.replaced) return;
    slot.replaced = true;
    this.#fail(slot, reason);
    slot.worker.terminate();
    const now = Date.now();
    this.restarts = this.restarts.filter((t) => now - t < RESTART_WINDOW_MS);
    if (this.restarts.length >= MAX_RESTARTS) {
      this.onEvent({ kind: 'crash', message: `${reason}. It crashed too often to be restarted; reload the page.` });
      return;
    }
    this.restarts.push(now);
    this.slots[slot.index] = this.#spawn(slot.index);
    this.onEvent({ kind: 'crash', message: `${reason}. Decoder ${slot.index + 1} was restarted and takes the next request.` });
  }

  #fail(slot, reason) {
    for (const { reject } of slot.pending.values()) reject(new Error(reason));
    slot.pending.clear();
  }
}
