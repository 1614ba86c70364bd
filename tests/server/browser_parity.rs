//! GPU parity in a real browser: the exported shaders, run by headless Chromium on SwiftShader
//! (a CPU implementation of a GPU: no GPU needed), against `/sample` at the same world points.
//! Two halves, over the same scenes, frames and probes:
//!
//! - **WebGL2 / GLSL ES**: each scene's `swell_probe_vs` / `swell_probe_fs` GLSL ES draws one
//!   point per probe into two RGBA32F targets, read back with `readPixels`; the page is a file
//!   run with `chromium --headless --dump-dom`, which writes the result into the DOM.
//! - **WebGPU / WGSL**: each scene's WGSL module, with a compute entry point appended by the page
//!   (`swell_probe_cs`: per probe, exactly what `swell_probe_fs` computes, from the exported
//!   `swell_sample`, `swell_invert`, `swell_normal` and `swell_jacobian`), writes into a storage
//!   buffer that is copied and mapped back. WebGPU needs a secure origin and is asynchronous, so
//!   this page is served from `http://127.0.0.1` by the test and posts its result back to it.
//!   Where Chromium offers no WebGPU adapter the half says so and is skipped, unless
//!   `SWELL_REQUIRE_WEBGPU=1` (set by `.ci/browser-parity`: SwiftShader's WebGPU works on the
//!   CI machine, so losing it is a failure there).
//!
//! Ignored by `cargo test` (it needs Chromium); `.ci/browser-parity` installs Chromium if
//! missing and runs it with `--ignored`. Each frame's uniform block comes from `/uniforms`.
//!
//! Bounds (issue 13): sine/Gerstner height and displacement ≤ 2 mm, normal ≤ 0.1°. FFT layers
//! need their pass shaders and textures, which `tests/server/browser_fft.rs` runs (bound 5 mm); this
//! page tests scenes with FFT layers on their analytic layers only (a copy of the scene without
//! its FFT layers) and skips an FFT-only scene.

use crate::common;

use common::{TestServer, config};
use serde_json::{Value, json};

const HEIGHT_BOUND_M: f64 = 2e-3;
const NORMAL_BOUND_DEG: f64 = 0.1;

/// Times (s) and origins (world x/z, m) every scene is probed at: the start, a few hours, and
/// t = 10⁶ s with origins up to 1000 km out, where f32 phases formed naively are whole radians
/// off.
const TIMES: [f64; 3] = [0.0, 9876.5, 1e6];
const ORIGINS: [[f64; 2]; 3] = [[0.0, 0.0], [1e6, 0.0], [-3.5e5, 1e6]];

/// Local probe offsets: a spiral out to ~60 m, in steps of 1/64 m so that every offset is
/// exact in f32 and `origin + local` is exact in f64.
fn probes() -> Vec<[f64; 2]> {
    (0..48)
        .map(|i| {
            let r = 1.25 * i as f64;
            let a = 0.7 * i as f64;
            [
                (r * a.cos() * 64.0).round() / 64.0,
                (r * a.sin() * 64.0).round() / 64.0,
            ]
        })
        .collect()
}

