// The model's library functions, ported operation for operation from the `libm` crate the model
// calls (crates/swell-waves/src/math/mod.rs: `exp`, `atan2`), which are themselves ports of
// FreeBSD msun / musl (e_exp.c, s_atan.c, e_atan2.c). JavaScript's `Math.exp` and `Math.atan2`
// are not specified to the bit (engines differ), so model values never use them.
//
// Used by the particle layer: a ring's amplitude `a0/3^g·exp(−d/decay)` and the angular window
// of a ring's particles around `atan2(rel)`.

const f64 = new Float64Array(1);
const u32 = new Uint32Array(f64.buffer);
const LITTLE = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;
const HI = LITTLE ? 1 : 0;
const LO = 1 - HI;

function highWord(x) { f64[0] = x; return u32[HI]; }
function lowWord(x) { f64[0] = x; return u32[LO]; }
function fromWords(hi, lo) { u32[HI] = hi >>> 0; u32[LO] = lo >>> 0; return f64[0]; }

/** `x·2ⁿ` (libm `generic::scalbn` for f64): prescales so that no step rounds twice. */
export function scalbn(x, n) {
  const EXP_MAX = 1023;
  const EXP_MIN = -1022;
  if (n > EXP_MAX) {
    x *= fromWords(0x7fe00000, 0); // 2^1023
    n -= EXP_MAX;
    if (n > EXP_MAX) {
      x *= fromWords(0x7fe00000, 0);
      n -= EXP_MAX;
      if (n > EXP_MAX) n = EXP_MAX;
    }
  } else if (n < EXP_MIN) {
    const mul = fromWords(0x00100000, 0) * fromWords((53 + 1023) << 20, 0); // 2^-1022 · 2^53
    const add = 1022 - 53;
    x *= mul;
    n += add;
    if (n < EXP_MIN) {
      x *= mul;
      n += add;
      if (n < EXP_MIN) n = EXP_MIN;
    }
  }
  return x * fromWords((1023 + n) << 20, 0);
}

const LN2HI = 6.93147180369123816490e-01;
const LN2LO = 1.90821492927058770002e-10;
const INVLN2 = 1.44269504088896338700e+00;
const P1 = 1.66666666666666019037e-01;
const P2 = -2.77777777770155933842e-03;
const P3 = 6.61375632143793436117e-05;
const P4 = -1.65339022054652515390e-06;
const P5 = 4.13813679705723846039e-08;

/** `eˣ`, the libm crate's `exp` (FreeBSD e_exp.c) to the bit. */
export function exp(x) {
  let hx = highWord(x);
  const sign = hx >>> 31;
  hx = (hx & 0x7fffffff) >>> 0;
  if (hx >= 0x4086232b) {
    if (Number.isNaN(x)) return x;
    if (x > 709.782712893383973096) return x * fromWords(0x7fe00000, 0);
    if (x < -708.39641853226410622 && x < -745.13321910194110842) return 0;
  }
  let hi; let lo; let k;
  if (hx > 0x3fd62e42) {
    if (hx >= 0x3ff0a2b2) {
      // `(INVLN2·x + ±0.5) as i32`: truncation towards zero (saturating; |x| < 746 here).
      k = Math.trunc(INVLN2 * x + (sign ? -0.5 : 0.5));
    } else {
      k = 1 - sign - sign;
    }
    hi = x - k * LN2HI;
    lo = k * LN2LO;
    x = hi - lo;
  } else if (hx > 0x3e300000) {
    k = 0;
    hi = x;
    lo = 0;
  } else {
    return 1 + x;
  }
  const xx = x * x;
  const c = x - xx * (P1 + xx * (P2 + xx * (P3 + xx * (P4 + xx * P5))));
  const y = 1 + (x * c / (2 - c) - lo + hi);
  return k === 0 ? y : scalbn(y, k);
}

const ATANHI = [4.63647609000806093515e-01, 7.85398163397448278999e-01, 9.82793723247329054082e-01, 1.57079632679489655800e+00];
const ATANLO = [2.26987774529616870924e-17, 3.06161699786838301793e-17, 1.39033110312309984516e-17, 6.12323399573676603587e-17];
const AT = [
  3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01,
  -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02,
  6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02,
  -3.65315727442169155270e-02, 1.62858201153657823623e-02,
];

/** Arctangent, the libm crate's `atan` (FreeBSD s_atan.c) to the bit. */
export function atan(x) {
  let ix = highWord(x);
  const sign = ix >>> 31;
  ix = (ix & 0x7fffffff) >>> 0;
  if (ix >= 0x44100000) {
    if (Number.isNaN(x)) return x;
    const z = ATANHI[3] + fromWords(0x03800000, 0);
    return sign ? -z : z;
  }
  let id;
  if (ix < 0x3fdc0000) {
    if (ix < 0x3e400000) return x;
    id = -1;
  } else {
    x = Math.abs(x);
    if (ix < 0x3ff30000) {
      if (ix < 0x3fe60000) { x = (2 * x - 1) / (2 + x); id = 0; } else { x = (x - 1) / (x + 1); id = 1; }
    } else if (ix < 0x40038000) {
      x = (x - 1.5) / (1 + 1.5 * x); id = 2;
    } else {
      x = -1 / x; id = 3;
    }
  }
  const z = x * x;
  const w = z * z;
  const s1 = z * (AT[0] + w * (AT[2] + w * (AT[4] + w * (AT[6] + w * (AT[8] + w * AT[10])))));
  const s2 = w * (AT[1] + w * (AT[3] + w * (AT[5] + w * (AT[7] + w * AT[9]))));
  if (id < 0) return x - x * (s1 + s2);
  const r = ATANHI[id] - (x * (s1 + s2) - ATANLO[id] - x);
  return sign ? -r : r;
}

