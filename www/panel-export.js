// Export: the current frame's merged cloud as PLY, its depth map as PFM and its
// correspondences (each family's projector coordinate per pixel) as colour PFM (formats
// as in conventions.md: mm, camera frame), encoded by a worker and saved as downloads.
// A result that came without the depth map or the correspondences (live frames carry
// neither, no frame carries the correspondences) is completed first (completeResult).

import { $, state, bridge, showMessage, download } from './page.js';
import { completeResult } from './panel-frames.js';

/** The current frame's name made safe for a file name, without its extension. */
function baseName() {
  return (state.current?.name ?? 'scan').replace(/\.[a-z0-9]+$/i, '').replace(/[^a-z0-9_-]+/gi, '-');
}

/** The current frame's result with `wants` in it, or null (with a message) if there is none. */
async function currentResult(wants = []) {
  const entry = state.current;
  if (!entry?.result) {
    showMessage('Nothing to export yet: scan a frame first.', 'error');
    return null;
  }
  return completeResult(entry, wants);
}

async function exportPly() {
  const r = await currentResult();
  if (!r) return;
  const m = r.merged;
  // Copies, transferred to the worker: the viewer keeps the originals.
  const copy = { positions: m.positions.slice(), colors: m.colors.slice(), pixels: m.pixels.slice(), families: m.families.slice() };
  const bytes = await bridge.request('encodePly', copy, Object.values(copy).map((a) => a.buffer));
  download(bytes, `stripelight-${baseName()}.ply`, 'application/octet-stream');
}

async function exportDepth() {
  const r = await currentResult(['depth']);
  if (!r) return;
  const depth = r.depth.slice();
  const bytes = await bridge.request('encodePfm', { depth, width: r.width, height: r.height }, [depth.buffer]);
  download(bytes, `stripelight-${baseName()}-depth.pfm`, 'application/octet-stream');
}

async function exportCorrespondence() {
  const r = await currentResult(['correspondence']);
  if (!r) return;
  // The correspondences are only needed here: they go to the worker and are not kept.
  const values = r.correspondence;
  delete r.correspondence;
  const bytes = await bridge.request('encodePfmRgb', { values, width: r.width, height: r.height }, [values.buffer]);
  download(bytes, `stripelight-${baseName()}-correspondence.pfm`, 'application/octet-stream');
}

/** Bind the export buttons. */
export function bindExportButtons() {
  $('export-corr').onclick = () => exportCorrespondence().catch((e) => showMessage(e.message, 'error'));
  $('export-ply').onclick = () => exportPly().catch((e) => showMessage(e.message, 'error'));
  $('export-pfm').onclick = () => exportDepth().catch((e) => showMessage(e.message, 'error'));
}
