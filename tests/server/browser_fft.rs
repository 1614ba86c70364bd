//! FFT layers on the GPU, in a real browser, by both of the exported pass modules: headless
//! Chromium (SwiftShader, no GPU needed) runs an FFT scene's evolve pass and 2·log₂N Stockham
//! butterfly passes, then the scene's probe shader, which samples the transformed grids with the
//! model's Catmull–Rom filter, adds the analytic layers and inverts the horizontal displacement.
//! What it reads back is the whole sea; it is compared with `/sample` at the same world points.
//!
//! - **WebGL2**: the GLSL ES fragment passes over RGBA32F render targets, then
//!   `swell_probe_vs`/`swell_probe_fs` into float targets (a file page, `--dump-dom`).
//! - **WebGPU**: the WGSL compute module (`swell_fft_evolve_cs`, `swell_fft_butterfly_cs`, one
//!   dispatch per pass into rgba32float storage textures), then the WGSL surface module with a
//!   probe compute entry point appended (as `browser_parity`'s WebGPU half), its FFT textures
//!   bound at `@group(1)`, into a storage buffer; one compute pass per frame. The page is served
//!   from `http://127.0.0.1` and posts its result back. Where Chromium offers no WebGPU adapter
//!   the half says so and is skipped, unless `SWELL_REQUIRE_WEBGPU=1` (`.ci/browser-parity`).
//!
//! Why the whole sea rather than the FFT layer alone: that is what a client renders and what
//! `/sample` answers, so nothing is subtracted and no CPU step of the test's own can hide an
//! error; the analytic layers' own GPU error (≤ 0.3 mm, `browser_parity`) is part of the figure.
//! (`storm` is FFT only: passes that did not run would leave it metres off.)
//!
//! The pages are the client recipe of `docs/clients.md`, pass by pass: each parses the raw
//! `/spectrum` export (`swell-spectrum/1`) itself into the spectrum texture, takes the evolve
//! pass's `cycle` and the block (with the FFT grid offset) from `/uniforms`, and binds samplers,
//! uniform blocks and bind groups by the names and bindings the exports give them.
//!
//! Bound (issue 13): FFT layers ≤ 5 mm in height and displacement, against `/sample` as the
//! server answers by default (time grid, linear between frames 1/60 s apart) at t ∈ {0,
//! 9876.54321 s, 10⁶ s, 10⁶ + 1/120 s} and origins up to 1000 km out. The GPU evaluates at t itself,
//! so the error against `accuracy.time = "exact"` is printed too (it separates the server's time
//! grid from the GPU's f32). Normals: 0.1°, the analytic layers' bound.
//!
//! Measured (SwiftShader, this test, both paths alike): open-sea 0.22 mm height, 0.19 mm
//! displacement, 0.0097° against the default answers (0.11 mm against exact time: the Gerstner
//! swell's f32 and the GPU's own sin/cos); storm 0.18 mm / 0.30 mm / 0.020° against the default
//! answers, 4.0 µm / 4.8 µm / 0.00067° against exact time: the f32 transform itself costs
//! microns (the CPU twin in `crates/swell-shaders/src/fft/tests.rs` measures the same), the rest
//! is the server's time grid. The WebGPU compute path's 9,216 read-back floats equal the WebGL2
//! fragment path's to the bit (the same per-texel arithmetic on SwiftShader's one Vulkan
//! implementation), so the two paths' maxima are the same numbers.
//!
//! Ignored by `cargo test` (it needs Chromium); `.ci/browser-parity` runs it with `--ignored`.

use crate::common;

use common::{TestServer, config};
use serde_json::{Value, json};

const BOUND_M: f64 = 5e-3;
const NORMAL_BOUND_DEG: f64 = 0.1;
const TIMES: [f64; 4] = [0.0, 9876.54321, 1e6, 1e6 + 1.0 / 120.0];
const ORIGINS: [[f64; 2]; 3] = [[0.0, 0.0], [1e6, 0.0], [-3.5e5, 1e6]];

