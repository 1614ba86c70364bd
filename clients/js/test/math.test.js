import { test } from 'node:test';
import assert from 'node:assert/strict';
import { roundTiesAway, reducePhase, sinCos, copysign, bitsHex, fromBitsHex } from '../src/math.js';

test('roundTiesAway is Rust f64::round: ties away from zero, sign kept', () => {
  const cases = [[0.5, 1], [-0.5, -1], [1.5, 2], [2.5, 3], [-2.5, -3], [0.49999999999999994, 0],
    [4503599627370497, 4503599627370497], [1e300, 1e300]];
  for (const [x, r] of cases) assert.equal(roundTiesAway(x), r, String(x));
  assert.ok(Object.is(roundTiesAway(-0.3), -0));
  assert.ok(Object.is(roundTiesAway(0.3), 0));
  assert.ok(Object.is(copysign(2, -0), -2));
});

test('sinCos is within 2 ulp of the exact values on [-π, π] and exact at 0', () => {
  assert.deepEqual(sinCos(0), [0, 1]);
  const eps = 2 * Number.EPSILON;
  for (let i = 0; i <= 20000; i++) {
    const x = -Math.PI + (2 * Math.PI * i) / 20000;
    const [s, c] = sinCos(x);
    assert.ok(Math.abs(s - Math.sin(x)) <= eps && Math.abs(c - Math.cos(x)) <= eps, String(x));
  }
});

test('reducePhase keeps large phases accurate (sin of the reduction matches)', () => {
  for (const x of [1e3, 12345.678, 1e6 + 0.5, 1e9, -1e9 - 0.25, 3.3e9]) {
    const r = reducePhase(x);
    assert.ok(Math.abs(r) <= Math.PI + 1e-15);
    assert.ok(Math.abs(sinCos(r)[0] - Math.sin(x)) < 1e-15 * Math.abs(x), String(x));
  }
});

test('bit helpers round-trip', () => {
  for (const x of [0, -0, 1, -1.5, 1e-310, Math.PI]) assert.ok(Object.is(fromBitsHex(bitsHex(x)), x));
  assert.equal(bitsHex(1), '3ff0000000000000');
});

test('model code uses no platform transcendental maths (Math.sin etc. are not specified to the bit)', async () => {
  const { readFileSync } = await import('node:fs');
  for (const f of ['math.js', 'surface.js', 'fft.js']) {
    const code = readFileSync(new URL(`../src/${f}`, import.meta.url), 'utf8')
      .split('\n').filter((l) => !l.trim().startsWith('//')).join('\n');
    const bad = code.match(/Math\.(sin|cos|tan|asin|acos|atan2?|sinh|cosh|tanh|exp|expm1|log|log2|log10|log1p|pow|hypot|cbrt)\b/g);
    assert.equal(bad, null, `${f}: ${bad}`);
  }
});
