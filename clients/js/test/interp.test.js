import { test } from 'node:test';
import assert from 'node:assert/strict';
import { BodyInterpolator } from '../src/interp.js';
import { ClockSync } from '../src/session.js';

const body = (id, x, vx = 0) => ({ id, position: [x, 0, 0], rotation: [0, 0, 0, 1], velocity: [vx, 0, 0] });

test('interpolates between the frames around t, extrapolates with a bound and flags it', () => {
  const ip = new BodyInterpolator({ delay: 0.1, capacity: 3, maxExtrapolation: 0.2 });
  ip.push({ tick: 30, t: 1.0, bodies: [body(1, 0)] });
  ip.push({ tick: 31, t: 1.1, bodies: [body(1, 1, 10)] });
  let s = ip.sample(1.05).get(1);
  assert.equal(s.mode, 'interpolated');
  assert.ok(Math.abs(s.position[0] - 0.5) < 1e-12);
  s = ip.sample(1.2).get(1);
  assert.equal(s.mode, 'extrapolated');
  assert.ok(Math.abs(s.position[0] - 2.0) < 1e-9);
  s = ip.sample(5).get(1);
  assert.equal(s.mode, 'held');
  assert.ok(Math.abs(s.position[0] - 3.0) < 1e-9, 'extrapolation stops at maxExtrapolation');
  assert.equal(ip.at(1.15).get(1).mode, 'interpolated', 'at() renders delay behind');
  // Bounded: the oldest frame goes.
  ip.push({ tick: 32, t: 1.2, bodies: [body(1, 2)] });
  ip.push({ tick: 33, t: 1.3, bodies: [body(1, 3)] });
  assert.equal(ip.frames.length, 3);
  assert.equal(ip.frameAt(30), null);
  // A clock that ran backwards resets the buffer.
  ip.push({ tick: 10, t: 0.33, bodies: [body(1, 9)] });
  assert.equal(ip.frames.length, 1);
});

test('clock sync takes the offset from the lowest round trips', () => {
  const c = new ClockSync({ best: 2 });
  // True offset 1000 s; symmetric samples with 2 ms RTT, and slow ones with asymmetric delay.
  c.add(0.0, 0.002, 1000.001);
  c.add(1.0, 1.200, 1001.190); // 200 ms RTT, answer late: midpoint is off by 90 ms
  c.add(2.0, 2.002, 1002.001);
  assert.ok(Math.abs(c.offset - 1000) < 1e-9, String(c.offset));
  assert.ok(Math.abs(c.sceneTime(10) - 1010) < 1e-6);
});