/// Local probe offsets: a spiral out to ~60 m in steps of 1/64 m (exact in f32 and in
/// `origin + local`).
fn probes() -> Vec<[f64; 2]> {
    (0..48)
        .map(|i| {
            let r = 1.25 * i as f64 + 0.37;
            let a = 0.7 * i as f64;
            [
                (r * a.cos() * 64.0).round() / 64.0,
                (r * a.sin() * 64.0).round() / 64.0,
            ]
        })
        .collect()
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let v = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// JS both pages use: `parseSpectrum(b64)` reads the raw `/spectrum` export (`swell-spectrum/1`)
/// into the spectrum texture's texels.
const SPECTRUM_JS: &str = r#"
function parseSpectrum(b64) {
  const bin = atob(b64);
  const u8 = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  const dv = new DataView(u8.buffer);
  if (String.fromCharCode(u8[0], u8[1], u8[2], u8[3]) !== 'SWSP') throw new Error('not a spectrum');
  const hlen = dv.getUint32(4, true);
  const header = JSON.parse(new TextDecoder().decode(u8.subarray(8, 8 + hlen)));
  const n = header.resolution, T = header.repeat_period;
  // Texel (i, j) = (h0.re, h0.im, q, 0) of record (i, j); q = omega*T/(2*pi), a whole number.
  const tex = new Float32Array(4 * n * n);
  for (let r = 0; r < n * n; r++) {
    const o = header.data_offset + 24 * r;
    tex[4 * r] = dv.getFloat64(o, true);
    tex[4 * r + 1] = dv.getFloat64(o + 8, true);
    tex[4 * r + 2] = Math.round(dv.getFloat64(o + 16, true) * T / (2 * Math.PI));
  }
  return { header, n, tex };
}
"#;

/// The page: per scene, the spectrum texture from the raw export, the pass programs and the
/// probe program; per run, evolve + butterflies into a ping-pong pair, then the probes.
const PAGE_JS: &str = r#"
function run() {
  const cv = document.createElement('canvas');
  const gl = cv.getContext('webgl2');
  if (!gl) throw new Error('no webgl2');
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
  const program = (name, vs, fs) => {
    const sh = (type, src) => {
      const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(name + ': ' + gl.getShaderInfoLog(s));
      return s;
    };
    const p = gl.createProgram();
    gl.attachShader(p, sh(gl.VERTEX_SHADER, vs)); gl.attachShader(p, sh(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(name + ' link: ' + gl.getProgramInfoLog(p));
    gl.useProgram(p);
    // Uniform blocks by name: SwellCamera at 1, the rest (SwellUniforms, SwellFftPass) at 0.
    const nb = gl.getProgramParameter(p, gl.ACTIVE_UNIFORM_BLOCKS);
    for (let i = 0; i < nb; i++) {
      gl.uniformBlockBinding(p, i, gl.getActiveUniformBlockName(p, i).startsWith('SwellCamera') ? 1 : 0);
    }
    // Samplers by naga's names, _group_G_binding_B_{vs,fs}: texture unit B.
    const nu = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < nu; i++) {
      const u = gl.getActiveUniform(p, i);
      const m = /_group_\d+_binding_(\d+)_/.exec(u.name);
      if (m && u.type === gl.SAMPLER_2D) gl.uniform1i(gl.getUniformLocation(p, u.name), Number(m[1]));
    }
    return p;
  };
  const texture = (w, h, data) => {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, w, h);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    if (data) gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, gl.RGBA, gl.FLOAT, data);
    return t;
  };
  const target = (a, b) => {
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, a, 0);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT1, gl.TEXTURE_2D, b, 0);
    gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) throw new Error('framebuffer incomplete');
    return fb;
  };
  const bindTex = (unit, t) => { gl.activeTexture(gl.TEXTURE0 + unit); gl.bindTexture(gl.TEXTURE_2D, t); };
  const out = [];
  for (const c of CASES) {
    const spec = parseSpectrum(c.spectrum);
    const n = spec.n;
    const spectrumTex = texture(n, n, spec.tex);
    const pairs = [0, 1].map(() => { const a = texture(n, n), b = texture(n, n); return { a, b, fb: target(a, b) }; });
    const evolve = program(c.scene + ' evolve', c.fft_vs, c.fft_evolve);
    const butterfly = program(c.scene + ' butterfly', c.fft_vs, c.fft_butterfly);
    const probe = program(c.scene + ' probe', c.probe_vs, c.probe_fs);
    const passUbo = gl.createBuffer();
    const setPass = (cycle, ns, axis) => {
      gl.bindBuffer(gl.UNIFORM_BUFFER, passUbo);
      gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array([...cycle, ns, axis, 0, 0]), gl.DYNAMIC_DRAW);
      gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, passUbo);
    };
    const np = c.probes.length;
    const ta = texture(np, 1), tb = texture(np, 1);
    const probeFb = target(ta, tb);
    const attrs = new Float32Array(4 * np);
    c.probes.forEach((p, i) => { attrs.set([p[0], p[1], -1 + (2 * i + 1) / np, 0], 4 * i); });
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const vb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vb);
    gl.bufferData(gl.ARRAY_BUFFER, attrs, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 16, 0);
    gl.enableVertexAttribArray(1); gl.vertexAttribPointer(1, 2, gl.FLOAT, false, 16, 8);
    const emptyVao = gl.createVertexArray();
    const ubo = gl.createBuffer();
    const cam = gl.createBuffer();
    gl.bindBuffer(gl.UNIFORM_BUFFER, cam);
    gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array([1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]), gl.STATIC_DRAW);
    const runs = [];
    const t0 = performance.now();
    for (const r of c.runs) {
      // 1. Evolve: spectrum -> pair 0.
      gl.bindVertexArray(emptyVao);
      gl.viewport(0, 0, n, n);
      gl.useProgram(evolve);
      setPass(r.cycle, 0, 0);
      bindTex(1, spectrumTex); bindTex(2, spectrumTex);
      gl.bindFramebuffer(gl.FRAMEBUFFER, pairs[0].fb);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
      // 2. Butterflies: Ns = 1 .. N/2 along x, then along z, ping-pong; 2·log2 N is even, so
      // the result is back in pair 0.
      gl.useProgram(butterfly);
      let src = 0;
      for (const axis of [0, 1]) {
        for (let ns = 1; ns < n; ns *= 2) {
          setPass([0, 0, 0, 0], ns, axis);
          bindTex(1, pairs[src].a); bindTex(2, pairs[src].b);
          gl.bindFramebuffer(gl.FRAMEBUFFER, pairs[1 - src].fb);
          gl.drawArrays(gl.TRIANGLES, 0, 3);
          src = 1 - src;
        }
      }
      if (src !== 0) throw new Error('odd number of passes');
      // 3. Probes: the surface shader samples the result textures (group 1, bindings 0 and 1).
      gl.useProgram(probe);
      bindTex(1, null); bindTex(2, null);
      bindTex(0, pairs[0].a); bindTex(1, pairs[0].b);
      gl.bindBuffer(gl.UNIFORM_BUFFER, ubo);
      gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array(r.block), gl.DYNAMIC_DRAW);
      gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, ubo);
      gl.bindBufferBase(gl.UNIFORM_BUFFER, 1, cam);
      gl.bindVertexArray(vao);
      gl.bindFramebuffer(gl.FRAMEBUFFER, probeFb);
      gl.viewport(0, 0, np, 1);
      gl.clearBufferfv(gl.COLOR, 0, [NaN, NaN, NaN, NaN]);
      gl.clearBufferfv(gl.COLOR, 1, [NaN, NaN, NaN, NaN]);
      gl.drawArrays(gl.POINTS, 0, np);
      const read = (a) => {
        const px = new Float32Array(4 * np);
        gl.readBuffer(gl.COLOR_ATTACHMENT0 + a);
        gl.readPixels(0, 0, np, 1, gl.RGBA, gl.FLOAT, px);
        return Array.from(px, (v) => Number.isFinite(v) ? v : null);
      };
      runs.push({ a: read(0), b: read(1) });
      bindTex(0, null); bindTex(1, null);
    }
    const err = gl.getError();
    if (err !== gl.NO_ERROR) throw new Error(c.scene + ': GL error ' + err);
    out.push({ scene: c.scene, n, ms_per_run: (performance.now() - t0) / c.runs.length, runs });
  }
  return out;
}
let result;
try { result = { ok: true, cases: run() }; } catch (e) { result = { ok: false, error: String(e) }; }
document.getElementById('out').textContent = JSON.stringify(result);
"#;

