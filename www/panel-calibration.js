// Panel 3, calibration: the camera and projector the decoder assumes (the demo rig, an
// approximate rig typed into the form, or a calibration JSON), drawn as a top view and
// kept in step with the real devices' sizes; and the camera's colour mixing (none, the
// simulator's, or measured: typed in, measured with the projector and the camera on a
// white card, or estimated from the stripes of the frame shown) and the camera's response
// (the power law, or measured on the same card from its white, grey and black frames, or
// loaded from `stripelight response`'s file).

import { $, state, bridge, busy, setStatus, showMessage, download } from './page.js';
import { drawRig, rigOf, hfovDeg } from './rig.js';
import { generateSpec, setSpec, checkSpecMatchesCalibration } from './panel-pattern.js';
import { matchCameraView } from './panel-results.js';
import { projectorIsOpen, showOnProjector, sendPatternToProjector } from './projector-link.js';

/** How long each flat colour stays up before its frame is taken: the projector redraws
 * and the camera delivers a few frames in this time. */
const COLOUR_SETTLE_MS = 800;

/** The grey level the projector shows for the camera response's grey frame. */
const RESPONSE_GREY_LEVEL = 128;

/** How many times estimating the colour mixing from a frame scans it: once with no
 * mixing, then once a round with each estimate (FRAME_MIXING_ROUNDS = 2 in src/scan.rs);
 * the worker's reply limit grows with it. */
const FRAME_MIXING_SCANS = 3;

/** Runs whenever the colour settings change (set by bindCalibrationPanel). */
let mixingChanged = () => {};

/** Use a calibration (JSON text; `source` is 'demo', 'rig' or a file name) from now on. */
export async function setCalibration(json, source) {
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
  matchCameraView(c);
  if (state.specSource === 'generated') {
    if (!state.spec || state.spec.width !== c.projector.width || state.spec.height !== c.projector.height) {
      await generateSpec();
    }
  } else {
    checkSpecMatchesCalibration();
  }
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

/** Use the calibration of an approximate rig; `why`, if given, becomes a message. */
async function applyRig(rig, why) {
  const json = await bridge.request('calibrationFromRig', { rig });
  await setCalibration(json, 'rig');
  if (why) showMessage(why);
}

/**
 * Keep a demo or approximate rig in step with a real device's size (`device` is 'camera'
 * or 'projector'); a loaded calibration is left alone, with an error message if it differs
 * (unless `report` is false: the caller says it). Resolves to whether the calibration now
 * has that size.
 */
export async function followDeviceSize(device, width, height, { report = true } = {}) {
  const c = state.calib;
  if (!c || (c[device].width === width && c[device].height === height)) return true;
  if (state.calibSource === 'demo' || state.calibSource === 'rig') {
    const rig = { ...rigOf(c), [`${device}_width`]: width, [`${device}_height`]: height };
    await applyRig(rig, `The ${device} gives ${width}x${height}: the approximate rig now uses that size (same field of view).`);
    return true;
  }
  if (report) {
    showMessage(
      `The ${device} gives ${width}x${height} but the calibration (${state.calibSource}) says ` +
        `${c[device].width}x${c[device].height}. Use the calibrated size or load a matching calibration.`,
      'error',
    );
  }
  return false;
}

/** Load a JSON file: a pattern spec or a calibration, told apart by their fields. */
export async function loadJsonFile(file) {
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
  } else if (parsed && typeof parsed === 'object' && 'linear' in parsed) {
    await loadResponse(text, file.name);
  } else {
    throw new Error(
      'neither a calibration (no "camera" field), a pattern spec (no "format": "stripelight-pattern") ' +
        'nor a camera response (no "linear" field)',
    );
  }
}

/** Read a camera response file (`stripelight response`'s JSON) and use it. */
async function loadResponse(text, name) {
  const response = await bridge.request('parseResponse', { text });
  setResponse({ ...response, source: name });
  showMessage(`Camera response ${name} loaded: ${responseWords(state.response)}.`);
  mixingChanged();
}

/** Words for a response: how far it departs from the power law. */
function responseWords(response) {
  if (!response) return 'the power law of gamma 2.2';
  const pct = (100 * response.departure).toFixed(response.departure < 0.1 ? 1 : 0);
  return `codes differ from the power law of gamma 2.2 by up to ${pct} % of their light`;
}

