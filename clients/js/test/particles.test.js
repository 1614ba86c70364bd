// The particle layer's pieces offline: the libm ports against V8's (which ports the same fdlibm
// sources), the grid-ordered ambient sum against a brute-force sum over every particle, the
// gradient against finite differences, ring closed forms, and the impact set's canonical order.
// The bit-for-bit check against the server is in live.test.js (harbour, with impacts).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { exp, atan2, expm1, tanh } from '../src/libm.js';
import { ParticleLayer, ImpactSet, kernel, wrap } from '../src/particles.js';
import { bitsHex, roundTiesAway } from '../src/math.js';

// A seeded generator for test inputs (not the model's): xorshift32.
function rng(seed) {
  let s = seed >>> 0;
  return () => { s ^= s << 13; s >>>= 0; s ^= s >>> 17; s ^= s << 5; s >>>= 0; return s / 4294967296; };
}

test('libm exp, expm1, atan2 equal V8 (fdlibm) bit for bit; tanh within 2 ulp', () => {
  const r = rng(7);
  let n = 0;
  let tanhExact = 0;
  const ulp = (x) => { const b = Math.abs(x); return b === 0 ? Number.MIN_VALUE : 2 ** (Math.floor(Math.log2(b)) - 52); };
  for (let i = 0; i < 20000; i++) {
    const scale = [1e-12, 1e-3, 0.3, 1, 5, 50, 700][i % 7];
    const x = (r() * 2 - 1) * scale;
    const y = (r() * 2 - 1) * [1e-3, 1, 1e3][i % 3];
    assert.equal(bitsHex(exp(x)), bitsHex(Math.exp(x)), `exp(${x})`);
    assert.equal(bitsHex(expm1(x)), bitsHex(Math.expm1(x)), `expm1(${x})`);
    assert.equal(bitsHex(atan2(y, x)), bitsHex(Math.atan2(y, x)), `atan2(${y}, ${x})`);
    const th = tanh(x);
    assert.ok(Math.abs(th - Math.tanh(x)) <= 2 * ulp(th), `tanh(${x}) = ${th} vs ${Math.tanh(x)}`);
    if (th === Math.tanh(x)) tanhExact++;
    n++;
  }
  for (const [y, x] of [[0, -1], [-0, -1], [1, 0], [-1, 0], [0, 0], [3, 2], [2, -1], [-2, -1], [1e-300, -1e10]]) {
    assert.equal(bitsHex(atan2(y, x)), bitsHex(Math.atan2(y, x)), `atan2(${y}, ${x})`);
  }
  assert.equal(exp(0), 1);
  assert.equal(exp(-800), 0);
  assert.equal(exp(800), Infinity);
  console.log(`libm: ${n} inputs; tanh equal to V8's for ${tanhExact} (musl's tanh is not fdlibm's)`);
});

// A small layer in the derived format, particles from a seeded generator.
function layer({ count = 64, tile = 8, radius = 0.6, scales = [0.5, 1], seed = 3 } = {}) {
  const r = rng(seed);
  const particles = [], tileList = [];
  for (let i = 0; i < count; i++) {
    const u = [r(), r()];
    const ang = r() * 2 * Math.PI;
    const w = [Math.cos(ang) * 0.3 / tile, Math.sin(ang) * 0.3 / tile];
    const a = 0.05 * (1 - 0.5 * r()) * (i % 2 ? -1 : 1);
    tileList.push([u[0], u[1], w[0], w[1]]);
    particles.push([u[0] * tile, u[1] * tile, w[0] * tile, w[1] * tile, a]);
  }
  return new ParticleLayer({
    kind: 'particles', tile_size: tile, radius, scales, particles, particles_tile: tileList,
    ripples: { particles: 8, decay: 30, floor: 1e-4, lifetime: 60, max_ring_particles: 2048 },
  });
}

// Every particle at every scale in index order (ambient.rs `sample_reference`).
function reference(L, x, z, t) {
  let h = 0, gx = 0, gz = 0;
  const k = [0, 0, 0];
  L.scales.forEach((s, si) => {
    const inv = L.invSl[si];
    const qx = wrap(x * inv), qz = wrap(z * inv);
    for (let i = 0; i < L.count; i++) {
      const [px, pz] = L.position(i, t);
      let dx = qx - px, dz = qz - pz;
      dx -= roundTiesAway(dx); dz -= roundTiesAway(dz);
      if (kernel(s * L.amp[i], dx, dz, L.invRr2, k)) { h += k[0]; gx += k[1] * inv; gz += k[2] * inv; }
    }
  });
  return [h, gx, gz];
}

