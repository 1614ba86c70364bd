// The Swell viewer: renders a scene's sea with the server's exported shader (WGSL on WebGPU where
// the browser has it and the scene has no FFT layer, see webgpu.js; else GLSL ES on WebGL2, with
// FFT layers computed on the CPU from the exported spectrum and uploaded as textures), wave
// particles and impact rings through the exported shader's particle uniforms (computed here in
// f64 from scene.derived and the scene's impacts), foam where the surface folds (Jacobian ≤ 0),
// the scene's floating bodies from the stream (interpolated, drawn at their hull's size from
// GET …/bodies/{id}), a HUD, a scene picker, an orbit camera and a click probe (server height
// beside the GPU's). Read-only: only GET endpoints, /sample and the stream. Uses the
// swell-client package.
import {
  SwellClient, SwellSession, BodyInterpolator, Surface, FftLayer,
} from '/viewer/assets/client/index.js';
import { webGpuDevice, createWebGpuRenderer } from '/viewer/assets/webgpu.js';

const $ = (id) => document.getElementById(id);
const client = new SwellClient(location.origin);
const state = {
  ready: false, scene: null, errors: [], lastTick: null, probe: null, frames: 0,
  tickHz: 30, origin: [0, 0], t: 0, fftT: NaN,
};
// For tests and tools: the viewer's live state and a few calls (see clients/js/test/viewer.test.js).
window.swellViewer = state;

// --- small matrix helpers (column-major, as GL wants) -------------------------------------------
function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}
function lookAt(eye, at, up) {
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const norm = (a) => { const l = Math.hypot(...a); return a.map((v) => v / l); };
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const z = norm(sub(eye, at)), x = norm(cross(up, z)), y = cross(z, x);
  return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, eye), -dot(y, eye), -dot(z, eye), 1];
}
function mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return o;
}
function invert(m) {
  const inv = new Array(16); const [a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, a30, a31, a32, a33] = m;
  const b00 = a00 * a11 - a01 * a10, b01 = a00 * a12 - a02 * a10, b02 = a00 * a13 - a03 * a10, b03 = a01 * a12 - a02 * a11;
  const b04 = a01 * a13 - a03 * a11, b05 = a02 * a13 - a03 * a12, b06 = a20 * a31 - a21 * a30, b07 = a20 * a32 - a22 * a30;
  const b08 = a20 * a33 - a23 * a30, b09 = a21 * a32 - a22 * a31, b10 = a21 * a33 - a23 * a31, b11 = a22 * a33 - a23 * a32;
  const det = 1 / (b00 * b11 - b01 * b10 + b02 * b09 + b03 * b08 - b04 * b07 + b05 * b06);
  inv[0] = (a11 * b11 - a12 * b10 + a13 * b09) * det; inv[1] = (a02 * b10 - a01 * b11 - a03 * b09) * det;
  inv[2] = (a31 * b05 - a32 * b04 + a33 * b03) * det; inv[3] = (a22 * b04 - a21 * b05 - a23 * b03) * det;
  inv[4] = (a12 * b08 - a10 * b11 - a13 * b07) * det; inv[5] = (a00 * b11 - a02 * b08 + a03 * b07) * det;
  inv[6] = (a32 * b02 - a30 * b05 - a33 * b01) * det; inv[7] = (a20 * b05 - a22 * b02 + a23 * b01) * det;
  inv[8] = (a10 * b10 - a11 * b08 + a13 * b06) * det; inv[9] = (a01 * b08 - a00 * b10 - a03 * b06) * det;
  inv[10] = (a30 * b04 - a31 * b02 + a33 * b00) * det; inv[11] = (a21 * b02 - a20 * b04 - a23 * b00) * det;
  inv[12] = (a11 * b07 - a10 * b09 - a12 * b06) * det; inv[13] = (a00 * b09 - a01 * b07 + a02 * b06) * det;
  inv[14] = (a31 * b01 - a30 * b03 - a32 * b00) * det; inv[15] = (a20 * b03 - a21 * b01 + a22 * b00) * det;
  return inv;
}
function quatMat(q, s, p) {
  const [x, y, z, w] = q;
  const r = [1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
    2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
    2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)];
  return [r[0] * s[0], r[1] * s[0], r[2] * s[0], 0, r[3] * s[1], r[4] * s[1], r[5] * s[1], 0,
    r[6] * s[2], r[7] * s[2], r[8] * s[2], 0, p[0], p[1], p[2], 1];
}

// --- shaders ------------------------------------------------------------------------------------

