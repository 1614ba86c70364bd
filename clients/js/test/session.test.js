// The session's clock logic without a server: drift tracking in ClockSync on synthetic samples,
// and the re-sync on reconnect against a fake WebSocket whose server clock jumps while the
// socket is down (a restarted server that was seeked). Time is the test's: `now` is a counter.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ClockSync, SwellSession } from '../src/session.js';

test('ClockSync leaves a held-up round trip out of the offset, even with only a few samples', () => {
  // Just after a change to rate 2: three samples, the third held up 30 ms on its way back (a
  // control frame or a busy receive loop ahead of it), so its midpoint is 15 ms after the
  // server read the clock: averaged in, it would put the estimate ~10 ms (scene) off.
  const scene = (c) => 1000 + 2 * c;
  const c = new ClockSync({}, { rate: 2, generation: 1 });
  c.add(10.0, 10.0002, scene(10.0001));
  c.add(10.1, 10.1002, scene(10.1001));
  c.add(10.2, 10.2302, scene(10.2001));
  assert.ok(Math.abs(c.sceneTime(11) - scene(11)) < 1e-9, `off by ${c.sceneTime(11) - scene(11)} s`);
});

test('ClockSync tracks drift: the slope of offset against time, from the low-RTT samples', () => {
  // Scene clock = 1000 + (1 + 2e-4)·client clock; one-way delays 1–6 ms, asymmetric noise.
  const drift = 2e-4;
  const scene = (c) => 1000 + (1 + drift) * c;
  const c = new ClockSync({ window: 64, best: 4 });
  let x = 7;
  const noise = () => { x = (x * 1103515245 + 12345) % 2147483648; return x / 2147483648; };
  for (let i = 0; i < 60; i++) {
    const sent = i * 0.1;
    const up = 0.001 + 0.005 * noise();
    const down = 0.001 + 0.005 * noise();
    c.add(sent, sent + up + down, scene(sent + up));
  }
  assert.ok(Math.abs(c.drift - drift) < 2e-5, `drift ${c.drift}, want ${drift}`);
  for (const at of [6.2, 10, 30]) {
    const err = c.sceneTime(at) - scene(at);
    assert.ok(Math.abs(err) < 0.003, `sceneTime(${at}) off by ${err} s`);
  }
  // Without the drift term the estimate would be 2e-4 · (30 − 3) ≈ 5 ms off at t = 30 s.
  const noDrift = c.offset + 30;
  assert.ok(Math.abs(noDrift - scene(30)) > 0.004);
  // Under a second of samples says nothing about drift: it stays 0.
  const short = new ClockSync();
  for (let i = 0; i < 8; i++) short.add(i * 0.1, i * 0.1 + 0.002, scene(i * 0.1 + 0.001));
  assert.equal(short.drift, 0);
});

// A fake WebSocket to a server whose scene clock is `now + server.offset`, answering pings after
// `server.rtt` (half each way) on the test's clock.
function fakeServer() {
  const server = { offset: 500, rtt: 0.002, sockets: [], now: 0, up: true };
  class FakeSocket {
    constructor(url, proto) {
      this.url = url; this.proto = proto; this.readyState = 0;
      server.sockets.push(this);
      setTimeout(() => {
        if (!server.up) { this.onerror?.({}); return; }
        this.readyState = 1;
        this.onopen?.();
      }, 1);
    }
    send(text) {
      const m = JSON.parse(text);
      if (m.type !== 'ping') return;
      server.now += server.rtt / 2;
      const pong = { type: 'pong', id: m.id, client_time: m.client_time, scene_time: server.now + server.offset, tick: 0 };
      server.now += server.rtt / 2;
      setTimeout(() => this.onmessage?.({ data: JSON.stringify(pong) }), 0);
    }
    close(code = 1006) {
      if (this.readyState === 3) return;
      this.readyState = 3;
      setTimeout(() => this.onclose?.({ code }), 0);
    }
  }
  return { server, FakeSocket };
}

