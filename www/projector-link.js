// The link to the projector window (projector.html, projector.js): opening it, moving it
// to another screen where the browser allows, sending it the pattern (or a flat colour
// for the colour calibration), hearing its screen size when it loads, and noticing when
// it is closed (the button opens it again).
//
// Messages (window.postMessage, same origin only):
//   projector -> page  {type: 'projector-hello', width, height, dpr}   screen in device pixels
//   page -> projector  {type: 'pattern', width, height, rgba, label}   pixels to show

import { $, state, showMessage } from './page.js';

/** How often the page looks whether the projector window is still open: no event tells
 * an opener that its pop-up closed (the pop-up's own `pagehide` also fires on a reload). */
const CLOSED_POLL_MS = 500;

/** Set by bindProjectorLink: stops continuous scanning, returns whether it was running. */
let stopScanning = () => false;
let watchTimer = 0;

/**
 * Open the projector window. It opens at once (a pop-up needs the click's user
 * activation, which a permission prompt would outlast) and is then moved to another
 * screen where the Window Management API offers one; otherwise the user drags it.
 */
export async function openProjector() {
  const win = window.open('projector.html', 'stripelight-projector', 'popup,width=1024,height=768');
  if (!win) {
    showMessage(
      'The browser blocked the projector window. Allow pop-ups for this page (the icon at the right of the address bar), then press “Open projector window” again.',
      'error',
    );
    return;
  }
  state.projectorWindow = win;
  watchProjector();
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

/** Look every CLOSED_POLL_MS whether the projector window was closed, until it is. */
function watchProjector() {
  clearInterval(watchTimer);
  watchTimer = setInterval(() => {
    if (!state.projectorWindow?.closed) return;
    clearInterval(watchTimer);
    state.projectorWindow = null;
    projectorClosed();
  }, CLOSED_POLL_MS);
}

/** The projector window was closed (by the user, or with its screen). */
function projectorClosed() {
  // Frames without the pattern decode to nothing: scanning on would only replace the
  // last cloud with empty ones.
  if (stopScanning()) {
    showMessage(
      'The projector window was closed while scanning, so the pattern is no longer shown: continuous scanning stopped ' +
        'and the last cloud stays. Press “Open projector window” to show the pattern again, then tick “Scan continuously”.',
      'error',
    );
  } else {
    showMessage('The projector window was closed. Press “Open projector window” to show the pattern again.');
  }
}

/** Whether the projector window is open. */
export function projectorIsOpen() {
  const win = state.projectorWindow;
  return Boolean(win && !win.closed);
}

/**
 * Show an image in the projector window, captioned `label`. The pixels are transferred,
 * not copied: pass a buffer the page does not keep.
 */
export function showOnProjector({ width, height, rgba, label }) {
  if (!projectorIsOpen()) return;
  state.projectorWindow.postMessage({ type: 'pattern', width, height, rgba, label }, location.origin, [rgba.buffer]);
}

/** Show the current pattern in the projector window, if both exist. */
export function sendPatternToProjector() {
  const p = state.patternPixels;
  if (!projectorIsOpen() || !p) return;
  // A copy: the thumbnail keeps the original.
  const rgba = p.rgba.slice();
  showOnProjector({ width: p.width, height: p.height, rgba, label: `${state.spec.families.length}-direction pattern` });
}

/**
 * Bind the “Open projector window” button and listen for the window's hello (sent when it
 * loads): it gets the pattern, and `onScreenSize(width, height)` (returning a promise)
 * hears the projector screen's native size. `onClosed()` runs when the window is closed:
 * it stops continuous scanning and returns whether scanning was running.
 */
export function bindProjectorLink({ onScreenSize, onClosed }) {
  stopScanning = onClosed;
  $('open-projector').onclick = () => openProjector();
  window.addEventListener('message', (event) => {
    if (event.origin !== location.origin || event.data?.type !== 'projector-hello') return;
    if (event.source && event.source !== state.projectorWindow) {
      state.projectorWindow = event.source;
      watchProjector();
    }
    const { width, height } = event.data;
    sendPatternToProjector();
    onScreenSize(width, height).catch((e) => showMessage(e.message, 'error'));
  });
}
