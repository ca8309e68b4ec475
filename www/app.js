// The scanner page: wires the pattern, projector window, camera, dropped files,
// calibration panel, viewer, exports and teaching view to the decoding workers.
// All decoding happens in the workers (bridge.js / worker.js); this thread only moves
// pixels and draws.

import { WorkerBridge } from './bridge.js';
import { PointCloudViewer, FAMILY_COLORS } from './viewer.js';
import { Camera, describeCameraError } from './camera.js';
import { drawRig, rigOf, hfovDeg } from './rig.js';

const $ = (id) => document.getElementById(id);

/** Decoding workers: the target machine has two cores, so two frames decode at once. */
const WORKERS = 2;
/** The built-in sample: a simulated scene, scanned on first open. */
const SAMPLE_SCENE = 'sphere';
/** Frames kept in the list (each holds its pixels and its cloud). */
const MAX_FRAMES = 12;
/** Frames list entries for the live camera are replaced, not added, while scanning continuously. */
const LIVE_NAME = 'camera (live)';

const state = {
  directions: 2,
  specJson: '',
  spec: null,
  specSource: 'generated', // 'generated' | file name
  calibJson: '',
  calib: null,
  calibSource: 'demo', // 'demo' | 'rig' | file name
  filter: 'loggrad',
  // The camera's colour mixing for camera and dropped frames: 'none' or 'simulator'.
  // Simulated frames always use the simulator's, which is known exactly.
  crosstalk: 'none',
  simulatorCrosstalk: null, // 9 numbers, row-major
  measuredCrosstalk: null, // 9 numbers, row-major, typed by the user
  frames: [],
  current: null,
  continuous: false,
  patternPixels: null, // {width, height, rgba} of the spec, for the projector window
  projectorWindow: null,
  busy: 0,
};

const bridge = new WorkerBridge(new URL('./worker.js', import.meta.url), {
  count: WORKERS,
  onEvent: ({ message }) => showMessage(message, 'error'),
});

let viewer = null;
try {
  viewer = new PointCloudViewer($('viewer'));
} catch (e) {
  showMessage(e.message, 'error');
}

const camera = new Camera($('camera-video'), $('exposure-canvas'), showMeter);

// ---------------------------------------------------------------- messages and status

