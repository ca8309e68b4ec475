// WebGL2 point-cloud viewer.
//
// Clouds arrive in the camera frame of conventions.md (x right, y down, z forward, mm)
// and are drawn in a y-up view frame (x, -y, -z), so the initial view is the one the
// real camera had. Each layer (the merged cloud, each family's cloud) owns one vertex
// array with three buffers that are uploaded once per cloud and reused while they are
// large enough; drawing a frame allocates nothing.
//
// Controls: drag to orbit, right-drag or shift-drag to pan, wheel or pinch to zoom,
// double-click to reset.

const VERTEX_SHADER = `#version 300 es
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aColor;
layout(location = 2) in float aFamilies;
uniform mat4 uViewProjection;
uniform float uPointSize;
uniform int uMode;            // 0 captured colour, 1 depth, 2 family
uniform vec2 uDepthRange;     // mm, mapped to the colour scale's ends
uniform vec3 uFamilyColors[3];
out vec3 vColor;

// A compact rainbow-like scale (blue near, red far) that stays readable in grey.
vec3 depthScale(float t) {
  t = clamp(t, 0.0, 1.0);
  return clamp(vec3(
    1.5 - abs(4.0 * t - 3.0),
    1.5 - abs(4.0 * t - 2.0),
    1.5 - abs(4.0 * t - 1.0)), 0.0, 1.0) * (0.35 + 0.65 * (1.0 - 0.5 * t));
}

void main() {
  gl_Position = uViewProjection * vec4(aPosition.x, -aPosition.y, -aPosition.z, 1.0);
  gl_PointSize = uPointSize;
  if (uMode == 0) {
    vColor = aColor;
  } else if (uMode == 1) {
    vColor = depthScale((aPosition.z - uDepthRange.x) / max(uDepthRange.y - uDepthRange.x, 1e-3));
  } else {
    int mask = int(aFamilies + 0.5);
    vec3 sum = vec3(0.0);
    float n = 0.0;
    for (int k = 0; k < 3; k++) {
      if ((mask & (1 << k)) != 0) { sum += uFamilyColors[k]; n += 1.0; }
    }
    // Points that several families measured are drawn lighter.
    vColor = n == 0.0 ? vec3(0.6) : mix(sum / n, vec3(1.0), n > 1.0 ? 0.45 : 0.0);
  }
}`;

const FRAGMENT_SHADER = `#version 300 es
precision mediump float;
in vec3 vColor;
out vec4 outColor;
void main() {
  outColor = vec4(vColor, 1.0);
}`;

/** Colours of stripe families 0, 1, 2 in "family" mode (also used by the page's legend). */
export const FAMILY_COLORS = ['#f08c2e', '#3aa0e8', '#56c25a'];

/** The background; the page's end-to-end test counts pixels that differ from it. */
export const BACKGROUND = [0.106, 0.114, 0.133];

const MODES = { color: 0, depth: 1, family: 2 };

export class PointCloudViewer {
  /** @param {HTMLCanvasElement} canvas */
  constructor(canvas) {
    this.canvas = canvas;
    const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
    if (!gl) throw new Error('WebGL2 is not available in this browser, so the point cloud cannot be shown');
    this.gl = gl;
    this.layers = [];
    this.mode = MODES.color;
    this.pointSize = 2;
    this.fovY = (45 * Math.PI) / 180;
    this.depthRange = [500, 1000];
    this.home = { target: [0, 0, -750], yaw: 0, pitch: 0, distance: 750 };
    this.view = { ...this.home, target: [...this.home.target] };
    this.viewProjection = new Float32Array(16);
    this.scratch = { view: new Float32Array(16), projection: new Float32Array(16), eye: new Float64Array(3) };
    this.familyColors = new Float32Array(FAMILY_COLORS.flatMap(hexToRgb));
    this.frameMs = 0;
    this.pendingFrame = 0;
    this.#initGl();
    this.#bindControls();
    this.resizeObserver = new ResizeObserver(() => this.requestRender());
    this.resizeObserver.observe(canvas);
    canvas.addEventListener('webglcontextlost', (e) => e.preventDefault());
    canvas.addEventListener('webglcontextrestored', () => {
      const clouds = this.layers.map((l) => l.source);
      this.layers = [];
      this.#initGl();
      this.setClouds(clouds, { keepView: true });
    });
  }

