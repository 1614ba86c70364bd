// The particle layer (wave particles): ambient particles on a periodic tile and rings from impact
// events, evaluated to the server's bits. A port of crates/swell-waves/src/particles: kernel.rs
// (`kernel`), ambient.rs (`position`, the cell grid and `visit`), ripple.rs (`Ring::new`,
// `Ring::state`, `Impacts::window`, canonical order) and field.rs (`visit_ring`, ambient first,
// then rings in canonical order), with the same operations in the same order, so a height or
// gradient summed here is the server's.
//
// The ambient particles come from the scene's `derived` layer: `particles_tile` holds each
// particle's start `u0` and velocity `w` in tile units, exactly the model's values (positions at t
// are `wrap(u0 + w·t)`); the amplitudes from `particles`. The ring maths needs `exp` and `atan2`
// (and `tanh` on finite depth), ported from the model's libm in libm.js.

import { TAU, roundTiesAway, sinCos, signBit } from './math.js';
import { exp, atan2, tanh } from './libm.js';
import { ArgumentError } from './errors.js';

/** Cells per tile side at most (ambient.rs `MAX_CELLS`). */
const MAX_CELLS = 128;
/** Live rings above which the server indexes rings in a grid; the grid never changes a result. */
export const MAX_LIVE_RINGS = 4096;
/**
 * Rings that count at one point at most (field.rs `MAX_RINGS_PER_POINT`): where more rings'
 * annuli cover a point, only the newest this many (last in canonical order) add to it.
 */
export const MAX_RINGS_PER_POINT = 32;
/** Ambient particles and live rings the exported shader carries (swell-shaders particles.rs). */
export const MAX_SHADER_PARTICLES = 512;
export const MAX_SHADER_RINGS = 32;

/** `u − floor(u)`, and 0 where that rounds up to 1 (ambient.rs `wrap`). */
export function wrap(u) {
  const v = u - Math.floor(u);
  return v >= 1.0 ? 0.0 : v;
}

/**
 * The kernel `a·(1 − q²)³` and its gradient for the offset (dx, dz), written into `out` as
 * `[h, gx, gz]`; returns false outside the support (kernel.rs `kernel`, same operations).
 */
export function kernel(a, dx, dz, invR2, out) {
  const q2 = (dx * dx + dz * dz) * invR2;
  if (q2 >= 1.0) return false;
  const w = 1.0 - q2;
  const w2 = w * w;
  const g = -6.0 * a * w2 * invR2;
  out[0] = a * (w2 * w);
  out[1] = g * dx;
  out[2] = g * dz;
  return true;
}

/** IEEE total order of two finite doubles (Rust's `f64::total_cmp` without NaNs): −0 < +0. */
function totalCmp(a, b) {
  if (a < b) return -1;
  if (a > b) return 1;
  if (a === 0 && b === 0) {
    const sa = signBit(a), sb = signBit(b);
    return sa === sb ? 0 : sa ? -1 : 1;
  }
  return 0;
}

/** The canonical order of impacts: t, then x, z, strength, radius (ripple.rs `canonical_cmp`). */
export function canonicalCmp(a, b) {
  return totalCmp(a.t, b.t) || totalCmp(a.position[0], b.position[0])
    || totalCmp(a.position[1], b.position[1]) || totalCmp(a.strength, b.strength)
    || totalCmp(a.radius, b.radius);
}

function checkImpact(e, where) {
  const fin = (v) => typeof v === 'number' && Number.isFinite(v);
  if (!e || !fin(e.t) || !Array.isArray(e.position) || e.position.length !== 2 || !e.position.every(fin)
    || !fin(e.strength) || !fin(e.radius)) {
    throw new ArgumentError(where, `${where} must be {t, position: [x, z], strength, radius} with finite numbers, got ${JSON.stringify(e)}`);
  }
}

/**
 * A scene's impacts in canonical order, as the server keeps them: fill it from
 * `GET …/impacts` and the `impacts` of tick frames. An impact seen twice (in the list and in a
 * frame) is kept once: two impacts equal in every field cannot be told apart on the wire, so
 * the client merges them (the server would sum both rings).
 */
