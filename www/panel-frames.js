// The frames panel and scanning: the list of frames (camera captures, dropped files,
// simulated scenes, the live camera), decoding a frame with the current pattern,
// calibration, filter and colour mixing, and choosing which frame the results show.
// Every 'scan' request to the workers starts here.
//
// A frame entry: {name, kind: 'sample' | 'camera' | 'file' | 'live', frame: {width,
// height, rgba}, result, error, item: its <li>, and the filter and colour settings it was
// decoded with}.

import { $, state, bridge, busy, setStatus, showMessage, drawImage } from './page.js';
import { checkSpecMatchesCalibration } from './panel-pattern.js';
import { loadJsonFile } from './panel-calibration.js';
import { showInput, showResult, showNoResult } from './panel-results.js';

/** Frames kept in the list (each holds its pixels and its cloud). */
const MAX_FRAMES = 12;
/** Frames list entries for the live camera are replaced, not added, while scanning continuously. */
const LIVE_NAME = 'camera (live)';

/** Add (or, for the live camera, replace) a frame in the list; returns the entry. */
export function addFrame(name, frame, kind) {
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
 * Scan a frame entry with the current spec, calibration and filter, and show it: its
 * clouds, its depth map and (unless scanning continuously) the teaching stages. The
 * correspondences are not sent: an export decodes them again (completeResult).
 */
export async function scanEntry(entry, { keepView = false } = {}) {
  const want = state.continuous ? ['families', 'depth'] : ['families', 'depth', 'stages'];
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
  const settings = scanSettings(entry.kind);
  try {
    entry.result = await scanWith(settings, frame, want, state.continuous ? undefined : setStatus);
    entry.filter = state.filter;
    entry.colour = colourFor(entry.kind);
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

/**
 * Scan one frame of continuous scanning; resolves to the worker's result: its figures and
 * merged cloud, and the family clouds if `families`.
 */
export async function scanLive(frame, { families = false } = {}) {
  const c = state.calib;
  if (frame.width !== c.camera.width || frame.height !== c.camera.height) {
    throw new Error(`the camera gives ${frame.width}x${frame.height} but the calibration’s camera is ${c.camera.width}x${c.camera.height}`);
  }
  return scanWith(scanSettings('live'), frame, families ? ['families'] : []);
}

/**
 * The result of `entry` with every one of `wants` (worker-scan.js's optional results) in
 * it. Those it lacks are decoded again from its frame with the settings it was made with
 * (decoding is deterministic: the same cloud comes back, which is checked) and added.
 */
export async function completeResult(entry, wants) {
  const r = entry.result;
  const missing = wants.filter((w) => !(w in r));
  if (!missing.length) return r;
  const more = await busy(`decoding ${entry.name} again for its ${missing.join(' and ')}`, () =>
    scanWith(r.settings, entry.frame, missing),
  );
  const [was, now] = [r.merged.families.length, more.merged.families.length];
  if (was !== now) throw new Error(`${entry.name} decoded to ${now} points this time, ${was} before: scan it again first`);
  for (const w of missing) r[w] = more[w];
  return r;
}

/** Scan `frame` with `settings` (scanSettings), asking for `want`; the result keeps the settings. */
async function scanWith(settings, frame, want, onProgress) {
  const rgba = frame.rgba.slice(); // transferred: the entry keeps its pixels
  const payload = { ...settings, width: frame.width, height: frame.height, rgba, want };
  const result = await bridge.request('scan', payload, [rgba.buffer], { onProgress });
  result.settings = settings;
  return result;
}

/** Put a continuous-scanning result in the list's live entry and show it; returns the entry. */
export function showLiveResult(frame, result, { keepView }) {
  const live = addFrame(LIVE_NAME, frame, 'live');
  Object.assign(live, { result, filter: state.filter, colour: colourFor('live'), error: '' });
  renderFrameItem(live);
  showEntry(live, { keepView });
  return live;
}

/**
 * Make an entry the current one: its frame, cloud, depth map and stages. It is decoded
 * (again) when `rescan` says so, or, unless scanning continuously, when its result was
 * made with other settings or without stages.
 */
function showEntry(entry, { keepView = false, rescan = false } = {}) {
  state.current = entry;
  for (const f of state.frames) {
    f.item.classList.toggle('current', f === entry);
    // Stages are a dozen full-size images: only the current frame keeps them.
    if (f !== entry && f.result) delete f.result.stages;
  }
  showInput(entry.frame, entry.name);
  const stale =
    entry.result &&
    (entry.filter !== state.filter || !sameColour(entry.colour, colourFor(entry.kind)) || !entry.result.stages);
  if (rescan || (stale && !state.continuous)) {
    busy(`decoding ${entry.name}`, () => scanEntry(entry, { keepView }))
      .then(() => setStatus(summary(entry)))
      .catch((e) => showMessage(e.message, 'error'));
    return;
  }
  if (entry.result) showResult(entry.result, { name: entry.name, text: summary(entry), keepView });
  else showNoResult(entry.name, entry.error || 'no cloud');
}

/** Show the current frame again after a setting changed (not while scanning continuously). */
export function refreshCurrent({ rescan = false } = {}) {
  if (state.current && !state.continuous) showEntry(state.current, { rescan, keepView: true });
}

/** Decode the current frame again, stages included (the “Recompute” button). */
export function redecodeCurrent() {
  if (state.current) showEntry(state.current, { rescan: true, keepView: true });
}

/** One line about an entry's result: points per family, filter, time. */
export function summary(entry) {
  const r = entry.result;
  if (!r) return entry.error;
  const fam = r.stats.decoded.map((n, k) => `family ${k + 1}: ${n.toLocaleString('en')}`).join(' · ');
  const mixing = entry.colour?.mode === 'simulator' ? ' · simulator’s colour mixing undone' : '';
  const response = entry.colour?.response ? ' · read through the camera response' : '';
  const threads = r.threads > 1 ? ` on ${r.threads} threads` : '';
  const f = r.stats.decode_factor;
  const scale = f > 1 ? ` · decoded at 1/${f} scale` : '';
  return `${entry.name}: ${r.merged.families.length.toLocaleString('en')} points (${fam}) · ${r.stats.filter}${mixing}${response}${scale} · ${r.ms.toFixed(0)} ms${threads}`;
}

/**
 * The colour settings for a kind of frame: the crosstalk mode, its 9 numbers (null for
 * none) and the camera response (256 numbers, null for the power law). Simulated frames
 * use the simulator's camera, whose mixing is known and whose codes follow the power law.
 */
function colourFor(kind) {
  const mode = kind === 'sample' ? 'simulator' : state.crosstalk;
  const crosstalk = mode === 'simulator' ? state.simulatorCrosstalk : mode === 'measured' ? state.measuredCrosstalk : null;
  const response = kind === 'sample' ? null : state.response?.values ?? null;
  return { mode, crosstalk, response };
}

/** Whether two colour settings decode alike (the arrays are replaced, never changed in place). */
function sameColour(a, b) {
  return Boolean(a) && a.mode === b.mode && a.crosstalk === b.crosstalk && a.response === b.response;
}

/** What a scan request needs besides the pixels. */
function scanSettings(kind) {
  const { crosstalk, response } = colourFor(kind);
  return { specJson: state.specJson, calibJson: state.calibJson, filter: state.filter, crosstalk, response };
}

/** Render a simulated scene with the current pattern and calibration, and scan it. */
export async function scanScene(name, seed = 1) {
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

/** After a pattern change: render the simulated scene on screen again, if one is. */
export function rescanShownSample() {
  if (state.current?.kind !== 'sample') return;
  const scene = state.current.name.replace('simulated ', '');
  busy(`simulating ${scene}`, () => scanScene(scene))
    .then((entry) => setStatus(summary(entry)))
    .catch((err) => showMessage(err.message, 'error'));
}

/** Handle dropped or chosen files: JSON first (they may change the rig), then images. */
export async function handleFiles(files) {
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
      setStatus(`${file.name} was not read`);
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

/** Offer the simulator's scenes, `chosen` selected. */
export function fillScenes(names, chosen) {
  $('scene').replaceChildren(...names.map((n) => new Option(n, n, false, n === chosen)));
}

/** Bind the drop zone (the whole page accepts drops), the file chooser and “Render and scan”. */
export function bindFramesPanel() {
  const zone = $('drop-zone');
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
  $('render-scene').onclick = () =>
    busy('simulating', () => scanScene($('scene').value, 1 + Math.floor(Math.random() * 1000)))
      .then((entry) => setStatus(summary(entry)))
      .catch((e) => showMessage(e.message, 'error'));
}