test('ambient: the cell grid finds every particle the brute-force sum finds', () => {
  const r = rng(11);
  for (const opts of [{}, { count: 200, tile: 32, radius: 1, scales: [0.33, 0.66, 1] }, { tile: 2, radius: 0.5 }]) {
    const L = layer(opts);
    assert.ok(L.cells >= 1);
    let hits = 0;
    for (let i = 0; i < 400; i++) {
      const x = (r() * 2 - 1) * 1e4, z = (r() * 2 - 1) * 50, t = r() * 1e5;
      const [h, gx, gz] = L.sample(x, z, t);
      const [rh, rgx, rgz] = reference(L, x, z, t);
      // Same terms, another order: equal up to rounding of the sums.
      assert.ok(Math.abs(h - rh) < 1e-15 && Math.abs(gx - rgx) < 1e-13 && Math.abs(gz - rgz) < 1e-13, `${x},${z},${t}: ${h} vs ${rh}`);
      if (rh !== 0) hits++;
    }
    assert.ok(hits > 100, `only ${hits} of 400 points touched a particle`);
  }
});

test('the layer gradient (ambient and rings) matches finite differences of its height', () => {
  const L = layer({ count: 100, tile: 16, radius: 1, scales: [0.5, 1] });
  const impacts = new ImpactSet([
    { t: 1, position: [3, 4], strength: 0.5, radius: 0.6 },
    { t: 2.5, position: [-6, 1], strength: 0.3, radius: 1.2 },
  ]);
  const t = 4;
  const rings = L.liveRings(t, impacts);
  assert.equal(rings.length, 2);
  const r = rng(5);
  const e = 1e-6;
  let ringHits = 0;
  for (let i = 0; i < 500; i++) {
    const x = r() * 30 - 15, z = r() * 30 - 10;
    const [h, gx, gz] = L.sample(x, z, t, rings);
    const hx = (L.sample(x + e, z, t, rings)[0] - L.sample(x - e, z, t, rings)[0]) / (2 * e);
    const hz = (L.sample(x, z + e, t, rings)[0] - L.sample(x, z - e, t, rings)[0]) / (2 * e);
    assert.ok(Math.abs(hx - gx) < 1e-6 && Math.abs(hz - gz) < 1e-6, `${x},${z}: (${gx}, ${gz}) vs (${hx}, ${hz})`);
    if (h !== L.sample(x, z, t, [])[0]) ringHits++;
  }
  assert.ok(ringHits > 20, `rings touched only ${ringHits} points`);
});

test('rings: closed-form state conserves the splash, subdivides, dies', () => {
  const L = layer();
  const ring = L.ring({ t: 10, position: [0, 0], strength: 0.8, radius: 0.5 });
  assert.equal(ring.speed, Math.sqrt(9.81 * (Math.PI / 1)) / (Math.PI / 1)); // k = π/(2r)
  assert.equal(ring.state(9.999), null, 'nothing before t0');
  assert.equal(ring.state(71), null, 'nothing after the lifetime');
  let last = 0;
  for (let t = 10; t < 70; t += 0.37) {
    const s = ring.state(t);
    if (!s) break;
    assert.ok(s.generation >= last);
    last = s.generation;
    assert.equal(s.count, 8 * 3 ** s.generation);
    const total = s.count * s.amplitude * Math.exp(s.distance / 30);
    assert.ok(Math.abs(total - 0.8) < 1e-12, `total amplitude ${total} at t=${t}`);
  }
  assert.ok(last >= 2, `the ring split ${last} times`);
});

test('impact set: canonical order (t, x, z, strength, radius; −0 before +0), merged duplicates, window', () => {
  const s = new ImpactSet();
  const a = { t: 5, position: [1, 2], strength: 0.5, radius: 1 };
  assert.ok(s.add({ ...a, tick: 150 }));
  assert.ok(!s.add(a), 'the same impact again is merged');
  s.add({ t: 5, position: [0, 9], strength: 0.5, radius: 1 });
  s.add({ t: 5, position: [-0, 9], strength: 0.5, radius: 1 });
  s.add({ t: -3, position: [100, 0], strength: 1, radius: 2 });
  s.add({ t: 5, position: [1, 2], strength: 0.5, radius: 0.5 });
  assert.deepEqual(s.events.map((e) => [e.t, Object.is(e.position[0], -0) ? '-0' : e.position[0], e.radius]),
    [[-3, 100, 2], [5, '-0', 1], [5, 0, 1], [5, 1, 0.5], [5, 1, 1]]);
  assert.equal(s.window(5, 1).length, 4);
  assert.equal(s.window(4.9, 100).length, 1);
  assert.equal(s.window(60, 56).length, 4);
  assert.equal(s.window(60, 54).length, 0);
  assert.throws(() => s.add({ t: NaN, position: [0, 0], strength: 1, radius: 1 }), /impact/);
  s.prune(10, 4);
  assert.equal(s.size, 0);
});