export class ImpactSet {
  constructor(events = []) {
    this.events = [];
    this.version = 0;
    this.addAll(events);
  }

  /** Adds one impact (`{t, position: [x, z], strength, radius}`, extra fields ignored); false if already held. */
  add(e) {
    checkImpact(e, 'impact');
    const ev = { t: e.t, position: [e.position[0], e.position[1]], strength: e.strength, radius: e.radius };
    // partition_point(|x| x <= ev): insert after every equal one, as `Impacts::with` does.
    let lo = 0, hi = this.events.length;
    while (lo < hi) {
      const mid = (lo + hi) >>> 1;
      if (canonicalCmp(this.events[mid], ev) <= 0) lo = mid + 1; else hi = mid;
    }
    if (lo > 0 && canonicalCmp(this.events[lo - 1], ev) === 0) return false;
    this.events.splice(lo, 0, ev);
    this.version++;
    return true;
  }

  /** Adds every impact of a list; returns how many were new. */
  addAll(list) {
    let n = 0;
    for (const e of list ?? []) if (this.add(e)) n++;
    return n;
  }

  /** Drops impacts older than `t − keep` s (they cannot ripple at t or later). */
  prune(t, keep) {
    const lo = this.events.findIndex((e) => !(t - e.t > keep));
    const cut = lo < 0 ? this.events.length : lo;
    if (cut > 0) { this.events.splice(0, cut); this.version++; }
  }

  get size() { return this.events.length; }

  /** Impacts with t0 in `[t − lifetime, t]`, in canonical order (ripple.rs `Impacts::window`). */
  window(t, lifetime) {
    const ev = this.events;
    let hi = 0;
    { let a = 0, b = ev.length; while (a < b) { const m = (a + b) >>> 1; if (ev[m].t <= t) a = m + 1; else b = m; } hi = a; }
    let lo = 0;
    { let a = 0, b = hi; while (a < b) { const m = (a + b) >>> 1; if (t - ev[m].t > lifetime) a = m + 1; else b = m; } lo = a; }
    return ev.slice(lo, hi);
  }
}

/** `3^g` as a double (ripple.rs `pow3`). */
function pow3(g) {
  let p = 1.0;
  for (let i = 0; i < g; i++) p *= 3.0;
  return p;
}

/** `(cos, sin)(2π·i/n)`: particle i of n's unit direction (ripple.rs `direction`). */
function direction(i, n, out) {
  sinCos(TAU * (i / n), out);
  const s = out[0];
  out[0] = out[1];
  out[1] = s;
  return out;
}

/**
 * A ring: one impact under a layer's ripple settings, in closed form (ripple.rs `Ring`).
 */
export class Ring {
  constructor(impact, ripples, omega) {
    const n0 = ripples.particles;
    let maxGeneration = 0;
    while (n0 * 3 ** (maxGeneration + 1) <= ripples.max_ring_particles) maxGeneration++;
    this.t0 = impact.t;
    this.center = [impact.position[0], impact.position[1]];
    this.radius = impact.radius;
    const k = Math.PI / (2.0 * impact.radius);
    this.speed = omega(k) / k;
    this.n0 = n0;
    this.a0 = impact.strength / n0;
    this.split0 = impact.radius * n0 / TAU;
    this.maxGeneration = maxGeneration;
    this.decay = ripples.decay;
    this.floor = ripples.floor;
    this.lifetime = ripples.lifetime;
  }

  /** `D_g = D_0·3^g`, m. */
  splitDistance(g) { return this.split0 * pow3(g); }

  /** `{distance, generation, count, amplitude}` at t, or null when the ring is not alive. */
  state(t) {
    const age = t - this.t0;
    if (!(age >= 0.0 && age <= this.lifetime)) return null;
    const d = this.speed * age;
    let g = 0;
    while (d > this.splitDistance(g)) {
      if (g === this.maxGeneration) return null;
      g++;
    }
    const amplitude = this.a0 / pow3(g) * exp(-d / this.decay);
    if (amplitude < this.floor) return null;
    return { distance: d, generation: g, count: this.n0 * 3 ** g, amplitude };
  }
}

