// The golden vectors bit for bit: the local evaluator against proto/vectors/surface_v1.json.
// Cases with explicit deep-water waves are built from their spec here; the cascade case needs
// the server's generated waves and is checked in live.test.js; the FFT cases need the server's
// spectrum and are checked, within the FFT tolerance, in fft.test.js.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Surface } from '../src/surface.js';
import { VECTORS, checkCase } from './golden.js';

test('model version of the vectors is the one this client ports', () => {
  assert.equal(VECTORS.model_version, 3);
});

for (const name of ['calm_sine', 'steep_gerstner_s095']) {
  test(`golden ${name}: every field bit for bit`, () => {
    const c = VECTORS.cases.find((k) => k.name === name);
    const n = checkCase(Surface.fromSpec(c.spec), c);
    assert.equal(n, c.times.length * c.points.length);
  });
}
