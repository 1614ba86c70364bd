// The WebSocket session of a scene's stream (`GET /v1/scenes/{id}/stream`, subprotocol
// `swell.v1.json`; see the README's "WebSocket stream").
//
// - Requests carry an `id`; answers are matched by id (they may arrive out of order).
// - Clock sync: pings every `pingInterval` ms; each pong gives a sample (send time, receive
//   time, scene time) and the clock's rate, pause flag and generation. The offset comes from
//   the samples with the lowest round trip (their midpoint error is at most RTT/2, and queueing
//   only ever adds delay), the drift from a least-squares slope over the window; `serverTime()`
//   is then scene time now, in seconds.
// - Clock changes (an admin seek, rate or pause change, or a scene put that moves the epoch): the
//   server sends a `clock` event and every later pong has the new generation. Either restarts the
//   fit (the old samples describe another clock): until the next pong `serverTime()` follows the
//   event's reading at its rate, and `resyncPings` pings go out at once. A pong of an older
//   generation (sent before the change, answered after the restart) is dropped.
// - Tick subscription with an interest set (`bodies`, `region`); frames go to `onTick` and to an
//   optional `BodyInterpolator`.
// - Reconnect: when the socket closes without `close()` having been called, it reopens after
//   an exponential backoff (with jitter), re-sends the subscription and re-syncs the clock from
//   scratch: the samples of the old connection are dropped (a restarted or other server, or
//   another network path, may have another offset and round trip; mixing them would keep the
//   old connection's lowest-RTT samples in the estimate). Until the new connection's first
//   pong, `serverTime()` still answers from the old estimate. Requests in flight when the
//   socket drops are rejected with `TransportError`. No reconnect when the first `connect()`
//   fails (it rejects: a wrong URL or a scene that does not exist should not be retried
//   forever), nor after Close 4404 (the scene was deleted: the server says so with a
//   `not_found` error, then closes); `onClose` gets the code and reason.
// - Errors the server sends without an id (the scene was deleted, a message it could not read
//   the id of, a rate limit) go to `onError(SwellError)`.

import { ArgumentError, SwellError, TransportError } from './errors.js';
import { checkOrientation, checkSample, checkFinite } from './client.js';

/** The Close code of a session whose scene was deleted (the server's `stream::SCENE_GONE`). */
export const SCENE_GONE = 4404;

const monotonicSeconds = () => (globalThis.performance?.now?.() ?? Date.now()) / 1000;

/**
 * Clock synchronisation from ping/pong samples. Times are seconds: `clientTime` on a local
 * monotonic clock, `sceneTime` on the scene clock.
 *
 * One fit describes one clock *generation* (the server counts every seek, rate or pause change and
 * every put that moves the epoch; pongs and `clock` events carry it): the session starts a new
 * ClockSync at each new generation, so samples from before a change never mix with those after it.
 * The scene clock runs at the rate the server states (`k` = rate, or 0 while paused), so each
 * sample gives the offset of `sceneTime − k·mid`, and the fitted drift is only the two machines'
 * clock-frequency error.
 */
export class ClockSync {
  constructor({ window = 32, best = 4 } = {}, { rate = 1, paused = false, generation = null } = {}) {
    this.window = window;
    this.best = best;
    this.samples = [];
    this.offset = NaN;
    this.drift = 0;
    this.ref = 0;
    this.rtt = NaN;
    this.rate = rate;
    this.paused = paused;
    /** The server's clock generation this fit describes (null: a server that sends none). */
    this.generation = generation;
    /**
     * Before the first sample of a generation announced by a `clock` event: the event's
     * reading `{at, t}` (client time of its arrival less the previous one-way delay, scene time).
     */
    this.provisional = null;
  }

  /** Scene seconds per client second: the rate, or 0 while paused. */
  get slope() { return this.paused ? 0 : this.rate; }

