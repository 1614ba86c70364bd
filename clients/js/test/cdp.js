// Headless Chromium driven over the DevTools protocol, with nothing but Node's WebSocket: launch
// (SwiftShader WebGL2, as .ci/browser-parity), open a page, evaluate, screenshot, and collect
// every console error and uncaught exception. CHROMIUM overrides the binary.
import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { inflateSync } from 'node:zlib';

export const CHROMIUM = process.env.CHROMIUM ?? 'chromium';

export class Browser {
  static async launch({ width = 1280, height = 720, extraArgs = [] } = {}) {
    const b = new Browser();
    b.dir = mkdtempSync(join(tmpdir(), 'swell-chromium-'));
    b.proc = spawn(CHROMIUM, ['--headless', '--no-sandbox', '--disable-gpu-sandbox', '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-first-run', '--no-default-browser-check',
      '--disable-extensions', '--mute-audio', `--window-size=${width},${height}`, `--user-data-dir=${b.dir}`,
      '--remote-debugging-port=0', '--remote-debugging-address=127.0.0.1', ...extraArgs, 'about:blank'], { stdio: ['ignore', 'ignore', 'pipe'] });
    const url = await new Promise((resolve, reject) => {
      let err = '';
      const timer = setTimeout(() => reject(new Error(`chromium did not start:\n${err}`)), 30000);
      b.proc.stderr.on('data', (d) => {
        err += d;
        const m = err.match(/DevTools listening on (ws:\/\/\S+)/);
        if (m) { clearTimeout(timer); resolve(m[1]); }
      });
      b.proc.once('exit', (c) => { clearTimeout(timer); reject(new Error(`chromium exited (${c}):\n${err}`)); });
    });
    b.ws = new WebSocket(url);
    await new Promise((r, j) => { b.ws.onopen = r; b.ws.onerror = () => j(new Error('CDP socket failed')); });
    b.next = 1; b.pending = new Map(); b.listeners = [];
    b.ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.id && b.pending.has(m.id)) {
        const p = b.pending.get(m.id); b.pending.delete(m.id);
        if (m.error) p.reject(new Error(`${p.method}: ${m.error.message}`)); else p.resolve(m.result);
      } else if (m.method) for (const l of b.listeners) l(m);
    };
    return b;
  }

  send(method, params = {}, sessionId) {
    const id = this.next++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject, method });
      this.ws.send(JSON.stringify({ id, method, params, ...(sessionId ? { sessionId } : {}) }));
    });
  }

  /** Opens `url` in a new page; returns a Page. */
  async open(url, { width = 1280, height = 720 } = {}) {
    const { targetId } = await this.send('Target.createTarget', { url: 'about:blank' });
    const { sessionId } = await this.send('Target.attachToTarget', { targetId, flatten: true });
    const page = new Page(this, sessionId);
    this.listeners.push((m) => { if (m.sessionId === sessionId) page._event(m); });
    await page.send('Runtime.enable');
    await page.send('Log.enable');
    await page.send('Page.enable');
    await page.send('Emulation.setDeviceMetricsOverride', { width, height, deviceScaleFactor: 1, mobile: false });
    // Wait for the page's load: an evaluation sent while about:blank is being replaced dies with
    // "Inspected target navigated or closed".
    const loaded = page.nextLoad();
    const nav = await page.send('Page.navigate', { url });
    if (nav.errorText) throw new Error(`navigating to ${url}: ${nav.errorText}`);
    await loaded;
    return page;
  }

  async close() {
    try { await this.send('Browser.close'); } catch { /* already gone */ }
    await new Promise((r) => { if (this.proc.exitCode !== null) r(); else { this.proc.once('exit', r); setTimeout(() => this.proc.kill('SIGKILL'), 3000); } });
    rmSync(this.dir, { recursive: true, force: true });
  }
}