// The exported vertex shader's own `main` is replaced by one that takes the camera as a plain
// uniform; every `swell_*` function, the uniform blocks and the in/out declarations stay as
// exported. The exported `swell_sample` includes the FFT layers: it reads naga's samplers
// `_group_1_binding_0_vs` / `_1_vs` (Catmull–Rom), which the page points at the textures its CPU
// FFT worker fills (same layout as the exported GPU passes' output, docs/clients.md).
function seaVertexShader(exported, far = false) {
  const at = exported.lastIndexOf('void main()');
  if (at < 0) throw new Error('exported shader has no main()');
  const head = exported.slice(0, at);
  return `${far ? farVariant(head) : head}
uniform mat4 u_view_proj;         // the camera (the exported block's name is naga's to choose)
void main() {
  vec2 p_local = _p2vs_location0;
  SwellSample s = ${far ? 'swell_sample_far' : 'swell_sample'}(p_local);
  vec3 pos = vec3(p_local.x, 0.0, p_local.y) + s.displacement;
  gl_Position = u_view_proj * vec4(pos, 1.0);
  _vs2fs_location0 = pos;
  _vs2fs_location1 = swell_normal(s);
  _vs2fs_location2 = swell_jacobian(s);
}
`;
}

/**
 * The exported shader with a `swell_sample_far`: `swell_sample` without its wave-particle terms
 * (ambient particles and impact rings: sub-metre ripples of millimetres to centimetres, which
 * the far field's metres-apart vertices could not resolve anyway, and which cost 3 × 512 kernel
 * evaluations per vertex). The far field beyond the particle mesh is drawn with it.
 */
function farVariant(exported) {
  const start = exported.indexOf('SwellSample swell_sample(vec2');
  if (start < 0) throw new Error('exported shader has no swell_sample');
  const end = exported.indexOf('\n}\n', start) + 3;
  const far = exported.slice(start, end).replace('swell_sample(', 'swell_sample_far(')
    .replace(/swell_ambient\((\w+),[^;]*\);/g, '$1;').replace(/swell_rings\((\w+),[^;]*\);/g, '$1;');
  return exported.slice(0, end) + far + exported.slice(end);
}

/** Points a program's exported FFT samplers (`_group_1_binding_B_{vs,fs}`) at texture unit B. */
function bindFftSamplers(gl, prog) {
  gl.useProgram(prog);
  for (const stage of ['vs', 'fs']) {
    for (const b of [0, 1]) {
      const loc = gl.getUniformLocation(prog, `_group_1_binding_${b}_${stage}`);
      if (loc) gl.uniform1i(loc, b);
    }
  }
}

const SEA_FS = `#version 300 es
precision highp float;
smooth in vec3 _vs2fs_location0;
smooth in vec3 _vs2fs_location1;
smooth in float _vs2fs_location2;
uniform vec3 u_eye;
out vec4 color;
void main() {
  vec3 n = normalize(_vs2fs_location1);
  vec3 v = normalize(u_eye - _vs2fs_location0);
  vec3 sun = normalize(vec3(0.4, 0.55, 0.25));
  float fres = 0.02 + 0.98 * pow(1.0 - max(dot(n, v), 0.0), 5.0);
  vec3 deep = vec3(0.01, 0.10, 0.16), shallow = vec3(0.05, 0.32, 0.38), sky = vec3(0.55, 0.72, 0.86);
  float crest = clamp(_vs2fs_location0.y * 0.25 + 0.5, 0.0, 1.0);
  vec3 water = mix(deep, shallow, crest) * (0.35 + 0.65 * max(dot(n, sun), 0.0));
  vec3 c = mix(water, sky, fres);
  c += vec3(1.0, 0.95, 0.85) * pow(max(dot(reflect(-sun, n), v), 0.0), 180.0) * 1.5;
  // Foam where the horizontal map folds (J <= 0) and fading in just before.
  float foam = 1.0 - smoothstep(0.0, 0.35, _vs2fs_location2);
  c = mix(c, vec3(0.92, 0.95, 0.97), foam * 0.85);
  float fog = 1.0 - exp(-length(u_eye - _vs2fs_location0) * 0.0025);
  color = vec4(mix(c, sky * 0.9, fog), 1.0);
}`;

const BODY_VS = `#version 300 es
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_view_proj;
uniform mat4 u_model;
out vec3 v_normal;
void main() {
  v_normal = mat3(u_model) * a_normal;
  gl_Position = u_view_proj * u_model * vec4(a_pos, 1.0);
}`;
const BODY_FS = `#version 300 es
precision highp float;
in vec3 v_normal;
uniform vec3 u_color;
out vec4 color;
void main() {
  float l = 0.35 + 0.65 * max(dot(normalize(v_normal), normalize(vec3(0.4, 0.8, 0.3))), 0.0);
  color = vec4(u_color * l, 1.0);
}`;