  /** Adds a sample: ping sent at `sent`, pong received at `received` (client clock), pong's scene time. */
  add(sent, received, sceneTime) {
    const rtt = received - sent;
    const mid = sent + rtt / 2;
    this.samples.push({ rtt, mid, offset: sceneTime - this.slope * mid });
    if (this.samples.length > this.window) this.samples.shift();
    this.rtt = rtt;
    const sorted = [...this.samples].sort((a, b) => a.rtt - b.rtt);
    // The lowest-RTT samples, leaving out any over twice the best round trip (+ 1 ms): a round
    // trip held up on one side carries up to all of its extra delay into its offset, and just
    // after a clock change, with a handful of samples, one such would be averaged in.
    const good = sorted.slice(0, Math.min(this.best, sorted.length))
      .filter((s, i) => i === 0 || s.rtt <= 2 * sorted[0].rtt + 1e-3);
    // Drift: slope of offset against time over the samples within twice the best RTT (needs a
    // spread of at least a second to mean anything; none while paused: the clock stands still).
    const within = this.samples.filter((s) => s.rtt <= 2 * sorted[0].rtt + 1e-3);
    const m0 = within.reduce((a, s) => a + s.mid, 0) / within.length;
    const o0 = within.reduce((a, s) => a + s.offset, 0) / within.length;
    let sxx = 0, sxy = 0;
    for (const s of within) { sxx += (s.mid - m0) ** 2; sxy += (s.mid - m0) * (s.offset - o0); }
    const span = within.length > 1 ? within[within.length - 1].mid - within[0].mid : 0;
    this.drift = this.slope !== 0 && span >= 1 && sxx > 0 ? sxy / sxx : 0;
    // Offset at `ref` from the lowest-RTT samples, each carried to ref along the drift.
    this.ref = good.reduce((a, s) => a + s.mid, 0) / good.length;
    this.offset = good.reduce((a, s) => a + s.offset + this.drift * (this.ref - s.mid), 0) / good.length;
    this.minRtt = sorted[0].rtt;
  }

  /** Whether there is at least one sample (or a `clock` event's reading). */
  get synced() { return this.samples.length > 0 || this.provisional !== null; }

  /** Scene time at client time `c` (s). */
  sceneTime(c) {
    if (this.samples.length === 0 && this.provisional) {
      return this.provisional.t + this.slope * (c - this.provisional.at);
    }
    return this.slope * c + this.offset + this.drift * (c - this.ref);
  }
}

/**
 * A session on one scene's stream.
 *
 * `new SwellSession(client.streamUrl('open-sea'), {onTick})`, then `await session.connect()`.
 * Options: `WebSocket` (constructor; default the global one: browsers, Node 22+, or Node 20
 * with `--experimental-websocket`), `pingInterval` (ms, 1000), `syncPings` (pings `connect()`
 * waits for, 5), `requestTimeout` (ms, 10000), `backoff` (`{initial: 200, max: 5000, factor:
 * 2}` ms), `onTick(frame)` (a TickFrame: `{tick, t, bodies, impacts?, anchor_tick?}`, each
 * impact with `body_tick`, the tick the scene's bodies feel it from, when they do), `onOpen()`,
 * `onClose({code, reason})` (4404: the scene was deleted, no reconnect), `onError(SwellError)`
 * (an error the server sent that answers no request of ours), `onClock(event)` (the scene's clock
 * changed: `{t, tick, tick_hz, rate, paused, unix, generation}`), `resyncPings` (pings sent at a
 * clock change, 3), `interpolator` (a BodyInterpolator fed every tick frame), `now` (client
 * clock in s; default `performance.now()/1000`).
 */
export class SwellSession {
  constructor(url, options = {}) {
    if (typeof url !== 'string' || !/^wss?:\/\//.test(url)) {
      throw new ArgumentError('url', `url must be a ws(s) URL, got ${JSON.stringify(url)}`);
    }
    this.url = url;
    this.WebSocket = options.WebSocket ?? globalThis.WebSocket;
    if (typeof this.WebSocket !== 'function') {
      throw new ArgumentError('WebSocket', 'no WebSocket implementation: pass options.WebSocket (Node 20: run with --experimental-websocket)');
    }
    this.pingInterval = options.pingInterval ?? 1000;
    this.syncPings = options.syncPings ?? 5;
    this.resyncPings = options.resyncPings ?? 3;
    this.onClock = options.onClock ?? null;
    this.requestTimeout = options.requestTimeout ?? 10000;
    this.backoff = { initial: 200, max: 5000, factor: 2, ...(options.backoff ?? {}) };
    this.onTick = options.onTick ?? null;
    this.onOpen = options.onOpen ?? null;
    this.onClose = options.onClose ?? null;
    this.onError = options.onError ?? null;
    this.interpolator = options.interpolator ?? null;
    this.now = options.now ?? monotonicSeconds;
    this.clockOptions = options.clock;
    this.clock = new ClockSync(options.clock);
    // The estimate of the previous connection, used by serverTime() until the new one has a
    // sample (see `_resync`).
    this.previousClock = null;
    /** Resolves when the clock re-sync after the latest reconnect is done (null before one). */
    this.resyncing = null;
    this.nextId = 1;
    this.pending = new Map();
    this.subscription = null;
    this.ws = null;
    this.closed = false;
    this.attempt = 0;
    this.reconnects = 0;
    this.lastTick = null;
    this._timer = null;
    this._retry = null;
    this._openWaiters = [];
  }

  /** Opens the socket and resolves once `syncPings` pongs have arrived. */
  async connect() {
    this.closed = false;
    await this._open(true);
    await this.syncNow(this.syncPings);
    return this;
  }

