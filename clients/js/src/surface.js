// Local evaluation of a scene's sine and Gerstner layers, to the server's bits.
//
// A port of crates/swell-waves: wave.rs (`WaveSoA::kernel`: per-wave factors formed once, the
// phase `k·(dx·x + dz·z) − ω·t + φ` reduced, then the nine sums in wave order), surface.rs
// (layers in order, one accumulator), query.rs (`invert_lanes`, `inversion_step`,
// `query_lanes`) and the normal/Jacobian of `SurfaceSample`. Every operation is a correctly
// rounded IEEE double operation in the model's order, so the results are the model's bits
// (checked against proto/vectors/surface_v1.json by test/golden.test.js).
//
// FFT layers are not analytic: a `Surface` built with FFT layers needs an `fft` evaluator per
// FFT layer (see fft.js, within a documented tolerance of the server) or refuses to evaluate.
// Particle layers (particles.js) are evaluated to the server's bits, with the rings of the
// surface's `impacts` (an ImpactSet) on its first particle layer, as the server does.

import { TAU, reducePhase, sinCos } from './math.js';
import { ArgumentError } from './errors.js';
import { ParticleLayer, ImpactSet, MAX_SHADER_PARTICLES } from './particles.js';

/** Standard gravity, m/s² (the model's default). */
export const STANDARD_GRAVITY = 9.81;

/** A fresh zeroed sample: `d` = (Dx, y, Dz), `dx` = ∂d/∂x0, `dz` = ∂d/∂z0 (world metres). */
export function emptySample() {
  return { d: [0, 0, 0], dx: [0, 0, 0], dz: [0, 0, 0] };
}

/** Default inversion: Newton, 8 steps, 1e-5 m (query.rs `Inversion::default`). */
export const DEFAULT_INVERSION = Object.freeze({ method: 'newton', iterations: 8, tolerance: 1e-5 });

function checkWave(w, where) {
  for (const f of ['amplitude', 'wavenumber', 'omega', 'phase', 'steepness']) {
    if (typeof w[f] !== 'number' || !Number.isFinite(w[f])) {
      throw new ArgumentError(`${where}.${f}`, `${where}.${f} must be a finite number, got ${w[f]}`);
    }
  }
  const d = w.direction;
  if (!Array.isArray(d) || d.length !== 2 || !d.every(Number.isFinite)) {
    throw new ArgumentError(`${where}.direction`, `${where}.direction must be [x, z], got ${JSON.stringify(d)}`);
  }
}

/**
 * The analytic waves of a scene, and its FFT layers as placeholders, ready to evaluate.
 *
 * Build it from a scene's `derived` block (`Surface.fromDerived(scene.derived)`, every built
 * wave exactly as the server evaluates it) or, for deep-water specs with explicit waves only,
 * from a surface spec (`Surface.fromSpec`).
 */