/** Use a camera response ({values, departure, source}, or null for the power law) for
 * camera and dropped frames, and show it in the panel. */
function setResponse(response) {
  state.response = response;
  const where = response?.source === 'measured' ? 'measured on the white card' : response ? `from ${response.source}` : '';
  $('response-summary').textContent = `Camera response${where ? `, ${where}` : ''}: ${responseWords(response)}.`;
  $('response-reset').disabled = !response;
  $('response-download').disabled = !response;
}

/** Use a measured colour-mixing matrix (9 numbers, row-major) for camera and dropped frames. */
function useMeasuredCrosstalk(values) {
  state.measuredCrosstalk = values;
  state.crosstalk = 'measured';
  $('crosstalk').value = 'measured';
  $('crosstalk-values').value = values.map((v) => v.toFixed(4)).join(',');
  showMessage('Measured colour mixing in use for camera and dropped frames.');
}

/**
 * The guided colour calibration: the projector shows full red, green, blue, white, grey
 * and black in turn on a white card, the camera captures each, and the worker turns the
 * frames into the camera's response (white, grey and black: which light its top codes
 * stand for) and its colour-mixing matrix (the primaries and black, read through that
 * response). Resolves to {crosstalk, response}: response null where it is the power law
 * within a measurement's noise. The pattern comes back afterwards. Nothing is taken
 * when any part fails.
 */
async function measureColour(camera) {
  if (!projectorIsOpen()) throw new Error('Open the projector window first, then point the camera at a white card it lights.');
  if (!camera.running) throw new Error('Start the camera first, pointed at a white card lit by the projector.');
  const { width, height } = state.patternPixels;
  const grey = RESPONSE_GREY_LEVEL;
  const shown = [
    ['red', [255, 0, 0]],
    ['green', [0, 255, 0]],
    ['blue', [0, 0, 255]],
    ['white', [255, 255, 255]],
    [`grey ${grey}`, [grey, grey, grey]],
    ['black', [0, 0, 0]],
  ];
  const frames = [];
  try {
    for (const [label, rgb] of shown) {
      const rgba = new Uint8ClampedArray(width * height * 4);
      for (let i = 0; i < rgba.length; i += 4) rgba.set([...rgb, 255], i);
      showOnProjector({ width, height, rgba, label: `colour calibration: ${label}` });
      setStatus(`colour calibration: ${label}`);
      await new Promise((resolve) => setTimeout(resolve, COLOUR_SETTLE_MS));
      if (!projectorIsOpen()) throw new Error('The projector window was closed during the colour calibration: open it again, then measure again.');
      frames.push(camera.capture());
    }
  } finally {
    sendPatternToProjector();
  }
  const { width: w, height: h } = frames[0];
  const [red, green, blue, white, greyFrame, black] = frames.map((f) => f.rgba);
  const primaries = { width: w, height: h, frames: [red, green, blue, black] };
  // Through the power law first: frames without the primaries are refused by name.
  const plain = await bridge.request('estimateCrosstalk', primaries);
  let response;
  try {
    response = await bridge.request('estimateResponse', { frames: [white, greyFrame, black], width: w, height: h, greyLevel: grey });
  } catch (e) {
    throw new Error(`${e.message} (the camera's exposure and white balance must stay fixed while the colours change)`);
  }
  if (response.powerLaw) return { crosstalk: plain, response: null, departure: response.departure };
  const crosstalk = await bridge.request('estimateCrosstalk', { ...primaries, response: response.values });
  return { crosstalk, response: { ...response, source: 'measured' } };
}

/**
 * The colour mixing read from the stripes of the frame the results show (`stripelight
 * scan --crosstalk frame`), for a rig whose white-card frames were never taken. The frame
 * is read as its scan reads it: through the camera response, except the built-in sample
 * (the simulator's camera follows the power law). Resolves to {values, entry}: 9 numbers,
 * row-major, columns summing to 1, and the frame's entry.
 */
