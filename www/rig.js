// The rig in numbers and in a small top-view diagram, both read from a calibration
// (conventions.md: X_p = R X_c + t, R row-major, mm).

const SVG = 'http://www.w3.org/2000/svg';

/** Horizontal field of view of a device, degrees. */
export function hfovDeg(device) {
  return (2 * Math.atan(device.width / 2 / device.fx) * 180) / Math.PI;
}

/** The projector's centre of projection in camera coordinates, mm: c = -Rᵀ t. */
export function projectorCenter(calib) {
  const r = calib.rotation;
  const t = calib.translation;
  return [0, 1, 2].map((j) => -(r[j] * t[0] + r[3 + j] * t[1] + r[6 + j] * t[2]));
}

/** The projector's optical axis in camera coordinates (third row of R). */
export function projectorAxis(calib) {
  return calib.rotation.slice(6, 9);
}

/**
 * Distance along the camera's axis of the point the projector aims at (closest approach
 * of the two optical axes), or null when they are parallel.
 */
export function aimDistance(calib) {
  const c = projectorCenter(calib);
  const a = projectorAxis(calib);
  // Camera axis: (0, 0, s). Projector axis: c + u a. Minimize |(0,0,s) - c - u a|.
  const b = a[2];
  const denom = 1 - b * b;
  if (denom < 1e-9) return null;
  const d = [-c[0], -c[1], -c[2]];
  const ad = a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
  const s = (b * ad - d[2]) / denom;
  return s > 0 ? s : null;
}

/** The approximate-rig fields (calibrationFromRig's input) that describe a calibration. */
export function rigOf(calib) {
  const c = projectorCenter(calib);
  return {
    camera_width: calib.camera.width,
    camera_height: calib.camera.height,
    camera_hfov_deg: round(hfovDeg(calib.camera), 2),
    projector_width: calib.projector.width,
    projector_height: calib.projector.height,
    projector_hfov_deg: round(hfovDeg(calib.projector), 2),
    baseline_mm: c.map((v) => round(v, 1)),
    aim_distance_mm: round(aimDistance(calib) ?? 750, 0),
  };
}

function round(v, digits) {
  const f = 10 ** digits;
  return Math.round(v * f) / f;
}

/** Draw the rig seen from above (x to the right, z, the camera's viewing direction, up). */
export function drawRig(svg, calib) {
  const W = 320, H = 210, M = 18, TOP = 30;
  svg.setAttribute('viewBox', `0 0 ${W} ${H}`);
  svg.replaceChildren();
  const c = projectorCenter(calib);
  const axis = projectorAxis(calib);
  const aim = aimDistance(calib) ?? 750;
  const depth = Math.max(aim * 1.1, Math.hypot(c[0], c[2]) * 2, 100);
  const xs = [0, c[0], -depth * 0.35, depth * 0.35];
  const zs = [0, c[2], depth];
  const [x0, x1] = [Math.min(...xs), Math.max(...xs)];
  const [z0, z1] = [Math.min(...zs), Math.max(...zs)];
  const scale = Math.min((W - 2 * M) / (x1 - x0), (H - TOP - M - 14) / (z1 - z0));
  const px = (x) => M + (x - x0) * scale + ((W - 2 * M) - (x1 - x0) * scale) / 2;
  const pz = (z) => H - M - 14 - (z - z0) * scale;

  const el = (name, attrs, text) => {
    const e = document.createElementNS(SVG, name);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    if (text) e.textContent = text;
    svg.append(e);
    return e;
  };
  const wedge = (ox, oz, dx, dz, hfov, cls) => {
    const len = Math.hypot(dx, dz) || 1;
    const [ux, uz] = [dx / len, dz / len];
    const half = ((hfov / 2) * Math.PI) / 180;
    const reach = depth * 1.02 / Math.max(0.2, uz);
    const ray = (s) => [ox + reach * (ux * Math.cos(s) - uz * Math.sin(s)), oz + reach * (ux * Math.sin(s) + uz * Math.cos(s))];
    const [a, b] = [ray(half), ray(-half)];
    el('polygon', { class: cls, points: `${px(ox)},${pz(oz)} ${px(a[0])},${pz(a[1])} ${px(b[0])},${pz(b[1])}` });
  };

  wedge(0, 0, 0, 1, hfovDeg(calib.camera), 'fov camera');
  wedge(c[0], c[2], axis[0], axis[2], hfovDeg(calib.projector), 'fov projector');
  el('line', { class: 'axis', x1: px(0), y1: pz(0), x2: px(0), y2: pz(depth) });
  el('line', { class: 'baseline', x1: px(0), y1: pz(0), x2: px(c[0]), y2: pz(c[2]) });
  el('circle', { class: 'aim', cx: px(0), cy: pz(aim), r: 3 });
  el('text', { x: px(0) + 5, y: pz(aim) - 4, class: 'label' }, `aim ${Math.round(aim)} mm`);
  el('rect', { class: 'device camera', x: px(0) - 6, y: pz(0) - 4, width: 12, height: 8 });
  el('rect', { class: 'device projector', x: px(c[0]) - 6, y: pz(c[2]) - 4, width: 12, height: 8 });
  const below = pz(Math.min(0, c[2])) + 16;
  el('text', { x: px(0), y: below, class: 'label', 'text-anchor': 'middle' }, 'camera');
  if (Math.abs(px(c[0]) - px(0)) > 64) {
    el('text', { x: px(c[0]), y: below, class: 'label', 'text-anchor': 'middle' }, 'projector');
  } else {
    el('text', { x: px(c[0]) + 10, y: pz(c[2]) - 8, class: 'label' }, 'projector');
  }
  const baseline = Math.hypot(...c);
  el('text', { x: M - 10, y: 12, class: 'label' },
    `top view · baseline ${baseline.toFixed(0)} mm (x ${c[0].toFixed(0)}, y ${c[1].toFixed(0)}, z ${c[2].toFixed(0)})`);
}