export class Surface {
  /**
   * @param {Array<{kind: string, waves?: object[]}>} layers  layers in order; sine/gerstner with
   *   built waves `{amplitude, wavenumber, omega, direction: [x, z], phase, steepness}`.
   * @param {{fft?: Array<object|null>, impacts?: ImpactSet, gravity?: number, depth?: number|null}} [options]
   *   `fft`: per layer index, an FFT evaluator with `sample(x0, z0, t, derivatives)` returning
   *   `{d, dx, dz}`, derivatives false, true or 'newton' (see fft.js `FftLayer.sample`); `impacts`: the scene's impacts (default an empty set, filled
   *   by the caller: `surface.impacts.addAll(...)`); `gravity`, `depth`: the surface's
   *   dispersion, for the speed of impact rings (`fromDerived` passes the scene's).
   */
  constructor(layers, options = {}) {
    if (!Array.isArray(layers) || layers.length === 0) {
      throw new ArgumentError('layers', 'a surface needs at least one layer');
    }
    this.impacts = options.impacts ?? new ImpactSet();
    const dispersion = { gravity: options.gravity ?? STANDARD_GRAVITY, depth: options.depth ?? null };
    this.layers = layers.map((l, i) => {
      if (l.kind === 'fft') {
        return { kind: 'fft', info: l, fft: options.fft?.[i] ?? null };
      }
      if (l.kind === 'particles') {
        return { kind: 'particles', info: l, particles: new ParticleLayer(l, dispersion, `layers[${i}]`) };
      }
      if (l.kind !== 'sine' && l.kind !== 'gerstner') {
        throw new ArgumentError(`layers[${i}].kind`, `unknown layer kind ${JSON.stringify(l.kind)}`);
      }
      if (!Array.isArray(l.waves)) throw new ArgumentError(`layers[${i}].waves`, 'waves must be an array');
      l.waves.forEach((w, j) => checkWave(w, `layers[${i}].waves[${j}]`));
      const n = l.waves.length;
      const col = (f) => Float64Array.from(l.waves, f);
      // The factors WaveSoA::new forms, each rounded as the model rounds it.
      return {
        kind: l.kind,
        waves: l.waves,
        n,
        k: col((w) => w.wavenumber),
        om: col((w) => w.omega),
        ph: col((w) => w.phase),
        dxs: col((w) => w.direction[0]),
        dzs: col((w) => w.direction[1]),
        a: col((w) => w.amplitude),
        qadx: col((w) => w.steepness * w.amplitude * w.direction[0]),
        qadz: col((w) => w.steepness * w.amplitude * w.direction[1]),
        ak: col((w) => w.amplitude * w.wavenumber),
        qak: col((w) => w.steepness * w.amplitude * w.wavenumber),
      };
    });
    this.horizontal = this.layers.some((l) =>
      l.kind === 'fft' ? l.info.choppiness > 0 : l.kind === 'gerstner' && l.waves.some((w) => w.steepness > 0));
    this._sc = [0, 0];
    this._pv = [0, 0, 0];
    this._rings = { t: NaN, version: -1, rings: [] };
    // The layer impacts ripple on: the first particle layer (surface.rs `impact_layer`).
    this.impactLayer = this.layers.find((l) => l.kind === 'particles') ?? null;
  }

  /** The rings of `impacts` alive at t on the impact layer, `[{ring, state, invR2}]` (cached per t and set version). */
  liveRings(t) {
    const c = this._rings;
    if (!Object.is(c.t, t) || c.version !== this.impacts.version) {
      c.rings = this.impactLayer ? this.impactLayer.particles.liveRings(t, this.impacts) : [];
      c.t = t;
      c.version = this.impacts.version;
    }
    return c.rings;
  }

  /** From a scene's `derived` (GET /v1/scenes/{id}). */
  static fromDerived(derived, options) {
    if (!derived || !Array.isArray(derived.layers)) {
      throw new ArgumentError('derived', 'derived.layers is missing: pass scene.derived from GET /v1/scenes/{id}');
    }
    return new Surface(derived.layers, { gravity: derived.gravity, depth: derived.depth, ...options });
  }

  /**
   * From a surface spec with explicit sine/Gerstner waves in deep water (no `depth`, no
   * cascade or spectrum generator): k = 2π/λ, ω = sqrt(g·k) or c·k, direction normalised, φ
   * reduced, as `Wave::build` does. Anything else needs the server's built waves
   * (`fromDerived`), since generators and finite depth use library functions (tanh, the RNG)
   * this client does not port.
   */
  static fromSpec(spec) {
    const g = spec.gravity ?? STANDARD_GRAVITY;
    if (spec.depth != null) {
      throw new ArgumentError('depth', 'finite depth needs tanh from the model: build from scene.derived');
    }
    const layers = spec.layers.map((l, i) => {
      if (l.kind !== 'sine' && l.kind !== 'gerstner') {
        throw new ArgumentError(`layers[${i}].kind`, `${l.kind} layers cannot be built locally: use scene.derived`);
      }
      if (l.cascade || l.spectrum) {
        throw new ArgumentError(`layers[${i}]`, 'generated waves (cascade, spectrum) come from scene.derived');
      }
      return {
        kind: l.kind,
        waves: l.waves.map((w, j) => buildWave(w, l.kind === 'gerstner' ? w.steepness : 0, g, `layers[${i}].waves[${j}]`)),
      };
    });
    return new Surface(layers);
  }