async function estimateFromShownFrame() {
  const entry = state.current;
  if (!entry) throw new Error('no frame is shown: capture, drop or render one, then estimate the colour mixing from it');
  const { frame } = entry;
  const c = state.calib;
  if (frame.width !== c.camera.width || frame.height !== c.camera.height) {
    throw new Error(
      `${entry.name} is ${frame.width}x${frame.height} but the calibration’s camera is ` +
        `${c.camera.width}x${c.camera.height}: load the calibration of the camera that took it`,
    );
  }
  if (!checkSpecMatchesCalibration()) throw new Error('the pattern spec does not match the calibration');
  const rgba = frame.rgba.slice(); // transferred: the entry keeps its pixels
  const payload = {
    specJson: state.specJson,
    calibJson: state.calibJson,
    filter: state.filter,
    response: entry.kind === 'sample' ? undefined : state.response?.values,
    rgba,
    width: frame.width,
    height: frame.height,
  };
  const values = await busy(`estimating the colour mixing from ${entry.name}`, () =>
    bridge.request('estimateCrosstalkFromFrame', payload, [rgba.buffer], { onProgress: setStatus, scans: FRAME_MIXING_SCANS }),
  );
  return { values, entry };
}

/**
 * Bind the panel's controls. `camera` is the page's Camera (for the guided colour
 * calibration); `onMixingChanged()` runs whenever the colour-mixing setting changes.
 */
export function bindCalibrationPanel({ camera, onMixingChanged }) {
  mixingChanged = onMixingChanged;
  const useMeasured = (values) => {
    useMeasuredCrosstalk(values);
    onMixingChanged();
  };
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
  $('crosstalk').onchange = (e) => {
    if (e.target.value === 'measured' && !state.measuredCrosstalk) {
      showMessage('Type the 9 numbers that `stripelight crosstalk` printed into "Measured colour mixing" first.', 'error');
      e.target.value = state.crosstalk;
      return;
    }
    state.crosstalk = e.target.value;
    onMixingChanged();
  };
  // The numbers are read and checked (9 finite numbers, an invertible matrix) by the
  // same parser as the command line's --crosstalk, in the worker.
  $('crosstalk-values').onchange = (e) => {
    bridge
      .request('parseCrosstalk', { text: e.target.value })
      .then(useMeasured)
      .catch((err) => showMessage(`Colour mixing: ${err.message}`, 'error'));
  };
  $('measure-mixing').onclick = () =>
    measureColour(camera)
      .then(({ crosstalk, response, departure }) => {
        setResponse(response);
        useMeasured(crosstalk);
        const within = `the power law of gamma 2.2 within ${(100 * departure).toFixed(1)} %, so the power law is kept`;
        showMessage(`Camera response measured: ${response ? responseWords(response) : within}.`);
        setStatus('colour mixing and camera response measured');
      })
      .catch((e) => showMessage(e.message, 'error'));
  $('estimate-mixing').onclick = () =>
    estimateFromShownFrame()
      .then(({ values, entry }) => {
        setStatus(`colour mixing estimated from ${entry.name}`);
        useMeasured(values); // rescans the frame shown, unless it is the sample
        const rows = [0, 3, 6].map((i) => values.slice(i, i + 3).map((v) => v.toFixed(3)).join(' '));
        // The built-in sample decodes with the simulator's mixing whatever is chosen here.
        const sample = entry.kind === 'sample' ? ' (the simulated sample itself keeps the simulator’s own mixing)' : '';
        showMessage(
          `Colour mixing estimated from ${entry.name}: ${rows.join(' / ')} (columns sum to 1); ` +
            `in use for camera and dropped frames${sample}.`,
        );
      })
      // The library's refusals already begin with these words: said once.
      .catch((e) => showMessage(`Colour mixing from the frame: ${e.message.replace(/^colour mixing from the frame: /i, '')}`, 'error'));
  $('response-file').onchange = (e) => {
    const file = e.target.files[0];
    e.target.value = '';
    if (!file) return;
    file
      .text()
      .then((text) => loadResponse(text, file.name))
      .catch((err) => showMessage(`${file.name}: ${err.message}`, 'error'));
  };
  $('response-reset').onclick = () => {
    setResponse(null);
    showMessage('Camera frames are read through the power law of gamma 2.2 again.');
    onMixingChanged();
  };
  $('response-download').onclick = () =>
    bridge
      .request('responseJson', { values: state.response.values })
      .then((json) => download(json, 'stripelight-response.json', 'application/json'))
      .catch((e) => showMessage(e.message, 'error'));
}
