// Panel 1, the pattern: how many stripe directions, the pattern spec the decoder uses
// (generated for the calibration's projector, or loaded from a file), its thumbnail and
// its JSON for download. Every new pattern also goes to the projector window.

import { $, state, bridge, busy, setStatus, showMessage, drawImage, download } from './page.js';
import { sendPatternToProjector } from './projector-link.js';

/** Generate a pattern with the chosen number of directions for the calibration's projector. */
export async function generateSpec() {
  const { width, height } = state.calib.projector;
  const json = await bridge.request('generatePattern', { directions: state.directions, width, height });
  await setSpec(json, 'generated');
}

/** Use a pattern spec (JSON text; `source` is 'generated' or a file name) from now on. */
export async function setSpec(json, source) {
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

/** Whether the spec fits the calibration's projector; an error message says so when not. */
export function checkSpecMatchesCalibration() {
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

/**
 * Bind the panel's controls. `onDirectionsChanged()` runs once a pattern with the newly
 * chosen number of directions is ready.
 */
export function bindPatternPanel({ onDirectionsChanged }) {
  $('directions').onchange = async (e) => {
    state.directions = Number(e.target.value);
    state.specSource = 'generated';
    await busy('generating the pattern', generateSpec).catch((err) => showMessage(err.message, 'error'));
    setStatus(`pattern with ${state.directions} direction(s) ready; capture or render a sample to decode it`);
    onDirectionsChanged();
  };
  $('download-spec').onclick = () => download(state.specJson, 'stripelight-pattern.json', 'application/json');
}