  // `first`: the socket of `connect()`; if it never opens, connect() rejects and nothing retries.
  _open(first = false) {
    return new Promise((resolve, reject) => {
      let ws;
      try {
        ws = new this.WebSocket(this.url, 'swell.v1.json');
      } catch (e) {
        reject(new TransportError(`cannot open ${this.url}: ${e.message}`, e));
        return;
      }
      this.ws = ws;
      let opened = false;
      ws.onopen = () => {
        opened = true;
        this.attempt = 0;
        this._startPings();
        if (this.subscription) this._send({ type: 'subscribe', ...this.subscription });
        this.onOpen?.();
        for (const w of this._openWaiters.splice(0)) w();
        resolve();
      };
      ws.onmessage = (ev) => this._onMessage(ev.data);
      // One way down per socket: a close, or an error before the socket opened (Node 20's
      // WebSocket reports a refused connection with an error and no close event).
      let down = false;
      const lost = (code, reason = '') => {
        if (down) return;
        down = true;
        if (this.ws === ws) this.ws = null;
        this._stopPings();
        const gone = code === SCENE_GONE;
        // The scene was deleted: reconnecting would be refused (404), so stop here.
        if (gone) this.closed = true;
        for (const [, p] of this.pending) {
          p.reject(gone
            ? new SwellError(0, 'not_found', reason || 'the scene was deleted')
            : new TransportError(`socket closed (${code}) before the answer`));
        }
        this.pending.clear();
        this.onClose?.({ code, reason });
        if (!opened) {
          reject(new TransportError(`cannot open ${this.url} (${code}): a scene that does not exist is refused (404), as is a server that is down`));
        }
        if (!this.closed && (opened || !first)) this._scheduleReconnect();
      };
      ws.onerror = () => { if (!opened) { lost('error'); try { ws.close(); } catch { /* never opened */ } } };
      ws.onclose = (ev) => lost(ev.code, ev.reason ?? '');
    });
  }

  _scheduleReconnect() {
    const { initial, max, factor } = this.backoff;
    const base = Math.min(max, initial * factor ** this.attempt);
    const delay = base * (0.5 + Math.random() * 0.5);
    this.attempt++;
    this._retry = setTimeout(() => {
      this._retry = null;
      if (this.closed) return;
      this._open().then(() => {
        this.reconnects++;
        this.resyncing = this._resync();
      }, () => {});
    }, delay);
  }

  // A fresh clock estimate for the new connection: old samples are dropped, `syncPings` pings
  // sent one after another. A failure (the socket dropped again) is left to the next reconnect.
  _resync() {
    this.previousClock = this.clock;
    this.clock = new ClockSync(this.clockOptions);
    return this.syncNow(this.syncPings).then(() => { this.previousClock = null; }, () => {});
  }

  // A new fit for the clock `c` (a pong or a `clock` event: rate, paused, generation), with the
  // event's reading as the estimate until the first pong (`received`: its arrival, or null).
  _restartFit(c, received) {
    const prev = this.clock;
    this.clock = new ClockSync(this.clockOptions, { rate: c.rate ?? 1, paused: c.paused ?? false, generation: c.generation ?? null });
    if (received !== null) {
      // The event left the server about one one-way delay before it arrived.
      const oneWay = Number.isFinite(prev.minRtt) ? prev.minRtt / 2 : 0;
      this.clock.provisional = { at: received - oneWay, t: c.t };
    }
  }

  _clockChanged(m, received) {
    this._restartFit(m, received);
    this.lastClock = m;
    this.onClock?.(m);
    if (this.ws && this.ws.readyState === 1) this.syncNow(this.resyncPings).catch(() => {});
  }

  /** Resolves when the socket is open (now or after a reconnect). */
  opened() {
    if (this.ws && this.ws.readyState === 1) return Promise.resolve();
    return new Promise((r) => this._openWaiters.push(r));
  }

  _startPings() {
    this._stopPings();
    this._timer = setInterval(() => { this.ping().catch(() => {}); }, this.pingInterval);
  }

  _stopPings() {
    if (this._timer) clearInterval(this._timer);
    this._timer = null;
  }

  _send(msg) {
    if (!this.ws || this.ws.readyState !== 1) throw new TransportError('the socket is not open');
    this.ws.send(JSON.stringify(msg));
  }

