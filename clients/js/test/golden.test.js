// The golden vectors bit for bit: the local evaluator against proto/vectors/surface_v1.json.
// Cases with explicit deep-water waves are built from their spec here; the cascade case needs
// the server's generated waves and is checked in live.test.js (FFT cases in fft.test.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { Surface } from '../src/surface.js';
import { bitsHex } from '../src/math.js';

export const VECTORS = JSON.parse(readFileSync(new URL('../../../proto/vectors/surface_v1.json', import.meta.url)));

/** Compares every field of every time × point of `c` with `surface`; returns the count. */
export function checkCase(surface, c) {
  let n = 0;
  for (const e of c.expected) {
    const r = surface.query(e.point[0], e.point[1], e.t);
    const got = {
      height: bitsHex(r.height),
      normal: r.normal.map(bitsHex),
      displacement: r.displacement.map(bitsHex),
      jacobian: bitsHex(r.jacobian),
      residual: bitsHex(r.residual),
      folded: r.folded,
    };
    assert.deepEqual(got, e.bits, `${c.name} t=${e.t} point=${e.point}`);
    n++;
  }
  return n;
}

test('model version of the vectors is the one this client ports', () => {
  assert.equal(VECTORS.model_version, 2);
});

for (const name of ['calm_sine', 'steep_gerstner_s095']) {
  test(`golden ${name}: every field bit for bit`, () => {
    const c = VECTORS.cases.find((k) => k.name === name);
    const n = checkCase(Surface.fromSpec(c.spec), c);
    assert.equal(n, c.times.length * c.points.length);
  });
}
