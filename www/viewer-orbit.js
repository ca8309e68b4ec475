// The point-cloud viewer's camera: an orbit around a target point in the y-up view frame
// (viewer.js draws the camera frame's x, -y, -z), moved by pointer, wheel and pinch, and
// turned into a view-projection matrix each frame. No WebGL here.
//
// Controls: drag to orbit, right-drag or shift-drag to pan, wheel or pinch to zoom,
// double-click to reset.

/** Where the orbit starts before any cloud: the demo rig's scene, 750 mm ahead. */
const DEFAULT_HOME = { target: [0, 0, -750], yaw: 0, pitch: 0, distance: 750 };
/** Radians of yaw and pitch per CSS pixel dragged. */
const ORBIT_PER_PX = 0.008;
/** Pitch stays short of straight up or down, where the look-at basis degenerates. */
const MAX_PITCH = 1.55;

export class OrbitCamera {
  /**
   * @param {HTMLCanvasElement} canvas listens to its pointer, wheel and double-click events
   * @param {() => void} onChange called whenever the view moved
   */
  constructor(canvas, onChange) {
    this.canvas = canvas;
    this.onChange = onChange;
    this.fovY = (45 * Math.PI) / 180;
    this.home = { ...DEFAULT_HOME, target: [...DEFAULT_HOME.target] };
    this.view = { ...this.home, target: [...this.home.target] };
    this.scratch = { view: new Float32Array(16), projection: new Float32Array(16), eye: new Float64Array(3) };
    this.#bindControls();
  }

  /** Back to the home view. */
  reset() {
    this.view = { ...this.home, target: [...this.home.target] };
    this.onChange();
  }

  /**
   * Make the home view look at `target` (view frame, mm) from the origin, where the real
   * camera was, and go there.
   */
  aimAt(target) {
    const distance = Math.hypot(...target) || 750;
    // The eye sits at the origin (the real camera): eye = target + distance * dir.
    const dir = target.map((c) => -c / distance);
    this.home = {
      target,
      distance,
      yaw: Math.atan2(dir[0], dir[2]),
      pitch: Math.asin(Math.max(-1, Math.min(1, dir[1]))),
    };
    this.reset();
  }

  /** Write the view-projection matrix for a viewport of `aspect` (width / height) into `out`. */
  viewProjection(out, aspect) {
    const { target, yaw, pitch, distance } = this.view;
    const eye = this.scratch.eye;
    eye[0] = target[0] + distance * Math.cos(pitch) * Math.sin(yaw);
    eye[1] = target[1] + distance * Math.sin(pitch);
    eye[2] = target[2] + distance * Math.cos(pitch) * Math.cos(yaw);
    lookAt(this.scratch.view, eye, target);
    perspective(this.scratch.projection, this.fovY, aspect, distance * 0.02, distance * 20);
    multiply(out, this.scratch.projection, this.scratch.view);
  }

  #bindControls() {
    const canvas = this.canvas;
    const pointers = new Map();
    let last = null;
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());
    canvas.addEventListener('pointerdown', (e) => {
      canvas.setPointerCapture(e.pointerId);
      pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey });
      last = pinchOf(pointers);
    });
    canvas.addEventListener('pointermove', (e) => {
      const p = pointers.get(e.pointerId);
      if (!p) return;
      const dx = e.clientX - p.x;
      const dy = e.clientY - p.y;
      p.x = e.clientX;
      p.y = e.clientY;
      if (pointers.size >= 2) {
        const now = pinchOf(pointers);
        if (last && now.spread > 0) this.#zoom(last.spread / now.spread);
        if (last) this.#pan(now.x - last.x, now.y - last.y);
        last = now;
      } else if (p.pan) {
        this.#pan(dx, dy);
      } else {
        this.view.yaw -= dx * ORBIT_PER_PX;
        this.view.pitch = Math.max(-MAX_PITCH, Math.min(MAX_PITCH, this.view.pitch + dy * ORBIT_PER_PX));
      }
      this.onChange();
    });
    const up = (e) => {
      pointers.delete(e.pointerId);
      last = pinchOf(pointers);
    };
    canvas.addEventListener('pointerup', up);
    canvas.addEventListener('pointercancel', up);
    canvas.addEventListener(
      'wheel',
      (e) => {
        e.preventDefault();
        this.#zoom(Math.exp(e.deltaY * (e.deltaMode === 1 ? 0.05 : 0.0015)));
      },
      { passive: false },
    );
    canvas.addEventListener('dblclick', () => this.reset());
  }

  #zoom(factor) {
    this.view.distance = Math.max(1, Math.min(1e6, this.view.distance * factor));
    this.onChange();
  }

  /** Move the target in the view plane by a drag of (dx, dy) CSS pixels. */
  #pan(dx, dy) {
    const { yaw, pitch, distance } = this.view;
    const scale = (2 * distance * Math.tan(this.fovY / 2)) / Math.max(1, this.canvas.clientHeight);
    const right = [Math.cos(yaw), 0, -Math.sin(yaw)];
    const up = [-Math.sin(pitch) * Math.sin(yaw), Math.cos(pitch), -Math.sin(pitch) * Math.cos(yaw)];
    for (let i = 0; i < 3; i++) this.view.target[i] += scale * (-dx * right[i] + dy * up[i]);
    this.onChange();
  }
}