function compile(gl, vs, fs, what) {
  const sh = (type, src) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`${what}: ${gl.getShaderInfoLog(s)}`);
    return s;
  };
  const p = gl.createProgram();
  gl.attachShader(p, sh(gl.VERTEX_SHADER, vs));
  gl.attachShader(p, sh(gl.FRAGMENT_SHADER, fs));
  gl.bindAttribLocation(p, 0, '_p2vs_location0');
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(`${what} link: ${gl.getProgramInfoLog(p)}`);
  const nb = gl.getProgramParameter(p, gl.ACTIVE_UNIFORM_BLOCKS);
  for (let i = 0; i < nb; i++) {
    gl.uniformBlockBinding(p, i, gl.getActiveUniformBlockName(p, i).startsWith('SwellCamera') ? 1 : 0);
  }
  return p;
}

// --- scene setup --------------------------------------------------------------------------------

const canvas = $('sea');
// The WebGL2 context, made only when the WebGL2 renderer is chosen (a canvas holds one kind).
let gl = null;
let floatTargets = null;

const camera = { yaw: 0.9, pitch: 0.42, dist: 70, target: [0, 0] };
state.camera = camera;
// The sea mesh: GRID² vertices over SPAN metres; the origin moves in whole grid cells (SNAP), so
// vertices stay put. Beyond it a far field carries the sea to the horizon (FAR metres, past the
// fog): a ring of cells that grow by FAR_GROWTH per step outwards, drawn with the same exported
// waves. Scenes with wave particles (radius ~1 m, rings of 0.5–1.3 m) get a finer, smaller inner
// mesh (0.5 m spacing over 20 m around the camera's target): every vertex there sums 3 × 512
// particle kernels, which is what made harbour draw at 0.5–1 fps on SwiftShader with 160²
// vertices (15× the vertices now); the far field draws without particles (farVariant).
let GRID = 160;
let SPAN = 480;
let SNAP = SPAN / (GRID - 1);
const FAR = 4000;
const FAR_GROWTH = 1.18;

/**
 * The sea's vertices (local x/z) and triangles: the GRID² inner grid first (`inner` indices),
 * then the far ring. The ring's grid lines are every 4th inner line inside the inner square and
 * grow geometrically outside it; cells wholly inside the inner square are left out.
 */
function seaMesh() {
  const verts = [];
  for (let j = 0; j < GRID; j++) for (let i = 0; i < GRID; i++) verts.push(-SPAN / 2 + i * SNAP, -SPAN / 2 + j * SNAP);
  const idx = [];
  for (let j = 0; j < GRID - 1; j++) for (let i = 0; i < GRID - 1; i++) {
    const a = j * GRID + i, b = a + 1, c = a + GRID, d = c + 1;
    idx.push(a, c, b, b, c, d);
  }
  const inner = idx.length;
  const half = SPAN / 2;
  const line = [];
  for (let i = 0; i < GRID; i += 4) line.push(-half + i * SNAP);
  if (line[line.length - 1] < half - 1e-9) line.push(half);
  const out = [];
  for (let step = 4 * SNAP, x = half; x < FAR; step *= FAR_GROWTH) { x = Math.min(FAR, x + step); out.push(x); }
  const coords = [...out.map((v) => -v).reverse(), ...line, ...out];
  const n = coords.length;
  const base = verts.length / 2;
  for (let j = 0; j < n; j++) for (let i = 0; i < n; i++) verts.push(coords[i], coords[j]);
  const eps = 1e-6;
  for (let j = 0; j < n - 1; j++) for (let i = 0; i < n - 1; i++) {
    const inside = coords[i] >= -half - eps && coords[i + 1] <= half + eps && coords[j] >= -half - eps && coords[j + 1] <= half + eps;
    if (inside) continue;
    const a = base + j * n + i, b = a + 1, c = a + n, d = c + 1;
    idx.push(a, c, b, b, c, d);
  }
  return { verts: new Float32Array(verts), idx: new Uint32Array(idx), inner, reach: FAR, innerVertices: GRID * GRID, farVertices: n * n };
}

function sceneFromPath() {
  const m = location.pathname.match(/^\/viewer\/([a-z0-9-]{1,64})\/?$/);
  return m ? m[1] : null;
}

