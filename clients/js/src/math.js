// Deterministic maths, ported operation for operation from crates/swell-waves/src/math
// (phase.rs, trig.rs). JavaScript numbers are IEEE-754 doubles and `*`, `+`, `-`, `/` and
// `Math.sqrt` are correctly rounded, so the same operations in the same order give the model's
// bits. `Math.sin`/`Math.cos` are not specified to the bit and are never used for model values.

/** 2π. */
export const TAU = 6.283185307179586;
const INV_TAU = 0.15915494309189535;
// 2π = TAU_1 + TAU_2 + TAU_3 + TAU_4: Cody–Waite pieces of 21 significant bits (phase.rs).
const TAU_1 = 6.283184051513672;
const TAU_2 = 1.2556656656670384e-6;
const TAU_3 = 2.489347703665823e-13;
const TAU_4 = 1.1650928224373424e-19;
const TWO_52 = 4503599627370496.0;

const f64buf = new Float64Array(1);
const u32buf = new Uint32Array(f64buf.buffer);
const LITTLE = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;
const HI = LITTLE ? 1 : 0;

/** Whether the sign bit of `x` is set (true for -0 and negative numbers). */
export function signBit(x) {
  f64buf[0] = x;
  return (u32buf[HI] >>> 31) === 1;
}

/** `|v|` with the sign of `s` (Rust's `f64::copysign`). */
export function copysign(v, s) {
  const neg = signBit(s);
  f64buf[0] = v;
  const hi = u32buf[HI] & 0x7fffffff;
  u32buf[HI] = neg ? (hi | 0x80000000) >>> 0 : hi;
  return f64buf[0];
}

/**
 * Nearest integer, ties away from zero, sign kept (Rust's `f64::round`), computed as the model
 * does (phase.rs `round_ties_away`). `Math.round` rounds ties towards +∞ and is not used.
 */
export function roundTiesAway(x) {
  const c = copysign(TWO_52, x);
  let r = (x + c) - c;
  const d = x - r;
  const half = copysign(0.5, x);
  if (d === half) r = r + 2.0 * half;
  if (Math.abs(x) >= TWO_52) r = x;
  return copysign(r, x);
}

/**
 * Reduces a phase (rad) to [−π, π]: `x − 2π·round(x/2π)` with 2π in four pieces, exact for
 * |x| < 2.7·10¹⁰ rad (phase.rs `reduce_phase`).
 */
export function reducePhase(x) {
  const n = roundTiesAway(x * INV_TAU);
  return ((x - n * TAU_1) - n * TAU_2) - n * TAU_3 - n * TAU_4;
}

const PIO2_1 = 1.5707963267341256;
const PIO2_2 = 6.077100506506192e-11;
const TWO_OVER_PI = 0.6366197723675814;
// fdlibm __kernel_sin / __kernel_cos coefficients (trig.rs).
const S1 = -1.66666666666666324348e-1;
const S2 = 8.33333333332248946124e-3;
const S3 = -1.98412698298579493134e-4;
const S4 = 2.75573137070700676789e-6;
const S5 = -2.50507602534068634195e-8;
const S6 = 1.58969099521155010221e-10;
const C1 = 4.16666666666666019037e-2;
const C2 = -1.38888888888741095749e-3;
const C3 = 2.48015872894767294178e-5;
const C4 = -2.75573143513906633035e-7;
const C5 = 2.08757232129817482790e-9;
const C6 = -1.13596475577881948265e-11;

function kernelSin(y) {
  const z = y * y;
  const r = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
  return y + y * z * (S1 + z * r);
}

function kernelCos(y) {
  const z = y * y;
  const r = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
  const hz = 0.5 * z;
  const w = 1.0 - hz;
  return w + (((1.0 - w) - hz) + z * r);
}

/**
 * `[sin x, cos x]` for finite `x` (rad), the model's kernel to the bit (trig.rs `sin_cos`):
 * reduce to [−π, π], then by quadrant to [−π/4, π/4], fdlibm polynomials, sign flips.
 * Writes into `out` (a 2-array) when given, to avoid an allocation per wave.
 */
export function sinCos(x, out = [0, 0]) {
  const r = reducePhase(x);
  const q = roundTiesAway(r * TWO_OVER_PI);
  const y = (r - q * PIO2_1) - q * PIO2_2;
  const s = kernelSin(y);
  const c = kernelCos(y);
  const odd = Math.abs(q) === 1.0;
  const a = odd ? c : s;
  const b = odd ? s : c;
  const negSin = q === 2.0 || q < -0.5;
  const negCos = q > 0.5 || q === -2.0;
  out[0] = negSin ? -a : a;
  out[1] = negCos ? -b : b;
  return out;
}

/** The hex of a double's IEEE-754 bits, big-endian (as proto/vectors writes them). */
export function bitsHex(x) {
  f64buf[0] = x;
  const hi = u32buf[HI].toString(16).padStart(8, '0');
  const lo = u32buf[1 - HI].toString(16).padStart(8, '0');
  return hi + lo;
}

/** The double whose IEEE-754 bits are the 16 hex digits `hex`. */
export function fromBitsHex(hex) {
  u32buf[HI] = parseInt(hex.slice(0, 8), 16);
  u32buf[1 - HI] = parseInt(hex.slice(8, 16), 16);
  return f64buf[0];
}