/**
 * The middle of a cloud (camera frame, mm: per-axis medians) and its depth range (2nd to
 * 98th percentile of z), from a subsample: robust to stray points, cheap for 300k.
 * Null for an empty cloud.
 */
export function robustExtent(positions) {
  const n = positions.length / 3;
  if (!n) return null;
  const step = Math.max(1, Math.floor(n / 4000));
  const xs = [], ys = [], zs = [];
  for (let i = 0; i < n; i += step) {
    xs.push(positions[3 * i]);
    ys.push(positions[3 * i + 1]);
    zs.push(positions[3 * i + 2]);
  }
  for (const a of [xs, ys, zs]) a.sort((p, q) => p - q);
  const at = (a, q) => a[Math.min(a.length - 1, Math.floor(q * a.length))];
  return { median: [at(xs, 0.5), at(ys, 0.5), at(zs, 0.5)], depthRange: [at(zs, 0.02), at(zs, 0.98)] };
}

function pinchOf(pointers) {
  if (pointers.size < 2) return null;
  const [a, b] = [...pointers.values()];
  return { x: (a.x + b.x) / 2, y: (a.y + b.y) / 2, spread: Math.hypot(a.x - b.x, a.y - b.y) };
}

// Column-major 4x4 matrices written into preallocated arrays.

function perspective(out, fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2);
  out.fill(0);
  out[0] = f / aspect;
  out[5] = f;
  out[10] = (far + near) / (near - far);
  out[11] = -1;
  out[14] = (2 * far * near) / (near - far);
}

function lookAt(out, eye, target) {
  let zx = eye[0] - target[0], zy = eye[1] - target[1], zz = eye[2] - target[2];
  let len = Math.hypot(zx, zy, zz) || 1;
  zx /= len; zy /= len; zz /= len;
  // x = up × z with up = +y; near the poles the pitch clamp keeps this well defined.
  let xx = zz, xy = 0, xz = -zx;
  len = Math.hypot(xx, xy, xz) || 1;
  xx /= len; xy /= len; xz /= len;
  const yx = zy * xz - zz * xy, yy = zz * xx - zx * xz, yz = zx * xy - zy * xx;
  out[0] = xx; out[1] = yx; out[2] = zx; out[3] = 0;
  out[4] = xy; out[5] = yy; out[6] = zy; out[7] = 0;
  out[8] = xz; out[9] = yz; out[10] = zz; out[11] = 0;
  out[12] = -(xx * eye[0] + xy * eye[1] + xz * eye[2]);
  out[13] = -(yx * eye[0] + yy * eye[1] + yz * eye[2]);
  out[14] = -(zx * eye[0] + zy * eye[1] + zz * eye[2]);
  out[15] = 1;
}

function multiply(out, a, b) {
  for (let c = 0; c < 4; c++) {
    for (let r = 0; r < 4; r++) {
      out[4 * c + r] =
        a[r] * b[4 * c] + a[4 + r] * b[4 * c + 1] + a[8 + r] * b[4 * c + 2] + a[12 + r] * b[4 * c + 3];
    }
  }
}