/// The page: compiles each scene's probe program, then per run uploads the uniform block, draws
/// the probes as points into an N×1 pair of RGBA32F targets and reads both back. Results (or
/// the first error) go into `<pre id="out">` as JSON, before the load event, so `--dump-dom`
/// sees them.
const PAGE_JS: &str = r#"
function run() {
  const cv = document.createElement('canvas');
  const gl = cv.getContext('webgl2');
  if (!gl) throw new Error('no webgl2');
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
  const out = [];
  for (const c of CASES) {
    const sh = (type, src) => {
      const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(c.scene + ': ' + gl.getShaderInfoLog(s));
      return s;
    };
    const prog = gl.createProgram();
    gl.attachShader(prog, sh(gl.VERTEX_SHADER, c.vs));
    gl.attachShader(prog, sh(gl.FRAGMENT_SHADER, c.fs));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(c.scene + ' link: ' + gl.getProgramInfoLog(prog));
    gl.useProgram(prog);
    const nb = gl.getProgramParameter(prog, gl.ACTIVE_UNIFORM_BLOCKS);
    for (let i = 0; i < nb; i++) {
      const name = gl.getActiveUniformBlockName(prog, i);
      gl.uniformBlockBinding(prog, i, name.startsWith('SwellCamera') ? 1 : 0);
    }
    const n = c.probes.length;
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    for (let a = 0; a < 2; a++) {
      const tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, n, 1);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0 + a, gl.TEXTURE_2D, tex, 0);
    }
    gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) throw new Error('framebuffer incomplete');
    gl.viewport(0, 0, n, 1);
    const attrs = new Float32Array(4 * n);
    c.probes.forEach((p, i) => { attrs.set([p[0], p[1], -1 + (2 * i + 1) / n, 0], 4 * i); });
    const vb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vb);
    gl.bufferData(gl.ARRAY_BUFFER, attrs, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 16, 0);
    gl.enableVertexAttribArray(1); gl.vertexAttribPointer(1, 2, gl.FLOAT, false, 16, 8);
    const ubo = gl.createBuffer();
    const cam = gl.createBuffer();
    gl.bindBuffer(gl.UNIFORM_BUFFER, cam);
    gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array([1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]), gl.STATIC_DRAW);
    gl.bindBufferBase(gl.UNIFORM_BUFFER, 1, cam);
    const runs = [];
    for (const r of c.runs) {
      gl.bindBuffer(gl.UNIFORM_BUFFER, ubo);
      gl.bufferData(gl.UNIFORM_BUFFER, new Float32Array(r.block), gl.DYNAMIC_DRAW);
      gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, ubo);
      gl.clearBufferfv(gl.COLOR, 0, [NaN, NaN, NaN, NaN]);
      gl.clearBufferfv(gl.COLOR, 1, [NaN, NaN, NaN, NaN]);
      gl.drawArrays(gl.POINTS, 0, n);
      const read = (a) => {
        const px = new Float32Array(4 * n);
        gl.readBuffer(gl.COLOR_ATTACHMENT0 + a);
        gl.readPixels(0, 0, n, 1, gl.RGBA, gl.FLOAT, px);
        return Array.from(px, (v) => Number.isFinite(v) ? v : null);
      };
      runs.push({ a: read(0), b: read(1) });
    }
    out.push({ scene: c.scene, runs });
  }
  return out;
}
let result;
try { result = { ok: true, cases: run() }; } catch (e) { result = { ok: false, error: String(e) }; }
document.getElementById('out').textContent = JSON.stringify(result);
"#;