/**
 * One particle layer, built from its entry in a scene's `derived.layers` (GET /v1/scenes/{id}),
 * and the surface's dispersion (`gravity`, `depth` of `derived`).
 */
export class ParticleLayer {
  constructor(info, { gravity = 9.81, depth = null } = {}, where = 'layer') {
    const need = (f, ok, what) => {
      if (!ok(info[f])) throw new ArgumentError(`${where}.${f}`, `${where}.${f} = ${JSON.stringify(info[f])}: ${what}`);
    };
    const pos = (v) => typeof v === 'number' && Number.isFinite(v) && v > 0;
    need('tile_size', pos, 'a tile size > 0 m');
    need('radius', pos, 'a radius > 0 m');
    need('scales', (v) => Array.isArray(v) && v.length > 0 && v.every(pos), 'a list of scales > 0');
    need('particles', Array.isArray, 'the ambient particles [[x0, z0, vx, vz, a], ...] (scene.derived)');
    need('ripples', (v) => v && typeof v === 'object', 'the ripple settings');
    this.info = info;
    this.tile = info.tile_size;
    this.radius = info.radius;
    this.scales = info.scales.slice();
    this.invSl = this.scales.map((s) => 1.0 / (s * this.tile));
    const rr = this.radius / this.tile;
    this.invRr2 = 1.0 / (rr * rr);
    const cells = Math.min(Math.floor(0.999 / rr), MAX_CELLS);
    this.cells = cells < 3 ? 1 : cells;
    this.ripples = info.ripples;
    this.gravity = gravity;
    this.depth = depth;
    const n = info.particles.length;
    this.count = n;
    this.u0x = new Float64Array(n); this.u0z = new Float64Array(n);
    this.wx = new Float64Array(n); this.wz = new Float64Array(n);
    this.amp = new Float64Array(n);
    const tileList = info.particles_tile;
    // Without the tile-unit list (a server before it), metres divided by L: exact when L is a
    // power of two (the model's values were multiplied by L), otherwise within an ulp.
    this.exact = Array.isArray(tileList) && tileList.length === n;
    if (!this.exact) {
      const m = Math.log2(this.tile);
      this.exact = Number.isInteger(m);
    }
    for (let i = 0; i < n; i++) {
      const p = info.particles[i];
      this.amp[i] = p[4];
      if (Array.isArray(tileList) && tileList.length === n) {
        const q = tileList[i];
        this.u0x[i] = q[0]; this.u0z[i] = q[1]; this.wx[i] = q[2]; this.wz[i] = q[3];
      } else {
        this.u0x[i] = p[0] / this.tile; this.u0z[i] = p[1] / this.tile;
        this.wx[i] = p[2] / this.tile; this.wz[i] = p[3] / this.tile;
      }
    }
    this._grid = null;
    this._k = [0, 0, 0];
    this._dir = [0, 0];
  }

  /** ω(k) of the surface: `sqrt(g·k)`, or `sqrt(g·k·tanh(k·h))` at depth h (dispersion.rs). */
  omega(k) {
    return this.depth == null ? Math.sqrt(this.gravity * k) : Math.sqrt(this.gravity * k * tanh(k * this.depth));
  }

  /** The ring an impact makes on this layer. */
  ring(impact) { return new Ring(impact, this.ripples, (k) => this.omega(k)); }

  /** Particle i's position at t in tile units, `[wrap(u0x + wx·t), wrap(u0z + wz·t)]`. */
  position(i, t) {
    return [wrap(this.u0x[i] + this.wx[i] * t), wrap(this.u0z[i] + this.wz[i] * t)];
  }

  _cellOf(v) { return Math.min(Math.floor(v * this.cells), this.cells - 1); }