/** Show a message in the corner; errors stay until dismissed, notes fade. */
function showMessage(text, kind = 'info') {
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

function setStatus(text) {
  $('status').textContent = text;
}

async function busy(label, task) {
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

// ---------------------------------------------------------------- pattern and calibration

async function setCalibration(json, source) {
  const canonical = await bridge.request('parseCalibration', { json });
  state.calibJson = canonical;
  state.calib = JSON.parse(canonical);
  state.calibSource = source;
  const c = state.calib;
  const where = source === 'demo' ? 'the demo rig' : source === 'rig' ? 'the approximate rig below' : source;
  $('calib-summary').textContent =
    `From ${where}: camera ${c.camera.width}x${c.camera.height} (${hfovDeg(c.camera).toFixed(1)}° wide), ` +
    `projector ${c.projector.width}x${c.projector.height} (${hfovDeg(c.projector).toFixed(1)}° wide).`;
  drawRig($('rig-diagram'), c);
  fillRigForm(rigOf(c));
  viewer?.setFieldOfView(2 * Math.atan(c.camera.height / 2 / c.camera.fy));
  if (state.specSource === 'generated') {
    if (!state.spec || state.spec.width !== c.projector.width || state.spec.height !== c.projector.height) {
      await generateSpec();
    }
  } else {
    checkSpecMatchesCalibration();
  }
}

async function generateSpec() {
  const { width, height } = state.calib.projector;
  const json = await bridge.request('generatePattern', { directions: state.directions, width, height });
  await setSpec(json, 'generated');
}

async function setSpec(json, source) {
  const canonical = await bridge.request('parseSpec', { json });
  state.specJson = canonical;
  state.spec = JSON.parse(canonical);
  state.specSource = source;
  state.directions = state.spec.families.length;
  $('directions').value = String(state.directions);
  const s = state.spec;
  $('pattern-info').textContent =
    `${s.families.length} direction${s.families.length > 1 ? 's' : ''} ` +
    `(${s.families.map((f) => `${f.angle_deg}°`).join(', ')}), ${s.width}x${s.height}, ` +
    `stripes ${s.families[0].stripe_width} px, window ${s.window}` +
    (source === 'generated' ? '' : `, from ${source}`);
  const pattern = await bridge.request('renderPattern', { specJson: canonical });
  drawImage($('pattern-thumb'), pattern);
  state.patternPixels = pattern;
  sendPatternToProjector();
  checkSpecMatchesCalibration();
}

function checkSpecMatchesCalibration() {
  const s = state.spec, c = state.calib;
  if (!s || !c) return true;
  if (s.width !== c.projector.width || s.height !== c.projector.height) {
    showMessage(
      `The pattern spec is ${s.width}x${s.height} but the calibration’s projector is ` +
        `${c.projector.width}x${c.projector.height}: load a matching spec or calibration.`,
      'error',
    );
    return false;
  }
  return true;
}

function readRigForm() {
  const f = $('rig-form').elements;
  const num = (name) => Number(f[name].value);
  return {
    camera_width: num('camera_width'),
    camera_height: num('camera_height'),
    camera_hfov_deg: num('camera_hfov_deg'),
    projector_width: num('projector_width'),
    projector_height: num('projector_height'),
    projector_hfov_deg: num('projector_hfov_deg'),
    baseline_mm: [num('baseline_x'), num('baseline_y'), num('baseline_z')],
    aim_distance_mm: num('aim_distance_mm'),
  };
}

function fillRigForm(rig) {
  const f = $('rig-form').elements;
  for (const [k, v] of Object.entries(rig)) {
    if (k === 'baseline_mm') {
      [f.baseline_x.value, f.baseline_y.value, f.baseline_z.value] = v;
    } else if (f[k]) {
      f[k].value = v;
    }
  }
}

async function applyRig(rig, why) {
  const json = await bridge.request('calibrationFromRig', { rig });
  await setCalibration(json, 'rig');
  if (why) showMessage(why);
}

/** Keep a demo or approximate rig in step with the real devices' sizes. */
async function followDeviceSize(device, width, height) {
  const c = state.calib;
  if (!c || (c[device].width === width && c[device].height === height)) return;
  if (state.calibSource === 'demo' || state.calibSource === 'rig') {
    const rig = { ...rigOf(c), [`${device}_width`]: width, [`${device}_height`]: height };
    await applyRig(rig, `The ${device} gives ${width}x${height}: the approximate rig now uses that size (same field of view).`);
  } else {
    showMessage(
      `The ${device} gives ${width}x${height} but the calibration (${state.calibSource}) says ` +
        `${c[device].width}x${c[device].height}. Use the calibrated size or load a matching calibration.`,
      'error',
    );
  }
}

// ---------------------------------------------------------------- projector window

/**
 * Open the projector window. It opens at once (a pop-up needs the click's user
 * activation, which a permission prompt would outlast) and is then moved to another
 * screen where the Window Management API offers one; otherwise the user drags it.
 */
async function openProjector() {
  const win = window.open('projector.html', 'stripelight-projector', 'popup,width=1024,height=768');
  if (!win) {
    showMessage(
      'The browser blocked the projector window. Allow pop-ups for this page (the icon at the right of the address bar), then press “Open projector window” again.',
      'error',
    );
    return;
  }
  state.projectorWindow = win;
  showMessage('Projector window opened: drag it to the projector screen if it is not there, then click it to go fullscreen.');
  const other = await otherScreen();
  if (other && !win.closed) {
    win.moveTo(other.availLeft, other.availTop);
    win.resizeTo(other.availWidth, other.availHeight);
    showMessage(`Projector window moved to the other screen (${other.label || `${other.width}x${other.height}`}): click it to go fullscreen.`);
  }
}

/** A screen other than this window's, where the browser offers and the user allows it. */
async function otherScreen() {
  if (!('getScreenDetails' in window)) return null;
  try {
    const details = await window.getScreenDetails();
    return details.screens.find((s) => s !== details.currentScreen) ?? null;
  } catch {
    return null; // refused: the user drags the window
  }
}

function sendPatternToProjector() {
  const win = state.projectorWindow;
  if (!win || win.closed || !state.patternPixels) return;
  const p = state.patternPixels;
  // A copy: the thumbnail keeps the original.
  const rgba = p.rgba.slice();
  const label = `${state.spec.families.length}-direction pattern`;
  win.postMessage({ type: 'pattern', width: p.width, height: p.height, rgba, label }, location.origin, [rgba.buffer]);
}

window.addEventListener('message', (event) => {
  if (event.origin !== location.origin || event.data?.type !== 'projector-hello') return;
  if (event.source && event.source !== state.projectorWindow) state.projectorWindow = event.source;
  const { width, height } = event.data;
  sendPatternToProjector();
  followDeviceSize('projector', width, height).catch((e) => showMessage(e.message, 'error'));
});

// ---------------------------------------------------------------- frames and scanning

/** Add (or replace) a frame in the list; returns the entry. */
function addFrame(name, frame, kind) {
  let entry = kind === 'live' ? state.frames.find((f) => f.kind === 'live') : null;
  if (!entry) {
    entry = { name, kind, frame, result: null, error: '', item: document.createElement('li') };
    entry.item.tabIndex = 0;
    entry.item.onclick = () => showEntry(entry, { rescan: !entry.result && !entry.error });
    entry.item.onkeydown = (e) => e.key === 'Enter' && entry.item.onclick();
    state.frames.unshift(entry);
    $('frames').prepend(entry.item);
    while (state.frames.length > MAX_FRAMES) state.frames.pop().item.remove();
  }
  entry.name = name;
  entry.frame = frame;
  return entry;
}

function renderFrameItem(entry) {
  const li = entry.item;
  li.replaceChildren();
  const thumb = document.createElement('canvas');
  drawImage(thumb, entry.frame, 96);
  const text = document.createElement('div');
  const title = document.createElement('strong');
  title.textContent = entry.name;
  const detail = document.createElement('span');
  if (entry.error) {
    detail.className = 'error-text';
    detail.textContent = entry.error;
  } else if (entry.result) {
    detail.textContent = `${entry.frame.width}x${entry.frame.height} · ${entry.result.merged.families.length.toLocaleString('en')} points`;
  } else {
    detail.textContent = `${entry.frame.width}x${entry.frame.height} · decoding…`;
  }
  text.append(title, detail);
  li.append(thumb, text);
  li.classList.toggle('current', entry === state.current);
  li.classList.toggle('failed', Boolean(entry.error));
}

/**
 * Scan a frame entry with the current spec, calibration and filter, show it, and (unless
 * scanning continuously) fetch the teaching stages with it.
 */
async function scanEntry(entry, { keepView = false } = {}) {
  const stages = !state.continuous;
  const { frame } = entry;
  const c = state.calib;
  entry.error = '';
  if (frame.width !== c.camera.width || frame.height !== c.camera.height) {
    entry.error =
      `${entry.name} is ${frame.width}x${frame.height} but the calibration’s camera is ` +
      `${c.camera.width}x${c.camera.height}: load the calibration of the camera that took it, ` +
      'or set that size in the approximate rig.';
    entry.result = null;
    renderFrameItem(entry);
    throw new Error(entry.error);
  }
  if (!checkSpecMatchesCalibration()) throw new Error('the pattern spec does not match the calibration');
  renderFrameItem(entry);
  const rgba = frame.rgba.slice();
  try {
    entry.result = await bridge.request(
      'scan',
      { ...scanSettings(entry.kind), width: frame.width, height: frame.height, rgba, stages },
      [rgba.buffer],
      { onProgress: state.continuous ? undefined : setStatus },
    );
    entry.filter = state.filter;
    entry.crosstalk = crosstalkFor(entry.kind);
    entry.result.stagesRequested = stages;
  } catch (e) {
    entry.error = `${entry.name}: ${e.message}`;
    entry.result = null;
    renderFrameItem(entry);
    throw new Error(entry.error);
  }
  renderFrameItem(entry);
  showEntry(entry, { keepView });
  return entry.result;
}

/** Make an entry the current one: its frame, cloud, depth map and stages. */
function showEntry(entry, { keepView = false, rescan = false } = {}) {
  state.current = entry;
  for (const f of state.frames) {
    f.item.classList.toggle('current', f === entry);
    // Stages are a dozen full-size images: only the current frame keeps them.
    if (f !== entry && f.result?.stages.length) {
      f.result.stages = [];
      f.result.stagesRequested = false;
    }
  }
  drawImage($('frame-canvas'), entry.frame);
  $('frame-caption').textContent = `input: ${entry.name}`;
  const stale =
    entry.result &&
    (entry.filter !== state.filter || entry.crosstalk !== crosstalkFor(entry.kind) || !entry.result.stagesRequested);
  if (rescan || (stale && !state.continuous)) {
    busy(`decoding ${entry.name}`, () => scanEntry(entry, { keepView }))
      .then(() => setStatus(summary(entry)))
      .catch((e) => showMessage(e.message, 'error'));
    return;
  }
  const r = entry.result;
  if (!r) {
    viewer?.setClouds([]);
    setPointCount(0, entry.error || 'no cloud');
    $('stages').replaceChildren();
    $('stages-note').textContent = `No stages: ${entry.name} was not decoded.`;
    return;
  }
  showCloud(r, keepView);
  drawDepth($('depth-canvas'), r);
  setPointCount(r.merged.families.length, summary(entry));
  if (r.stagesRequested) drawStages(r.stages, entry.name);
}

function summary(entry) {
  const r = entry.result;
  if (!r) return entry.error;
  const fam = r.stats.decoded.map((n, k) => `family ${k + 1}: ${n.toLocaleString('en')}`).join(' · ');
  const mixing = entry.crosstalk === 'simulator' ? ' · simulator’s colour mixing undone' : '';
  return `${entry.name}: ${r.merged.families.length.toLocaleString('en')} points (${fam}) · ${r.stats.filter}${mixing} · ${r.ms.toFixed(0)} ms`;
}

function setPointCount(n, text) {
  const out = $('point-count');
  out.dataset.count = String(n);
  out.textContent = `${n.toLocaleString('en')} points`;
  $('scan-stats').textContent = text;
}

function showCloud(r, keepView) {
  if (!viewer) return;
  const toggles = ensureLayerToggles(r.families.length);
  const clouds = [
    { positions: r.merged.positions, colors: r.merged.colors, families: r.merged.families, visible: toggles[0].checked },
    ...r.families.map((f, k) => ({
      positions: f.positions,
      colors: f.colors,
      families: null,
      familyMask: 1 << k,
      visible: toggles[k + 1].checked,
    })),
  ];
  viewer.setClouds(clouds, { keepView });
}

function ensureLayerToggles(families) {
  const box = $('layers');
  const wanted = families + 1;
  if (box.querySelectorAll('input').length !== wanted) {
    box.replaceChildren();
    for (let i = 0; i < wanted; i++) {
      const label = document.createElement('label');
      label.className = 'check';
      const input = document.createElement('input');
      input.type = 'checkbox';
      input.checked = i === 0;
      input.dataset.layer = String(i);
      input.onchange = () => viewer?.setVisible(i, input.checked);
      const swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = i === 0 ? '#ddd' : FAMILY_COLORS[i - 1];
      label.append(input, swatch, document.createTextNode(i === 0 ? 'merged' : `family ${i}`));
      box.append(label);
    }
  }
  return [...box.querySelectorAll('input')];
}

// ---------------------------------------------------------------- drawing helpers

/** Draw an RGBA image into a canvas, scaled down to `maxWidth` CSS pixels if given. */
function drawImage(canvas, img, maxWidth) {
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

/** The depth map in grey (near bright), no depth in dark blue. */
function drawDepth(canvas, r) {
  const { width, height, depth } = r;
  // The grey scale spans the 1st to 99th percentile, so stray far points do not flatten it.
  const sample = [];
  const step = Math.max(1, Math.floor(depth.length / 20000));
  for (let i = 0; i < depth.length; i += step) if (depth[i] === depth[i]) sample.push(depth[i]);
  sample.sort((a, b) => a - b);
  const lo = sample.length ? sample[Math.floor(0.01 * sample.length)] : NaN;
  const hi = sample.length ? sample[Math.floor(0.99 * (sample.length - 1))] : NaN;
  const rgba = new Uint8ClampedArray(width * height * 4);
  const span = Math.max(hi - lo, 1e-3);
  for (let i = 0; i < depth.length; i++) {
    const z = depth[i];
    if (z === z) {
      const g = 255 - Math.round(200 * Math.min(1, Math.max(0, (z - lo) / span)));
      rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = g;
    } else {
      rgba[4 * i] = 12; rgba[4 * i + 1] = 16; rgba[4 * i + 2] = 40;
    }
    rgba[4 * i + 3] = 255;
  }
  drawImage(canvas, { width, height, rgba });
  $('depth-caption').textContent = Number.isFinite(lo)
    ? `depth ${lo.toFixed(0)}–${hi.toFixed(0)} mm (near bright; 1st–99th percentile)`
    : 'depth: none decoded';
}

function drawStages(stages, name) {
  const grid = $('stages');
  grid.replaceChildren();
  if (!stages.length) {
    $('stages-note').textContent = `The decoder kept no stages for ${name}.`;
    return;
  }
  for (const s of stages) {
    const fig = document.createElement('figure');
    const canvas = document.createElement('canvas');
    drawImage(canvas, s);
    const cap = document.createElement('figcaption');
    const b = document.createElement('strong');
    b.textContent = s.name;
    cap.append(b, document.createTextNode(` ${s.caption}`));
    fig.append(canvas, cap);
    fig.title = 'click to enlarge';
    fig.onclick = () => fig.classList.toggle('wide');
    grid.append(fig);
  }
  $('stages-note').textContent = `${stages.length} stages of ${name}, filter ${state.filter}.`;
}

// ---------------------------------------------------------------- camera

function showMeter({ clipped, dark, mean, verdict }) {
  const el = $('exposure');
  el.textContent = `clipped ${(100 * clipped).toFixed(1)}% · dark ${(100 * dark).toFixed(1)}% · mean ${mean.toFixed(0)} — ${verdict}`;
  el.className = verdict.startsWith('exposure looks') ? 'meter ok' : 'meter warn';
}

async function startCamera() {
  const [width, height] = $('camera-resolution').value.split('x').map(Number);
  try {
    const got = await busy('starting the camera', () =>
      camera.start({ deviceId: $('camera-device').value, width, height, lockExposure: $('lock-exposure').checked }),
    );
    $('camera-info').textContent = `${got.width}x${got.height} · ${got.notes.join(' · ')}`;
    for (const id of ['capture', 'continuous', 'camera-stop']) $(id).disabled = false;
    document.body.classList.add('camera-on');
    await fillDevices();
    buildCameraSliders();
    await followDeviceSize('camera', got.width, got.height);
    setStatus('camera running: point the projector at the object and capture');
  } catch (e) {
    camera.stop();
    const text = describeCameraError(e);
    $('camera-info').textContent = text;
    showMessage(text, 'error');
    setStatus('camera not available');
  }
}

function stopCamera() {
  setContinuous(false);
  camera.stop();
  for (const id of ['capture', 'continuous', 'camera-stop']) $(id).disabled = true;
  document.body.classList.remove('camera-on');
  $('exposure').textContent = '';
  setStatus('camera stopped');
}

async function fillDevices() {
  const select = $('camera-device');
  const chosen = camera.track?.getSettings().deviceId ?? select.value;
  const devices = await Camera.devices();
  select.replaceChildren(new Option('default camera', ''));
  for (const d of devices) select.append(new Option(d.label, d.deviceId, false, d.deviceId === chosen));
}

function buildCameraSliders() {
  const box = $('camera-controls');
  box.replaceChildren();
  for (const s of camera.adjustable()) {
    const label = document.createElement('label');
    const input = document.createElement('input');
    Object.assign(input, { type: 'range', min: s.min, max: s.max, step: s.step || (s.max - s.min) / 100, value: s.value });
    const value = document.createElement('output');
    value.textContent = String(s.value);
    input.oninput = () => {
      value.textContent = input.value;
      camera.set(s.name, Number(input.value)).catch((e) => showMessage(`${s.name}: ${e.message}`, 'error'));
    };
    label.append(document.createTextNode(s.name.replace(/([A-Z])/g, ' $1').toLowerCase()), input, value);
    box.append(label);
  }
}

async function captureOnce() {
  let frame;
  try {
    frame = camera.capture();
  } catch (e) {
    showMessage(e.message, 'error');
    return;
  }
  const name = `camera ${new Date().toLocaleTimeString('en-GB')}`;
  const entry = addFrame(name, frame, 'camera');
  try {
    await busy(`decoding ${name}`, () => scanEntry(entry));
    setStatus(summary(entry));
  } catch (e) {
    showMessage(e.message, 'error');
    setStatus('capture failed');
  }
}

/**
 * Continuous scanning: each new video frame goes to a worker when one is free, so with
 * two workers consecutive frames alternate between them and two are in flight; a result
 * older than the one on screen is dropped.
 */
let continuousRun = 0;
function setContinuous(on) {
  state.continuous = on;
  $('continuous').checked = on;
  const run = ++continuousRun; // a loop from an earlier switch-on stops at its next frame
  if (!on) return;
  const started = performance.now();
  let sent = 0, shown = 0, inFlight = 0, done = 0;
  const nextFrame = () => {
    if ('requestVideoFrameCallback' in HTMLVideoElement.prototype) camera.video.requestVideoFrameCallback(tick);
    else requestAnimationFrame(tick);
  };
  const tick = () => {
    if (run !== continuousRun || !camera.running) return;
    nextFrame();
    if (inFlight >= WORKERS) return;
    let frame;
    try {
      frame = camera.capture();
    } catch {
      return;
    }
    const seq = ++sent;
    inFlight++;
    scanLive(frame)
      .then((result) => {
        done++;
        if (seq <= shown || run !== continuousRun) return;
        shown = seq;
        const live = addFrame(LIVE_NAME, frame, 'live');
        Object.assign(live, { result, filter: state.filter, crosstalk: crosstalkFor('live'), error: '' });
        renderFrameItem(live);
        showEntry(live, { keepView: shown > 1 });
        const fps = (1000 * done) / (performance.now() - started);
        setStatus(`scanning continuously: ${fps.toFixed(1)} frames/s · ${summary(live)}`);
      })
      .catch((e) => {
        if (run !== continuousRun) return;
        setContinuous(false);
        showMessage(`Continuous scanning stopped: ${e.message}`, 'error');
      })
      .finally(() => inFlight--);
  };
  tick();
}

async function scanLive(frame) {
  const c = state.calib;
  if (frame.width !== c.camera.width || frame.height !== c.camera.height) {
    throw new Error(`the camera gives ${frame.width}x${frame.height} but the calibration’s camera is ${c.camera.width}x${c.camera.height}`);
  }
  const rgba = frame.rgba.slice();
  return bridge.request(
    'scan',
    { ...scanSettings('live'), width: frame.width, height: frame.height, rgba, stages: false },
    [rgba.buffer],
  );
}

/** Use a measured colour-mixing matrix for camera and dropped frames. */
function useMeasuredCrosstalk(values) {
  state.measuredCrosstalk = values;
  state.crosstalk = 'measured';
  $('crosstalk').value = 'measured';
  $('crosstalk-values').value = values.map((v) => v.toFixed(4)).join(',');
  showMessage('Measured colour mixing in use for camera and dropped frames.');
  if (state.current && !state.continuous) showEntry(state.current, { keepView: true });
}

/**
 * The guided colour calibration: the projector shows full red, green, blue and black in
 * turn on a white card, the camera captures each, and the worker turns the four frames
 * into the camera's colour-mixing matrix. The pattern comes back afterwards.
 */
async function measureColourMixing() {
  const win = state.projectorWindow;
  if (!win || win.closed) throw new Error('Open the projector window first, then point the camera at a white card it lights.');
  if (!camera.running) throw new Error('Start the camera first, pointed at a white card lit by the projector.');
  const { width, height } = state.patternPixels;
  const frames = [];
  try {
    for (const [label, rgb] of [['red', [255, 0, 0]], ['green', [0, 255, 0]], ['blue', [0, 0, 255]], ['black', [0, 0, 0]]]) {
      const rgba = new Uint8ClampedArray(width * height * 4);
      for (let i = 0; i < rgba.length; i += 4) rgba.set([...rgb, 255], i);
      win.postMessage({ type: 'pattern', width, height, rgba, label: `colour calibration: ${label}` }, location.origin, [rgba.buffer]);
      setStatus(`colour calibration: ${label}`);
      // The projector redraws and the camera delivers a few frames in this time.
      await new Promise((resolve) => setTimeout(resolve, 800));
      frames.push(camera.capture());
    }
  } finally {
    sendPatternToProjector();
  }
  const { width: w, height: h } = frames[0];
  const values = await bridge.request('estimateCrosstalk', { frames: frames.map((f) => f.rgba), width: w, height: h });
  useMeasuredCrosstalk(values);
  setStatus('colour mixing measured');
}

/** The crosstalk setting for a kind of frame: simulated ones use the simulator's. */
function crosstalkFor(kind) {
  return kind === 'sample' ? 'simulator' : state.crosstalk;
}

/** What a scan request needs besides the pixels. */
function scanSettings(kind) {
  const mode = crosstalkFor(kind);
  const crosstalk = mode === 'simulator' ? state.simulatorCrosstalk : mode === 'measured' ? state.measuredCrosstalk : null;
  return { specJson: state.specJson, calibJson: state.calibJson, filter: state.filter, crosstalk };
}

// ---------------------------------------------------------------- dropped files

/** Handle dropped or chosen files: JSON first (they may change the rig), then images. */
async function handleFiles(files) {
  files = [...files];
  const json = files.filter((f) => /\.json$/i.test(f.name) || f.type === 'application/json');
  const others = files.filter((f) => !json.includes(f));
  for (const file of json) {
    try {
      await loadJsonFile(file);
    } catch (e) {
      showMessage(`${file.name}: ${e.message}`, 'error');
    }
  }
  for (const file of others) {
    let frame;
    try {
      const bytes = await file.arrayBuffer();
      frame = await bridge.request('decodeImage', { bytes }, [bytes]);
    } catch (e) {
      showMessage(`${file.name}: ${e.message}`, 'error');
      setStatus(`${file.name} is not a frame`);
      continue;
    }
    const entry = addFrame(file.name, frame, 'file');
    try {
      await busy(`decoding ${file.name}`, () => scanEntry(entry));
      setStatus(summary(entry));
    } catch (e) {
      showEntry(entry);
      showMessage(e.message, 'error');
      setStatus(`${file.name} could not be decoded`);
    }
  }
}

async function loadJsonFile(file) {
  const text = await file.text();
  let parsed;
  try {
    parsed = JSON.parse(text);
  } catch (e) {
    throw new Error(`not valid JSON (${e.message})`);
  }
  if (parsed?.format === 'stripelight-pattern') {
    await setSpec(text, file.name);
    showMessage(`Pattern spec ${file.name} loaded: ${state.spec.families.length} directions, ${state.spec.width}x${state.spec.height}.`);
  } else if (parsed && typeof parsed === 'object' && 'camera' in parsed) {
    await setCalibration(text, file.name);
    showMessage(`Calibration ${file.name} loaded.`);
  } else {
    throw new Error('neither a calibration (no "camera" field) nor a pattern spec (no "format": "stripelight-pattern")');
  }
}

function bindDropZone() {
  const zone = $('drop-zone');
  // The whole page accepts drops; the zone shows where.
  const over = (e) => {
    if (![...(e.dataTransfer?.types ?? [])].includes('Files')) return;
    e.preventDefault();
    zone.classList.add('over');
  };
  document.addEventListener('dragover', over);
  document.addEventListener('dragenter', over);
  document.addEventListener('dragleave', (e) => {
    if (!e.relatedTarget) zone.classList.remove('over');
  });
  document.addEventListener('drop', (e) => {
    e.preventDefault();
    zone.classList.remove('over');
    const files = e.dataTransfer?.files;
    if (files?.length) handleFiles(files).catch((err) => showMessage(err.message, 'error'));
  });
  $('file-input').onchange = (e) => {
    handleFiles(e.target.files).catch((err) => showMessage(err.message, 'error'));
    e.target.value = '';
  };
}

// ---------------------------------------------------------------- export

function download(bytes, name, type) {
  const url = URL.createObjectURL(new Blob([bytes], { type }));
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}

function baseName() {
  return (state.current?.name ?? 'scan').replace(/\.[a-z0-9]+$/i, '').replace(/[^a-z0-9_-]+/gi, '-');
}

async function exportPly() {
  const r = state.current?.result;
  if (!r) return showMessage('Nothing to export yet: scan a frame first.', 'error');
  const m = r.merged;
  const copy = { positions: m.positions.slice(), colors: m.colors.slice(), pixels: m.pixels.slice(), families: m.families.slice() };
  const bytes = await bridge.request('encodePly', copy, Object.values(copy).map((a) => a.buffer));
  download(bytes, `stripelight-${baseName()}.ply`, 'application/octet-stream');
}

async function exportDepth() {
  const r = state.current?.result;
  if (!r) return showMessage('Nothing to export yet: scan a frame first.', 'error');
  const depth = r.depth.slice();
  const bytes = await bridge.request('encodePfm', { depth, width: r.width, height: r.height }, [depth.buffer]);
  download(bytes, `stripelight-${baseName()}-depth.pfm`, 'application/octet-stream');
}

// ---------------------------------------------------------------- sample

async function scanScene(name, seed = 1) {
  const frame = await bridge.request(
    'renderScene',
    { name, specJson: state.specJson, calibJson: state.calibJson, seed },
    [],
    { onProgress: setStatus },
  );
  const entry = addFrame(`simulated ${name}`, frame, 'sample');
  await scanEntry(entry);
  return entry;
}

// ---------------------------------------------------------------- wiring

function bindControls() {
  $('directions').onchange = async (e) => {
    state.directions = Number(e.target.value);
    state.specSource = 'generated';
    await busy('generating the pattern', generateSpec).catch((err) => showMessage(err.message, 'error'));
    setStatus(`pattern with ${state.directions} direction(s) ready; capture or render a sample to decode it`);
    if (state.current?.kind === 'sample') {
      const scene = state.current.name.replace('simulated ', '');
      busy(`simulating ${scene}`, () => scanScene(scene))
        .then((entry) => setStatus(summary(entry)))
        .catch((err) => showMessage(err.message, 'error'));
    }
  };
  $('open-projector').onclick = () => openProjector();
  $('download-spec').onclick = () => download(state.specJson, 'stripelight-pattern.json', 'application/json');
  $('camera-start').onclick = () => startCamera();
  $('camera-stop').onclick = () => stopCamera();
  $('capture').onclick = () => captureOnce();
  $('continuous').onchange = (e) => setContinuous(e.target.checked);
  $('render-scene').onclick = () =>
    busy('simulating', () => scanScene($('scene').value, 1 + Math.floor(Math.random() * 1000)))
      .then((entry) => setStatus(summary(entry)))
      .catch((e) => showMessage(e.message, 'error'));
  $('rig-form').onsubmit = (e) => {
    e.preventDefault();
    busy('building the calibration', () => applyRig(readRigForm(), 'Approximate rig applied.'))
      .then(() => setStatus('calibration updated'))
      .catch((err) => showMessage(err.message, 'error'));
  };
  $('calib-file').onchange = (e) => {
    const file = e.target.files[0];
    e.target.value = '';
    if (file) loadJsonFile(file).catch((err) => showMessage(`${file.name}: ${err.message}`, 'error'));
  };
  $('calib-demo').onclick = () =>
    bridge
      .request('defaultCalibration')
      .then((json) => setCalibration(json, 'demo'))
      .catch((e) => showMessage(e.message, 'error'));
  $('calib-download').onclick = () => download(state.calibJson, 'stripelight-calibration.json', 'application/json');
  for (const input of document.querySelectorAll('input[name="color-mode"]')) {
    input.onchange = () => viewer?.setColorMode(input.value);
  }
  $('point-size').oninput = (e) => {
    viewer?.setPointSize(Number(e.target.value));
    $('point-size-value').textContent = e.target.value;
  };
  $('reset-view').onclick = () => viewer?.resetView();
  $('export-ply').onclick = () => exportPly().catch((e) => showMessage(e.message, 'error'));
  $('export-pfm').onclick = () => exportDepth().catch((e) => showMessage(e.message, 'error'));
  for (const input of document.querySelectorAll('input[name="filter"]')) {
    input.onchange = () => setFilter(input.value);
  }
  $('crosstalk').onchange = (e) => {
    if (e.target.value === 'measured' && !state.measuredCrosstalk) {
      showMessage('Type the 9 numbers that `stripelight crosstalk` printed into "Measured colour mixing" first.', 'error');
      e.target.value = state.crosstalk;
      return;
    }
    state.crosstalk = e.target.value;
    if (state.current && !state.continuous) showEntry(state.current, { keepView: true });
  };
  $('crosstalk-values').onchange = (e) => {
    const values = e.target.value.split(/[\s,;]+/).filter((v) => v !== '').map(Number);
    if (values.length !== 9 || !values.every(Number.isFinite)) {
      showMessage(`Colour mixing needs 9 numbers, row by row; got ${values.length}.`, 'error');
      return;
    }
    useMeasuredCrosstalk(values);
  };
  $('measure-mixing').onclick = () => measureColourMixing().catch((e) => showMessage(e.message, 'error'));
  $('refresh-stages').onclick = () => {
    if (state.current) showEntry(state.current, { rescan: true, keepView: true });
  };
  bindDropZone();
}

function setFilter(filter) {
  state.filter = filter;
  for (const input of document.querySelectorAll('input[name="filter"]')) input.checked = input.value === filter;
  if (state.current && !state.continuous) showEntry(state.current, { rescan: true, keepView: true });
}

async function main() {
  bindControls();
  try {
    await bridge.ready();
  } catch (e) {
    setStatus('the decoder could not start');
    return;
  }
  state.simulatorCrosstalk = await bridge.request('simulatorCrosstalk');
  const names = await bridge.request('sceneNames');
  $('scene').replaceChildren(...names.map((n) => new Option(n, n, false, n === SAMPLE_SCENE)));
  await setCalibration(await bridge.request('defaultCalibration'), 'demo');
  const entry = await busy('decoding the built-in sample', () => scanScene(SAMPLE_SCENE));
  setStatus(`Built-in sample decoded. ${summary(entry)}. Open the projector window and start the camera to scan for real.`);
  document.body.dataset.sample = 'done';
}

const started = main().catch((e) => {
  showMessage(`Start-up failed: ${e.message}`, 'error');
  setStatus('start-up failed');
  document.body.dataset.sample = 'failed';
});

// For the end-to-end test and for poking around in the console.
window.stripelight = { state, bridge, get viewer() { return viewer; }, started, handleFiles };