  #initGl() {
    const gl = this.gl;
    this.program = linkProgram(gl, VERTEX_SHADER, FRAGMENT_SHADER);
    this.uniforms = {};
    for (const name of ['uViewProjection', 'uPointSize', 'uMode', 'uDepthRange', 'uFamilyColors']) {
      this.uniforms[name] = gl.getUniformLocation(this.program, name);
    }
  }

  /**
   * Replace the clouds. Each cloud: {positions: Float32Array (xyz), colors: Uint8Array
   * (rgb), families: Uint8Array | null (bit masks), familyMask: number (used when
   * `families` is null), visible: boolean}.
   * The view is reset unless `keepView` (continuous scanning keeps it).
   */
  setClouds(clouds, { keepView = false } = {}) {
    const gl = this.gl;
    while (this.layers.length > clouds.length) this.#deleteLayer(this.layers.pop());
    while (this.layers.length < clouds.length) this.layers.push(this.#createLayer());
    clouds.forEach((cloud, i) => {
      const layer = this.layers[i];
      const n = cloud.positions.length / 3;
      layer.source = cloud;
      layer.count = n;
      layer.visible = cloud.visible !== false;
      upload(gl, layer.buffers[0], cloud.positions, layer.capacity, 0);
      upload(gl, layer.buffers[1], cloud.colors, layer.capacity, 1);
      gl.bindVertexArray(layer.vao);
      // A layer without per-point masks uses one constant mask, set when it is drawn
      // (a constant attribute value is global state, not part of the vertex array).
      layer.familyMask = cloud.families ? -1 : cloud.familyMask ?? 0;
      if (cloud.families) {
        upload(gl, layer.buffers[2], cloud.families, layer.capacity, 2);
        gl.enableVertexAttribArray(2);
      } else {
        gl.disableVertexAttribArray(2);
      }
      gl.bindVertexArray(null);
    });
    const all = clouds.find((c) => c.positions.length) ?? clouds[0];
    if (all) this.#frame(all.positions, keepView);
    this.requestRender();
  }

  setVisible(index, visible) {
    if (this.layers[index]) {
      this.layers[index].visible = visible;
      this.requestRender();
    }
  }

  /** @param {'color' | 'depth' | 'family'} mode */
  setColorMode(mode) {
    if (!(mode in MODES)) throw new Error(`unknown colour mode ${mode}`);
    this.mode = MODES[mode];
    this.requestRender();
  }

  setPointSize(px) {
    this.pointSize = px;
    this.requestRender();
  }

  /** Vertical field of view of the camera that took the frames (radians). */
  setFieldOfView(fovY) {
    this.fovY = fovY;
    this.requestRender();
  }

  resetView() {
    this.view = { ...this.home, target: [...this.home.target] };
    this.requestRender();
  }

  /** Number of points drawn with the current toggles. */
  get visiblePoints() {
    return this.layers.reduce((n, l) => n + (l.visible ? l.count : 0), 0);
  }

  requestRender() {
    if (!this.pendingFrame) this.pendingFrame = requestAnimationFrame(() => this.render());
  }

  render() {
    this.pendingFrame = 0;
    const t0 = performance.now();
    const gl = this.gl;
    const dpr = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(this.canvas.clientWidth * dpr));
    const height = Math.max(1, Math.round(this.canvas.clientHeight * dpr));
    if (this.canvas.width !== width || this.canvas.height !== height) {
      this.canvas.width = width;
      this.canvas.height = height;
    }
    gl.viewport(0, 0, width, height);
    gl.clearColor(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    this.#updateMatrices(width / height);
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.uniforms.uViewProjection, false, this.viewProjection);
    gl.uniform1f(this.uniforms.uPointSize, this.pointSize * dpr);
    gl.uniform1i(this.uniforms.uMode, this.mode);
    gl.uniform2f(this.uniforms.uDepthRange, this.depthRange[0], this.depthRange[1]);
    gl.uniform3fv(this.uniforms.uFamilyColors, this.familyColors);
    for (const layer of this.layers) {
      if (!layer.visible || !layer.count) continue;
      gl.bindVertexArray(layer.vao);
      if (layer.familyMask >= 0) gl.vertexAttrib1f(2, layer.familyMask);
      gl.drawArrays(gl.POINTS, 0, layer.count);
    }
    gl.bindVertexArray(null);
    this.frameMs = performance.now() - t0;
  }

  destroy() {
    this.resizeObserver.disconnect();
    for (const layer of this.layers) this.#deleteLayer(layer);
    this.layers = [];
  }

  #createLayer() {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    const buffers = [gl.createBuffer(), gl.createBuffer(), gl.createBuffer()];
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffers[0]);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffers[1]);
    gl.enableVertexAttribArray(1);
    gl.vertexAttribPointer(1, 3, gl.UNSIGNED_BYTE, true, 0, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffers[2]);
    gl.vertexAttribPointer(2, 1, gl.UNSIGNED_BYTE, false, 0, 0);
    gl.bindVertexArray(null);
    return { vao, buffers, capacity: [0, 0, 0], count: 0, visible: true, familyMask: 0, source: null };
  }

  #deleteLayer(layer) {
    const gl = this.gl;
    gl.deleteVertexArray(layer.vao);
    for (const b of layer.buffers) gl.deleteBuffer(b);
  }

  /** Aim the home view at the cloud's middle from the real camera's position. */
  #frame(positions, keepView) {
    const n = positions.length / 3;
    if (!n) return;
    // Medians and percentiles of a subsample: robust to stray points, cheap for 300k.
    const step = Math.max(1, Math.floor(n / 4000));
    const xs = [], ys = [], zs = [];
    for (let i = 0; i < n; i += step) {
      xs.push(positions[3 * i]);
      ys.push(positions[3 * i + 1]);
      zs.push(positions[3 * i + 2]);
    }
    for (const a of [xs, ys, zs]) a.sort((p, q) => p - q);
    const at = (a, q) => a[Math.min(a.length - 1, Math.floor(q * a.length))];
    this.depthRange = [at(zs, 0.02), at(zs, 0.98)];
    if (keepView) return;
    const target = [at(xs, 0.5), -at(ys, 0.5), -at(zs, 0.5)];
    const distance = Math.hypot(...target) || 750;
    // The eye sits at the origin (the real camera): eye = target + distance * dir.
    const dir = target.map((c) => -c / distance);
    this.home = {
      target,
      distance,
      yaw: Math.atan2(dir[0], dir[2]),
      pitch: Math.asin(Math.max(-1, Math.min(1, dir[1]))),
    };
    this.resetView();
  }

  #updateMatrices(aspect) {
    const { target, yaw, pitch, distance } = this.view;
    const eye = this.scratch.eye;
    eye[0] = target[0] + distance * Math.cos(pitch) * Math.sin(yaw);
    eye[1] = target[1] + distance * Math.sin(pitch);
    eye[2] = target[2] + distance * Math.cos(pitch) * Math.cos(yaw);
    lookAt(this.scratch.view, eye, target);
    perspective(this.scratch.projection, this.fovY, aspect, distance * 0.02, distance * 20);
    multiply(this.viewProjection, this.scratch.projection, this.scratch.view);
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
        this.view.yaw -= dx * 0.008;
        this.view.pitch = Math.max(-1.55, Math.min(1.55, this.view.pitch + dy * 0.008));
      }
      this.requestRender();
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
    canvas.addEventListener('dblclick', () => this.resetView());
  }

  #zoom(factor) {
    this.view.distance = Math.max(1, Math.min(1e6, this.view.distance * factor));
    this.requestRender();
  }

  /** Move the target in the view plane by a drag of (dx, dy) CSS pixels. */
  #pan(dx, dy) {
    const { yaw, pitch, distance } = this.view;
    const scale = (2 * distance * Math.tan(this.fovY / 2)) / Math.max(1, this.canvas.clientHeight);
    const right = [Math.cos(yaw), 0, -Math.sin(yaw)];
    const up = [-Math.sin(pitch) * Math.sin(yaw), Math.cos(pitch), -Math.sin(pitch) * Math.cos(yaw)];
    for (let i = 0; i < 3; i++) this.view.target[i] += scale * (-dx * right[i] + dy * up[i]);
    this.requestRender();
  }
}