test('a reconnect drops the old clock samples and re-syncs to the new server clock', async () => {
  const { server, FakeSocket } = fakeServer();
  const s = new SwellSession('ws://fake/v1/scenes/calm/stream', {
    WebSocket: FakeSocket, now: () => server.now, pingInterval: 1e6, syncPings: 5, backoff: { initial: 1, max: 2 },
  });
  await s.connect();
  try {
  assert.ok(Math.abs(s.serverTime() - (server.now + 500)) < 1e-9);
  assert.equal(s.clock.samples.length, 5);
  // The old connection had the faster path (1 ms RTT vs 20 ms after): kept, its samples would
  // win the lowest-RTT selection and pin the old offset.
  server.rtt = 0.001;
  await s.syncNow(5);
  const old = s.clock;
  // The server restarts seeked 3 s ahead, on a slower path.
  server.offset = 503;
  server.rtt = 0.02;
  server.sockets.at(-1).close(1001);
  await new Promise((r) => setTimeout(r, 10));
  await s.opened();
  for (let i = 0; i < 200 && !s.resyncing; i++) await new Promise((r) => setTimeout(r, 1));
  assert.ok(s.resyncing, 'a clock re-sync started after the reconnect');
  await s.resyncing;
  assert.equal(s.reconnects, 1);
  assert.notEqual(s.clock, old, 'a fresh estimate after the reconnect');
  assert.equal(s.clock.samples.length, 5, 'only the new connection\'s samples');
  assert.equal(s.previousClock, null);
  const err = s.serverTime() - (server.now + 503);
  assert.ok(Math.abs(err) < 0.011, `serverTime off by ${err} s after the reconnect`);
  // What keeping the old samples would have given: their 1 ms RTTs win, the offset stays ~500.
  const mixed = new ClockSync();
  for (const smp of [...old.samples, ...s.clock.samples]) mixed.add(smp.mid - smp.rtt / 2, smp.mid + smp.rtt / 2, smp.offset + smp.mid);
  assert.ok(Math.abs(mixed.sceneTime(server.now) - (server.now + 503)) > 1, 'old samples would pin the old offset');
  } finally { s.close(); }
});

// Issue 28: a fake server whose clock reads `t0 + rate·(now − a0)` (frozen while paused), with a
// generation that each change increments; pongs carry rate, paused and generation.
test('clock generations: a clock event or a newer pong restarts the fit, an older pong is dropped', async () => {
  const srv = { now: 0, rtt: 0.002, t0: 100, a0: 0, rate: 1, paused: false, gen: 0, answerGen: null, sock: null };
  const sceneAt = (c) => (srv.paused ? srv.t0 : srv.t0 + srv.rate * (c - srv.a0));
  const change = ({ t, rate, paused }) => {
    srv.t0 = t ?? sceneAt(srv.now);
    srv.a0 = srv.now;
    if (rate !== undefined) srv.rate = rate;
    if (paused !== undefined) srv.paused = paused;
    srv.gen++;
  };
  class Sock {
    constructor() { this.readyState = 0; srv.sock = this; setTimeout(() => { this.readyState = 1; this.onopen?.(); }, 1); }
    send(text) {
      const m = JSON.parse(text);
      if (m.type !== 'ping') return;
      srv.now += srv.rtt / 2;
      const pong = { type: 'pong', id: m.id, client_time: m.client_time, scene_time: sceneAt(srv.now), tick: 0,
        rate: srv.rate, paused: srv.paused, generation: srv.answerGen ?? srv.gen };
      srv.now += srv.rtt / 2;
      setTimeout(() => this.onmessage?.({ data: JSON.stringify(pong) }), 0);
    }
    close() { this.readyState = 3; }
  }
  const events = [];
  const s = new SwellSession('ws://fake/v1/scenes/x/stream', { WebSocket: Sock, now: () => srv.now, pingInterval: 1e6, syncPings: 3, onClock: (e) => events.push(e) });
  await s.connect();
  try {
    assert.ok(Math.abs(s.serverTime() - sceneAt(srv.now)) < 1e-9);
    assert.equal(s.clockStats().generation, 0);
    // Seek to 5000 at rate 2, announced by an event (it arrives at once here).
    change({ t: 5000, rate: 2 });
    srv.sock.onmessage({ data: JSON.stringify({ type: 'clock', t: sceneAt(srv.now), tick: 0, tick_hz: 30, rate: 2, paused: false, unix: 0, generation: srv.gen }) });
    assert.equal(events.length, 1);
    assert.ok(Math.abs(s.serverTime() - sceneAt(srv.now)) < 0.005, 'the event\'s reading until the next pong');
    for (let i = 0; i < 50 && s.clock.samples.length < 3; i++) await new Promise((r) => setTimeout(r, 1));
    assert.equal(s.clock.samples.length, 3, 'resyncPings pings at once, on a fresh fit');
    srv.now += 10;
    assert.ok(Math.abs(s.serverTime() - sceneAt(srv.now)) < 1e-9, 'rate 2 from the pongs');
    // A pong answered before a change the session already restarted at: dropped.
    srv.answerGen = 0;
    await s.ping();
    srv.answerGen = null;
    assert.equal(s.clock.samples.length, 3, 'an older generation\'s pong is not a sample');
    // A change whose event was missed: the next pong's newer generation restarts the fit.
    change({ paused: true });
    await s.ping();
    assert.equal(s.clockStats().generation, 2);
    assert.equal(s.clock.samples.length, 1);
    const frozen = sceneAt(srv.now);
    srv.now += 5;
    assert.equal(s.serverTime(), frozen, 'paused: frozen');
  } finally { s.close(); }
});
