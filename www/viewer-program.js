// The point-cloud viewer's one GL program: where each point goes (through the orbit
// camera's view-projection) and which colour it gets (captured, depth, or stripe family).
// Points arrive in the camera frame of conventions.md and are drawn as (x, -y, -z).

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

/** The uniforms the program reads. */
const UNIFORMS = ['uViewProjection', 'uPointSize', 'uMode', 'uDepthRange', 'uFamilyColors'];

/**
 * Compile and link the program: `{program, uniforms}` with each uniform's location by
 * name. Throws with the driver's log when it fails.
 */
export function createPointProgram(gl) {
  const program = linkProgram(gl, VERTEX_SHADER, FRAGMENT_SHADER);
  const uniforms = {};
  for (const name of UNIFORMS) uniforms[name] = gl.getUniformLocation(program, name);
  return { program, uniforms };
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
