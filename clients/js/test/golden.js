// The golden vectors (proto/vectors/surface_v1.json) and a checker shared by the tests.
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
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

