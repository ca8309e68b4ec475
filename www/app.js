// The scanner page: wires the panels together and starts up. All decoding happens in the
// workers (bridge.js / worker.js); the page only moves pixels and draws.
//
// Where things live (www/):
//   page.js               shared state, the workers' bridge, status line, messages, helpers
//   panel-pattern.js      1 pattern: directions, spec, thumbnail
//   panel-camera.js       2 camera: webcam, capture, continuous scanning
//   live.js               continuous scanning's frame scheduling (latest wins) and figures
//   panel-frames.js       frames list and scanning: drops, simulated scenes, current frame
//   panel-calibration.js  3 calibration: rig, calibration files, colour mixing
//   panel-results.js      viewer, depth map, teaching view (draws only)
//   viewer.js             the WebGL point-cloud viewer (viewer-program.js: its shaders;
//                         viewer-orbit.js: its orbit camera and mouse and touch controls)
//   panel-export.js       PLY and PFM downloads
//   projector-link.js     the projector window
//   camera.js             the webcam (getUserMedia), its exposure meter and frame grabs
//   bridge.js, worker.js  the decoding workers and their message protocol (worker-scan.js:
//                         the worker's scanners and what a scan reply carries)
//   frame-size.js         the largest frame the page decodes, read from image headers
//
// Modules import only "downwards" in this order: page, projector-link, pattern, results,
// calibration, frames, camera (results needs page only, export page and frames; live.js
// and camera.js know no other module). Where a module must reach one above it, it takes
// a callback, and this file passes it in.

import { state, bridge, busy, setStatus, showMessage } from './page.js';
import { bindProjectorLink } from './projector-link.js';
import { bindPatternPanel } from './panel-pattern.js';
import { viewer, bindResultsPanel } from './panel-results.js';
import { setCalibration, followDeviceSize, bindCalibrationPanel } from './panel-calibration.js';
import {
  bindFramesPanel, fillScenes, handleFiles, redecodeCurrent, refreshCurrent, rescanShownSample, scanScene, summary,
} from './panel-frames.js';
import { camera, bindCameraPanel, stopContinuous } from './panel-camera.js';
import { bindExportButtons } from './panel-export.js';
import { Camera } from './camera.js';

/** The built-in sample: a simulated scene, scanned on first open. */
const SAMPLE_SCENE = 'sphere';

function bindPanels() {
  bindPatternPanel({ onDirectionsChanged: rescanShownSample });
  bindProjectorLink({
    onScreenSize: (width, height) => followDeviceSize('projector', width, height),
    onClosed: stopContinuous,
  });
  bindCameraPanel();
  bindFramesPanel();
  bindCalibrationPanel({ camera, onMixingChanged: () => refreshCurrent() });
  bindResultsPanel({
    onFilterChanged: () => refreshCurrent({ rescan: true }),
    onRecompute: redecodeCurrent,
    // Only a live frame comes without family clouds; shown again, it is decoded in full.
    onFamiliesWanted: () => state.current?.result?.families || refreshCurrent(),
  });
  bindExportButtons();
}

async function main() {
  bindPanels();
  try {
    await bridge.ready();
  } catch (e) {
    setStatus('the decoder could not start');
    return;
  }
  state.simulatorCrosstalk = await bridge.request('simulatorCrosstalk');
  Camera.clipLevel = await bridge.request('saturationLevel');
  fillScenes(await bridge.request('sceneNames'), SAMPLE_SCENE);
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
window.stripelight = { state, bridge, viewer, started, handleFiles };