  /** Every analytic wave in shader slot order (layer order, then wave order). */
  analyticWaves() {
    return this.layers.flatMap((l) => (l.kind === 'fft' || l.kind === 'particles' ? [] : l.waves));
  }

  /**
   * Sum of every layer's displacement (Dx, y, Dz) at the undisplaced point (x0, z0), time t,
   * and its derivatives when `derivatives` (else those stay 0); `'newton'` gives an inversion
   * round's (FFT layers' Jacobian from their displacement interpolant). `surface.rs sample_lanes`.
   */
  sample(x0, z0, t, derivatives = false, out = emptySample()) {
    const sc = this._sc;
    const { d, dx: ddx, dz: ddz } = out;
    for (const L of this.layers) {
      if (L.kind === 'fft') {
        if (!L.fft) throw new Error('this surface has an FFT layer and no FFT evaluator for it (see fft.js)');
        const s = L.fft.sample(x0, z0, t, derivatives);
        d[0] += s.d[0]; d[1] += s.d[1]; d[2] += s.d[2];
        if (derivatives) {
          ddx[0] += s.dx[0]; ddx[1] += s.dx[1]; ddx[2] += s.dx[2];
          ddz[0] += s.dz[0]; ddz[1] += s.dz[1]; ddz[2] += s.dz[2];
        }
        continue;
      }
      if (L.kind === 'particles') {
        // The layer's own sums, then added to the surface's (surface.rs `add_particles`):
        // particles move the surface vertically only.
        const rings = L === this.impactLayer ? this.liveRings(t) : [];
        const p = L.particles.sample(x0, z0, t, rings, this._pv);
        d[1] += p[0];
        if (derivatives) {
          ddx[1] += p[1];
          ddz[1] += p[2];
        }
        continue;
      }
      const { n, k, om, ph, dxs, dzs, a, qadx, qadz, ak, qak } = L;
      for (let w = 0; w < n; w++) {
        const wt = om[w] * t;
        const dxw = dxs[w];
        const dzw = dzs[w];
        const along = dxw * x0 + dzw * z0;
        sinCos(reducePhase(k[w] * along - wt + ph[w]), sc);
        const s = sc[0];
        const c = sc[1];
        d[0] += qadx[w] * c;
        d[1] += a[w] * s;
        d[2] += qadz[w] * c;
        if (derivatives) {
          const akc = ak[w] * c;
          const qaks = qak[w] * s;
          ddx[0] -= qaks * dxw * dxw;
          ddx[1] += akc * dxw;
          ddx[2] -= qaks * dxw * dzw;
          ddz[0] -= qaks * dxw * dzw;
          ddz[1] += akc * dzw;
          ddz[2] -= qaks * dzw * dzw;
        }
      }
    }
    return out;
  }

  /**
   * Solves `p0 + D(p0, t) = (x, z)` (query.rs `invert_lanes` for one lane): returns the best
   * iterate `{source: [x0, z0], sample, residual, iterations}`.
   */
  invert(x, z, t, derivatives = false, inversion = DEFAULT_INVERSION) {
    if (!this.horizontal) {
      return { source: [x, z], sample: this.sample(x, z, t, derivatives), residual: 0, iterations: 0 };
    }
    const newton = inversion.method !== 'fixed_point';
    const fft = this.layers.some((L) => L.kind === 'fft');
    // What a round reads (query.rs `invert_lanes_v`): Newton's Jacobian (an FFT layer's from
    // its displacement grids' interpolant); the Jacobian and slope grids of an FFT layer only
    // in one more evaluation at the point kept, for a caller that wants derivatives.
    const rounds = newton ? 'newton' : derivatives && !fft;
    let px = x;
    let pz = z;
    let best = null;
    for (let it = 0; ; it++) {
      const s = this.sample(px, pz, t, rounds);
      const fx = (px + s.d[0]) - x;
      const fz = (pz + s.d[2]) - z;
      const r = Math.sqrt(fx * fx + fz * fz);
      if (best === null || r < best.residual) {
        best = { source: [px, pz], sample: s, residual: r, iterations: it };
      }
      if (r <= inversion.tolerance || it >= inversion.iterations || !Number.isFinite(r)) break;
      let sx = fx;
      let sz = fz;
      if (newton) {
        const a = 1.0 + s.dx[0];
        const b = s.dz[0];
        const c = s.dx[2];
        const dd = 1.0 + s.dz[2];
        const det = a * dd - b * c;
        if (det > 1e-9) {
          sx = (dd * fx - b * fz) / det;
          sz = (a * fz - c * fx) / det;
        }
      }
      px -= sx;
      pz -= sz;
    }
    if (derivatives && fft) best.sample = this.sample(best.source[0], best.source[1], t, true);
    return best;
  }