/// The WebGPU page: per scene, the exported WGSL plus a compute entry point that evaluates what
/// `swell_probe_fs` does at each probe into a storage buffer; per run, the frame's block in the
/// uniform buffer, one dispatch, a copy, a map. The result (same shape as the WebGL2 page's) is
/// POSTed to `/result`; an unavailable adapter is reported as such, not as a failure.
const GPU_PAGE_JS: &str = r#"
const KERNEL = probeKernel(1);
async function run() {
  const gpu = await openDevice();
  if (gpu.unavailable) return { ok: false, unavailable: gpu.unavailable };
  const { device, errors } = gpu;
  const out = [];
  for (const c of CASES) {
    const module = device.createShaderModule({ code: c.wgsl + KERNEL });
    const ci = await module.getCompilationInfo();
    const bad = ci.messages.filter((m) => m.type === 'error');
    if (bad.length) throw new Error(c.scene + ': ' + bad.map((m) => m.lineNum + ': ' + m.message).join('; '));
    device.pushErrorScope('validation');
    const pipeline = device.createComputePipeline({ layout: 'auto', compute: { module, entryPoint: 'swell_probe_cs' } });
    const n = c.probes.length;
    const probes = new Float32Array(2 * n);
    c.probes.forEach((p, i) => probes.set(p, 2 * i));
    const inBuf = device.createBuffer({ size: probes.byteLength, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST });
    device.queue.writeBuffer(inBuf, 0, probes);
    const outBytes = 2 * 16 * n;
    const outBuf = device.createBuffer({ size: outBytes, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC });
    const ubo = device.createBuffer({ size: 4 * c.runs[0].block.length, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
    const g0 = device.createBindGroup({ layout: pipeline.getBindGroupLayout(0), entries: [{ binding: 0, resource: { buffer: ubo } }] });
    const g1 = device.createBindGroup({ layout: pipeline.getBindGroupLayout(1), entries: [
      { binding: 0, resource: { buffer: inBuf } }, { binding: 1, resource: { buffer: outBuf } }] });
    const scope = await device.popErrorScope();
    if (scope) throw new Error(c.scene + ': ' + scope.message);
    const runs = [];
    for (const r of c.runs) {
      device.queue.writeBuffer(ubo, 0, new Float32Array(r.block));
      const read = device.createBuffer({ size: outBytes, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
      const enc = device.createCommandEncoder();
      const pass = enc.beginComputePass();
      pass.setPipeline(pipeline);
      pass.setBindGroup(0, g0);
      pass.setBindGroup(1, g1);
      pass.dispatchWorkgroups(Math.ceil(n / 64));
      pass.end();
      enc.copyBufferToBuffer(outBuf, 0, read, 0, outBytes);
      device.queue.submit([enc.finish()]);
      await read.mapAsync(GPUMapMode.READ);
      const v = new Float32Array(read.getMappedRange().slice(0));
      read.unmap();
      read.destroy();
      runs.push(probeValues(v, n));
    }
    out.push({ scene: c.scene, runs });
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

struct Case {
    scene: String,
    /// `(t, origin)` per run, in page order.
    runs: Vec<(f64, [f64; 2])>,
    /// `/sample` at each run's world points: height, normal, displacement.
    expected: Vec<Value>,
}

/// Largest errors of one scene or of all: height (m), displacement (m), normal angle (°).
#[derive(Debug, Clone, Copy, Default)]
struct Worst {
    height: f64,
    displacement: f64,
    normal_deg: f64,
}

impl Worst {
    fn max(self, o: Worst) -> Worst {
        Worst {
            height: self.height.max(o.height),
            displacement: self.displacement.max(o.displacement),
            normal_deg: self.normal_deg.max(o.normal_deg),
        }
    }
}

/// Compares a page's readback (`cases[*].runs[*].{a, b}`: per probe `(Dx, y, Dz, J)` and
/// `(normal, height)`) with `/sample`; prints each scene's maxima and asserts the bounds.
fn compare(half: &str, cases: &[Case], result: &Value, probes: usize) -> Worst {
    let mut overall = Worst::default();
    let got_cases = result["cases"].as_array().expect("cases");
    assert_eq!(got_cases.len(), cases.len(), "{half}: one result per scene");
    for (case, got) in cases.iter().zip(got_cases) {
        assert_eq!(got["scene"], json!(case.scene));
        let mut worst = Worst::default();
        let got_runs = got["runs"].as_array().unwrap();
        assert_eq!(got_runs.len(), case.runs.len(), "{half} {}", case.scene);
        for (((t, o), run), v) in case.runs.iter().zip(got_runs).zip(&case.expected) {
            let px = |k: &str, i: usize| {
                run[k][i].as_f64().unwrap_or_else(|| {
                    panic!("{half} {} t={t} o={o:?}: non-finite value", case.scene)
                })
            };
            for i in 0..probes {
                let d = &v["displacement"][i];
                let n = &v["normal"][i];
                let dv = |j: usize| d[j].as_f64().unwrap();
                let nv = |j: usize| n[j].as_f64().unwrap();
                let disp_err = (0..3)
                    .map(|j| (px("a", 4 * i + j) - dv(j)).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let h_err = (px("b", 4 * i + 3) - v["height"][i].as_f64().unwrap()).abs();
                let g = [px("b", 4 * i), px("b", 4 * i + 1), px("b", 4 * i + 2)];
                let dot = (0..3).map(|j| g[j] * nv(j)).sum::<f64>();
                let len = (0..3).map(|j| g[j] * g[j]).sum::<f64>().sqrt();
                let ang = (dot / len).clamp(-1.0, 1.0).acos().to_degrees();
                worst = worst.max(Worst {
                    height: h_err,
                    displacement: disp_err,
                    normal_deg: ang,
                });
            }
        }
        eprintln!(
            "{half:<7} {:<20} max |Δheight| {:.3e} m, max |Δdisplacement| {:.3e} m, max normal angle {:.3e}°",
            case.scene, worst.height, worst.displacement, worst.normal_deg
        );
        overall = overall.max(worst);
        assert!(
            worst.height <= HEIGHT_BOUND_M && worst.displacement <= HEIGHT_BOUND_M,
            "{half} {}: height {} m / displacement {} m over {HEIGHT_BOUND_M} m",
            case.scene,
            worst.height,
            worst.displacement
        );
        assert!(
            worst.normal_deg <= NORMAL_BOUND_DEG,
            "{half} {}: normal {}° over {NORMAL_BOUND_DEG}°",
            case.scene,
            worst.normal_deg
        );
    }
    overall
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs chromium: run by .ci/browser-parity"]
async fn exported_glsl_es_and_wgsl_match_sample_in_headless_chromium() {
    let s = TestServer::start(config()).await;
    // The acceptance-style steep Gerstner sea: fold number 0.9.
    let steep = json!({"description": "fold 0.9", "seed": 5, "layers": [{"kind": "gerstner",
        "waves": [{"amplitude": 1.2, "wavelength": 30, "direction": [1, 0.25], "steepness": 1.0},
                  {"amplitude": 0.4, "wavelength": 8, "direction": [0.2, 1], "steepness": 1.0, "phase": 1.0},
                  {"amplitude": 0.21, "wavelength": 4, "direction": [-0.7, 0.6], "steepness": 1.0, "phase": -2.0}]}]});
    let (st, v) = s.put_scene("steep", &steep).await;
    assert_eq!(st, 201, "{v}");
    let fold = v["derived"]["fold_number"].as_f64().unwrap();
    assert!((fold - 0.9).abs() < 0.02, "fold number {fold}");

    // Built-in scenes; those with FFT layers are probed on a copy without them.
    let mut scenes = vec!["steep".to_owned()];
    // harbour's particle layer with impact rings around the probes at every run (issue 15).
    // Impacts are dated near their scene clock's now and expire a lifetime behind the newest
    // (issue 27), so each time gets its own copy of harbour, its clock held at that time.
    let (_, d) = s.get_json("/v1/scenes/harbour").await;
    for (i, &t) in TIMES.iter().enumerate() {
        let id = format!("harbour-{i}");
        let (st, v) = s.put_scene(&id, &d["spec"]).await;
        assert_eq!(st, 201, "{v}");
        let (st, v) = s.put_clock(&id, &json!({"t": t, "paused": true})).await;
        assert_eq!(st, 200, "{v}");
        for (k, o) in ORIGINS.iter().enumerate() {
            // Rings of radii from about 1 m to 22 m around a point near the origin, so the
            // probe spiral crosses several of them (24 live rings per time: within the 32 a
            // shader takes).
            for age in [0.6, 1.2, 2.0, 3.0, 4.5, 6.0, 8.0, 10.0] {
                let body = json!({"position": [o[0] + 0.3 + k as f64, o[1] + 0.2],
                    "t": t - age, "strength": 0.4, "radius": 0.8});
                let (st, v) = s
                    .admin(
                        reqwest::Method::POST,
                        &format!("/v1/scenes/{id}/impacts"),
                        Some(&body),
                        Some(common::TOKEN),
                    )
                    .await;
                assert_eq!(st, 202, "{v}");
            }
        }
        scenes.push(id);
    }
    for id in ["calm", "lake", "open-sea", "storm"] {
        let (_, d) = s.get_json(&format!("/v1/scenes/{id}")).await;
        let mut spec = d["spec"].clone();
        let layers: Vec<Value> = spec["layers"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["kind"] != "fft")
            .cloned()
            .collect();
        if layers.is_empty() {
            eprintln!("{id}: FFT layers only: skipped here (tests/server/browser_fft.rs runs it)");
            continue;
        }
        if layers.len() == spec["layers"].as_array().unwrap().len() {
            scenes.push(id.to_owned());
        } else {
            spec["layers"] = Value::Array(layers);
            let copy = format!("{id}-analytic");
            let (st, v) = s.put_scene(&copy, &spec).await;
            assert_eq!(st, 201, "{v}");
            scenes.push(copy);
        }
    }

    let probes = probes();
    let mut page_cases = Vec::new();
    let mut cases = Vec::new();
    for id in &scenes {
        let text = |query: String| {
            let url = format!("/v1/scenes/{id}/shader?{query}");
            let s = &s;
            async move {
                let r = s.get(&url).await;
                assert_eq!(r.status(), 200, "{url}");
                r.text().await.unwrap()
            }
        };
        let vs = text("lang=glsl_es&entry=swell_probe_vs".into()).await;
        let fs = text("lang=glsl_es&entry=swell_probe_fs".into()).await;
        let wgsl = text("lang=wgsl".into()).await;
        let mut runs = Vec::new();
        let mut page_runs = Vec::new();
        let mut expected = Vec::new();
        for &t in &TIMES {
            for o in ORIGINS {
                let (st, u) = s
                    .get_json(&format!(
                        "/v1/scenes/{id}/uniforms?t={t}&origin={},{}",
                        o[0], o[1]
                    ))
                    .await;
                assert_eq!(st, 200, "{u}");
                page_runs.push(json!({"block": u["block"]}));
                runs.push((t, o));
                let world: Vec<[f64; 2]> =
                    probes.iter().map(|p| [o[0] + p[0], o[1] + p[1]]).collect();
                let (st, v) = s
                    .post_json(
                        &format!("/v1/scenes/{id}/sample"),
                        &json!({"t": t, "points": world, "fields": ["height", "normal", "displacement"]}),
                    )
                    .await;
                assert_eq!(st, 200, "{v}");
                expected.push(v);
            }
        }
        page_cases.push(
            json!({"scene": id, "vs": vs, "fs": fs, "wgsl": wgsl, "probes": probes, "runs": page_runs}),
        );
        cases.push(Case {
            scene: id.clone(),
            runs,
            expected,
        });
    }
    let page_cases = Value::Array(page_cases);

    // WebGL2: a file page, its result in the DOM.
    let started = std::time::Instant::now();
    let result = common::browser::run_webgl_page(
        "parity",
        &format!("const CASES = {page_cases};\n{PAGE_JS}"),
        180,
        10_000,
    );
    eprintln!(
        "chromium ran {} scenes × {} frames × {} probes in {:.1} s (WebGL2, GLSL ES)",
        cases.len(),
        TIMES.len() * ORIGINS.len(),
        probes.len(),
        started.elapsed().as_secs_f64()
    );
    let gl = compare("webgl2", &cases, &result, probes.len());
    let gl_result = result;
    eprintln!(
        "PARITY webgl2 (GLSL ES), all scenes: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
        gl.height, gl.displacement, gl.normal_deg
    );

    // WebGPU: the same cases through the WGSL, on loopback HTTP.
    let started = std::time::Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let script = format!(
        "const CASES = {page_cases};\n{}{GPU_PAGE_JS}",
        common::browser::PROBE_VALUES_JS
    );
    match common::browser::run_webgpu_page(dir.path(), &script, 180).await {
        Ok(result) => {
            assert_eq!(result["ok"], json!(true), "webgpu page failed: {result}");
            eprintln!(
                "chromium ran {} scenes × {} frames × {} probes in {:.1} s (WebGPU, WGSL; adapter {})",
                cases.len(),
                TIMES.len() * ORIGINS.len(),
                probes.len(),
                started.elapsed().as_secs_f64(),
                result["adapter"]
            );
            let gpu = compare("webgpu", &cases, &result, probes.len());
            // Both halves run on SwiftShader's one Vulkan implementation (ANGLE and Dawn each
            // sit on it): how many read-back values agree to the bit says whether the two
            // paths differ at all.
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
            let (a, b) = (values(&gl_result), values(&result));
            let same = a.iter().zip(&b).filter(|(x, y)| x == y).count();
            eprintln!(
                "webgpu vs webgl2 read-backs: {same} of {} values identical",
                a.len()
            );
            eprintln!(
                "PARITY webgpu (WGSL), all scenes: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
                gpu.height, gpu.displacement, gpu.normal_deg
            );
        }
        Err(why) => {
            assert!(
                std::env::var("SWELL_REQUIRE_WEBGPU").as_deref() != Ok("1"),
                "WebGPU unavailable in this chromium ({why}) and SWELL_REQUIRE_WEBGPU=1"
            );
            eprintln!(
                "webgpu half skipped: WebGPU unavailable in this chromium ({why}); the WebGL2 half ran"
            );
        }
    }
    s.stop().await;
}