  _request(msg) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        this.pending.delete(id);
        reject(new TransportError(`no answer to ${msg.type} #${id} within ${this.requestTimeout} ms`));
      }, this.requestTimeout);
      this.pending.set(id, {
        resolve: (v) => { clearTimeout(timer); resolve(v); },
        reject: (e) => { clearTimeout(timer); reject(e); },
      });
      try {
        this._send({ ...msg, id });
      } catch (e) {
        this.pending.get(id)?.reject(e);
        this.pending.delete(id);
      }
    });
  }

  _onMessage(data) {
    if (typeof data !== 'string') return;
    const received = this.now();
    let m;
    try { m = JSON.parse(data); } catch { return; }
    if (m.type === 'tick') {
      this.lastTick = m;
      this.interpolator?.push(m);
      this.onTick?.(m);
      return;
    }
    if (m.type === 'clock') {
      this._clockChanged(m, received);
      return;
    }
    const p = m.id != null ? this.pending.get(m.id) : undefined;
    if (!p) {
      if (m.type === 'error') this.onError?.(new SwellError(0, m.code, m.message, m.field));
      return;
    }
    this.pending.delete(m.id);
    if (m.type === 'error') {
      p.reject(new SwellError(0, m.code, m.message, m.field));
      return;
    }
    if (m.type === 'pong') {
      const g = m.generation ?? null;
      const cur = this.clock.generation;
      if (g !== null && cur !== null && g < cur) {
        // Answered before a change this session already restarted at: another clock's sample.
      } else {
        if (g !== cur && (this.clock.synced || cur === null)) {
          this._restartFit(m, null);
        } else if (!this.clock.synced) {
          // The first pong of a fit states the clock it samples.
          Object.assign(this.clock, { rate: m.rate ?? 1, paused: m.paused ?? false, generation: g });
        }
        this.clock.add(m.client_time, received, m.scene_time);
      }
      this.lastPong = m;
    }
    delete m.type;
    delete m.id;
    p.resolve(m);
  }

  /**
   * One ping: resolves to the pong (`{client_time, scene_time, tick, rate, paused, generation}`)
   * and feeds the clock.
   */
  ping() { return this._request({ type: 'ping', client_time: this.now() }); }

  /** Sends `n` pings one after another (so their RTTs are not inflated by each other). */
  async syncNow(n = this.syncPings) {
    for (let i = 0; i < n; i++) await this.ping();
    return this.clock;
  }

  /** Scene time now (s), from the synced clock. */
  serverTime() {
    const clock = this.clock.synced ? this.clock : this.previousClock;
    if (!clock?.synced) throw new TransportError('the clock is not synced yet: await connect()');
    return clock.sceneTime(this.now());
  }

  /**
   * Clock offset (scene time − rate·client time, s), drift, round trip of the last pong and its
   * minimum (s), and the clock the fit describes (rate, paused, generation).
   */
  clockStats() {
    const c = this.clock.synced ? this.clock : (this.previousClock ?? this.clock);
    return { offset: c.offset, drift: c.drift, rtt: c.rtt, minRtt: c.minRtt, rate: c.rate, paused: c.paused, generation: c.generation };
  }

  /** A sample query on the socket: the same answer as POST …/sample. */
  sample(req) { checkSample(req); return this._request({ type: 'sample', ...req }); }

  /** An orientation query on the socket: the same answer as POST …/orientation. */
  orientation(req) { checkOrientation(req); return this._request({ type: 'orientation', ...req }); }

  /**
   * Subscribes to tick frames: `bodies` (ids) and/or `region` ([x0, z0, x1, z1]) pick the bodies
   * a frame carries (neither: all). Kept and re-sent after a reconnect.
   */
  subscribe({ bodies, region } = {}) {
    const sub = { ticks: true };
    if (bodies != null) {
      if (!Array.isArray(bodies) || !bodies.every((b) => Number.isSafeInteger(b) && b >= 0)) {
        throw new ArgumentError('bodies', 'bodies must be an array of body ids (integers >= 0)');
      }
      sub.bodies = bodies;
    }
    if (region != null) {
      if (!Array.isArray(region) || region.length !== 4) throw new ArgumentError('region', 'region must be [x0, z0, x1, z1]');
      region.forEach((v, i) => checkFinite(`region[${i}]`, v));
      if (region[0] > region[2] || region[1] > region[3]) throw new ArgumentError('region', 'region needs x0 <= x1 and z0 <= z1');
      sub.region = region;
    }
    this.subscription = sub;
    if (this.ws && this.ws.readyState === 1) this._send({ type: 'subscribe', ...sub });
  }

  /** Stops tick frames. */
  unsubscribe() {
    this.subscription = null;
    if (this.ws && this.ws.readyState === 1) this._send({ type: 'subscribe', ticks: false });
  }

  /** Closes the socket for good (no reconnect). */
  close() {
    this.closed = true;
    this._stopPings();
    if (this._retry) clearTimeout(this._retry);
    this._retry = null;
    this.ws?.close(1000);
  }
}
