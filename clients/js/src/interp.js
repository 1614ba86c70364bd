// Body-state interpolation: render bodies at server time minus a delay, between the two tick
// frames around that time. Beyond the newest frame the state is extrapolated along its velocity
// for at most `maxExtrapolation` seconds and flagged; before the oldest it is held and flagged.

/** Spherical interpolation between unit quaternions [x, y, z, w] (shortest arc). */
export function slerp(a, b, u) {
  let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  let bb = b;
  if (dot < 0) { dot = -dot; bb = b.map((v) => -v); }
  if (dot > 0.9995) {
    const q = a.map((v, i) => v + (bb[i] - v) * u);
    const n = Math.hypot(...q);
    return q.map((v) => v / n);
  }
  const th = Math.acos(dot);
  const s = Math.sin(th);
  const wa = Math.sin((1 - u) * th) / s, wb = Math.sin(u * th) / s;
  return a.map((v, i) => wa * v + wb * bb[i]);
}

/**
 * A bounded buffer of tick frames (`{tick, t, bodies}`) and the states between them.
 * Options: `delay` (s behind server time to render, default 0.1 = 3 ticks at 30 Hz),
 * `capacity` (frames kept, default 64), `maxExtrapolation` (s, default 0.25).
 */
export class BodyInterpolator {
  constructor({ delay = 0.1, capacity = 64, maxExtrapolation = 0.25 } = {}) {
    this.delay = delay;
    this.capacity = capacity;
    this.maxExtrapolation = maxExtrapolation;
    this.frames = [];
  }

  /** Adds a tick frame. A frame older than the newest (the clock ran back or seeked) resets. */
  push(frame) {
    const last = this.frames[this.frames.length - 1];
    if (last && frame.t <= last.t) {
      if (frame.t === last.t) return;
      this.frames = [];
    }
    const byId = new Map(frame.bodies.map((b) => [b.id, b]));
    this.frames.push({ tick: frame.tick, t: frame.t, bodies: frame.bodies, byId });
    if (this.frames.length > this.capacity) this.frames.shift();
  }

  /** The frame of tick `tick`, if still buffered. */
  frameAt(tick) { return this.frames.find((f) => f.tick === tick) ?? null; }

  /** States at `serverTime − delay`. */
  at(serverTime) { return this.sample(serverTime - this.delay); }

  /**
   * Every body's state at scene time `t`: a Map id → `{id, position, rotation, t, mode}` where
   * mode is 'interpolated', 'extrapolated' (past the newest frame, ≤ maxExtrapolation),
   * 'held' (past that bound, or before the oldest frame) — anything but 'interpolated' is a flag.
   */
  sample(t) {
    const out = new Map();
    const fr = this.frames;
    if (fr.length === 0) return out;
    const newest = fr[fr.length - 1];
    if (t >= newest.t) {
      const dt = Math.min(t - newest.t, this.maxExtrapolation);
      const mode = t - newest.t <= this.maxExtrapolation ? (t === newest.t ? 'interpolated' : 'extrapolated') : 'held';
      for (const b of newest.bodies) {
        out.set(b.id, {
          id: b.id, t, mode, tick: newest.tick,
          position: b.position.map((p, i) => p + (b.velocity?.[i] ?? 0) * dt),
          rotation: b.rotation,
        });
      }
      return out;
    }
    if (t <= fr[0].t) {
      for (const b of fr[0].bodies) out.set(b.id, { id: b.id, t, mode: 'held', tick: fr[0].tick, position: b.position, rotation: b.rotation });
      return out;
    }
    let k = fr.length - 1;
    while (k > 0 && fr[k - 1].t > t) k--;
    const a = fr[k - 1], b = fr[k];
    const u = (t - a.t) / (b.t - a.t);
    for (const sb of b.bodies) {
      const sa = a.byId.get(sb.id);
      if (!sa) { out.set(sb.id, { id: sb.id, t, mode: 'held', tick: b.tick, position: sb.position, rotation: sb.rotation }); continue; }
      out.set(sb.id, {
        id: sb.id, t, mode: 'interpolated', tick: a.tick,
        position: sa.position.map((p, i) => p + (sb.position[i] - p) * u),
        rotation: slerp(sa.rotation, sb.rotation, u),
      });
    }
    return out;
  }
}
