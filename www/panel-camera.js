// Panel 2, the camera: choosing and starting a webcam, its exposure meter and sliders,
// capturing one frame to scan, and continuous scanning, where the two workers decode
// alternate video frames.

import { $, state, WORKERS, busy, setStatus, showMessage } from './page.js';
import { Camera, describeCameraError } from './camera.js';
import { followDeviceSize } from './panel-calibration.js';
import { addFrame, scanEntry, scanLive, showLiveResult, summary } from './panel-frames.js';

/** The webcam, its preview and its exposure meter. */
export const camera = new Camera($('camera-video'), $('exposure-canvas'), showMeter);

/** Controls that only work while the camera runs. */
const CAMERA_CONTROLS = ['capture', 'continuous', 'camera-stop'];

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
    for (const id of CAMERA_CONTROLS) $(id).disabled = false;
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
  for (const id of CAMERA_CONTROLS) $(id).disabled = true;
  document.body.classList.remove('camera-on');
  $('exposure').textContent = '';
  setStatus('camera stopped');
}

/** List the cameras (their names are known once access was granted), keeping the choice. */
async function fillDevices() {
  const select = $('camera-device');
  const chosen = camera.track?.getSettings().deviceId ?? select.value;
  const devices = await Camera.devices();
  select.replaceChildren(new Option('default camera', ''));
  for (const d of devices) select.append(new Option(d.label, d.deviceId, false, d.deviceId === chosen));
}

/** One slider per setting the camera lets the page adjust. */
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

/** Capture the current video frame, add it to the list and scan it. */
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
        const live = showLiveResult(frame, result, { keepView: shown > 1 });
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

/** Bind the panel's buttons. */
export function bindCameraPanel() {
  $('camera-start').onclick = () => startCamera();
  $('camera-stop').onclick = () => stopCamera();
  $('capture').onclick = () => captureOnce();
  $('continuous').onchange = (e) => setContinuous(e.target.checked);
}