  /** Every particle's position at t bucketed by cell, stable in index (ambient.rs `grid`). */
  grid(t) {
    if (this._grid && Object.is(this._grid.t, t)) return this._grid;
    const n = this.cells, len = this.count;
    const px = new Float64Array(len), pz = new Float64Array(len), cell = new Int32Array(len);
    for (let i = 0; i < len; i++) {
      px[i] = wrap(this.u0x[i] + this.wx[i] * t);
      pz[i] = wrap(this.u0z[i] + this.wz[i] * t);
      cell[i] = this._cellOf(pz[i]) * n + this._cellOf(px[i]);
    }
    const start = new Int32Array(n * n + 1);
    for (let i = 0; i < len; i++) start[cell[i] + 1]++;
    for (let c = 0; c < n * n; c++) start[c + 1] += start[c];
    const fill = start.slice();
    const gx = new Float64Array(len), gz = new Float64Array(len), ga = new Float64Array(len);
    for (let i = 0; i < len; i++) {
      const k = fill[cell[i]]++;
      gx[k] = px[i]; gz[k] = pz[i]; ga[k] = this.amp[i];
    }
    this._grid = { t, start, gx, gz, ga };
    return this._grid;
  }

  /**
   * The rings of `impacts` alive at t, in canonical order: `[{ring, state, invR2}]`
   * (mod.rs `live_rings` and `field`).
   *
   * @throws {Error} over MAX_LIVE_RINGS rings alive at t (the server answers 4xx then).
   */
  liveRings(t, impacts) {
    if (!impacts || impacts.size === 0) return [];
    const out = [];
    for (const e of impacts.window(t, this.ripples.lifetime)) {
      const ring = this.ring(e);
      const st = ring.state(t);
      if (st) out.push({ ring, state: st, invR2: 1.0 / (ring.radius * ring.radius) });
    }
    if (out.length > MAX_LIVE_RINGS) throw new Error(`${out.length} rings alive at t = ${t}: at most ${MAX_LIVE_RINGS}`);
    return out;
  }

  /**
   * Height and gradient of the layer at world (x, z), time t, with the live rings `rings`
   * (from `liveRings(t, …)`): `[h, ∂h/∂x, ∂h/∂z]`, summed as the server sums them (ambient:
   * scales in order, the 3×3 cells around the point row by row, particles by index; then each
   * ring's particles in its angular window).
   */
  sample(x, z, t, rings = [], out = [0, 0, 0]) {
    let h = 0.0, gx = 0.0, gz = 0.0;
    const kv = this._k;
    if (this.count > 0) {
      const grid = this.grid(t);
      const n = this.cells;
      for (let si = 0; si < this.scales.length; si++) {
        // Every scale is kept: queries filter with min_wavelength 0 (surface.rs `add_particles`).
        const s = this.scales[si], inv = this.invSl[si];
        const qx = wrap(x * inv), qz = wrap(z * inv);
        const cx = this._cellOf(qx), cz = this._cellOf(qz);
        const visitCell = (c) => {
          const lo = grid.start[c], hi = grid.start[c + 1];
          for (let k = lo; k < hi; k++) {
            let dx = qx - grid.gx[k];
            let dz = qz - grid.gz[k];
            dx -= roundTiesAway(dx);
            dz -= roundTiesAway(dz);
            if (kernel(s * grid.ga[k], dx, dz, this.invRr2, kv)) {
              h += kv[0];
              gx += kv[1] * inv;
              gz += kv[2] * inv;
            }
          }
        };
        if (n === 1) { visitCell(0); continue; }
        for (const oz of [n - 1, 0, 1]) {
          for (const ox of [n - 1, 0, 1]) {
            visitCell(((cz + oz) % n) * n + ((cx + ox) % n));
          }
        }
      }
    }
    // The newest MAX_RINGS_PER_POINT rings whose annulus covers the point (field.rs
    // `visit_rings`), then summed oldest first, in canonical order.
    let first = 0;
    if (rings.length > MAX_RINGS_PER_POINT) {
      let found = 0;
      first = rings.length;
      for (let i = rings.length - 1; i >= 0 && found < MAX_RINGS_PER_POINT; i--) {
        if (this.covers(rings[i], x, z)) { found++; first = i; }
      }
    }
    for (let i = first; i < rings.length; i++) {
      const acc = this._ring(rings[i], x, z, kv);
      if (acc) for (let j = 0; j < acc.length; j += 3) { h += acc[j]; gx += acc[j + 1]; gz += acc[j + 2]; }
    }
    out[0] = h; out[1] = gx; out[2] = gz;
    return out;
  }

