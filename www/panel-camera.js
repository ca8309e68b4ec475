// Panel 2, the camera: choosing and starting a webcam, its exposure meter and sliders,
// capturing one frame to scan, and continuous scanning, where each free worker takes the
// newest video frame, with its figures (frames per second, latency, dropped frames). A
// camera that ends (unplugged, taken by another program) stops scanning with a message;
// one that changes resolution is followed by an approximate rig, while a loaded
// calibration, made for one size, stops continuous scanning with a message.

import { $, state, WORKERS, busy, setStatus, showMessage } from './page.js';
import { Camera, describeCameraError } from './camera.js';
import { followDeviceSize } from './panel-calibration.js';
import { addFrame, scanEntry, scanLive, showLiveResult, summary } from './panel-frames.js';
import { viewer, familyLayersShown } from './panel-results.js';
import { LiveScan, describeFigures } from './live.js';

/** The webcam, its preview and its exposure meter. */
export const camera = new Camera($('camera-video'), $('exposure-canvas'), showMeter, cameraEnded);

/** Controls that only work while the camera runs. */
const CAMERA_CONTROLS = ['capture', 'continuous', 'camera-stop'];

/** What could and could not be fixed on the running camera (shown after its size). */
let cameraNotes = [];

function showCameraInfo() {
  const { videoWidth: width, videoHeight: height } = camera.video;
  $('camera-info').textContent = [`${width}x${height}`, ...cameraNotes].join(' · ');
}

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
    cameraNotes = got.notes;
    showCameraInfo();
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
  camera.stop();
  cameraStopped();
  setStatus('camera stopped');
}

/** Back to the stopped state: no scanning, controls that need a camera disabled. */
function cameraStopped() {
  setContinuous(false);
  for (const id of CAMERA_CONTROLS) $(id).disabled = true;
  document.body.classList.remove('camera-on');
  $('exposure').textContent = '';
}

/** The camera ended by itself (camera.js has already stopped it). */
function cameraEnded() {
  const scanning = state.continuous;
  cameraStopped();
  const text =
    'The camera stopped delivering pictures: it was unplugged, switched off or taken by another program' +
    `${scanning ? ', so continuous scanning stopped' : ''}. Press “Start camera” to use it again.`;
  $('camera-info').textContent = text;
  showMessage(text, 'error');
  setStatus('camera lost');
}

/** Stop continuous scanning (the projector window was closed); returns whether it ran. */
export function stopContinuous() {
  const was = state.continuous;
  setContinuous(false);
  return was;
}

/**
 * The camera gives frames of another size than the calibration's camera: at start, or
 * because its driver or another program changed its mode while it runs. An approximate
 * rig follows (as at start) and this resolves to true; a loaded calibration cannot, and
 * this resolves to false without a message (the caller says what it means).
 */
async function followCamera(width, height) {
  showCameraInfo();
  return followDeviceSize('camera', width, height, { report: false });
}

/** Whether a frame has the calibration camera's size (true before any calibration). */
function fitsCalibration(frame) {
  const c = state.calib?.camera;
  return !c || (frame.width === c.width && frame.height === c.height);
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
  // A loaded calibration of another size is left alone; scanEntry says so with the frame.
  if (!fitsCalibration(frame)) await followCamera(frame.width, frame.height).catch((e) => showMessage(e.message, 'error'));
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
 * Continuous scanning (scheduling and figures: live.js): the newest video frame goes to a
 * worker as soon as one is free, older waiting frames are dropped. When the frames change
 * size, none is sent until the calibration has followed (or scanning stops, see
 * followCamera). A live frame's reply holds its figures and the merged cloud, plus the
 * family clouds while a family layer is ticked; the rest is decoded again on request.
 */
let live = null;
function setContinuous(on) {
  state.continuous = on;
  $('continuous').checked = on;
  live?.stop(); // results of the earlier run still coming are not shown
  live = null;
  if (!on) return;
  let following = false, shown = 0, lastSummary = '';
  const stop = (text) => {
    if (live !== run) return;
    setContinuous(false);
    showMessage(`Continuous scanning stopped: ${text}`, 'error');
    setStatus('continuous scanning stopped');
  };
  const follow = ({ width, height }) => {
    following = true;
    const c = state.calib;
    followCamera(width, height)
      .then((fits) => {
        if (!fits) {
          stop(
            `the camera now gives ${width}x${height} but the calibration (${state.calibSource}) is for ` +
              `${c.camera.width}x${c.camera.height}. Set the camera back to ${c.camera.width}x${c.camera.height} ` +
              `or load a calibration for ${width}x${height}.`,
          );
        }
      })
      .catch((e) => stop(e.message))
      .finally(() => (following = false));
  };
  const grab = () => {
    if (following || !camera.running) return null;
    let frame;
    try {
      frame = camera.capture();
    } catch {
      return null;
    }
    if (fitsCalibration(frame)) return frame;
    follow(frame);
    return null;
  };
  const run = new LiveScan({
    video: camera.video,
    workers: WORKERS,
    grab,
    decode: (frame) => scanLive(frame, { families: familyLayersShown() }),
    show: (frame, result) => {
      lastSummary = summary(showLiveResult(frame, result, { keepView: shown++ > 0 }));
    },
    viewerMs: () => viewer?.frameMs ?? 0,
    report: (figures) => {
      $('live-figures').textContent = describeFigures(figures);
      setStatus(`scanning continuously: ${figures.recent.fps.toFixed(1)} frames/s · ${lastSummary}`);
    },
    fail: (e) => stop(e.message),
  });
  live = run;
  $('live-figures').textContent = 'waiting for the first cloud…';
  state.live = run.start();
}

/** Bind the panel's buttons. */
export function bindCameraPanel() {
  $('camera-start').onclick = () => startCamera();
  $('camera-stop').onclick = () => stopCamera();
  $('capture').onclick = () => captureOnce();
  $('continuous').onchange = (e) => setContinuous(e.target.checked);
  // The preview's size follows the camera's: keep the size shown in the panel current.
  camera.video.addEventListener('resize', () => camera.running && showCameraInfo());
}
