// Webcam capture: device choice, a resolution request, a live preview, fixed exposure
// and white balance where the track allows it, an exposure meter, and frame grabs as
// RGBA for the decoder. A camera that ends by itself (unplugged, switched off, taken by
// another program) is stopped here and reported to the page.

/** Fraction of clipped pixels above which a frame counts as over-exposed. */
const CLIPPED_LIMIT = 0.02;
/** Mean brightness (0..255, max over channels) below which a frame counts as too dark. */
const DARK_MEAN = 45;
/** A channel at or above this value is clipped. */
/** Camera values from this level count as clipped; the decoder's own level
 * (`raster::SATURATED`), set from the worker at start-up (`Camera.clipLevel`). */
let clipLevel = 255;
/** Exposure meter size: a cheap thumbnail is plenty for percentages. */
const METER_WIDTH = 160;

/** A sentence a person can act on for a getUserMedia failure. */
export function describeCameraError(e) {
  switch (e?.name) {
    case 'NotAllowedError':
    case 'SecurityError':
      return 'Camera access was denied. Allow the camera for this page in the browser’s site settings and press “Start camera” again, or drop image files instead.';
    case 'NotFoundError':
      return 'No camera was found. Connect one and press “Start camera”, or drop image files instead.';
    case 'OverconstrainedError':
      return `The camera cannot give the requested ${e.constraint || 'settings'}; choose another camera or resolution.`;
    case 'NotReadableError':
    case 'AbortError':
      return 'The camera could not be opened: another program may be using it.';
    default:
      return `The camera could not be started: ${e?.message || e}`;
  }
}

export class Camera {
  /** Set the level from which the exposure meter counts a value as clipped. */
  static set clipLevel(level) {
    clipLevel = level;
  }

  /**
   * @param {HTMLVideoElement} video live preview
   * @param {HTMLCanvasElement} meterCanvas exposure thumbnail (clipped pixels red, dark ones blue)
   * @param {(report: {clipped: number, dark: number, mean: number, verdict: string}) => void} onMeter
   * @param {() => void} onEnded the running camera's track ended without the page stopping
   *   it; the camera is already stopped when this runs
   */
  constructor(video, meterCanvas, onMeter, onEnded) {
    this.video = video;
    this.meterCanvas = meterCanvas;
    this.onMeter = onMeter;
    this.onEnded = onEnded;
    this.stream = null;
    this.grabCanvas = document.createElement('canvas');
    this.meterTimer = 0;
  }

  get running() {
    return Boolean(this.stream);
  }

  get track() {
    return this.stream?.getVideoTracks()[0] ?? null;
  }

  /** Video inputs as {deviceId, label}; labels are empty until access was granted once. */
  static async devices() {
    if (!navigator.mediaDevices?.enumerateDevices) return [];
    const all = await navigator.mediaDevices.enumerateDevices();
    return all.filter((d) => d.kind === 'videoinput').map((d, i) => ({ deviceId: d.deviceId, label: d.label || `camera ${i + 1}` }));
  }