  /** Whether live ring r's annulus covers (x, z): `|ρ − d| < r` (field.rs `reaches`). */
  covers(r, x, z) {
    const relx = x - r.ring.center[0];
    const relz = z - r.ring.center[1];
    const rho = Math.sqrt(relx * relx + relz * relz);
    return Math.abs(rho - r.state.distance) < r.ring.radius;
  }

  // One ring's particles near (x, z) (field.rs `visit_ring`): their kernels `[h, gx, gz, ...]`
  // in the window's index order, for the caller to add one by one as the server does; null if
  // none reaches the point.
  _ring(r, x, z, kv) {
    const { ring, state, invR2 } = r;
    const relx = x - ring.center[0];
    const relz = z - ring.center[1];
    const rho = Math.sqrt(relx * relx + relz * relz);
    const rad = ring.radius;
    const d = state.distance;
    if (Math.abs(rho - d) >= rad) return null;
    const n = state.count;
    const dr = d * rho;
    const acc = this._acc ?? (this._acc = []);
    acc.length = 0;
    const dir = this._dir;
    const each = (i) => {
      direction(i, n, dir);
      if (kernel(state.amplitude, relx - dir[0] * d, relz - dir[1] * d, invR2, kv)) acc.push(kv[0], kv[1], kv[2]);
    };
    if (rad * rad >= 4.0 * dr) {
      for (let i = 0; i < n; i++) each(i);
    } else {
      const half = Math.PI * rad / (2.0 * Math.sqrt(dr));
      const per = n / TAU;
      const phi = atan2(relz, relx);
      const lo = Math.floor((phi - half) * per) - 1;
      const hi = Math.ceil((phi + half) * per) + 1;
      if (hi - lo + 1 >= n) {
        for (let i = 0; i < n; i++) each(i);
      } else {
        for (let k = lo; k <= hi; k++) each(((k % n) + n) % n);
      }
    }
    return acc.length ? acc : null;
  }

  /**
   * The particle members of the exported shader's uniform block at t for render origin o, as
   * f32 values (swell-shaders particles.rs `block`): a head (live rings uploaded), each scale's
   * origin offset on its tile, every ambient particle `(u.x, u.z, a, 0)` at t, then
   * MAX_SHADER_RINGS rings `(c − o, d, a), (r, N, 1/r², 0)`. Returns `{values, ringsDropped}`.
   */
  shaderBlock(t, origin, impacts) {
    const live = this.liveRings(t, impacts);
    const kept = Math.min(live.length, MAX_SHADER_RINGS);
    const n = this.count;
    const values = new Float32Array(4 + 8 + 4 * Math.max(n, 1) + 8 * MAX_SHADER_RINGS);
    values[0] = kept;
    for (let k = 0; k < this.scales.length; k++) {
      const inv = 1.0 / (this.scales[k] * this.tile);
      values[4 + 2 * k] = wrap(origin[0] * inv);
      values[4 + 2 * k + 1] = wrap(origin[1] * inv);
    }
    let o = 12;
    for (let i = 0; i < n; i++) {
      values[o] = wrap(this.u0x[i] + this.wx[i] * t);
      values[o + 1] = wrap(this.u0z[i] + this.wz[i] * t);
      values[o + 2] = this.amp[i];
      o += 4;
    }
    if (n === 0) o += 4;
    for (let k = 0; k < kept; k++) {
      const { ring, state } = live[k];
      const r = ring.radius;
      values.set([ring.center[0] - origin[0], ring.center[1] - origin[1], state.distance, state.amplitude,
        r, state.count, 1.0 / (r * r), 0], o + 8 * k);
    }
    return { values, ringsDropped: live.length - kept };
  }
}