  /** Height of the surface above world (x, z) at t, m (with inversion). */
  height(x, z, t, inversion) {
    return this.invert(x, z, t, false, inversion).sample.d[1];
  }

  /**
   * Every field `/sample` answers at world (x, z), time t, as the server computes it:
   * `{height, normal: [x,y,z], displacement: [Dx,y,Dz], jacobian, folded, residual}`.
   * `fields` limits the work (names as on the wire); fields not asked keep their defaults.
   */
  query(x, z, t, fields = ['height', 'normal', 'displacement', 'jacobian', 'residual'], inversion) {
    const want = new Set(fields);
    const out = { height: 0, normal: [0, 1, 0], displacement: [0, 0, 0], jacobian: 1, folded: false, residual: 0 };
    if (want.has('height') || want.has('normal') || want.has('jacobian') || want.has('residual')) {
      const derivs = want.has('normal') || want.has('jacobian');
      const inv = this.invert(x, z, t, derivs, inversion);
      if (want.has('height')) out.height = inv.sample.d[1];
      if (want.has('normal')) out.normal = normalOf(inv.sample);
      if (want.has('jacobian')) {
        out.jacobian = jacobianOf(inv.sample);
        out.folded = out.jacobian <= 0.0;
      }
      if (want.has('residual')) out.residual = inv.residual;
    }
    if (want.has('displacement')) out.displacement = this.sample(x, z, t, false).d.slice();
    return out;
  }

  /**
   * The frame's uniform block for the exported shaders (docs/clients.md), in f64:
   * `phases[i] = wrap(k_i·(d_i·o) − ω_i·t + φ_i)` for every sine and Gerstner wave, and `block`,
   * those rounded to f32 and padded to `4·max(1, ⌈n/4⌉)` values, then, for a surface with one
   * particle layer of at most 512 particles (what the shader exports), the particle members with
   * the live rings of `impacts` (particles.js `shaderBlock`), then one vec4 per FFT layer (its
   * grid offset). Equal to GET …/uniforms.
   */
  uniforms(t, origin = [0, 0]) {
    if (!Number.isFinite(t)) throw new ArgumentError('t', `t must be finite, got ${t}`);
    if (!Array.isArray(origin) || origin.length !== 2 || !origin.every(Number.isFinite)) {
      throw new ArgumentError('origin', `origin must be two finite numbers [x, z], got ${JSON.stringify(origin)}`);
    }
    const [ox, oz] = origin;
    const phases = [];
    for (const L of this.layers) {
      if (L.kind === 'fft' || L.kind === 'particles') continue;
      for (let w = 0; w < L.n; w++) {
        const along = L.dxs[w] * ox + L.dzs[w] * oz;
        phases.push(reducePhase(L.k[w] * along - L.om[w] * t + L.ph[w]));
      }
    }
    const waves = 4 * Math.max(1, Math.ceil(phases.length / 4));
    const particleLayers = this.layers.filter((l) => l.kind === 'particles');
    const exported = particleLayers.length === 1 && particleLayers[0].particles.count <= MAX_SHADER_PARTICLES;
    const more = exported ? particleLayers[0].particles.shaderBlock(t, [ox, oz], this.impacts) : null;
    // Then one vec4 per FFT layer: the origin's grid coordinate on its tile, (o mod L)·N/L per
    // axis (Rust's rem_euclid, then ·N/L, in that order: the server's bits), for the exported
    // shader's FFT sampling (crates/swell-shaders/src/fft.rs).
    const ffts = this.layers.filter((l) => l.kind === 'fft');
    const head = waves + (more ? more.values.length : 0);
    const block = new Float32Array(head + 4 * ffts.length);
    phases.forEach((p, i) => { block[i] = p; });
    if (more) block.set(more.values, waves);
    const grid = (x, L, n) => {
      let r = x % L;
      if (r < 0) r += L;
      const v = (r * n) / L;
      return v >= n ? 0 : v;
    };
    ffts.forEach((l, f) => {
      block[head + 4 * f] = grid(ox, l.info.tile_size, l.info.resolution);
      block[head + 4 * f + 1] = grid(oz, l.info.tile_size, l.info.resolution);
    });
    return { t, origin: [ox, oz], phases, block, ringsDropped: more ? more.ringsDropped : 0 };
  }
}

