// The viewer in headless Chromium (CDP, SwiftShader WebGL2): no console errors, a canvas that is
// not blank, body positions equal to the streamed state at the same tick, the probe's GPU height
// within the shader-parity bound of /sample. Skips without a swell binary or chromium.
//
// SWELL_VIEWER_SHOT=path also writes a screenshot of open-sea with boats there (docs/viewer.png
// is made this way: see docs/clients.md "The viewer").
import { describe, test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { writeFileSync } from 'node:fs';
import { SwellProcess, available } from './server.js';
import { Browser, CHROMIUM, decodePng, pixelStats } from './cdp.js';
import { SwellClient, SwellSession } from '../src/index.js';

const HEIGHT_BOUND_M = 2e-3; // issue 13's shader-parity bound
let hasChromium = true;
try { execFileSync(CHROMIUM, ['--version'], { stdio: 'ignore' }); } catch { hasChromium = false; }
const skip = !available() ? 'no swell binary' : !hasChromium ? `no chromium (${CHROMIUM})` : false;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const hull = (length, beam, height) => ({ kind: 'box', length, beam, height });

describe('viewer in headless chromium', { skip }, () => {
  let srv; let http; let admin; let browser;
  before(async () => {
    srv = await SwellProcess.start();
    http = new SwellClient(srv.url);
    admin = new SwellClient(srv.url, { adminToken: srv.token });
    browser = await Browser.launch();
  });
  after(async () => { await browser?.close(); await srv?.dispose(); });

  test('assets are served from the binary; unknown ones are 404', async () => {
    const page = await fetch(`${srv.url}/viewer`);
    assert.equal(page.status, 200);
    assert.match(page.headers.get('content-type'), /text\/html/);
    assert.doesNotMatch(await page.text(), /https?:\/\//);
    assert.equal((await fetch(`${srv.url}/viewer/assets/client/surface.js`)).status, 200);
    assert.equal((await fetch(`${srv.url}/viewer/assets/fft-worker.js`)).status, 200);
    assert.equal((await fetch(`${srv.url}/viewer/assets/client/nope.js`)).status, 404);
  });

  test('lake: renders, streams a body, probes within the parity bound', async () => {
    const spawned = await admin.spawnBody('lake', { mass: 3000, hull: hull(8, 3, 1.5), position: [6, 0.5, -4], yaw: 0.4 });
    const page = await browser.open(`${srv.url}/viewer/lake`);
    await page.waitFor('window.swellViewer && swellViewer.ready && swellViewer.frames > 3');
    await page.waitFor('swellViewer.lastTick && swellViewer.lastTick.bodies.length > 0');

    const hud = await page.eval(`document.getElementById('hud').textContent`);
    assert.match(hud, /lake/);
    assert.match(hud, /scene time \d+\.\d+ s/);
    assert.match(hud, /tick \d+/);
    assert.match(hud, /RTT \d+\.\d+ ms/);
    assert.match(hud, /clock offset/);
    const png = decodePng(await page.screenshot());
    const stats = pixelStats(png);
    console.log(`lake screenshot ${png.width}x${png.height}: luma mean ${stats.mean.toFixed(1)}, std ${stats.std.toFixed(1)}, ${stats.colours} colours`);
    assert.ok(stats.std > 8 && stats.colours > 100, `canvas looks blank: ${JSON.stringify(stats)}`);

    // The page's body state for a tick equals what the stream sends any client for that tick.
    const frames = new Map();
    const s = new SwellSession(http.streamUrl('lake'), { onTick: (f) => frames.set(f.tick, f) });
    await s.connect();
    s.subscribe({ bodies: [spawned.id] });
    try {
      for (let i = 0; i < 200 && frames.size < 5; i++) await sleep(20);
      const ticks = [...frames.keys()];
      const tick = ticks[ticks.length - 2];
      const mine = frames.get(tick).bodies.find((b) => b.id === spawned.id);
      const theirs = await page.waitFor(`swellViewer.bodyAtTick(${spawned.id}, ${tick})`, 5000);
      assert.deepEqual(theirs.position, mine.position, `tick ${tick}`);
      assert.deepEqual(theirs.rotation, mine.rotation);
      console.log(`body ${spawned.id} at tick ${tick}: page ${JSON.stringify(theirs.position)} = stream`);
    } finally { s.close(); }

    // Probe: the exported shader on the GPU against /sample, and the client's CPU evaluation.
    let worst = 0;
    for (const [x, z] of [[12.5, -7.25], [-31, 44.5], [0.75, 0.5]]) {
      const p = await page.eval(`swellViewer.probeAt(swellViewer.origin[0] + ${x}, swellViewer.origin[1] + ${z})`);
      assert.ok(Math.abs(p.gpu - p.server) <= HEIGHT_BOUND_M, JSON.stringify(p));
      assert.equal(p.cpu, p.server, 'client CPU height is the server bits');
      worst = Math.max(worst, Math.abs(p.gpu - p.server));
    }
    console.log(`probe |GPU − server| max ${(worst * 1e3).toFixed(4)} mm (bound ${HEIGHT_BOUND_M * 1e3} mm)`);

    // A click on the sea runs the same probe through the UI.
    await page.click(640, 520);
    const clicked = await page.waitFor('swellViewer.probe && swellViewer.probe.world[0] !== swellViewer.origin[0] + 0.75 && swellViewer.probe', 10000);
    assert.ok(Math.abs(clicked.gpu - clicked.server) <= HEIGHT_BOUND_M, JSON.stringify(clicked));
    assert.match(await page.eval(`document.getElementById('probe').textContent`), /server .* GPU/);
    assert.deepEqual(page.errors, []);
  });

  test('open-sea (FFT + Gerstner) with boats: renders without errors', async () => {
    const boats = [[0, 0, 0.3], [22, -14, 1.2], [-18, 20, -0.8], [40, 25, 2.2]];
    for (const [x, z, yaw] of boats) {
      await admin.spawnBody('open-sea', { mass: 3000, hull: hull(8, 3, 1.5), position: [x, 0.5, z], yaw });
    }
    const page = await browser.open(`${srv.url}/viewer`);
    await page.waitFor('window.swellViewer && swellViewer.ready && swellViewer.frames > 3 && swellViewer.bodies.size === 4 && swellViewer.fftFrames > 1');
    assert.equal(await page.eval('swellViewer.scene'), 'open-sea', '/viewer opens open-sea');
    await sleep(500);
    const shot = await page.screenshot();
    const stats = pixelStats(decodePng(shot));
    console.log(`open-sea screenshot: luma mean ${stats.mean.toFixed(1)}, std ${stats.std.toFixed(1)}, ${stats.colours} colours`);
    assert.ok(stats.std > 8 && stats.colours > 100, JSON.stringify(stats));
    if (process.env.SWELL_VIEWER_SHOT) writeFileSync(process.env.SWELL_VIEWER_SHOT, shot);
    const p = await page.eval('swellViewer.probeAt(swellViewer.origin[0] + 5, swellViewer.origin[1] - 3)');
    assert.ok(Math.abs(p.cpu - p.server) < 1e-6, `client FFT height vs server: ${JSON.stringify(p)}`);
    assert.deepEqual(page.errors, []);
  });
});
