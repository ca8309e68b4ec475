// Continuous scanning: which camera frames are decoded, and the figures shown meanwhile.
//
// Frames are never queued. Each new video frame becomes the one waiting for a worker and
// replaces any frame still waiting, which counts as dropped (latest wins). As soon as a
// worker is free the waiting frame is grabbed from the video and sent; pixels are grabbed
// only then, so a replaced frame costs nothing, and the grab is the newest picture the
// video holds. A result older than one already shown (two workers may finish out of
// order) is not drawn and also counts as dropped. New frames are known from the video's
// frame callbacks and, where the browser keeps one, its frame counter, which keeps
// counting when the page's drawing holds the callbacks back (see #dispatch).
//
// Latency runs from the frame's capture (the video frame's `captureTime` where the
// browser gives it, else the moment the page learnt of the frame; for a frame the
// callbacks have not reported yet, see #newestCapture) to the end of the viewer's next
// drawing, when the cloud is on screen. Drawing time is what the page
// spends on a result (frame, depth map, cloud upload) plus the viewer's drawing.

/** Rates and means shown while scanning cover the last this many milliseconds. */
const WINDOW_MS = 2000;
/** A capture time further back than this is taken for another clock and not used. */
const MAX_CAPTURE_AGE_MS = 1000;

/** Events of the last WINDOW_MS: how many per second, and the mean of their values. */
class Recent {
  #items = []; // [time, value], oldest first

  add(value, now) {
    this.#items.push([now, value]);
    this.#prune(now);
  }

  /** Events per second, over the window or the time since `since` if that is shorter. */
  rate(now, since) {
    this.#prune(now);
    const span = Math.min(WINDOW_MS, now - since);
    return span > 0 ? (1000 * this.#items.length) / span : 0;
  }

  mean() {
    return this.#items.length ? this.#items.reduce((s, [, v]) => s + v, 0) / this.#items.length : NaN;
  }

  #prune(now) {
    while (this.#items.length && now - this.#items[0][0] > WINDOW_MS) this.#items.shift();
  }
}

/**
 * The figures of one run (state.live while it runs). Counts and sums are since the start,
 * so that a reader can take rates and means over any stretch from two readings; `recent`
 * covers the last WINDOW_MS and is what the page shows.
 */
function newFigures() {
  return {
    started: performance.now(),
    arrived: 0, // camera frames: the video's frame counter, or the frame callbacks without one
    sent: 0, // frames sent to a worker
    decoded: 0, // results that came back
    shown: 0, // results on screen
    dropped: 0, // frames never sent (replaced by a newer one), and results older than one shown
    // Sums over decoded frames (workerMs, scanMs) and shown ones (drawMs, latencyMs, and
    // screenMs: from the reply's arrival to the cloud on screen).
    sums: { workerMs: 0, scanMs: 0, drawMs: 0, latencyMs: 0, screenMs: 0 },
    recent: { fps: 0, decodeFps: 0, workerMs: NaN, drawMs: NaN, latencyMs: NaN },
    workers: {}, // per worker name: {frames, firstBytes, lastBytes} of its wasm memory
  };
}

/** One line for the page: what the user sees, and what the workers and the drawing cost. */
export function describeFigures(f) {
  const r = f.recent;
  const ms = (v) => (Number.isFinite(v) ? `${v.toFixed(0)} ms` : '–');
  return (
    `${r.fps.toFixed(1)} frames/s · latency ${ms(r.latencyMs)} (capture to cloud) · ${f.dropped.toLocaleString('en')} dropped · ` +
    `decoding ${r.decodeFps.toFixed(1)} frames/s, ${ms(r.workerMs)} a frame in a worker · drawing ${ms(r.drawMs)}`
  );
}

/** One run of continuous scanning; make a new one for each run. */
export class LiveScan {
  /**
   * @param {object} hooks
   * @param {HTMLVideoElement} hooks.video the camera's video
   * @param {number} hooks.workers how many frames may decode at once
   * @param {() => ({width: number, height: number, rgba: Uint8ClampedArray} | null)} hooks.grab
   *   the video's current frame, or null to skip it
   * @param {(frame: object) => Promise<object>} hooks.decode the worker's result for a frame
   * @param {(frame: object, result: object) => void} hooks.show put a result on screen
   * @param {() => number} hooks.viewerMs how long the viewer's last drawing took
   * @param {(figures: object) => void} hooks.report runs after each result is on screen
   * @param {(error: Error) => void} hooks.fail scanning cannot go on
   */
  constructor(hooks) {
    this.hooks = hooks;
    this.figures = newFigures();
    this.stopped = false;
    this.inFlight = 0;
    this.callbacks = 0; // frame callbacks heard
    this.heard = null; // the last callback's frame: {time (its capture), counter (the video's, then)}
    this.grabbed = { counter: -1, callbacks: 0 }; // the video's counter and the callbacks at the last grab
    this.stale = 0; // results not shown: one of a later frame was already on screen
    this.pollTimer = 0;
    this.lastShown = 0; // sequence number of the newest result drawn
    this.recent = { shown: new Recent(), decoded: new Recent(), draw: new Recent(), latency: new Recent() };
  }

  /** Start listening to the video's frames; returns the figures (updated in place). */
  start() {
    const video = this.hooks.video;
    const counter = this.#counter();
    this.counterStart = counter === null ? 0 : counter - 1; // the frame on show counts
    if ('requestVideoFrameCallback' in HTMLVideoElement.prototype) {
      const onFrame = (now, meta) => {
        if (this.stopped) return;
        video.requestVideoFrameCallback(onFrame);
        this.#heard(captureTime(now, meta));
      };
      video.requestVideoFrameCallback(onFrame);
    } else {
      // Without frame callbacks: a changed playback position is a new frame.
      let last = -1;
      const onAnimation = (now) => {
        if (this.stopped) return;
        requestAnimationFrame(onAnimation);
        if (video.currentTime !== last) this.#heard(now);
        last = video.currentTime;
      };
      requestAnimationFrame(onAnimation);
    }
    this.#dispatch(); // the frame on show goes at once
    return this.figures;
  }

