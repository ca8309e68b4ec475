// The projector window. It draws the pattern the scanner page sends, pixel for pixel,
// and tells the page the screen's native resolution so that the rig and pattern can
// follow it.
//
// Messages (window.postMessage, same origin only):
//   projector -> page  {type: 'projector-hello', width, height, dpr}   screen in device pixels
//   page -> projector  {type: 'pattern', width, height, rgba, label}   pixels to show

const canvas = document.getElementById('pattern');
const ctx = canvas.getContext('2d', { alpha: false, colorSpace: 'srgb' });
const hintPattern = document.getElementById('hint-pattern');
const hintScreen = document.getElementById('hint-screen');
let pattern = null;

function screenSize() {
  const dpr = window.devicePixelRatio || 1;
  return { width: Math.round(screen.width * dpr), height: Math.round(screen.height * dpr), dpr };
}

function hello() {
  if (!window.opener) {
    hintPattern.textContent = 'Open this window with the scanner page’s “Open projector window” button.';
    return;
  }
  window.opener.postMessage({ type: 'projector-hello', ...screenSize() }, location.origin);
}

function draw() {
  const { width, height, dpr } = screenSize();
  hintScreen.textContent = `This screen: ${width} x ${height} device pixels (devicePixelRatio ${dpr}).`;
  if (!pattern) return;
  canvas.width = pattern.width;
  canvas.height = pattern.height;
  canvas.style.width = `${pattern.width / dpr}px`;
  canvas.style.height = `${pattern.height / dpr}px`;
  ctx.imageSmoothingEnabled = false;
  ctx.putImageData(new ImageData(new Uint8ClampedArray(pattern.rgba.buffer), pattern.width, pattern.height), 0, 0);
  hintPattern.textContent = `${pattern.label}: ${pattern.width} x ${pattern.height} pixels, drawn 1:1 from the top-left corner.`;
  if (pattern.width !== width || pattern.height !== height) {
    hintScreen.innerHTML = '';
    const warn = document.createElement('span');
    warn.className = 'warn';
    warn.textContent =
      `This screen is ${width} x ${height} device pixels but the pattern is ${pattern.width} x ${pattern.height}: ` +
      'the calibration’s projector size should match the projector’s native resolution.';
    hintScreen.append(warn);
  }
}

window.addEventListener('message', (event) => {
  if (event.origin !== location.origin || event.data?.type !== 'pattern') return;
  pattern = event.data;
  draw();
});

function toggleFullscreen() {
  if (document.fullscreenElement) document.exitFullscreen();
  else document.documentElement.requestFullscreen({ navigationUI: 'hide' }).catch(() => {});
}

document.addEventListener('click', toggleFullscreen);
document.addEventListener('keydown', (e) => {
  if (e.key === 'f' || e.key === 'F') toggleFullscreen();
});
document.addEventListener('fullscreenchange', () => {
  document.body.classList.toggle('fullscreen', Boolean(document.fullscreenElement));
});

// A move to another screen or a zoom change alters the device-pixel size: redraw and
// tell the page.
let lastKey = '';
function watchScreen() {
  const s = screenSize();
  const key = `${s.width}x${s.height}@${s.dpr}`;
  if (key !== lastKey) {
    lastKey = key;
    draw();
    hello();
  }
}
window.addEventListener('resize', watchScreen);
setInterval(watchScreen, 1000);
watchScreen();