async function setup() {
  const { scenes } = await client.scenes();
  const wanted = sceneFromPath();
  const id = wanted ?? (scenes.find((s) => s.id === 'open-sea') ?? scenes[0])?.id;
  if (!id) throw new Error('the server has no scenes');
  const sel = $('scene');
  for (const s of scenes) {
    const o = document.createElement('option');
    o.value = s.id; o.textContent = `${s.id} (${s.layers.join(' + ')})`;
    if (s.id === id) o.selected = true;
    sel.append(o);
  }
  sel.onchange = () => { location.href = `/viewer/${sel.value}`; };
  state.scene = id;

  const detail = await client.scene(id);
  state.tickHz = detail.spec.tick_hz ?? 30;
  const fft = [];
  const fftLayers = [];
  for (const [i, l] of detail.derived.layers.entries()) {
    if (l.kind !== 'fft') continue;
    fft[i] = new FftLayer(await client.spectrum(id, i), { cacheFrames: 2 });
    fftLayers.push(fft[i]);
  }
  const surface = Surface.fromDerived(detail.derived, { fft });
  const particles = surface.impactLayer?.particles ?? null;
  if (particles) {
    GRID = 41; SPAN = 20; SNAP = SPAN / (GRID - 1);
    camera.dist = 32;
  }
  // The renderer: WebGPU where the browser has an adapter and the scene has no FFT layer (the
  // WebGPU path does not read the FFT textures yet), else WebGL2; `?gpu=webgl2` or
  // `?gpu=webgpu` forces one.
  const params = new URLSearchParams(location.search);
  const asked = params.get('gpu');
  // Why an earlier load of this page left WebGPU (see fallBack), shown in the HUD.
  const fallback = params.get('fallback');
  state.fallback = fallback;
  const device = asked === 'webgl2' || (asked !== 'webgpu' && fftLayers.length) ? null : await webGpuDevice();
  if (asked === 'webgpu' && !device) throw new Error('WebGPU is not available in this browser (?gpu=webgpu)');
  state.backend = device ? 'webgpu' : 'webgl2';

  // Sea mesh: the inner grid and the far ring, in local x/z, triangles as an index list.
  const mesh = seaMesh();
  const { verts, idx } = mesh;
  state.mesh = { reach: mesh.reach, innerVertices: mesh.innerVertices, farVertices: mesh.farVertices, span: SPAN };
  // Unit box for hulls (±0.5), with face normals.
  const boxV = [];
  const faces = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[-1, 0, 0], [0, 1, 0], [0, 0, -1]], [[0, 1, 0], [0, 0, 1], [1, 0, 0]],
    [[0, -1, 0], [0, 0, -1], [1, 0, 0]], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [[0, 0, -1], [-1, 0, 0], [0, 1, 0]]];
  for (const [n, u, v] of faces) {
    const c = (su, sv) => [0, 1, 2].map((a) => 0.5 * (n[a] + su * u[a] + sv * v[a]));
    for (const [su, sv] of [[-1, -1], [1, -1], [1, 1], [-1, -1], [1, 1], [-1, 1]]) boxV.push(...c(su, sv), ...n);
  }

  let renderer;
  let fftLayer = null;
  let requestFft = () => {};
  if (device) {
    const wgsl = await client.shader(id, 'wgsl');
    // An adapter that cannot draw (seen: SwiftShader without Vulkan, whose first present loses
    // the device) would leave a blank canvas: on a lost device, a validation error, or a GPU
    // probe that reads nothing, the page reloads itself on WebGL2 and the HUD says why. A
    // canvas keeps the context kind it was first given, hence the reload.
    let leaving = false;
    const fallBack = (reason) => {
      if (leaving || asked === 'webgpu') return;
      leaving = true;
      state.errors.push(`WebGPU fell back: ${reason}`);
      location.replace(`/viewer/${id}?gpu=webgl2&fallback=${encodeURIComponent(`WebGPU: ${reason}; drawing with WebGL2`)}`);
    };
    state.fallBack = fallBack;
    device.lost.then((info) => { if (info.reason !== 'destroyed') fallBack(`device lost (${info.message || info.reason})`); });
    device.addEventListener?.('uncapturederror', (e) => fallBack(`error: ${e.error?.message ?? e}`));
    renderer = await createWebGpuRenderer(canvas, device, { wgsl: wgsl.text, verts, idx, box: new Float32Array(boxV) });
    renderer.check = async () => {
      const { u } = frameUniforms(state.t);
      const gpu = await renderer.probe([0.25, -0.5], u.block);
      if (!Number.isFinite(gpu) || gpu === 0) fallBack(`its probe drew nothing (read ${gpu})`);
      return gpu;
    };
  } else {
    gl = canvas.getContext('webgl2', { antialias: true, preserveDrawingBuffer: true });
    if (!gl) throw new Error('WebGL2 is not available');
    floatTargets = gl.getExtension('EXT_color_buffer_float');
    const [vs, pvs, pfs] = await Promise.all([
      client.shader(id, 'glsl_es', { entry: 'swell_vs' }),
      client.shader(id, 'glsl_es', { entry: 'swell_probe_vs' }),
      client.shader(id, 'glsl_es', { entry: 'swell_probe_fs' }),
    ]);
    const sea = compile(gl, seaVertexShader(vs.text), SEA_FS, 'sea');
    const far = particles ? compile(gl, seaVertexShader(vs.text, true), SEA_FS, 'far field') : sea;
    const probe = compile(gl, pvs.text, pfs.text, 'probe');
    bindFftSamplers(gl, sea);
    bindFftSamplers(gl, far);
    bindFftSamplers(gl, probe);
    const body = compile(gl, BODY_VS, BODY_FS, 'body');
    const seaVao = gl.createVertexArray();
    gl.bindVertexArray(seaVao);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, verts, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW);
    gl.bindVertexArray(null);

    const boxVao = gl.createVertexArray();
    gl.bindVertexArray(boxVao);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(boxV), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 24, 0);
    gl.enableVertexAttribArray(1); gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 24, 12);
    gl.bindVertexArray(null);

    // Uniform buffers: the waves' phases (binding 0) and the camera (binding 1).
    const phasesUbo = gl.createBuffer();
    const cameraUbo = gl.createBuffer();

    // FFT textures (first FFT layer; the built-in scenes have one).
    fftLayer = fftLayers[0] ?? null;
    const fftTex = [gl.createTexture(), gl.createTexture()];
    if (fftLayer) {
      for (const t of fftTex) {
        gl.bindTexture(gl.TEXTURE_2D, t);
        gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, fftLayer.n, fftLayer.n);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      }
    }
    // FFT frames come from a worker (a 256² frame is tens of ms of JavaScript): the page asks for
    // the frame 0.1 s of scene time ahead and uploads it when it arrives; the sea meanwhile keeps
    // the last frame (it moves in steps of 0.1 s, never blocks the render loop).
    let fftBusy = false;
    const fftWorker = fftLayer ? new Worker('/viewer/assets/fft-worker.js', { type: 'module' }) : null;
    if (fftWorker) {
      fftWorker.onerror = (e) => report(new Error(`FFT worker: ${e.message}`));
      fftWorker.postMessage({ type: 'spectrum', spectrum: { header: fftLayer.header, n: fftLayer.n, records: fftLayer.records } });
      fftWorker.onmessage = (ev) => {
        const { t, a, b } = ev.data;
        const n = fftLayer.n;
        gl.bindTexture(gl.TEXTURE_2D, fftTex[0]);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, n, n, gl.RGBA, gl.FLOAT, a);
        gl.bindTexture(gl.TEXTURE_2D, fftTex[1]);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, n, n, gl.RGBA, gl.FLOAT, b);
        state.fftT = t;
        state.fftFrames = (state.fftFrames ?? 0) + 1;
        fftBusy = false;
      };
    }
    requestFft = (t) => {
      if (fftBusy) return;
      fftBusy = true;
      fftWorker.postMessage({ type: 'frame', t });
    };

    // The WebGL2 renderer: the frame's uniform block and camera into their buffers, the sea (with
    // the FFT textures), the hulls; the probe through the exported probe shaders into RGBA32F.
    renderer = {
      kind: 'webgl2',
      frame: ({ w, h, block, viewProj, eye, origin, bodies }) => {
        gl.bindBuffer(gl.UNIFORM_BUFFER, phasesUbo);
        gl.bufferData(gl.UNIFORM_BUFFER, block, gl.DYNAMIC_DRAW);
        gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, phasesUbo);
        gl.bindBuffer(gl.UNIFORM_BUFFER, cameraUbo);
        gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array(viewProj), gl.DYNAMIC_DRAW);
        gl.bindBufferBase(gl.UNIFORM_BUFFER, 1, cameraUbo);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.viewport(0, 0, w, h);
        gl.clearColor(0.5, 0.66, 0.8, 1);
        gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        gl.enable(gl.DEPTH_TEST);
        // The exported shader samples the FFT layer at units 0 and 1 (zeros until the first frame).
        gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, fftTex[0]);
        gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, fftTex[1]);
        gl.bindVertexArray(seaVao);
        // The inner grid, then the far ring (without wave particles on particle scenes).
        // `swellViewer.timeDraws = true` (tests): each part waited for (a 1-pixel readPixels: in
        // Chromium gl.finish() does not wait for the GPU) and timed into swellViewer.drawMs,
        // which shows where a frame's time goes.
        const timing = state.timeDraws ? {} : null;
        const sync = () => gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
        for (const [part, prog, first, count] of [['inner', sea, 0, mesh.inner], ['far', far, mesh.inner, idx.length - mesh.inner]]) {
          const t0 = timing && (sync(), performance.now());
          gl.useProgram(prog);
          gl.uniform3fv(gl.getUniformLocation(prog, 'u_eye'), eye);
          gl.uniformMatrix4fv(gl.getUniformLocation(prog, 'u_view_proj'), false, viewProj);
          gl.drawElements(gl.TRIANGLES, count, gl.UNSIGNED_INT, first * 4);
          if (timing) { sync(); timing[part] = performance.now() - t0; }
        }
        if (timing) state.drawMs = timing;
        gl.useProgram(body);
        gl.uniformMatrix4fv(gl.getUniformLocation(body, 'u_view_proj'), false, viewProj);
        gl.bindVertexArray(boxVao);
        for (const b of bodies) {
          gl.uniformMatrix4fv(gl.getUniformLocation(body, 'u_model'), false, b.model);
          gl.uniform3fv(gl.getUniformLocation(body, 'u_color'), b.color);
          gl.drawArrays(gl.TRIANGLES, 0, 36);
        }
        gl.bindVertexArray(null);
      },
      probe: async (local, block) => {
        if (!floatTargets) return null;
        gl.bindBuffer(gl.UNIFORM_BUFFER, phasesUbo);
        gl.bufferData(gl.UNIFORM_BUFFER, block, gl.DYNAMIC_DRAW);
        gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, phasesUbo);
        const fb = gl.createFramebuffer();
        gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
        const texs = [0, 1].map((a) => {
          const tex = gl.createTexture();
          gl.bindTexture(gl.TEXTURE_2D, tex);
          gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, 1, 1);
          gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0 + a, gl.TEXTURE_2D, tex, 0);
          return tex;
        });
        gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
        gl.viewport(0, 0, 1, 1);
        gl.useProgram(probe);
        gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, fftTex[0]);
        gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, fftTex[1]);
        const vao = gl.createVertexArray();
        gl.bindVertexArray(vao);
        const vb = gl.createBuffer();
        gl.bindBuffer(gl.ARRAY_BUFFER, vb);
        gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([local[0], local[1], 0, 0]), gl.STATIC_DRAW);
        gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 16, 0);
        gl.enableVertexAttribArray(1); gl.vertexAttribPointer(1, 2, gl.FLOAT, false, 16, 8);
        gl.drawArrays(gl.POINTS, 0, 1);
        const px = new Float32Array(4);
        gl.readBuffer(gl.COLOR_ATTACHMENT1);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, px);
        gl.bindVertexArray(null);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.deleteFramebuffer(fb); texs.forEach((x) => gl.deleteTexture(x)); gl.deleteBuffer(vb); gl.deleteVertexArray(vao);
        return px[3];
      },
    };
  }

  // The stream: clock sync, body states, impacts (their rings ripple on the particle layer).
  const interp = new BodyInterpolator({ delay: 3 / state.tickHz, capacity: 90 });
  const session = new SwellSession(client.streamUrl(id), {
    interpolator: interp,
    onTick: (f) => {
      state.lastTick = f;
      if (particles && f.impacts) surface.impacts.addAll(f.impacts);
    },
  });
  await session.connect();
  session.subscribe();
  // Impacts made before this page subscribed (the set merges one seen in both).
  if (particles) surface.impacts.addAll((await client.impacts(id)).impacts);

  // Hull sizes: tick frames carry states only, so each new body id's description (mass, hull
  // kind and extent) is fetched once; a body is drawn from the moment it is known.
  const hulls = new Map(); // id → {kind, length, beam, height, center} | 'pending'
  state.hulls = hulls;
  const describe = (bid) => {
    if (hulls.has(bid)) return;
    hulls.set(bid, 'pending');
    client.body(id, bid).then((d) => { hulls.set(bid, d.hull); }, (e) => {
      hulls.delete(bid);
      if (e?.status !== 404) report(e); // a body removed meanwhile is no error
    });
  };
  state.session = session;
  state.interp = interp;
  state.surface = surface;

  /** The streamed state the page holds for `body` at `tick` (null if not buffered). */
  state.bodyAtTick = (bid, tick) => {
    const f = interp.frameAt(tick);
    const b = f?.byId.get(bid);
    return b ? { tick, t: f.t, position: b.position, rotation: b.rotation } : null;
  };

  let viewProj = null;
  // Ring markers float at the sum of the analytic waves' amplitudes (the swell's highest crest).
  let ringY = 0.05;
  for (const l of detail.derived.layers) for (const w of l.waves ?? []) ringY += w.amplitude;
  const frameUniforms = (t) => {
    const origin = [Math.round(camera.target[0] / SNAP) * SNAP, Math.round(camera.target[1] / SNAP) * SNAP];
    state.origin = origin;
    return { origin, u: surface.uniforms(t, origin) };
  };

  /** GPU (exported probe shader) vs server (/sample) vs this client (CPU) at world (x, z). */
  state.probeAt = async (wx, wz, tNow = session.serverTime()) => {
    // Scenes with FFT layers: the GPU reads the FFT textures, which hold the worker's last
    // frame (scene time state.fftT, up to a few tenths of a second behind on a slow machine), so
    // the whole probe (GPU, server, CPU) is evaluated at that frame's own time: the three then
    // describe the same sea, and the HUD says which time it was.
    const t = fftLayers.length && Number.isFinite(state.fftT) ? state.fftT : tNow;
    const { origin, u } = frameUniforms(t);
    const local = [wx - origin[0], wz - origin[1]];
    const gpu = await renderer.probe(local, u.block);
    const server = (await client.sample(id, { t, points: [[wx, wz]] })).height[0];
    const cpu = surface.height(wx, wz, t);
    state.probe = {
      world: [wx, wz], t, asked: tNow, server, gpu, cpu, ringsDropped: u.ringsDropped,
      gpuLayers: fftLayers.length ? `at the FFT frame's time t = ${t}` : u.ringsDropped ? `all layers, ${u.ringsDropped} rings left out` : 'all layers',
    };
    const mm = (v) => (v == null ? 'n/a' : `${v.toFixed(4)} m`);
    $('probe').innerHTML = `probe (${wx.toFixed(2)}, ${wz.toFixed(2)}) at t = ${t.toFixed(3)} s<br>`
      + (fftLayers.length ? `(the FFT frame's time, ${((tNow - t) * 1000).toFixed(0)} ms before now)<br>` : '')
      + `server <b>${mm(server)}</b> · GPU ${mm(gpu)}`
      + (gpu != null ? ` · Δ ${((gpu - server) * 1000).toFixed(3)} mm` : '')
      + `<br>client CPU ${mm(cpu)} · Δ ${((cpu - server) * 1000).toFixed(3)} mm`;
    return state.probe;
  };

  // Camera controls.
  let drag = null;
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('mousedown', (e) => { drag = { x: e.clientX, y: e.clientY, moved: 0, pan: e.shiftKey || e.button === 2 }; });
  window.addEventListener('mouseup', (e) => {
    if (drag && drag.moved < 4 && e.target === canvas) {
      const hit = pick(e.clientX, e.clientY);
      if (hit) state.probeAt(hit[0], hit[1]).catch(report);
    }
    drag = null;
  });
  window.addEventListener('mousemove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.moved += Math.abs(dx) + Math.abs(dy);
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      const s = camera.dist * 0.002;
      const c = Math.cos(camera.yaw), sn = Math.sin(camera.yaw);
      camera.target[0] -= (c * dx + sn * dy) * s * -1;
      camera.target[1] -= (-sn * dx + c * dy) * s * -1;
    } else {
      camera.yaw -= dx * 0.005;
      camera.pitch = Math.min(1.45, Math.max(0.05, camera.pitch + dy * 0.005));
    }
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    camera.dist = Math.min(400, Math.max(8, camera.dist * Math.exp(e.deltaY * 0.001)));
  }, { passive: false });

  // Screen point → world (x, z) on the plane y = 0.
  const pick = (cx, cy) => {
    if (!viewProj) return null;
    const r = canvas.getBoundingClientRect();
    const nx = ((cx - r.left) / r.width) * 2 - 1, ny = 1 - ((cy - r.top) / r.height) * 2;
    const inv = invert(viewProj);
    const un = (z) => { const v = [0, 1, 2, 3].map((i) => inv[i] * nx + inv[4 + i] * ny + inv[8 + i] * z + inv[12 + i]); return v.slice(0, 3).map((a) => a / v[3]); };
    const a = un(-1), b = un(1);
    const dir = b.map((v, i) => v - a[i]);
    if (Math.abs(dir[1]) < 1e-9) return null;
    const s = -a[1] / dir[1];
    if (s < 0) return null;
    return [state.origin[0] + a[0] + s * dir[0], state.origin[1] + a[2] + s * dir[2]];
  };
  state.pick = pick;

  const render = () => {
    // `swellViewer.paused = true` (tests and tools) stops drawing: on SwiftShader a particle
    // scene's frame takes seconds, and probes (which draw too) would queue behind frames.
    if (state.paused) { requestAnimationFrame(() => { try { render(); } catch (e) { report(e); } }); return; }
    const started = performance.now();
    const dpr = Math.min(window.devicePixelRatio || 1, 2);
    const w = Math.floor(canvas.clientWidth * dpr), h = Math.floor(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    // `swellViewer.holdT = <scene time>` (tests) draws that moment instead of the clock's, so
    // two frames drawn seconds apart on a slow renderer show the same sea.
    const t = typeof state.holdT === 'number' ? state.holdT : session.serverTime();
    state.t = t;
    // FFT frames on the CPU, in the worker: one per 1/10 s of scene time.
    if (fftLayer && !(Math.abs(t - state.fftT) < 0.1)) requestFft(t + 0.05);
    if (particles) surface.impacts.prune(t, 2 * particles.ripples.lifetime);
    const { origin, u } = frameUniforms(t);
    const tl = [camera.target[0] - origin[0], camera.target[1] - origin[1]];
    const eye = [tl[0] + camera.dist * Math.cos(camera.pitch) * Math.cos(camera.yaw), camera.dist * Math.sin(camera.pitch),
      tl[1] + camera.dist * Math.cos(camera.pitch) * Math.sin(camera.yaw)];
    viewProj = mul(perspective(0.9, w / h, 0.5, 2 * FAR), lookAt(eye, [tl[0], 0, tl[1]], [0, 1, 0]));

    // Bodies at server time minus the interpolation delay, each as its hull's bounding box.
    const bodies = interp.at(t);
    const drawn = [];
    const boxes = [];
    for (const b of bodies.values()) {
      describe(b.id);
      const hull = hulls.get(b.id);
      if (!hull || hull === 'pending') continue;
      // The box's centre in the body frame, rotated with the body.
      const [x, y, z, w] = b.rotation;
      const c = hull.center;
      const rc = [ // rotate c by the quaternion
        (1 - 2 * (y * y + z * z)) * c[0] + 2 * (x * y - z * w) * c[1] + 2 * (x * z + y * w) * c[2],
        2 * (x * y + z * w) * c[0] + (1 - 2 * (x * x + z * z)) * c[1] + 2 * (y * z - x * w) * c[2],
        2 * (x * z - y * w) * c[0] + 2 * (y * z + x * w) * c[1] + (1 - 2 * (x * x + y * y)) * c[2]];
      const p = [b.position[0] - origin[0] + rc[0], b.position[1] + rc[1], b.position[2] - origin[1] + rc[2]];
      const size = [hull.length, hull.height, hull.beam]; // x, y, z of the unit box
      boxes.push({ model: quatMat(b.rotation, size, p), color: [0.86, 0.42, 0.16] });
      drawn.push({ id: b.id, size });
    }
    // Impact rings: each live ring's front as a circle of thin white segments just above the
    // swell's crest height. The ripples themselves are millimetres to centimetres high under a
    // swell of decimetres: drawn, but not visible from the default camera without a marker.
    let ringsDrawn = 0;
    if (particles && state.showRings !== false) {
      for (const r of surface.liveRings(t)) {
        const c = [r.ring.center[0] - origin[0], r.ring.center[1] - origin[1]];
        const rad = r.state.distance;
        const segs = 48;
        const chord = 2 * Math.PI * rad / segs;
        for (let i = 0; i < segs; i++) {
          const a = (2 * Math.PI * (i + 0.5)) / segs;
          const yaw = -a; // the segment's long axis (x) along the tangent
          const q = [0, Math.sin(yaw / 2 + Math.PI / 4), 0, Math.cos(yaw / 2 + Math.PI / 4)];
          boxes.push({ model: quatMat(q, [chord, 0.08, 0.2], [c[0] + rad * Math.cos(a), ringY, c[1] + rad * Math.sin(a)]), color: [1.25, 1.25, 1.25] });
        }
        ringsDrawn++;
      }
    }
    state.ringsDrawn = ringsDrawn;
    renderer.frame({ w, h, block: u.block, viewProj, eye, origin, bodies: boxes });
    state.bodies = bodies;
    state.drawn = drawn;
    state.frames++;
    state.renderMs = performance.now() - started;
    if (state.frames === 2 && renderer.check) renderer.check().catch((e) => state.fallBack?.(String(e?.message ?? e)));

    const st = session.clockStats();
    const tick = state.lastTick;
    $('hud').innerHTML = `<b>${id}</b> · model v${detail.model_version} · ${renderer.kind}<br>`
      + `scene time ${t.toFixed(3)} s<br>tick ${tick ? tick.tick : '—'} (${state.tickHz} Hz)<br>`
      + `RTT ${(st.rtt * 1000).toFixed(2)} ms (min ${(st.minRtt * 1000).toFixed(2)})<br>`
      + `clock offset ${st.offset.toFixed(4)} s ± ${(st.minRtt * 500).toFixed(2)} ms · drift ${(st.drift * 1e6).toFixed(1)} ppm<br>`
      + (particles ? `particles ${particles.count} · impacts ${surface.impacts.size} · rings ${surface.liveRings(t).length}<br>` : '')
      + (fallback ? `<span class="warn">${escapeHtml(fallback)}</span><br>` : '')
      + `bodies ${bodies.size}${[...bodies.values()].map((b) => `<br>#${b.id} (${b.position.map((v) => v.toFixed(2)).join(', ')}) ${b.mode}`).join('')}`;
    state.ready = true;
    requestAnimationFrame(() => { try { render(); } catch (e) { report(e); } });
  };
  render();
}

function escapeHtml(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
}

function report(e) {
  state.errors.push(String(e?.stack ?? e));
  console.error(e);
  $('hud').textContent = `error: ${e?.message ?? e}`;
}

setup().catch(report);
