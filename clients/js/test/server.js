// A real `swell` process for the live tests: temp data dir, a free port on 127.0.0.1, an admin
// token. The binary is $SWELL_BIN or target/debug/swell of this repository (`cargo build --bin
// swell`); `available()` is false when neither exists, and the live tests then skip.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { createServer } from 'node:net';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = fileURLToPath(new URL('../../../', import.meta.url));
export const SWELL_BIN = process.env.SWELL_BIN ?? join(ROOT, 'target/debug/swell');

export function available() { return existsSync(SWELL_BIN); }

export function freePort() {
  return new Promise((resolve, reject) => {
    const s = createServer();
    s.once('error', reject);
    s.listen(0, '127.0.0.1', () => { const { port } = s.address(); s.close(() => resolve(port)); });
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export class SwellProcess {
  constructor({ port, dataDir, token = 'test-token', args = [] } = {}) {
    this.port = port;
    this.dataDir = dataDir ?? mkdtempSync(join(tmpdir(), 'swell-js-'));
    this.ownDir = dataDir == null;
    this.token = token;
    this.args = args;
    this.url = null;
    this.child = null;
    this.log = '';
  }

  static async start(opts) { const s = new SwellProcess(opts); await s.start(); return s; }

  async start() {
    this.port ??= await freePort();
    this.url = `http://127.0.0.1:${this.port}`;
    // A short read check: the server closes (1008) a session whose pong is 2 s late, so every
    // session the tests hold open for longer proves the client answers pings as it reads.
    const config = join(this.dataDir, 'test-limits.toml');
    writeFileSync(config, '[limits]\nws_read_check_ms = 2000\n');
    this.child = spawn(SWELL_BIN, ['serve', '--bind', `127.0.0.1:${this.port}`, '--data-dir', this.dataDir,
      '--admin-token', this.token, '--shutdown-timeout', '2', '--drain-delay', '0', '--config', config, ...this.args],
    { stdio: ['ignore', 'pipe', 'pipe'] });
    const keep = (d) => { this.log = (this.log + d).slice(-20000); };
    this.child.stdout.on('data', keep);
    this.child.stderr.on('data', keep);
    const exited = new Promise((r) => this.child.once('exit', r));
    for (let i = 0; i < 300; i++) {
      try {
        const r = await fetch(`${this.url}/readyz`);
        if (r.ok) return this;
      } catch { /* not listening yet */ }
      if (this.child.exitCode !== null) break;
      await sleep(50);
    }
    this.child.kill('SIGKILL');
    await exited;
    throw new Error(`swell did not become ready on ${this.url}:\n${this.log}`);
  }

  /** Stops the process (SIGTERM: graceful, sockets get Close 1001); keeps the data dir. */
  async stop() {
    if (!this.child || this.child.exitCode !== null) return;
    const exited = new Promise((r) => this.child.once('exit', r));
    this.child.kill('SIGTERM');
    const t = setTimeout(() => this.child.kill('SIGKILL'), 5000);
    await exited;
    clearTimeout(t);
  }

  async dispose() {
    await this.stop();
    if (this.ownDir) rmSync(this.dataDir, { recursive: true, force: true });
  }
}
