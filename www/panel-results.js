// The results: the point-cloud viewer and its toolbar (colouring, layers per stripe
// family, point size), the point count, the input frame and its depth map, and the
// teaching view with every decoding stage and the filter choice. This module only draws
// what it is given; the frames panel decides which frame is shown and decodes it.

import { $, state, showMessage, drawImage } from './page.js';
import { PointCloudViewer, FAMILY_COLORS } from './viewer.js';

/** The WebGL point-cloud viewer; null where it could not start (a message says why). */
export const viewer = createViewer();

function createViewer() {
  try {
    return new PointCloudViewer($('viewer'));
  } catch (e) {
    showMessage(e.message, 'error');
    return null;
  }
}

/** Give the viewer the calibration camera's vertical field of view. */
export function matchCameraView(calib) {
  viewer?.setFieldOfView(2 * Math.atan(calib.camera.height / 2 / calib.camera.fy));
}

/** Show the input frame under the viewer. */
export function showInput(frame, name) {
  drawImage($('frame-canvas'), frame);
  $('frame-caption').textContent = `input: ${name}`;
}

/**
 * Show a scan result `r` of frame `name`: cloud, depth map, point count with `text`, and
 * the stages if they were asked for. `keepView` keeps the viewer's camera where it is.
 */
export function showResult(r, { name, text, keepView }) {
  showCloud(r, keepView);
  drawDepth($('depth-canvas'), r);
  setPointCount(r.merged.families.length, text);
  if (r.stages) drawStages(r.stages, name);
  else if (!state.continuous || $('stages').childElementCount) showNoStages(name);
}

/** The stages of `name` were not decoded (continuous scanning skips them). */
function showNoStages(name) {
  $('stages').replaceChildren();
  $('stages-note').textContent = `Continuous scanning skips the stages: click ${name} in the frames list to decode them.`;
}

/** Show that frame `name` has no result; `text` says why. */
export function showNoResult(name, text) {
  viewer?.setClouds([]);
  setPointCount(0, text);
  $('stages').replaceChildren();
  $('stages-note').textContent = `No stages: ${name} was not decoded.`;
}

function setPointCount(n, text) {
  const out = $('point-count');
  out.dataset.count = String(n);
  out.textContent = `${n.toLocaleString('en')} points`;
  $('scan-stats').textContent = text;
}

/**
 * The merged cloud and one cloud per family, each shown as its layer toggle says. Live
 * results carry family clouds only while a family layer is ticked: until one comes, an
 * empty cloud stands in.
 */
function showCloud(r, keepView) {
  if (!viewer) return;
  const toggles = ensureLayerToggles(r.familyCount);
  const clouds = [{ positions: r.merged.positions, colors: r.merged.colors, families: r.merged.families, visible: toggles[0].checked }];
  for (let k = 0; k < r.familyCount; k++) {
    const f = r.families?.[k] ?? NO_CLOUD;
    clouds.push({ positions: f.positions, colors: f.colors, families: null, familyMask: 1 << k, visible: toggles[k + 1].checked });
  }
  viewer.setClouds(clouds, { keepView });
}

const NO_CLOUD = { positions: new Float32Array(0), colors: new Uint8Array(0) };

/** Whether a family layer is ticked (continuous scanning then asks for the family clouds). */
export function familyLayersShown() {
  return [...$('layers').querySelectorAll('input')].some((input) => input.dataset.layer !== '0' && input.checked);
}

/** Called when a family layer is ticked while the frame shown has no family clouds. */
let onFamiliesWanted = () => {};

/** One checkbox for the merged cloud and one per family (made again when the count changes). */
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
      input.onchange = () => {
        viewer?.setVisible(i, input.checked);
        if (i > 0 && input.checked) onFamiliesWanted();
      };
      const swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = i === 0 ? '#ddd' : FAMILY_COLORS[i - 1];
      label.append(input, swatch, document.createTextNode(i === 0 ? 'merged' : `family ${i}`));
      box.append(label);
    }
  }
  return [...box.querySelectorAll('input')];
}

/** The depth map in grey (near bright), no depth in dark blue. */
function drawDepth(canvas, r) {
  const { width, height } = r;
  const depth = r.depth ?? depthOfCloud(r.merged, width, height);
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

/** Scratch for depthOfCloud, kept between live frames of one size. */
let cloudDepth = new Float32Array(0);

/**
 * The depth map of a result that came without one (a live frame): the merged cloud's Z
 * at the pixel each point came from. Where the cloud has no point this is NaN, as in the
 * decoder's depth map.
 */
function depthOfCloud(cloud, width, height) {
  if (cloudDepth.length !== width * height) cloudDepth = new Float32Array(width * height);
  cloudDepth.fill(NaN);
  const { positions, pixels } = cloud;
  for (let i = 0; i < pixels.length / 2; i++) {
    const u = Math.round(pixels[2 * i]), v = Math.round(pixels[2 * i + 1]);
    if (u >= 0 && u < width && v >= 0 && v < height) cloudDepth[v * width + u] = positions[3 * i + 2];
  }
  return cloudDepth;
}

/** The teaching view: one captioned image per decoding stage; a click enlarges one. */
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

/**
 * Bind the viewer's toolbar and the teaching view's controls. `onFilterChanged()` runs
 * after another filter was chosen, `onRecompute()` when “Recompute” is pressed,
 * `onFamiliesWanted()` when a family layer is ticked.
 */
export function bindResultsPanel({ onFilterChanged, onRecompute, onFamiliesWanted: familiesWanted }) {
  onFamiliesWanted = familiesWanted;
  for (const input of document.querySelectorAll('input[name="color-mode"]')) {
    input.onchange = () => viewer?.setColorMode(input.value);
  }
  $('point-size').oninput = (e) => {
    viewer?.setPointSize(Number(e.target.value));
    $('point-size-value').textContent = e.target.value;
  };
  $('reset-view').onclick = () => viewer?.resetView();
  const filters = document.querySelectorAll('input[name="filter"]');
  for (const input of filters) {
    input.onchange = () => {
      state.filter = input.value;
      for (const other of filters) other.checked = other.value === state.filter;
      onFilterChanged();
    };
  }
  $('refresh-stages').onclick = () => onRecompute();
}