function pinchOf(pointers) {
  if (pointers.size < 2) return null;
  const [a, b] = [...pointers.values()];
  return { x: (a.x + b.x) / 2, y: (a.y + b.y) / 2, spread: Math.hypot(a.x - b.x, a.y - b.y) };
}

/** bufferSubData while the buffer is large enough, bufferData (with headroom) otherwise. */
function upload(gl, buffer, data, capacity, slot) {
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  if (data.byteLength <= capacity[slot] && data.byteLength > 0) {
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, data);
  } else {
    capacity[slot] = Math.ceil(data.byteLength * 1.25);
    gl.bufferData(gl.ARRAY_BUFFER, capacity[slot], gl.DYNAMIC_DRAW);
    if (data.byteLength) gl.bufferSubData(gl.ARRAY_BUFFER, 0, data);
  }
  gl.bindBuffer(gl.ARRAY_BUFFER, null);
}

function linkProgram(gl, vsSource, fsSource) {
  const compile = (type, source) => {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
      throw new Error(`shader does not compile: ${gl.getShaderInfoLog(shader)}`);
    }
    return shader;
  };
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl.VERTEX_SHADER, vsSource));
  gl.attachShader(program, compile(gl.FRAGMENT_SHADER, fsSource));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
    throw new Error(`shaders do not link: ${gl.getProgramInfoLog(program)}`);
  }
  return program;
}

function hexToRgb(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [(v >> 16) / 255, ((v >> 8) & 255) / 255, (v & 255) / 255];
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
