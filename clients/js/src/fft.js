// FFT layers on the CPU from the exported spectrum (GET …/spectrum?layer=N, `swell-spectrum/1`,
// see crates/swell-shaders/src/spectrum.rs and docs/clients.md "FFT layers").
//
// Per frame time t: `t_r = t mod T`; `h̃(k) = h0(k)·e^{−iω t_r} + conj(h0(−k))·e^{+iω t_r}`;
// inverse 2-D FFTs (radix 2, unnormalised) give the grids the model keeps: height h,
// displacement Dx, Dz (`D = Σ i·λ·(k/|k|)·h̃·e^{ik·x}`), slopes ∂h/∂x, ∂h/∂z and the Jacobian terms
// ∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z. Two real grids share one complex transform (h̃ is Hermitian, so each
// field is real). The layer is read like the server reads it by default: frames at grid times
// `n·time_step`, linear in time between the two around t, Catmull–Rom (bicubic) in space; the
// remaining difference to the server is the FFT's rounding (different butterflies), measured by
// test/fft.test.js (documented in docs/clients.md).

import { ArgumentError } from './errors.js';
import { sinCos, TAU } from './math.js';

/** Parses a `swell-spectrum/1` export: `{header, n, records}` (records: Float64Array, 3 per mode). */
export function parseSpectrum(bytes) {
  const u8 = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
  const magic = String.fromCharCode(u8[0], u8[1], u8[2], u8[3]);
  if (magic !== 'SWSP') throw new ArgumentError('spectrum', `not a swell-spectrum export (magic ${JSON.stringify(magic)})`);
  const dv = new DataView(u8.buffer, u8.byteOffset, u8.byteLength);
  const hlen = dv.getUint32(4, true);
  const header = JSON.parse(new TextDecoder().decode(u8.subarray(8, 8 + hlen)));
  if (header.format !== 'swell-spectrum/1') throw new ArgumentError('spectrum', `unknown format ${header.format}`);
  const n = header.resolution;
  const count = n * n * 3;
  const records = new Float64Array(count);
  for (let i = 0; i < count; i++) records[i] = dv.getFloat64(header.data_offset + 8 * i, true);
  return { header, n, records };
}

/** In-place iterative radix-2 complex FFT with `e^{+i…}` (an inverse DFT, unnormalised). */
export function ifft1(re, im, n, off, stride, tw) {
  // Bit reversal.
  for (let i = 1, j = 0; i < n; i++) {
    let bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) {
      const a = off + i * stride, b = off + j * stride;
      let t = re[a]; re[a] = re[b]; re[b] = t;
      t = im[a]; im[a] = im[b]; im[b] = t;
    }
  }
  for (let len = 2; len <= n; len <<= 1) {
    const half = len >> 1;
    const step = n / len;
    for (let i = 0; i < n; i += len) {
      for (let k = 0; k < half; k++) {
        const wr = tw[2 * k * step], wi = tw[2 * k * step + 1];
        const a = off + (i + k) * stride, b = off + (i + k + half) * stride;
        const xr = re[b] * wr - im[b] * wi;
        const xi = re[b] * wi + im[b] * wr;
        re[b] = re[a] - xr; im[b] = im[a] - xi;
        re[a] += xr; im[a] += xi;
      }
    }
  }
}

/** Twiddles `e^{+2πik/n}`, k < n/2, interleaved (re, im). */
export function twiddles(n) {
  const tw = new Float64Array(n);
  const sc = [0, 0];
  for (let k = 0; k < n / 2; k++) {
    sinCos((TAU * k) / n, sc);
    tw[2 * k] = sc[1]; tw[2 * k + 1] = sc[0];
  }
  return tw;
}

/** 2-D inverse FFT of an n×n complex grid (row-major, index j·n + i). */
export function ifft2(re, im, n, tw = twiddles(n)) {
  for (let j = 0; j < n; j++) ifft1(re, im, n, j * n, 1, tw);
  // Columns through a contiguous scratch line: strided butterflies thrash the cache.
  const cr = new Float64Array(n), ci = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    for (let j = 0; j < n; j++) { cr[j] = re[j * n + i]; ci[j] = im[j * n + i]; }
    ifft1(cr, ci, n, 0, 1, tw);
    for (let j = 0; j < n; j++) { re[j * n + i] = cr[j]; im[j * n + i] = ci[j]; }
  }
}

const GRIDS = ['h', 'dx', 'dz', 'sx', 'sz', 'jxx', 'jzz', 'jxz'];

/** Catmull–Rom weights for nodes −1, 0, 1, 2 at fraction t (sample.rs `catmull_rom`). */
const catmullRom = (t) => [0.5 * (((-t + 2.0) * t - 1.0) * t), 0.5 * ((3.0 * t - 5.0) * t * t + 2.0),
  0.5 * (((-3.0 * t + 4.0) * t + 1.0) * t), 0.5 * ((t - 1.0) * t * t)];
