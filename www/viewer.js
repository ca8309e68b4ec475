// WebGL2 point-cloud viewer.
//
// Clouds arrive in the camera frame of conventions.md (x right, y down, z forward, mm)
// and are drawn in a y-up view frame (x, -y, -z), so the initial view is the one the
// real camera had. Each layer (the merged cloud, each family's cloud) owns one vertex
// array with three buffers that are uploaded once per cloud and reused while they are
// large enough; drawing a frame allocates nothing.
//
// This file holds the layers, their buffers and the drawing; the GL program is in
// viewer-program.js, the orbit camera and its mouse and touch controls in viewer-orbit.js.

import { createPointProgram } from './viewer-program.js';
import { OrbitCamera, robustExtent } from './viewer-orbit.js';

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
    this.depthRange = [500, 1000];
    this.viewProjection = new Float32Array(16);
    this.familyColors = new Float32Array(FAMILY_COLORS.flatMap(hexToRgb));
    this.frameMs = 0;
    this.pendingFrame = 0;
    this.#initGl();
    this.orbit = new OrbitCamera(canvas, () => this.requestRender());
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
    ({ program: this.program, uniforms: this.uniforms } = createPointProgram(this.gl));
  }

  /** The orbit camera's current view: {target, yaw, pitch, distance}. */
  get view() {
    return this.orbit.view;
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
    this.orbit.fovY = fovY;
    this.requestRender();
  }

  resetView() {
    this.orbit.reset();
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
    this.orbit.viewProjection(this.viewProjection, width / height);
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

  /** Set the depth colour scale from the cloud and, unless `keepView`, aim the view at it. */
  #frame(positions, keepView) {
    const extent = robustExtent(positions);
    if (!extent) return;
    this.depthRange = extent.depthRange;
    if (keepView) return;
    const [x, y, z] = extent.median;
    this.orbit.aimAt([x, -y, -z]);
  }
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

function hexToRgb(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [(v >> 16) / 255, ((v >> 8) & 255) / 255, (v & 255) / 255];
}