/// The WebGPU page: per scene, the spectrum texture from the raw export, the layer's WGSL
/// compute module (`swell_fft_evolve_cs`, `swell_fft_butterfly_cs`: 8×8 workgroups, inputs
/// sampled textures at bindings 1 and 2, outputs rgba32float storage textures at 3 and 4) and
/// the scene's WGSL surface module with a probe compute entry point appended (what
/// `swell_probe_fs` computes, as in `browser_parity`; its buffers at `@group(2)`, since the
/// surface module's FFT textures hold `@group(1)`). Per run, one compute pass: evolve, the
/// 2·log₂N butterflies (one uniform buffer per stage, written once: a `writeBuffer` between
/// dispatches of one submission would not land between them), then the probes reading pair 0;
/// a copy and a map. POSTs the result (same shape as the WebGL2 page's) to `/result`.
const GPU_PAGE_JS: &str = r#"
const PROBE_KERNEL = probeKernel(2);
async function run() {
  const gpu = await openDevice();
  if (gpu.unavailable) return { ok: false, unavailable: gpu.unavailable };
  const { device, errors } = gpu;
  const compile = async (name, code) => {
    const module = device.createShaderModule({ code });
    const ci = await module.getCompilationInfo();
    const bad = ci.messages.filter((m) => m.type === 'error');
    if (bad.length) throw new Error(name + ': ' + bad.map((m) => m.lineNum + ': ' + m.message).join('; '));
    return module;
  };
  const U = GPUBufferUsage, T = GPUTextureUsage;
  const out = [];
  for (const c of CASES) {
    const spec = parseSpectrum(c.spectrum);
    const n = spec.n;
    const passes = await compile(c.scene + ' fft compute', c.fft_compute);
    const surface = await compile(c.scene + ' surface', c.wgsl + PROBE_KERNEL);
    device.pushErrorScope('validation');
    const spectrumTex = device.createTexture({ size: [n, n], format: 'rgba32float', usage: T.TEXTURE_BINDING | T.COPY_DST });
    device.queue.writeTexture({ texture: spectrumTex }, spec.tex, { bytesPerRow: 16 * n }, [n, n]);
    const tex = () => device.createTexture({ size: [n, n], format: 'rgba32float', usage: T.TEXTURE_BINDING | T.STORAGE_BINDING });
    const pairs = [0, 1].map(() => ({ a: tex(), b: tex() }));
    const evolve = device.createComputePipeline({ layout: 'auto', compute: { module: passes, entryPoint: 'swell_fft_evolve_cs' } });
    const butterfly = device.createComputePipeline({ layout: 'auto', compute: { module: passes, entryPoint: 'swell_fft_butterfly_cs' } });
    const probe = device.createComputePipeline({ layout: 'auto', compute: { module: surface, entryPoint: 'swell_probe_cs' } });
    const ubo = (values) => {
      const b = device.createBuffer({ size: 32, usage: U.UNIFORM | U.COPY_DST });
      device.queue.writeBuffer(b, 0, new Float32Array(values));
      return b;
    };
    // SwellFftPass = (cycle, stage). The evolve pass reads the spectrum at binding 1 only
    // (binding 2 is unused there, so the 'auto' layout leaves it out).
    const evolveUbo = ubo([0, 0, 0, 0, 0, 0, 0, 0]);
    const evolveGroup = device.createBindGroup({ layout: evolve.getBindGroupLayout(0), entries: [
      { binding: 0, resource: { buffer: evolveUbo } },
      { binding: 1, resource: spectrumTex.createView() },
      { binding: 3, resource: pairs[0].a.createView() },
      { binding: 4, resource: pairs[0].b.createView() }] });
    // Butterflies: Ns = 1 .. N/2 along x, then along z, ping-pong; 2·log2 N is even, so the
    // result is back in pair 0.
    const stages = [];
    let src = 0;
    for (const axis of [0, 1]) {
      for (let ns = 1; ns < n; ns *= 2) {
        stages.push(device.createBindGroup({ layout: butterfly.getBindGroupLayout(0), entries: [
          { binding: 0, resource: { buffer: ubo([0, 0, 0, 0, ns, axis, 0, 0]) } },
          { binding: 1, resource: pairs[src].a.createView() },
          { binding: 2, resource: pairs[src].b.createView() },
          { binding: 3, resource: pairs[1 - src].a.createView() },
          { binding: 4, resource: pairs[1 - src].b.createView() }] }));
        src = 1 - src;
      }
    }
    if (src !== 0) throw new Error('odd number of passes');
    const np = c.probes.length;
    const probes = new Float32Array(2 * np);
    c.probes.forEach((p, i) => probes.set(p, 2 * i));
    const inBuf = device.createBuffer({ size: probes.byteLength, usage: U.STORAGE | U.COPY_DST });
    device.queue.writeBuffer(inBuf, 0, probes);
    const outBytes = 2 * 16 * np;
    const outBuf = device.createBuffer({ size: outBytes, usage: U.STORAGE | U.COPY_SRC });
    const blockBuf = device.createBuffer({ size: 4 * c.runs[0].block.length, usage: U.UNIFORM | U.COPY_DST });
    // The surface module: its block at group 0, the FFT layer's result textures (pair 0) at
    // group 1 bindings 0 and 1, the probe buffers at group 2.
    const g0 = device.createBindGroup({ layout: probe.getBindGroupLayout(0), entries: [{ binding: 0, resource: { buffer: blockBuf } }] });
    const g1 = device.createBindGroup({ layout: probe.getBindGroupLayout(1), entries: [
      { binding: 0, resource: pairs[0].a.createView() }, { binding: 1, resource: pairs[0].b.createView() }] });
    const g2 = device.createBindGroup({ layout: probe.getBindGroupLayout(2), entries: [
      { binding: 0, resource: { buffer: inBuf } }, { binding: 1, resource: { buffer: outBuf } }] });
    const scope = await device.popErrorScope();
    if (scope) throw new Error(c.scene + ': ' + scope.message);
    const groups = Math.ceil(n / 8);
    const runs = [];
    const t0 = performance.now();
    for (const r of c.runs) {
      device.queue.writeBuffer(evolveUbo, 0, new Float32Array([...r.cycle, 0, 0, 0, 0]));
      device.queue.writeBuffer(blockBuf, 0, new Float32Array(r.block));
      const read = device.createBuffer({ size: outBytes, usage: U.MAP_READ | U.COPY_DST });
      const enc = device.createCommandEncoder();
      const pass = enc.beginComputePass();
      pass.setPipeline(evolve);
      pass.setBindGroup(0, evolveGroup);
      pass.dispatchWorkgroups(groups, groups);
      pass.setPipeline(butterfly);
      for (const g of stages) {
        pass.setBindGroup(0, g);
        pass.dispatchWorkgroups(groups, groups);
      }
      pass.setPipeline(probe);
      pass.setBindGroup(0, g0);
      pass.setBindGroup(1, g1);
      pass.setBindGroup(2, g2);
      pass.dispatchWorkgroups(Math.ceil(np / 64));
      pass.end();
      enc.copyBufferToBuffer(outBuf, 0, read, 0, outBytes);
      device.queue.submit([enc.finish()]);
      await read.mapAsync(GPUMapMode.READ);
      const v = new Float32Array(read.getMappedRange().slice(0));
      read.unmap();
      read.destroy();
      runs.push(probeValues(v, np));
      if (errors.length) throw new Error(c.scene + ': device errors: ' + errors.join('; '));
    }
    out.push({ scene: c.scene, n, ms_per_run: (performance.now() - t0) / c.runs.length, runs });
  }
  if (errors.length) throw new Error('device errors: ' + errors.join('; '));
  return { ok: true, adapter: gpu.name, cases: out };
}
(async () => {
  let result;
  try { result = await run(); } catch (e) { result = { ok: false, error: String(e) }; }
  document.getElementById('out').textContent = JSON.stringify(result).slice(0, 200);
  await fetch('/result', { method: 'POST', headers: { 'content-type': 'application/json' }, body: JSON.stringify(result) });
})();
"#;