export class Page {
  constructor(browser, sessionId) { this.browser = browser; this.sessionId = sessionId; this.errors = []; this.console = []; this.onLoad = []; }
  send(method, params) { return this.browser.send(method, params, this.sessionId); }
  /** Resolves at the page's next `load` event; rejects after `timeoutMs`. */
  nextLoad(timeoutMs = 30000) {
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`the page did not load in ${timeoutMs} ms`)), timeoutMs);
      this.onLoad.push(() => { clearTimeout(timer); resolve(); });
    });
  }
  _event(m) {
    if (m.method === 'Page.loadEventFired') {
      for (const f of this.onLoad.splice(0)) f();
    } else if (m.method === 'Runtime.consoleAPICalled') {
      const text = m.params.args.map((a) => a.value ?? a.description ?? '').join(' ');
      this.console.push(`${m.params.type}: ${text}`);
      if (m.params.type === 'error') this.errors.push(`console.error: ${text}`);
    } else if (m.method === 'Runtime.exceptionThrown') {
      const d = m.params.exceptionDetails;
      this.errors.push(`exception: ${d.exception?.description ?? d.text}`);
    } else if (m.method === 'Log.entryAdded' && m.params.entry.level === 'error') {
      this.errors.push(`log: ${m.params.entry.text} ${m.params.entry.url ?? ''}`);
    }
  }
  /** Evaluates `expr` in the page (awaiting a promise) and returns its value. */
  async eval(expr) {
    const r = await this.send('Runtime.evaluate', { expression: expr, awaitPromise: true, returnByValue: true });
    if (r.exceptionDetails) throw new Error(`in page: ${r.exceptionDetails.exception?.description ?? r.exceptionDetails.text}`);
    return r.result.value;
  }
  /** Polls `expr` every 100 ms until it is truthy. A page may replace itself meanwhile (the viewer
   *  reloads on WebGL2 when WebGPU cannot draw): an evaluation cut off by that navigation is
   *  retried, not fatal. */
  async waitFor(expr, timeoutMs = 60000) {
    const end = Date.now() + timeoutMs;
    for (;;) {
      let v;
      try {
        v = await this.eval(expr);
      } catch (e) {
        if (!/navigated or closed|context was destroyed|Cannot find context/.test(e.message) || Date.now() > end) throw e;
      }
      if (v) return v;
      if (Date.now() > end) throw new Error(`timed out waiting for ${expr}; errors: ${this.errors.join('\n')}`);
      await new Promise((r) => setTimeout(r, 100));
    }
  }
  /** A PNG screenshot of the viewport (bytes). */
  async screenshot() {
    const { data } = await this.send('Page.captureScreenshot', { format: 'png' });
    return Buffer.from(data, 'base64');
  }
  async click(x, y) {
    for (const type of ['mousePressed', 'mouseReleased']) {
      await this.send('Input.dispatchMouseEvent', { type, x, y, button: 'left', clickCount: 1 });
    }
  }
}

/** Decodes an 8-bit, non-interlaced RGB/RGBA PNG: `{width, height, channels, pixels}`. */
export function decodePng(buf) {
  let pos = 8; let width = 0, height = 0, ctype = 0; const idat = [];
  while (pos < buf.length) {
    const len = buf.readUInt32BE(pos); const type = buf.toString('latin1', pos + 4, pos + 8);
    const data = buf.subarray(pos + 8, pos + 8 + len);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4); ctype = data[9];
      if (data[8] !== 8 || data[12] !== 0) throw new Error('only 8-bit non-interlaced PNGs');
    } else if (type === 'IDAT') idat.push(data);
    pos += 12 + len;
  }
  const ch = ctype === 6 ? 4 : ctype === 2 ? 3 : 0;
  if (!ch) throw new Error(`PNG colour type ${ctype} not supported`);
  const raw = inflateSync(Buffer.concat(idat));
  const stride = width * ch; const px = new Uint8Array(height * stride);
  for (let y = 0; y < height; y++) {
    const f = raw[y * (stride + 1)]; const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= ch ? px[y * stride + x - ch] : 0; const b = y > 0 ? px[(y - 1) * stride + x] : 0;
      const c = x >= ch && y > 0 ? px[(y - 1) * stride + x - ch] : 0;
      let v = line[x];
      if (f === 1) v += a; else if (f === 2) v += b; else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) { const p = a + b - c; const pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c); v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      px[y * stride + x] = v & 255;
    }
  }
  return { width, height, channels: ch, pixels: px };
}

/** Mean and standard deviation of the luma, and the number of distinct colours (quantised). */
export function pixelStats({ pixels, channels }) {
  let s = 0, s2 = 0, n = 0; const colours = new Set();
  for (let i = 0; i < pixels.length; i += channels) {
    const l = 0.2126 * pixels[i] + 0.7152 * pixels[i + 1] + 0.0722 * pixels[i + 2];
    s += l; s2 += l * l; n++;
    colours.add(((pixels[i] >> 3) << 10) | ((pixels[i + 1] >> 3) << 5) | (pixels[i + 2] >> 3));
  }
  const mean = s / n;
  return { mean, std: Math.sqrt(Math.max(0, s2 / n - mean * mean)), colours: colours.size };
}