const PI = 3.1415926535897931160E+00;
const PI_LO = 1.2246467991473531772E-16;

/** Four-quadrant arctangent of y/x, the libm crate's `atan2` (FreeBSD e_atan2.c) to the bit. */
export function atan2(y, x) {
  if (Number.isNaN(x) || Number.isNaN(y)) return x + y;
  let ix = highWord(x);
  const lx = lowWord(x);
  let iy = highWord(y);
  const ly = lowWord(y);
  if ((((ix - 0x3ff00000) >>> 0) | lx) === 0) return atan(y);
  const m = ((iy >>> 31) & 1) | ((ix >>> 30) & 2);
  ix = (ix & 0x7fffffff) >>> 0;
  iy = (iy & 0x7fffffff) >>> 0;
  if ((iy | ly) === 0) {
    if (m <= 1) return y;
    return m === 2 ? PI : -PI;
  }
  if ((ix | lx) === 0) return m & 1 ? -PI / 2 : PI / 2;
  if (ix === 0x7ff00000) {
    if (iy === 0x7ff00000) return [PI / 4, -PI / 4, 3 * PI / 4, -3 * PI / 4][m];
    return [0, -0, PI, -PI][m];
  }
  if (((ix + (64 << 20)) >>> 0) < iy || iy === 0x7ff00000) return m & 1 ? -PI / 2 : PI / 2;
  const z = (m & 2) && ((iy + (64 << 20)) >>> 0) < ix ? 0 : atan(Math.abs(y / x));
  switch (m) {
    case 0: return z;
    case 1: return -z;
    case 2: return PI - (z - PI_LO);
    default: return (z - PI_LO) - PI;
  }
}

const O_THRESHOLD = 7.09782712893383973096e+02;
const Q1 = -3.33333333333331316428e-02;
const Q2 = 1.58730158725481460165e-03;
const Q3 = -7.93650757867487942473e-05;
const Q4 = 4.00821782732936239552e-06;
const Q5 = -2.01099218183624371326e-07;

/** `eˣ − 1`, the libm crate's `expm1` (FreeBSD s_expm1.c) to the bit. */
export function expm1(x) {
  const hw = highWord(x);
  const hx = (hw & 0x7fffffff) >>> 0;
  const sign = hw >>> 31;
  if (hx >= 0x4043687a) {
    if (Number.isNaN(x)) return x;
    if (sign) return -1;
    if (x > O_THRESHOLD) return x * fromWords(0x7fe00000, 0);
  }
  let hi; let lo; let k; let c;
  if (hx > 0x3fd62e42) {
    if (hx < 0x3ff0a2b2) {
      if (!sign) { hi = x - LN2HI; lo = LN2LO; k = 1; } else { hi = x + LN2HI; lo = -LN2LO; k = -1; }
    } else {
      k = Math.trunc(INVLN2 * x + (sign ? -0.5 : 0.5));
      hi = x - k * LN2HI;
      lo = k * LN2LO;
    }
    x = hi - lo;
    c = (hi - x) - lo;
  } else if (hx < 0x3c900000) {
    return x;
  } else {
    c = 0;
    k = 0;
  }
  const hfx = 0.5 * x;
  const hxs = x * hfx;
  const r1 = 1 + hxs * (Q1 + hxs * (Q2 + hxs * (Q3 + hxs * (Q4 + hxs * Q5))));
  const t = 3 - r1 * hfx;
  let e = hxs * ((r1 - t) / (6 - x * t));
  if (k === 0) return x - (x * e - hxs);
  e = x * (e - c) - c;
  e -= hxs;
  if (k === -1) return 0.5 * (x - e) - 0.5;
  if (k === 1) {
    if (x < -0.25) return -2 * (e - (x + 0.5));
    return 1 + 2 * (x - e);
  }
  const twopk = fromWords((0x3ff + k) << 20, 0);
  if (k < 0 || k > 56) {
    let y = x - e + 1;
    y = k === 1024 ? y * 2 * fromWords(0x7fe00000, 0) : y * twopk;
    return y - 1;
  }
  const uf = fromWords((0x3ff - k) << 20, 0);
  return k < 20 ? (x - e + (1 - uf)) * twopk : (x - (e + uf) + 1) * twopk;
}

/** Hyperbolic tangent, the libm crate's `tanh` (musl tanh.c) to the bit. */
export function tanh(x) {
  const sign = highWord(x) >>> 31;
  x = Math.abs(x);
  const w = highWord(x);
  let t;
  if (w > 0x3fe193ea) {
    if (w > 0x40340000) {
      t = 1 - 0 / x;
    } else {
      t = expm1(2 * x);
      t = 1 - 2 / (t + 2);
    }
  } else if (w > 0x3fd058ae) {
    t = expm1(2 * x);
    t = t / (t + 2);
  } else if (w >= 0x00100000) {
    t = expm1(-2 * x);
    t = -t / (t + 2);
  } else {
    t = x;
  }
  return sign ? -t : t;
}
