// Against a live `swell` on 127.0.0.1 (see server.js): HTTP and protobuf answers, typed errors,
// local evaluation and uniforms equal to the server's bits, the WebSocket session (clock sync,
// queries, subscriptions with interest sets, reconnect after a restart).
import { describe, test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { SwellProcess, available, freePort } from './server.js';
import { SwellClient, SwellSession, Surface, SwellError, TransportError, ArgumentError, BodyInterpolator, bitsHex, MAX_RINGS_PER_POINT, SCENE_GONE } from '../src/index.js';
import { VECTORS, checkCase } from './golden.js';

const EPOCH = 1767225600; // built-in scenes' epoch (README): t = unix − epoch at rate 1
const skip = available() ? false : 'no swell binary (cargo build --bin swell, or set SWELL_BIN)';
const wallSeconds = () => (performance.timeOrigin + performance.now()) / 1000;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
// Every number as its IEEE bits, object keys sorted (answers may list fields in any order).
const bits = (v) => JSON.stringify(v, (k, x) => {
  if (typeof x === 'number') return bitsHex(x);
  if (x && typeof x === 'object' && !Array.isArray(x)) return Object.fromEntries(Object.entries(x).sort(([a], [b]) => (a < b ? -1 : 1)));
  return x;
});

describe('live server', { skip }, () => {
  let srv; let http; let admin;
  before(async () => {
    srv = await SwellProcess.start();
    http = new SwellClient(srv.url);
    admin = new SwellClient(srv.url, { adminToken: srv.token });
  });
  after(async () => { await srv?.dispose(); });

  test('scenes and scene detail', async () => {
    const { scenes } = await http.scenes();
    assert.deepEqual(scenes.map((s) => s.id).filter((id) => !['golden-lake', 'ripple-shallow'].includes(id)).sort(),
      ['calm', 'harbour', 'lake', 'open-sea', 'storm']);
    const lake = await http.scene('lake');
    assert.equal(lake.model_version, VECTORS.model_version);
    assert.equal(lake.derived.layers[0].kind, 'gerstner');
  });

  test('server errors are SwellErrors with the code, message and field', async () => {
    await assert.rejects(http.scene('atlantis'), (e) => e instanceof SwellError && e.status === 404 && e.code === 'not_found');
    await assert.rejects(http.sample('calm', { points: [[0, 0]], t: 1e12 }),
      (e) => e instanceof SwellError && e.status === 400 && e.code === 'invalid_value' && /t/.test(e.field));
    const pb = new SwellClient(srv.url, { wire: 'protobuf' });
    await assert.rejects(pb.sample('calm', { points: [[0, 0]], t: 1e12 }),
      (e) => e instanceof SwellError && e.code === 'invalid_value' && e.serverMessage.length > 0);
  });

  test('bad arguments throw before any request', async () => {
    let calls = 0;
    const counting = new SwellClient(srv.url, { fetch: (...a) => { calls++; return fetch(...a); } });
    assert.throws(() => counting.scene('Bad Id'), (e) => e instanceof ArgumentError && e.field === 'scene');
    await assert.rejects(counting.height('calm', NaN, 0), (e) => e instanceof ArgumentError && e.field === 'x');
    await assert.rejects(counting.sample('calm', { points: [[0, Infinity]] }), (e) => e.field === 'points[0][1]');
    await assert.rejects(counting.sample('calm', { points: [], fields: ['colour'] }), (e) => e.field === 'fields');
    await assert.rejects(counting.orientation('calm', { bodies: [{ position: [0, 0], length: -1, beam: 2 }] }),
      (e) => e.field === 'bodies[0].length');
    await assert.rejects(counting.shader('calm', 'cobol'), (e) => e.field === 'lang');
    await assert.rejects(counting.spawnBody('calm', {}), (e) => e.field === 'adminToken');
    assert.equal(calls, 0);
  });

  const points = [[0, 0], [13.7, -4.2], [-250.5, 999.25], [1e6 + 0.125, -3e5], [-7.75, 1234.5]];
  const fields = ['height', 'normal', 'displacement', 'jacobian', 'residual'];

  for (const scene of ['calm', 'lake']) {
    test(`${scene}: local evaluation equals /sample bit for bit at the scene's now`, async () => {
      const detail = await http.scene(scene);
      const surface = Surface.fromDerived(detail.derived);
      const { t } = await http.clock(scene);
      assert.ok(t > 2e7, `wall-anchored scene time ${t}`);
      for (const tt of [t, t + 0.5, 12.345]) {
        const server = await http.sample(scene, { t: tt, points, fields });
        points.forEach(([x, z], i) => {
          const r = surface.query(x, z, tt);
          assert.equal(bitsHex(r.height), bitsHex(server.height[i]), `${scene} height t=${tt} ${x},${z}`);
          assert.equal(bits(r.normal), bits(server.normal[i]));
          assert.equal(bits(r.displacement), bits(server.displacement[i]));
          assert.equal(bitsHex(r.jacobian), bitsHex(server.jacobian[i]));
          assert.equal(bitsHex(r.residual), bitsHex(server.residual[i]));
          assert.equal(r.folded, server.folded[i]);
        });
        const h = await http.height(scene, 13.7, -4.2, { t: tt });
        assert.equal(bitsHex(surface.height(13.7, -4.2, tt)), bitsHex(h.height));
      }
    });
  }

  // Particle layers (issue 15): ambient particles and the rings of posted impacts, evaluated
  // locally from scene.derived and GET …/impacts, against /sample, every field, bit for bit.
  // `harbour` is deep water with no wind direction; `ripple-shallow` is finite depth (the ring
  // speed goes through the ported tanh) with a wind direction and several scales.
  const ringPoints = (impacts, t, surface) => impacts.flatMap((e) => {
    const ring = surface.impactLayer.particles.ring(e);
    const st = ring.state(t);
    if (!st) return [];
    return [0.3, 1.9, 2.6, 4.4].map((a, j) => [e.position[0] + (st.distance + 0.2 * (j - 1.5)) * Math.cos(a),
      e.position[1] + (st.distance + 0.2 * (j - 1.5)) * Math.sin(a)]);
  });
  const particleScenes = {
    harbour: null,
    'ripple-shallow': {
      description: 'particles on finite depth', depth: 2.5, seed: 99,
      layers: [
        { kind: 'sine', waves: [{ amplitude: 0.2, wavelength: 17, direction: [1, 0.4] }] },
        { kind: 'particles', count: 300, tile_size: 20, radius: 0.8, direction: [1, 0.5], spread: 70, scales: [0.5, 1],
          ripples: { particles: 6, decay: 25, floor: 1e-4, lifetime: 40 } },
      ],
    },
  };
  for (const [scene, spec] of Object.entries(particleScenes)) {
    test(`${scene}: particle layer and impact rings locally equal /sample and /uniforms bit for bit`, async () => {
      const detail = spec ? await admin.putScene(scene, spec) : await http.scene(scene);
      const layer = detail.derived.layers.find((l) => l.kind === 'particles');
      assert.equal(layer.particles_tile.length, layer.count);
      const surface = Surface.fromDerived(detail.derived);
      assert.ok(surface.impactLayer.particles.exact);
      const bare = Surface.fromDerived(detail.derived); // never gets the impacts
      const { t } = await http.clock(scene);
      // Splashes in the past (rings already out and split), now-ish and at a later time.
      for (const imp of [{ position: [3.5, -2], t: t - 9, strength: 0.6, radius: 0.7 },
        { position: [-12, 7.25], t: t - 2.5, strength: 0.35, radius: 1.3 },
        { position: [40, 40], t: t + 1, strength: 0.9, radius: 0.4 },
        { position: [-0.5, 0.25], strength: 0.2, radius: 0.5 }]) {
        await admin.addImpact(scene, imp);
      }
      const list = await http.impacts(scene, { t: t - 30 });
      assert.equal(list.impacts.length, 4);
      surface.impacts.addAll(list.impacts);
      let touched = 0;
      for (const tt of [t, t + 0.75, t + 3.3]) {
        const pts = [...points, [0.3, 0.1], ...ringPoints(list.impacts, tt, surface)];
        const server = await http.sample(scene, { t: tt, points: pts, fields });
        pts.forEach(([x, z], i) => {
          const r = surface.query(x, z, tt);
          const where = `${scene} t=${tt} (${x}, ${z})`;
          assert.equal(bitsHex(r.height), bitsHex(server.height[i]), `height ${where}`);
          assert.equal(bits(r.normal), bits(server.normal[i]), `normal ${where}`);
          assert.equal(bits(r.displacement), bits(server.displacement[i]), `displacement ${where}`);
          assert.equal(bitsHex(r.jacobian), bitsHex(server.jacobian[i]));
          assert.equal(bitsHex(r.residual), bitsHex(server.residual[i]));
          if (r.height !== bare.height(x, z, tt)) touched++;
        });
        for (const origin of [[0, 0], [-37.5, 12.5], [2.5e5, -1e4]]) {
          const su = await http.uniforms(scene, { t: tt, origin });
          const lu = surface.uniforms(tt, origin);
          assert.equal(bits(lu.phases), bits(su.phases));
          assert.equal(lu.block.length, su.block.length, `${scene} block length`);
          assert.deepEqual(Array.from(lu.block), su.block, `${scene} uniforms t=${tt} origin=${origin}`);
          assert.equal(lu.ringsDropped, su.rings_dropped);
          assert.ok(lu.block[lu.phases.length > 0 ? 4 * Math.ceil(lu.phases.length / 4) : 4] >= 2, 'live rings in the block');
        }
      }
      console.log(`${scene}: ${touched} probes inside a live ring, every field equal to /sample`);
      assert.ok(touched >= 12, `only ${touched} probes were inside a live ring`);
    });
  }

  // More rings over a point than MAX_RINGS_PER_POINT: only the newest count there, on the
  // server and here alike.
  test('piled-up rings: the per-point cap gives /sample\'s bits', async () => {
    const scene = 'ring-pile';
    const detail = await admin.putScene(scene, {
      description: 'splashes piled on one spot', seed: 5,
      layers: [{ kind: 'particles', count: 16, tile_size: 20, radius: 0.8,
        ripples: { particles: 8, decay: 30, floor: 1e-4, lifetime: 60 } }],
    });
    const surface = Surface.fromDerived(detail.derived);
    const { t } = await http.clock(scene);
    for (let i = 0; i < 60; i++) {
      const a = i * 2.399;
      await admin.addImpact(scene, { t: t + 0.5 + 0.01 * i, position: [1.5 * Math.cos(a), 1.5 * Math.sin(a)],
        strength: 0.3, radius: 1.5 });
    }
    const list = await http.impacts(scene, { t: t - 30 });
    assert.equal(list.impacts.length, 60);
    surface.impacts.addAll(list.impacts);
    const tt = t + 2.0;
    const pts = [];
    for (let i = 0; i < 400; i++) pts.push([(i % 20) * 0.6 - 6, Math.floor(i / 20) * 0.6 - 6]);
    const server = await http.sample(scene, { t: tt, points: pts, fields: ['height', 'normal'] });
    const layer = surface.impactLayer.particles;
    const rings = layer.liveRings(tt, surface.impacts);
    let capped = 0;
    pts.forEach(([x, z], i) => {
      if (rings.filter((r) => layer.covers(r, x, z)).length > MAX_RINGS_PER_POINT) capped++;
      const r = surface.query(x, z, tt);
      assert.equal(bitsHex(r.height), bitsHex(server.height[i]), `height (${x}, ${z})`);
      assert.equal(bits(r.normal), bits(server.normal[i]), `normal (${x}, ${z})`);
    });
    assert.ok(capped >= 20, `only ${capped} points had more than ${MAX_RINGS_PER_POINT} rings over them`);
  });

  test('golden lake_gerstner_cascade bit for bit from the server-built cascade waves', async () => {
    const c = VECTORS.cases.find((k) => k.name === 'lake_gerstner_cascade');
    const detail = await admin.putScene('golden-lake', { description: 'golden', ...c.spec });
    const n = checkCase(Surface.fromDerived(detail.derived), c);
    assert.equal(n, 20);
  });

  test('frame uniforms computed locally equal GET /uniforms', async () => {
    for (const scene of ['calm', 'lake', 'open-sea']) {
      const surface = Surface.fromDerived((await http.scene(scene)).derived);
      const { t } = await http.clock(scene);
      for (const origin of [[0, 0], [1e6, -3.5e5], [12.5, 7.25]]) {
        const server = await http.uniforms(scene, { t, origin });
        const local = surface.uniforms(t, origin);
        assert.equal(local.phases.length, server.waves);
        assert.equal(bits(local.phases), bits(server.phases), `${scene} ${origin}`);
        assert.deepEqual(Array.from(local.block), server.block);
      }
    }
  });

  test('protobuf answers decode to the JSON answers bit for bit', async () => {
    const pb = new SwellClient(srv.url, { wire: 'protobuf' });
    const req = { t: 60, origin: [10000, 20000], points: [[0, 0], [1.5, 2], [-3, 4]], fields, accuracy: { iterations: 12, filter: 'bilinear' } };
    for (const scene of ['lake', 'open-sea']) {
      const j = await http.sample(scene, req);
      const p = await pb.sample(scene, req);
      assert.equal(bits(p), bits(j), scene);
    }
    const oreq = { t: 61, bodies: [{ position: [5, 5], yaw: 0.3, length: 12, beam: 4 }, { position: [-20, 3], length: 30, beam: 8, probes: [[0, 0], [10, 2], [-10, -2]] }] };
    assert.equal(bits(await pb.orientation('storm', oreq)), bits(await http.orientation('storm', oreq)));
    assert.equal(bits(await pb.height('lake', 3, 4, { t: 9 })), bits(await http.height('lake', 3, 4, { t: 9 })));
  });

  test('shader and spectrum fetches carry the version headers', async () => {
    const s = await http.shader('lake', 'glsl_es', { entry: 'swell_vs' });
    assert.match(s.text, /swell_sample/);
    assert.equal(s.modelVersion, VECTORS.model_version);
    const spec = await http.spectrum('open-sea', 0);
    assert.equal(spec.records.length, spec.n * spec.n * 3);
    await assert.rejects(http.spectrum('open-sea', 1), (e) => e instanceof SwellError && e.field === 'layer');
    // An FFT layer's pass shaders need the layer; a non-FFT layer is the server's 400.
    const evolve = await http.shader('open-sea', 'glsl_es', { entry: 'swell_fft_evolve', layer: 0 });
    assert.match(evolve.text, /^#version 300 es/);
    assert.match(evolve.text, /texelFetch/);
    await assert.rejects(http.shader('open-sea', 'glsl_es', { entry: 'swell_fft_evolve' }), (e) => e.field === 'layer');
    await assert.rejects(http.shader('open-sea', 'glsl_es', { entry: 'swell_fft_evolve', layer: 1 }), (e) => e instanceof SwellError && e.field === 'layer');
  });

  describe('WebSocket session', () => {
    test('clock sync converges: offset within 5 ms of the wall-anchored scene clock', async () => {
      const s = new SwellSession(http.streamUrl('calm'), { pingInterval: 100, syncPings: 10 });
      await s.connect();
      try {
        await sleep(300);
        const err = s.serverTime() - (wallSeconds() - EPOCH);
        const { minRtt } = s.clockStats();
        console.log(`clock sync: error ${(err * 1e3).toFixed(3)} ms, min RTT ${(minRtt * 1e3).toFixed(3)} ms`);
        assert.ok(Math.abs(err) < 0.005, `scene time off by ${err} s`);
      } finally { s.close(); }
    });

    // Issue 28: after an admin clock change the fit restarts at the new generation. Truth is
    // the server's own reading carried to now: `t + rate·(unix_now − unix)` (0 while paused).
    const truth = (r) => r.t + (r.paused ? 0 : r.rate) * (wallSeconds() - r.unix);
    const smallSpec = { description: 'clock test', tick_hz: 20, seed: 3, layers: [{ kind: 'gerstner', waves: [{ amplitude: 0.4, wavelength: 30, direction: [1, 0.5], steepness: 0.6 }] }] };

    test('seek and rate change while connected: serverTime() within 5 ms 1 s after each', async () => {
      await admin.putScene('clock-live', smallSpec);
      const events = [];
      const s = new SwellSession(http.streamUrl('clock-live'), { onClock: (e) => events.push(e) });
      await s.connect();
      try {
        for (const [what, update] of [['seek', { t: 118000 }], ['rate 1 -> 2', { rate: 2 }], ['pause', { paused: true }], ['resume', { paused: false }], ['seek back, rate -1', { t: 50, rate: -1 }]]) {
          const before = s.clockStats().generation;
          const r = await admin.setClock('clock-live', update);
          assert.equal(r.generation, before + 1, `${what}: one generation per change`);
          await sleep(1000);
          const err = s.serverTime() - truth(r);
          console.log(`clock change (${what}): error 1 s after ${(err * 1e3).toFixed(3)} ms, generation ${s.clockStats().generation}`);
          assert.ok(Math.abs(err) < 0.005, `${what}: scene time off by ${err} s 1 s after the change`);
          assert.equal(s.clockStats().generation, r.generation);
          assert.equal(events.at(-1)?.generation, r.generation, `${what}: a clock event`);
        }
      } finally { s.close(); }
    });

    test('joining a paused or rate-2 scene: serverTime() within 5 ms after the first pong', async () => {
      for (const [what, update] of [['paused', { t: 777.25, paused: true }], ['rate 2', { paused: false, rate: 2 }]]) {
        await admin.putScene('clock-join', smallSpec);
        const r = await admin.setClock('clock-join', update);
        const s = new SwellSession(http.streamUrl('clock-join'), { syncPings: 1 });
        await s.connect();
        try {
          const err = s.serverTime() - truth(r);
          console.log(`joining a ${what} scene: error after the first pong ${(err * 1e3).toFixed(3)} ms`);
          assert.ok(Math.abs(err) < 0.005, `${what}: scene time off by ${err} s`);
          assert.equal(s.clock.samples.length, 1);
        } finally { s.close(); }
      }
    });

    test('sample and orientation on the socket equal the HTTP answers bit for bit', async () => {
      const s = new SwellSession(http.streamUrl('lake'));
      await s.connect();
      try {
        const req = { t: 1234.5, origin: [100, -200], points: [[0, 0], [5, 6]], fields };
        assert.equal(bits(await s.sample(req)), bits(await http.sample('lake', req)));
        const oreq = { t: 77, bodies: [{ position: [1, 2], yaw: -0.4, length: 10, beam: 3 }] };
        assert.equal(bits(await s.orientation(oreq)), bits(await http.orientation('lake', oreq)));
        await assert.rejects(s.sample({ points: [[0, 0]], t: -1e12 }), (e) => e instanceof SwellError && e.code === 'invalid_value');
        assert.throws(() => s.sample({ points: 'x' }), ArgumentError);
      } finally { s.close(); }
    });

    test('tick subscription with interest sets (bodies, region)', async () => {
      const a = await admin.spawnBody('calm', { mass: 3000, hull: { kind: 'box', length: 8, beam: 3, height: 1.5 }, position: [0, 0.5, 0] });
      const b = await admin.spawnBody('calm', { mass: 500, hull: { kind: 'box', length: 3, beam: 1.5, height: 1 }, position: [100, 0.5, 100] });
      const frames = [];
      const s = new SwellSession(http.streamUrl('calm'), { onTick: (f) => frames.push(f) });
      await s.connect();
      try {
        const next = async (pred) => {
          for (let i = 0; i < 100; i++) {
            const f = frames.find(pred);
            if (f) return f;
            await sleep(20);
          }
          throw new Error('no matching tick frame');
        };
        s.subscribe({ bodies: [a.id] });
        let f = await next((f) => f.bodies.length > 0);
        assert.deepEqual(f.bodies.map((x) => x.id), [a.id]);
        assert.equal(f.t, f.tick / 30);
        frames.length = 0;
        s.subscribe({ bodies: [], region: [50, 50, 150, 150] });
        await sleep(150);
        frames.length = 0;
        f = await next(() => true);
        assert.deepEqual(f.bodies.map((x) => x.id), [b.id]);
        s.unsubscribe();
        await sleep(150);
        frames.length = 0;
        await sleep(200);
        assert.equal(frames.length, 0, 'no frames after unsubscribe');
      } finally { s.close(); }
    });

    test('a tick frame carries each API impact with its body_tick, as the POST answer', async () => {
      // Its own scene with bodies and a particle layer, so no other test's sea changes.
      await admin.putScene('jsfelt', { tick_hz: 30, seed: 4, layers: [
        { kind: 'gerstner', waves: [{ amplitude: 0.1, wavelength: 20, direction: [1, 0], steepness: 0.3 }] },
        { kind: 'particles', count: 16, tile_size: 32, radius: 1, amplitude: 0.02 }] });
      await admin.spawnBody('jsfelt', { mass: 3000, hull: { kind: 'box', length: 8, beam: 3, height: 1.5 }, position: [0, 0.4, 0] });
      const frames = [];
      const s = new SwellSession(http.streamUrl('jsfelt'), { onTick: (f) => frames.push(f) });
      await s.connect();
      try {
        s.subscribe();
        for (let i = 0; i < 100 && frames.length === 0; i++) await sleep(20);
        const answer = await admin.addImpact('jsfelt', { position: [2, 1], strength: 0.5, radius: 1 });
        assert.equal(typeof answer.body_tick, 'number', JSON.stringify(answer));
        let carried;
        for (let i = 0; i < 200 && !carried; i++) {
          carried = frames.flatMap((f) => f.impacts ?? []).find((e) => e.t === answer.t);
          if (!carried) await sleep(20);
        }
        assert.ok(carried, 'no tick frame carried the impact');
        assert.equal(carried.body_tick, answer.body_tick);
        assert.equal(carried.tick, answer.tick);
      } finally { s.close(); }
    });
  });
});

describe('a scene that goes away', { skip }, () => {
  let srv; let admin;
  before(async () => {
    srv = await SwellProcess.start();
    admin = new SwellClient(srv.url, { adminToken: srv.token });
  });
  after(async () => { await srv?.dispose(); });

  test('deleted under a subscriber: onError(not_found), onClose(4404), no reconnect', async () => {
    await admin.putScene('doomed', { layers: [{ kind: 'sine', waves: [{ amplitude: 0.1, wavelength: 8, direction: [1, 0] }] }] });
    const errors = []; const closes = []; const frames = [];
    const s = new SwellSession(admin.streamUrl('doomed'), {
      onError: (e) => errors.push(e), onClose: (c) => closes.push(c), onTick: (f) => frames.push(f),
      backoff: { initial: 20, max: 50 }, pingInterval: 100,
    });
    try {
      await s.connect();
      s.subscribe();
      for (let i = 0; i < 100 && frames.length < 2; i++) await sleep(20);
      await admin.deleteScene('doomed');
      for (let i = 0; i < 100 && closes.length === 0; i++) await sleep(20);
      assert.equal(closes[0]?.code, SCENE_GONE, JSON.stringify(closes));
      assert.match(closes[0].reason, /doomed/);
      assert.ok(errors.some((e) => e instanceof SwellError && e.code === 'not_found'), 'onError heard not_found');
      await sleep(300);
      assert.equal(s.reconnects, 0, 'no reconnect to a deleted scene');
      assert.equal(closes.length, 1);
      await assert.rejects(s.ping(), TransportError);
    } finally { s.close(); }
  });

  test('connect() to a scene that does not exist rejects once and does not retry', async () => {
    let opened = 0;
    const Counting = class extends WebSocket { constructor(...a) { super(...a); opened++; } };
    const s = new SwellSession(admin.streamUrl('atlantis'), { WebSocket: Counting, backoff: { initial: 20, max: 50 } });
    try {
      await assert.rejects(s.connect(), (e) => e instanceof TransportError && /404/.test(e.message));
      await sleep(300);
      assert.equal(opened, 1, 'one attempt, no background retries');
    } finally { s.close(); }
  });
});

describe('reconnect', { skip }, () => {
  test('the session reconnects after the server restarts and resubscribes', async () => {
    const port = await freePort();
    const srv = await SwellProcess.start({ port });
    const frames = [];
    const ip = new BodyInterpolator();
    let closes = 0;
    const s = new SwellSession(`ws://127.0.0.1:${port}/v1/scenes/calm/stream`, {
      onTick: (f) => frames.push(f), interpolator: ip, onClose: () => { closes++; }, backoff: { initial: 50, max: 400 }, pingInterval: 200,
    });
    try {
      await s.connect();
      s.subscribe();
      while (frames.length < 3) await sleep(20);
      await srv.stop();
      await sleep(300);
      assert.ok(closes >= 1, 'the socket closed with the server');
      frames.length = 0;
      const restartedAt = performance.now() / 1000;
      await srv.start();
      await s.opened();
      for (let i = 0; i < 200 && frames.length < 3; i++) await sleep(20);
      assert.ok(frames.length >= 3, 'tick frames resume after the restart without a new subscribe');
      assert.ok(s.reconnects >= 1);
      // The clock was re-synced on the new connection only: no sample from before the restart.
      for (let i = 0; i < 100 && !s.resyncing; i++) await sleep(10);
      await s.resyncing;
      assert.ok(s.clock.samples.length >= s.syncPings && s.clock.samples.every((x) => x.mid > restartedAt),
        'clock samples from the new connection only');
      await s.syncNow(3);
      assert.ok(Math.abs(s.serverTime() - (wallSeconds() - EPOCH)) < 0.005);
    } finally {
      s.close();
      await srv.dispose();
    }
  });
});
