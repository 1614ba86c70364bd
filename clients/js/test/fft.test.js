// FFT layers from the exported spectrum: the JS inverse FFT against a direct DFT, and the CPU
// evaluation (grid times, bicubic, as the server reads by default) against a live server's
// /sample and against the golden vectors' FFT cases. Tolerance: FFT_TOLERANCE_M, documented in docs/clients.md; the measured figure is
// printed.
import { describe, test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { ifft2, FftLayer } from '../src/fft.js';
import { Surface } from '../src/surface.js';
import { SwellClient } from '../src/client.js';
import { SwellProcess, available } from './server.js';
import { VECTORS } from './golden.js';
import { fromBitsHex } from '../src/math.js';

export const FFT_TOLERANCE_M = 1e-9; // measured ~1e-15 (open-sea) to ~1e-14 (storm): FFT rounding only

test('ifft2 equals a direct inverse DFT', () => {
  const n = 16; const re = new Float64Array(n * n); const im = new Float64Array(n * n);
  for (let i = 0; i < n * n; i++) { re[i] = Math.sin(i * 1.37) * 0.3; im[i] = Math.cos(i * 0.71) * 0.2; }
  const r0 = re.slice(), i0 = im.slice();
  ifft2(re, im, n);
  let err = 0;
  for (let q = 0; q < n; q++) for (let p = 0; p < n; p++) {
    let sr = 0, si = 0;
    for (let j = 0; j < n; j++) for (let i = 0; i < n; i++) {
      const a = (2 * Math.PI * (i * p + j * q)) / n;
      sr += r0[j * n + i] * Math.cos(a) - i0[j * n + i] * Math.sin(a);
      si += r0[j * n + i] * Math.sin(a) + i0[j * n + i] * Math.cos(a);
    }
    err = Math.max(err, Math.abs(sr - re[q * n + p]), Math.abs(si - im[q * n + p]));
  }
  assert.ok(err < 1e-12, String(err));
});

describe('FFT layers against a live server', { skip: available() ? false : 'no swell binary' }, () => {
  let srv; let http; let admin;
  before(async () => {
    srv = await SwellProcess.start();
    http = new SwellClient(srv.url);
    admin = new SwellClient(srv.url, { adminToken: srv.token });
  });
  after(async () => { await srv?.dispose(); });

  // The golden vectors' FFT cases (proto/vectors/surface_v1.json): the spectrum comes from the
  // server (the case's spec put as a scene), the evaluation is this package's; every field of
  // every time × point within FFT_TOLERANCE_M of the vector (not bit for bit: other butterflies).
  for (const c of VECTORS.cases.filter((k) => k.spec.layers.some((l) => l.kind === 'fft'))) {
    test(`golden ${c.name}: every field within ${FFT_TOLERANCE_M} of the vector`, async () => {
      const id = `golden-${c.name.replaceAll('_', '-')}`.slice(0, 64);
      const detail = await admin.putScene(id, { description: 'golden', ...c.spec });
      const fft = [];
      for (const [i, l] of detail.derived.layers.entries()) {
        if (l.kind === 'fft') fft[i] = new FftLayer(await http.spectrum(id, i));
      }
      const surface = Surface.fromDerived(detail.derived, { fft });
      let worst = 0;
      let folded = 0;
      for (const e of c.expected) {
        const r = surface.query(e.point[0], e.point[1], e.t);
        const want = (h) => fromBitsHex(h);
        const diffs = [
          Math.abs(r.height - want(e.bits.height)),
          ...r.normal.map((v, k) => Math.abs(v - want(e.bits.normal[k]))),
          ...r.displacement.map((v, k) => Math.abs(v - want(e.bits.displacement[k]))),
          Math.abs(r.jacobian - want(e.bits.jacobian)),
          Math.abs(r.residual - want(e.bits.residual)),
        ];
        const d = Math.max(...diffs);
        assert.ok(d <= FFT_TOLERANCE_M, `${c.name} t=${e.t} ${e.point}: ${d} (${JSON.stringify(diffs)})`);
        if (r.folded === e.bits.folded) folded++;
        worst = Math.max(worst, d);
      }
      assert.equal(folded, c.expected.length, 'folded flags');
      console.log(`golden ${c.name}: ${c.expected.length} time × point, largest difference ${worst.toExponential(2)}`);
    });
  }

  for (const scene of ['open-sea', 'storm']) {
    test(`${scene}: CPU FFT evaluation within ${FFT_TOLERANCE_M} m of /sample`, async () => {
      const detail = await http.scene(scene);
      const fft = [];
      for (const [i, l] of detail.derived.layers.entries()) {
        if (l.kind === 'fft') fft[i] = new FftLayer(await http.spectrum(scene, i));
      }
      const surface = Surface.fromDerived(detail.derived, { fft });
      const { t } = await http.clock(scene);
      const points = [[0, 0], [3.3, -7.1], [100.25, 40.5], [-1234.5, 987.125], [1e5 + 0.3, -2e5]];
      const fields = ['height', 'normal', 'displacement'];
      let worst = { height: 0, displacement: 0, normal: 0 };
      const started = performance.now();
      for (const tt of [t, 60.5, 12.345]) {
        const server = await http.sample(scene, { t: tt, points, fields });
        points.forEach(([x, z], i) => {
          const r = surface.query(x, z, tt, fields);
          worst.height = Math.max(worst.height, Math.abs(r.height - server.height[i]));
          worst.displacement = Math.max(worst.displacement, ...r.displacement.map((v, k) => Math.abs(v - server.displacement[i][k])));
          worst.normal = Math.max(worst.normal, ...r.normal.map((v, k) => Math.abs(v - server.normal[i][k])));
        });
      }
      const ms = performance.now() - started;
      console.log(`${scene}: |Δheight| ${worst.height.toExponential(2)} m, |Δdisplacement| ${worst.displacement.toExponential(2)} m, |Δnormal| ${worst.normal.toExponential(2)} (${ms.toFixed(0)} ms incl. frames)`);
      assert.ok(worst.height <= FFT_TOLERANCE_M && worst.displacement <= FFT_TOLERANCE_M, JSON.stringify(worst));
      assert.ok(worst.normal <= FFT_TOLERANCE_M, JSON.stringify(worst));
    });
  }
});