  /**
   * Open a camera. Returns {width, height, notes}: the size the camera actually gives and
   * what could or could not be fixed. Throws the getUserMedia error (see describeCameraError).
   */
  async start({ deviceId = '', width = 640, height = 480, lockExposure = true } = {}) {
    this.stop();
    if (!navigator.mediaDevices?.getUserMedia) {
      const e = new Error('this browser offers no camera access here (it needs https or localhost)');
      e.name = 'SecurityError';
      throw e;
    }
    const video = { width: { ideal: width }, height: { ideal: height }, frameRate: { ideal: 30 } };
    if (deviceId) video.deviceId = { exact: deviceId };
    const stream = await navigator.mediaDevices.getUserMedia({ video, audio: false });
    this.stream = stream;
    // `ended` fires when the device goes away, never for the page's own track.stop().
    for (const track of stream.getTracks()) track.addEventListener('ended', () => this.#ended(stream), { once: true });
    this.video.srcObject = stream;
    await this.video.play().catch(() => {});
    await this.#firstFrame(stream);
    const notes = lockExposure ? await this.#lockAutomatics() : ['exposure and white balance left automatic'];
    this.#startMeter();
    return { width: this.video.videoWidth, height: this.video.videoHeight, notes };
  }

  stop() {
    clearInterval(this.meterTimer);
    this.meterTimer = 0;
    for (const t of this.stream?.getTracks() ?? []) t.stop();
    this.stream = null;
    this.video.srcObject = null;
  }

  /** Adjustable settings the track offers: [{name, min, max, step, value}]. */
  adjustable() {
    const track = this.track;
    if (!track?.getCapabilities) return [];
    const caps = track.getCapabilities();
    const settings = track.getSettings();
    return ['exposureTime', 'exposureCompensation', 'colorTemperature', 'brightness']
      .filter((name) => caps[name] && typeof caps[name].min === 'number')
      .map((name) => ({ name, ...caps[name], value: settings[name] ?? caps[name].min }));
  }

  async set(name, value) {
    await this.track?.applyConstraints({ advanced: [{ [name]: value }] });
  }

  /** The current video frame as {width, height, rgba: Uint8ClampedArray}. */
  capture() {
    const { videoWidth: width, videoHeight: height } = this.video;
    if (!this.running || !width || !height) throw new Error('the camera is not running');
    const c = this.grabCanvas;
    if (c.width !== width || c.height !== height) {
      c.width = width;
      c.height = height;
    }
    const ctx = c.getContext('2d', { willReadFrequently: true });
    ctx.drawImage(this.video, 0, 0, width, height);
    return { width, height, rgba: ctx.getImageData(0, 0, width, height).data };
  }

  /** The device ended `stream`: stop (if it is still this camera's) and tell the page. */
  #ended(stream) {
    if (this.stream !== stream) return;
    this.stop();
    this.onEnded();
  }

  #firstFrame(stream) {
    return new Promise((resolve, reject) => {
      const started = performance.now();
      const check = () => {
        if (this.stream !== stream) reject(new Error('the camera ended while it was starting'));
        else if (this.video.videoWidth > 0 && this.video.readyState >= 2) resolve();
        else if (performance.now() - started > 10_000) reject(new Error('the camera gave no picture within 10 s'));
        else setTimeout(check, 30);
      };
      check();
    });
  }

  /** Ask for manual exposure and white balance where the track's capabilities offer them. */
  async #lockAutomatics() {
    const track = this.track;
    const notes = [];
    const caps = track?.getCapabilities ? track.getCapabilities() : {};
    for (const [name, label] of [['exposureMode', 'exposure'], ['whiteBalanceMode', 'white balance'], ['focusMode', 'focus']]) {
      if (!caps[name]?.includes?.('manual')) {
        if (name !== 'focusMode') notes.push(`${label} cannot be fixed from the browser on this camera`);
        continue;
      }
      try {
        await track.applyConstraints({ advanced: [{ [name]: 'manual' }] });
        notes.push(`${label} fixed`);
      } catch (e) {
        notes.push(`${label} could not be fixed (${e.message || e.name})`);
      }
    }
    return notes;
  }

  #startMeter() {
    const canvas = this.meterCanvas;
    const ctx = canvas.getContext('2d', { willReadFrequently: true });
    this.meterTimer = setInterval(() => {
      const { videoWidth: w, videoHeight: h } = this.video;
      if (!w || !h) return;
      canvas.width = METER_WIDTH;
      canvas.height = Math.round((METER_WIDTH * h) / w);
      ctx.drawImage(this.video, 0, 0, canvas.width, canvas.height);
      const img = ctx.getImageData(0, 0, canvas.width, canvas.height);
      const d = img.data;
      let clipped = 0, dark = 0, sum = 0;
      for (let i = 0; i < d.length; i += 4) {
        const max = Math.max(d[i], d[i + 1], d[i + 2]);
        sum += max;
        if (max >= clipLevel) {
          clipped++;
          d[i] = 255; d[i + 1] = 0; d[i + 2] = 0;
        } else if (max < 16) {
          dark++;
          d[i] = 0; d[i + 1] = 60; d[i + 2] = 255;
        }
      }
      ctx.putImageData(img, 0, 0);
      const n = d.length / 4;
      const report = { clipped: clipped / n, dark: dark / n, mean: sum / n };
      report.verdict =
        report.clipped > CLIPPED_LIMIT
          ? 'over-exposed: lower the camera’s exposure or the projector’s brightness'
          : report.mean < DARK_MEAN
            ? 'under-exposed: raise the camera’s exposure or the projector’s brightness'
            : 'exposure looks usable';
      this.onMeter(report);
    }, 300);
  }
}