/// Max over probes of (|Δheight|, |Δdisplacement|, normal angle in degrees).
fn errors(run: &Value, v: &Value, n: usize) -> (f64, f64, f64) {
    let px = |k: &str, i: usize| run[k][i].as_f64().expect("finite pixel");
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        let d = &v["displacement"][i];
        let nv = &v["normal"][i];
        let disp = (0..3)
            .map(|j| (px("a", 4 * i + j) - d[j].as_f64().unwrap()).powi(2))
            .sum::<f64>()
            .sqrt();
        let h = (px("b", 4 * i + 3) - v["height"][i].as_f64().unwrap()).abs();
        let g = [px("b", 4 * i), px("b", 4 * i + 1), px("b", 4 * i + 2)];
        let dot: f64 = (0..3).map(|j| g[j] * nv[j].as_f64().unwrap()).sum();
        let len = (0..3).map(|j| g[j] * g[j]).sum::<f64>().sqrt();
        let ang = (dot / len).clamp(-1.0, 1.0).acos().to_degrees();
        worst = (worst.0.max(h), worst.1.max(disp), worst.2.max(ang));
    }
    worst
}

/// A scene's `(t, origin)` per run, in page order.
type Runs = Vec<(f64, [f64; 2])>;

/// Compares one path's read-backs with `/sample` (`expected[scene][run] = [grid, exact]`),
/// prints per run and per scene maxima, and asserts the bounds.
fn compare(
    path: &str,
    runs_of: &[(&str, Runs)],
    expected: &[Vec<Vec<Value>>],
    result: &Value,
    n: usize,
) {
    let got_cases = result["cases"].as_array().expect("cases");
    assert_eq!(
        got_cases.len(),
        runs_of.len(),
        "{path}: one result per scene"
    );
    for (((id, runs), exp), got) in runs_of.iter().zip(expected).zip(got_cases) {
        assert_eq!(got["scene"], json!(id));
        let got_runs = got["runs"].as_array().unwrap();
        assert_eq!(got_runs.len(), runs.len(), "{path} {id}");
        let (mut grid, mut exact) = ((0.0f64, 0.0f64, 0.0f64), (0.0f64, 0.0f64, 0.0f64));
        for (((t, o), run), pair) in runs.iter().zip(got_runs).zip(exp) {
            for (label, v, worst) in [
                ("grid", &pair[0], &mut grid),
                ("exact", &pair[1], &mut exact),
            ] {
                let e = errors(run, v, n);
                eprintln!(
                    "  {path} {id} t={t} o={o:?} {label:<5}: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
                    e.0, e.1, e.2
                );
                *worst = (worst.0.max(e.0), worst.1.max(e.1), worst.2.max(e.2));
            }
        }
        eprintln!(
            "FFT {path:<6} {id:<9} N={} ({:.0} ms per frame of passes + probes): vs /sample (grid): height {:.3e} m, displacement {:.3e} m, normal {:.3e}°; vs exact time: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
            got["n"],
            got["ms_per_run"].as_f64().unwrap(),
            grid.0,
            grid.1,
            grid.2,
            exact.0,
            exact.1,
            exact.2
        );
        assert!(
            grid.0 <= BOUND_M && grid.1 <= BOUND_M && exact.0 <= BOUND_M && exact.1 <= BOUND_M,
            "{path} {id}: over {BOUND_M} m: grid {grid:?}, exact {exact:?}"
        );
        assert!(
            grid.2 <= NORMAL_BOUND_DEG && exact.2 <= NORMAL_BOUND_DEG,
            "{path} {id}: normal over {NORMAL_BOUND_DEG}°: grid {}°, exact {}°",
            grid.2,
            exact.2
        );
    }
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs chromium: run by .ci/browser-parity"]
async fn fft_passes_in_headless_chromium_match_sample() {
    let s = TestServer::start(config()).await;
    let probes = probes();
    let mut page_cases = Vec::new();
    let mut runs_of = Vec::new();
    for id in ["open-sea", "storm"] {
        let (_, d) = s.get_json(&format!("/v1/scenes/{id}")).await;
        let li = d["spec"]["layers"]
            .as_array()
            .unwrap()
            .iter()
            .position(|l| l["kind"] == "fft")
            .expect("an FFT layer");
        let text = |q: String| {
            let s = &s;
            async move {
                let url = format!("/v1/scenes/{id}/shader?{q}");
                let r = s.get(&url).await;
                assert_eq!(r.status(), 200, "{url}");
                r.text().await.unwrap()
            }
        };
        let fft = |e: &str| text(format!("lang=glsl_es&entry={e}&layer={li}"));
        let spectrum = s.get(&format!("/v1/scenes/{id}/spectrum?layer={li}")).await;
        assert_eq!(spectrum.status(), 200);
        let spectrum = spectrum.bytes().await.unwrap();
        let mut page_runs = Vec::new();
        let mut runs = Vec::new();
        for &t in &TIMES {
            for o in ORIGINS {
                let (st, u) = s
                    .get_json(&format!(
                        "/v1/scenes/{id}/uniforms?t={t}&origin={},{}",
                        o[0], o[1]
                    ))
                    .await;
                assert_eq!(st, 200, "{u}");
                assert_eq!(u["fft"][0]["layer"], json!(li));
                page_runs.push(json!({"block": u["block"], "cycle": u["fft"][0]["cycle"]}));
                runs.push((t, o));
            }
        }
        page_cases.push(json!({
            "scene": id,
            "spectrum": base64(&spectrum),
            "fft_vs": fft("swell_fft_vs").await,
            "fft_evolve": fft("swell_fft_evolve").await,
            "fft_butterfly": fft("swell_fft_butterfly").await,
            "probe_vs": text("lang=glsl_es&entry=swell_probe_vs".into()).await,
            "probe_fs": text("lang=glsl_es&entry=swell_probe_fs".into()).await,
            // WebGPU: the surface module, and the layer's compute module (either compute
            // entry point gives the whole module).
            "wgsl": text("lang=wgsl".into()).await,
            "fft_compute": text(format!("lang=wgsl&entry=swell_fft_evolve_cs&layer={li}")).await,
            "probes": probes,
            "runs": page_runs,
        }));
        runs_of.push((id, runs));
    }

    // /sample at every run's world points, as the server answers by default (time grid) and at
    // exact time; the same for both GPU paths.
    let mut expected = Vec::new();
    for (id, runs) in &runs_of {
        let mut per_run = Vec::new();
        for (t, o) in runs {
            let world: Vec<[f64; 2]> = probes.iter().map(|p| [o[0] + p[0], o[1] + p[1]]).collect();
            let mut pair = Vec::new();
            for acc in [Value::Null, json!({"time": "exact"})] {
                let mut req = json!({"t": t, "points": world, "fields": ["height", "normal", "displacement"]});
                if !acc.is_null() {
                    req["accuracy"] = acc;
                }
                let (st, v) = s.post_json(&format!("/v1/scenes/{id}/sample"), &req).await;
                assert_eq!(st, 200, "{v}");
                pair.push(v);
            }
            per_run.push(pair);
        }
        expected.push(per_run);
    }
    let page_cases = Value::Array(page_cases);

    // WebGL2: the fragment passes, a file page, its result in the DOM.
    let started = std::time::Instant::now();
    let gl = common::browser::run_webgl_page(
        "fft",
        &format!("const CASES = {page_cases};\n{SPECTRUM_JS}{PAGE_JS}"),
        300,
        60_000,
    );
    eprintln!(
        "chromium ran the FFT pages in {:.1} s (WebGL2, fragment passes)",
        started.elapsed().as_secs_f64()
    );
    compare("webgl2", &runs_of, &expected, &gl, probes.len());

    // WebGPU: the compute passes, on loopback HTTP.
    let started = std::time::Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let script = format!(
        "const CASES = {page_cases};\n{SPECTRUM_JS}{}{GPU_PAGE_JS}",
        common::browser::PROBE_VALUES_JS
    );
    match common::browser::run_webgpu_page(dir.path(), &script, 300).await {
        Ok(gpu) => {
            assert_eq!(gpu["ok"], json!(true), "webgpu FFT page failed: {gpu}");
            eprintln!(
                "chromium ran the FFT pages in {:.1} s (WebGPU, compute passes; adapter {})",
                started.elapsed().as_secs_f64(),
                gpu["adapter"]
            );
            compare("webgpu", &runs_of, &expected, &gpu, probes.len());
            // Same SwiftShader underneath both paths: how many read-back values agree to the
            // bit says whether the compute passes do the fragment passes' arithmetic.
            let values = |r: &Value| -> Vec<Option<f64>> {
                r["cases"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .flat_map(|c| c["runs"].as_array().unwrap().iter())
                    .flat_map(|run| ["a", "b"].map(|k| run[k].as_array().unwrap().clone()))
                    .flatten()
                    .map(|v| v.as_f64())
                    .collect()
            };
            let (a, b) = (values(&gl), values(&gpu));
            let same = a.iter().zip(&b).filter(|(x, y)| x == y).count();
            eprintln!(
                "FFT webgpu vs webgl2 read-backs: {same} of {} values identical",
                a.len()
            );
        }
        Err(why) => {
            assert!(
                std::env::var("SWELL_REQUIRE_WEBGPU").as_deref() != Ok("1"),
                "WebGPU unavailable in this chromium ({why}) and SWELL_REQUIRE_WEBGPU=1"
            );
            eprintln!(
                "FFT webgpu half skipped: WebGPU unavailable in this chromium ({why}); the WebGL2 half ran"
            );
        }
    }
    s.stop().await;
}