/** Their derivatives dw/dt (sample.rs `catmull_rom_slope`). */
const catmullRomSlope = (t) => [0.5 * ((-3.0 * t + 4.0) * t - 1.0), 0.5 * ((9.0 * t - 10.0) * t),
  0.5 * ((-9.0 * t + 8.0) * t + 1.0), 0.5 * ((3.0 * t - 2.0) * t)];

/**
 * One FFT layer, evaluated on the CPU. `new FftLayer(parseSpectrum(bytes))`; `frame(t)` gives the
 * grids at t; `sample(x0, z0, t, derivatives)` reads the layer at an undisplaced point as the
 * server does (grid times, bicubic), in the shape `Surface` sums (see surface.js).
 */
export class FftLayer {
  constructor(spectrum, { cacheFrames = 4 } = {}) {
    const { header, n, records } = spectrum;
    this.header = header;
    this.n = n;
    this.L = header.tile_size;
    this.T = header.repeat_period;
    this.lambda = header.choppiness;
    this.timeStep = header.time_step;
    this.gridSteps = header.grid_steps;
    this.records = records;
    this.tw = twiddles(n);
    this.cache = new Map();
    this.cacheFrames = cacheFrames;
    const dk = TAU / this.L;
    const h = n / 2;
    // Per record: kx, kz, |k| (the wave vector of mode (i − N/2, j − N/2)).
    this.kx = new Float64Array(n * n); this.kz = new Float64Array(n * n); this.kl = new Float64Array(n * n);
    for (let j = 0; j < n; j++) {
      for (let i = 0; i < n; i++) {
        const r = j * n + i;
        this.kx[r] = (i - h) * dk; this.kz[r] = (j - h) * dk;
        this.kl[r] = Math.sqrt(this.kx[r] * this.kx[r] + this.kz[r] * this.kz[r]);
      }
    }
  }

  /** The grids at time t (exactly t, no time grid): `{t, h, dx, dz, sx, sz, jxx, jzz, jxz}`. */
  frame(t) {
    const key = t;
    const hit = this.cache.get(key);
    if (hit) return hit;
    const { n, records, kx, kz, kl, lambda } = this;
    let tr = t % this.T;
    if (tr < 0) tr += this.T;
    const N2 = n * n;
    // Four complex transforms, two real fields each: (h, sx), (sz, dx), (dz, jxx), (jzz, jxz).
    const pairs = [['h', 'sx'], ['sz', 'dx'], ['dz', 'jxx'], ['jzz', 'jxz']];
    const bufs = pairs.map(() => [new Float64Array(N2), new Float64Array(N2)]);
    const [[b0r, b0i], [b1r, b1i], [b2r, b2i], [b3r, b3i]] = bufs;
    const sc = [0, 0];
    for (let j = 0; j < n; j++) {
      const jm = (n - j) & (n - 1);
      for (let i = 0; i < n; i++) {
        const r = j * n + i;
        const im_ = (n - i) & (n - 1);
        const rm = jm * n + im_;
        const omega = records[3 * r + 2];
        sinCos(omega * tr, sc);
        const s = sc[0], c = sc[1];
        const ar = records[3 * r], ai = records[3 * r + 1];
        const br = records[3 * rm], bi = -records[3 * rm + 1];
        // h0(k)·e^{−iωt} + conj(h0(−k))·e^{+iωt}
        const hr = (ar * c + ai * s) + (br * c - bi * s);
        const hi = (ai * c - ar * s) + (bi * c + br * s);
        if (hr === 0 && hi === 0) continue;
        const k = kl[r];
        const kxr = kx[r], kzr = kz[r];
        const ux = k > 0 ? kxr / k : 0, uz = k > 0 ? kzr / k : 0;
        // Field spectra c·h̃ with c = 1 (h), i·kx (sx), i·kz (sz), i·λ·ux (dx), i·λ·uz (dz),
        // −λ·kx·ux (jxx), −λ·kz·uz (jzz), −λ·kx·uz (jxz); two real fields A, B per transform
        // packed as A + i·B: re = A.re − B.im, im = A.im + B.re.
        const sxr = -kxr * hi, sxi = kxr * hr;
        const szr = -kzr * hi, szi = kzr * hr;
        const dxr = -lambda * ux * hi, dxi = lambda * ux * hr;
        const dzr = -lambda * uz * hi, dzi = lambda * uz * hr;
        const cxx = -lambda * kxr * ux, czz = -lambda * kzr * uz, cxz = -lambda * kxr * uz;
        b0r[r] = hr - sxi; b0i[r] = hi + sxr;
        b1r[r] = szr - dxi; b1i[r] = szi + dxr;
        b2r[r] = dzr - cxx * hi; b2i[r] = dzi + cxx * hr;
        b3r[r] = czz * hr - cxz * hi; b3i[r] = czz * hi + cxz * hr;
      }
    }
    const out = { t };
    pairs.forEach(([a, b], p) => {
      const [re, im] = bufs[p];
      ifft2(re, im, n, this.tw);
      // Mode index i − N/2: node (p, q) picks up (−1)^(p+q).
      for (let j = 0; j < n; j++) {
        for (let i = 0; i < n; i++) {
          const r = j * n + i;
          if ((i + j) & 1) { re[r] = -re[r]; im[r] = -im[r]; }
        }
      }
      out[a] = re; out[b] = im;
    });
    if (this.cache.size >= this.cacheFrames) this.cache.delete(this.cache.keys().next().value);
    this.cache.set(key, out);
    return out;
  }

