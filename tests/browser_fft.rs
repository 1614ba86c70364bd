//! FFT layers on the GPU, in a real browser: headless Chromium's WebGL2 (SwiftShader, no GPU
//! needed) runs an FFT scene's exported pass shaders — the evolve pass and 2·log₂N Stockham
//! butterfly passes over RGBA32F textures — and then the scene's exported probe shader, which
//! samples the transformed grids with the model's Catmull–Rom filter, adds the analytic layers
//! and inverts the horizontal displacement. What it reads back is the whole sea; it is compared
//! with `/sample` at the same world points.
//!
//! Why the whole sea rather than the FFT layer alone: that is what a client renders and what
//! `/sample` answers, so nothing is subtracted and no CPU step of the test's own can hide an
//! error; the analytic layers' own GPU error (≤ 0.3 mm, `browser_parity`) is part of the figure.
//!
//! The page is the client recipe of `docs/clients.md`, pass by pass: it parses the raw
//! `/spectrum` export (`swell-spectrum/1`) itself into the spectrum texture, takes the evolve
//! pass's `cycle` and the block (with the FFT grid offset) from `/uniforms`, and binds samplers
//! and uniform blocks by the names naga gives them.
//!
//! Bound (issue 13): FFT layers ≤ 5 mm in height and displacement, against `/sample` as the
//! server answers by default (time grid, linear between frames 1/60 s apart) at t ∈ {0,
//! 9876.54321 s, 10⁶ s, 10⁶ + 1/120 s} and origins up to 1000 km out. The GPU evaluates at t itself,
//! so the error against `accuracy.time = "exact"` is printed too (it separates the server's time
//! grid from the GPU's f32). Normals: 0.1°, the analytic layers' bound.
//!
//! Measured (SwiftShader, this test): open-sea 0.22 mm height, 0.19 mm displacement, 0.01°
//! against the default answers (0.11 mm against exact time: the Gerstner swell's f32 and the
//! GPU's own sin/cos); storm 0.18 mm / 0.30 mm / 0.02° against the default answers, 4 µm / 5 µm /
//! 0.001° against exact time: the f32 transform itself costs microns (the CPU twin in
//! `crates/swell-shaders/src/fft/tests.rs` measures the same), the rest is the server's time
//! grid.
//!
//! Ignored by `cargo test` (it needs Chromium); `.ci/browser-parity` runs it with `--ignored`.

mod common;

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

/// The page: per scene, the spectrum texture from the raw export, the pass programs and the
/// probe program; per run, evolve + butterflies into a ping-pong pair, then the probes.
const PAGE_JS: &str = r#"
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
                let url = format!("/v1/scenes/{id}/shader?lang=glsl_es&{q}");
                let r = s.get(&url).await;
                assert_eq!(r.status(), 200, "{url}");
                r.text().await.unwrap()
            }
        };
        let fft = |e: &str| text(format!("entry={e}&layer={li}"));
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
            "probe_vs": text("entry=swell_probe_vs".into()).await,
            "probe_fs": text("entry=swell_probe_fs".into()).await,
            "probes": probes,
            "runs": page_runs,
        }));
        runs_of.push((id, runs));
    }

    let started = std::time::Instant::now();
    let result = common::browser::run_webgl_page(
        "fft",
        &format!("const CASES = {};\n{PAGE_JS}", Value::Array(page_cases)),
        300,
        60_000,
    );
    eprintln!(
        "chromium ran the FFT pages in {:.1} s",
        started.elapsed().as_secs_f64()
    );

    for ((id, runs), got) in runs_of.iter().zip(result["cases"].as_array().unwrap()) {
        assert_eq!(got["scene"], json!(id));
        let (mut grid, mut exact) = ((0.0f64, 0.0f64, 0.0f64), (0.0f64, 0.0f64, 0.0f64));
        for ((t, o), run) in runs.iter().zip(got["runs"].as_array().unwrap()) {
            let world: Vec<[f64; 2]> = probes.iter().map(|p| [o[0] + p[0], o[1] + p[1]]).collect();
            let fields = json!(["height", "normal", "displacement"]);
            for (label, acc) in [("grid", Value::Null), ("exact", json!({"time": "exact"}))] {
                let mut req = json!({"t": t, "points": world, "fields": fields});
                if !acc.is_null() {
                    req["accuracy"] = acc;
                }
                let (st, v) = s.post_json(&format!("/v1/scenes/{id}/sample"), &req).await;
                assert_eq!(st, 200, "{v}");
                let e = errors(run, &v, world.len());
                eprintln!(
                    "  {id} t={t} o={o:?} {label:<5}: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
                    e.0, e.1, e.2
                );
                let worst = if label == "grid" {
                    &mut grid
                } else {
                    &mut exact
                };
                *worst = (worst.0.max(e.0), worst.1.max(e.1), worst.2.max(e.2));
            }
        }
        eprintln!(
            "FFT {id:<9} N={} ({:.0} ms per frame of passes + probes): vs /sample (grid): height {:.3e} m, displacement {:.3e} m, normal {:.3e}°; vs exact time: height {:.3e} m, displacement {:.3e} m, normal {:.3e}°",
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
            "{id}: over {BOUND_M} m: grid {grid:?}, exact {exact:?}"
        );
        assert!(
            grid.2 <= NORMAL_BOUND_DEG,
            "{id}: normal {}° over {NORMAL_BOUND_DEG}°",
            grid.2
        );
    }
    s.stop().await;
}