/** Unit normal of the displaced surface (`SurfaceSample::normal`), straight up at a fold's edge. */
export function normalOf(s) {
  // (e_x + dx) and (e_z + dz); `0 + v` as glam adds the unit vector (it turns -0 into +0).
  const tx0 = 1.0 + s.dx[0], tx1 = 0.0 + s.dx[1], tx2 = 0.0 + s.dx[2];
  const tz0 = 0.0 + s.dz[0], tz1 = 0.0 + s.dz[1], tz2 = 1.0 + s.dz[2];
  const nx = tz1 * tx2 - tx1 * tz2;
  const ny = tz2 * tx0 - tx2 * tz0;
  const nz = tz0 * tx1 - tx0 * tz1;
  const len = Math.sqrt(nx * nx + ny * ny + nz * nz);
  if (len > 1e-300 && Number.isFinite(len)) return [nx / len, ny / len, nz / len];
  return [0, 1, 0];
}

/** Jacobian determinant of p0 ↦ p0 + (Dx, Dz): `(1 + ∂Dx/∂x)(1 + ∂Dz/∂z) − (∂Dx/∂z)(∂Dz/∂x)`. */
export function jacobianOf(s) {
  return (1.0 + s.dx[0]) * (1.0 + s.dz[2]) - s.dz[0] * s.dx[2];
}

function buildWave(w, steepness, g, where) {
  const need = (f, v, ok, allowed) => {
    if (typeof v !== 'number' || !Number.isFinite(v) || !ok(v)) {
      throw new ArgumentError(`${where}.${f}`, `${where}.${f} = ${v}: ${allowed}`);
    }
  };
  need('amplitude', w.amplitude, (v) => v >= 0, 'a finite amplitude >= 0 m');
  need('wavelength', w.wavelength, (v) => v > 0, 'a finite wavelength > 0 m');
  const phase = w.phase ?? 0;
  need('phase', phase, () => true, 'a finite phase');
  need('steepness', steepness ?? 0, (v) => v >= 0 && v <= 1, 'in [0, 1]');
  const [x, z] = w.direction;
  let len = Math.sqrt(x * x + z * z);
  let dir;
  if (len > 0 && Number.isFinite(len)) dir = [x / len, z / len];
  else if (len > 0) {
    const m = Math.max(Math.abs(x), Math.abs(z));
    const ux = x / m, uz = z / m;
    len = Math.sqrt(ux * ux + uz * uz);
    dir = [ux / len, uz / len];
  } else throw new ArgumentError(`${where}.direction`, `${where}.direction must not be zero`);
  const k = TAU / w.wavelength;
  let omega;
  if (w.speed != null) {
    need('speed', w.speed, (v) => v > 0, 'a finite speed > 0 m/s');
    omega = w.speed * k;
  } else omega = Math.sqrt(g * k);
  return { amplitude: w.amplitude, wavenumber: k, omega, direction: dir, phase: reducePhase(phase), steepness: steepness ?? 0 };
}