  /** Stop: frames are no longer sent, and results still coming are not shown. */
  stop() {
    this.stopped = true;
    clearTimeout(this.pollTimer);
  }

  /**
   * The video's count of frames received, where the browser keeps one (Chromium counts
   * camera frames as they come, however slowly the page draws); null otherwise.
   */
  #counter() {
    const n = this.hooks.video.getVideoPlaybackQuality?.().totalVideoFrames;
    return n > 0 ? n : null;
  }

  /** A frame callback: its frame is the newest the page knows the capture time of. */
  #heard(time) {
    this.callbacks++;
    this.heard = { time, counter: this.#counter() };
    this.#dispatch();
  }

  /**
   * Whether the video holds a frame newer than the last grab: its frame counter moved, or
   * without one, a frame callback came. This is the frame waiting for a worker; a newer
   * one replaces it.
   */
  #waiting() {
    const counter = this.#counter();
    return counter === null ? this.callbacks > this.grabbed.callbacks : counter > this.grabbed.counter;
  }

  /**
   * When the video's newest frame was captured: the last callback's frame if the counter
   * has not moved since; otherwise a newer frame, taken one frame interval back (it is at
   * most about that old) unless that is before the callback's frame.
   */
  #newestCapture() {
    const h = this.heard;
    const estimate = performance.now() - this.#frameInterval();
    if (!h) return estimate;
    const counter = this.#counter();
    return counter === null || counter === h.counter ? h.time : Math.max(h.time, estimate);
  }

  /**
   * Send the waiting frame to each free worker. Frame callbacks come with the page's
   * drawing, which can lag the camera (software WebGL drawing a large cloud); the frame
   * counter does not, so a free worker takes a new frame at once, and looks again every
   * half frame interval while it has none.
   */
  #dispatch() {
    clearTimeout(this.pollTimer);
    while (!this.stopped && this.inFlight < this.hooks.workers && this.#waiting()) {
      const captured = this.#newestCapture();
      this.grabbed = { counter: this.#counter() ?? -1, callbacks: this.callbacks };
      const frame = this.hooks.grab();
      if (frame) this.#send(frame, captured); // a frame not grabbed counts as dropped
    }
    this.#account();
    if (!this.stopped && this.inFlight < this.hooks.workers) {
      this.pollTimer = setTimeout(() => this.#dispatch(), this.#frameInterval() / 2);
    }
  }

  /** The camera's frame interval in ms (30 frames per second where it does not say). */
  #frameInterval() {
    const rate = this.hooks.video.srcObject?.getVideoTracks?.()[0]?.getSettings().frameRate;
    return 1000 / (rate > 0 ? rate : 30);
  }

  /** Frames that came, and those neither decoded, nor on their way, nor waiting. */
  #account() {
    const f = this.figures;
    const counter = this.#counter();
    f.arrived = Math.max(this.callbacks, counter === null ? 0 : counter - this.counterStart);
    f.dropped = Math.max(0, f.arrived - f.sent - (this.#waiting() ? 1 : 0)) + this.stale;
  }

  #send(frame, captured) {
    const seq = ++this.figures.sent;
    this.inFlight++;
    this.hooks
      .decode(frame)
      .then((result) => this.#received(frame, result, seq, captured))
      .catch((e) => this.stopped || this.hooks.fail(e))
      .finally(() => {
        this.inFlight--;
        this.#dispatch();
      });
  }

  #received(frame, result, seq, captured) {
    if (this.stopped) return;
    const f = this.figures;
    const now = performance.now();
    f.decoded++;
    f.sums.workerMs += result.workerMs;
    f.sums.scanMs += result.ms;
    this.recent.decoded.add(result.workerMs, now);
    noteMemory(f.workers, result);
    if (seq < this.lastShown) {
      this.stale++;
      this.#account();
      return;
    }
    this.lastShown = seq;
    this.hooks.show(frame, result);
    const pageMs = performance.now() - now;
    // Runs after the viewer's drawing, which show() asked for first.
    requestAnimationFrame(() => {
      if (this.stopped) return;
      const end = performance.now();
      const drawMs = pageMs + this.hooks.viewerMs();
      const latencyMs = end - captured;
      f.shown++;
      f.sums.drawMs += drawMs;
      f.sums.latencyMs += latencyMs;
      f.sums.screenMs += end - now;
      const r = this.recent;
      r.shown.add(1, end);
      r.draw.add(drawMs, end);
      r.latency.add(latencyMs, end);
      f.recent = {
        fps: r.shown.rate(end, f.started),
        decodeFps: r.decoded.rate(end, f.started),
        workerMs: r.decoded.mean(),
        drawMs: r.draw.mean(),
        latencyMs: r.latency.mean(),
      };
      this.hooks.report(f);
    });
  }
}

/** When a video frame was captured, on the page's clock (see the top of this file). */
function captureTime(now, meta) {
  const t = meta?.captureTime;
  const current = performance.now();
  return Number.isFinite(t) && t <= current && current - t < MAX_CAPTURE_AGE_MS ? t : now;
}

/** Record the wasm memory of the worker that sent `result`. */
function noteMemory(workers, { worker, memoryBytes }) {
  if (!worker || !Number.isFinite(memoryBytes)) return;
  const w = (workers[worker] ??= { frames: 0, firstBytes: memoryBytes, lastBytes: memoryBytes });
  w.frames++;
  w.lastBytes = memoryBytes;
}
