// The viewer's FFT worker: evaluates an FFT layer's frame off the main thread (one 256² frame is
// tens of milliseconds of JavaScript) and sends back the two RGBA32F textures the sea shader reads.
import { FftLayer } from '/viewer/assets/client/fft.js';

let layer = null;
self.onmessage = (ev) => {
  const m = ev.data;
  if (m.type === 'spectrum') {
    layer = new FftLayer(m.spectrum, { cacheFrames: 1 });
    return;
  }
  if (m.type === 'frame' && layer) {
    const f = layer.frame(m.t);
    layer.cache.clear();
    const n = layer.n;
    const a = new Float32Array(4 * n * n), b = new Float32Array(4 * n * n);
    for (let r = 0; r < n * n; r++) {
      a[4 * r] = f.dx[r]; a[4 * r + 1] = f.h[r]; a[4 * r + 2] = f.dz[r]; a[4 * r + 3] = f.jxx[r];
      b[4 * r] = f.sx[r]; b[4 * r + 1] = f.sz[r]; b[4 * r + 2] = f.jzz[r]; b[4 * r + 3] = f.jxz[r];
    }
    self.postMessage({ t: m.t, a, b }, [a.buffer, b.buffer]);
  }
};