  /** Grid index and weight of t on the layer's time grid (`FftLayer::grid_position`). */
  gridPosition(t) {
    let tr = t % this.T;
    if (tr < 0) tr += this.T;
    const M = this.gridSteps;
    const gt = (i) => (i % M) * this.timeStep;
    let index = Math.min(Math.floor(tr / this.timeStep), M - 1);
    if (index + 1 < M && gt(index + 1) <= tr) index += 1;
    else if (index > 0 && gt(index) > tr) index -= 1;
    const weight = Math.min(Math.max((tr - gt(index)) / this.timeStep, 0), 1);
    return { index, next: index + 1 === M ? 0 : index + 1, weight, time: gt(index), nextTime: gt(index + 1 === M ? 0 : index + 1) };
  }

  /**
   * Where (x0, z0) falls on the grid (sample.rs `grid_coord` and `Stencil`): node row j and
   * fractions fx, fz; the four columns i − 1 … i + 2, wrapped (mask m = n − 1).
   */
  stencil(x0, z0) {
    const { n, L } = this;
    const coord = (x) => {
      const u = Math.abs(x) < L ? (x < 0 ? x + L : x) : ((x % L) + L) % L;
      const g = (u * n) / L;
      const t = Math.floor(g);
      return [t & (n - 1), (g - t) + 0];
    };
    const [i, fx] = coord(x0);
    const [j, fz] = coord(z0);
    const m = n - 1;
    return { n, j, fx, fz, m, cols: [(i - 1) & m, i, (i + 1) & m, (i + 2) & m] };
  }

  /** Catmull–Rom (bicubic) read of every grid of `frame` at (x0, z0), the server's default filter. */
  read(frame, x0, z0) {
    const { n, j, fx, fz, m, cols } = this.stencil(x0, z0);
    const wx = catmullRom(fx), wz = catmullRom(fz);
    const out = {};
    for (const name of GRIDS) {
      const g = frame[name];
      let acc = 0;
      for (let b = 0; b < 4; b++) {
        const row = ((j + b - 1) & m) * n;
        let r = 0;
        for (let a = 0; a < 4; a++) r += wx[a] * g[row + cols[a]];
        acc += wz[b] * r;
      }
      out[name] = acc;
    }
    return out;
  }

  /**
   * The horizontal Jacobian a Newton step uses at (x0, z0) (sample.rs
   * `FftFrame::newton_jacobian`): the derivatives of the Catmull–Rom interpolant of the
   * frame's dx and dz grids, `{jxx, jzz, jxz}` with jxz the mean of the two cross terms.
   */
  readNewton(frame, x0, z0) {
    const { n, j, fx, fz, m, cols } = this.stencil(x0, z0);
    const wx = catmullRom(fx), wz = catmullRom(fz);
    const dwx = catmullRomSlope(fx), dwz = catmullRomSlope(fz);
    const grad = (g) => {
      let gx = 0, gz = 0;
      for (let b = 0; b < 4; b++) {
        const row = ((j + b - 1) & m) * n;
        let rv = 0, rd = 0;
        for (let a = 0; a < 4; a++) {
          const v = g[row + cols[a]];
          rv += wx[a] * v;
          rd += dwx[a] * v;
        }
        gx += wz[b] * rd;
        gz += dwz[b] * rv;
      }
      return [gx, gz];
    };
    const s = n / this.L;
    const [xx, xz] = grad(frame.dx);
    const [zx, zz] = grad(frame.dz);
    return { jxx: xx * s, jzz: zz * s, jxz: 0.5 * (xz * s + zx * s) };
  }

  /**
   * The layer at undisplaced (x0, z0), time t: `{d, dx, dz}` as `Surface.sample` sums it.
   * `derivatives`: false (displacement only), true (the Jacobian and slope grids) or
   * `'newton'` (an inversion round: the Jacobian of `readNewton`, no slopes).
   */
  sample(x0, z0, t, derivatives = false) {
    const p = this.gridPosition(t);
    const newton = derivatives === 'newton';
    const readAt = (time) => {
      const f = this.frame(time);
      const v = this.read(f, x0, z0);
      if (newton) Object.assign(v, this.readNewton(f, x0, z0), { sx: 0, sz: 0 });
      return v;
    };
    let v = readAt(p.time);
    if (p.weight > 0) {
      const b = readAt(p.nextTime);
      const w = p.weight;
      const lerp = {};
      for (const k of GRIDS) lerp[k] = v[k] + (b[k] - v[k]) * w;
      v = lerp;
    }
    const out = { d: [v.dx, v.h, v.dz], dx: [0, 0, 0], dz: [0, 0, 0] };
    if (derivatives) {
      out.dx = [v.jxx, v.sx, v.jxz];
      out.dz = [v.jxz, v.sz, v.jzz];
    }
    return out;
  }
}
