// A small hand-written protobuf codec for the query messages of proto/swell/v1/query.proto:
// SampleRequest, OrientationRequest (encode); SampleResponse, OrientationResponse,
// HeightResponse, ErrorResponse (decode). Doubles travel as little-endian IEEE-754, so a value
// decodes to exactly the double the server encoded. Repeated scalars are decoded packed or
// unpacked (both are valid proto3 encodings); unknown fields are skipped.
// test/live.test.js checks the codec against the Rust server (prost) byte for byte in effect:
// a protobuf request gets the same answer as its JSON twin, and protobuf answers decode to the
// JSON answers' numbers bit for bit.

const FIELD = { height: 1, normal: 2, displacement: 3, jacobian: 4, residual: 5 };
const METHOD = { newton: 1, fixed_point: 2 };
const FILTER = { nearest: 1, bilinear: 2, bicubic: 3 };
const PRECISION = { f64: 1, f32: 2 };
const TIME = { grid: 1, exact: 2 };

class Writer {
  constructor() { this.buf = new Uint8Array(256); this.len = 0; this.dv = new DataView(this.buf.buffer); }
  ensure(n) {
    if (this.len + n <= this.buf.length) return;
    const b = new Uint8Array(Math.max(this.buf.length * 2, this.len + n));
    b.set(this.buf.subarray(0, this.len));
    this.buf = b; this.dv = new DataView(b.buffer);
  }
  varint(v) {
    // Non-negative integers below 2^53 (tags, lengths, enums, uint32).
    this.ensure(10);
    while (v >= 0x80) { this.buf[this.len++] = (v % 0x80) | 0x80; v = Math.floor(v / 0x80); }
    this.buf[this.len++] = v;
  }
  tag(field, wire) { this.varint(field * 8 + wire); }
  double(field, v) { this.tag(field, 1); this.ensure(8); this.dv.setFloat64(this.len, v, true); this.len += 8; }
  message(field, fn) {
    const inner = new Writer(); fn(inner);
    this.tag(field, 2); this.varint(inner.len); this.ensure(inner.len);
    this.buf.set(inner.buf.subarray(0, inner.len), this.len); this.len += inner.len;
  }
  packedVarints(field, vs) {
    if (vs.length === 0) return;
    const inner = new Writer(); for (const v of vs) inner.varint(v);
    this.tag(field, 2); this.varint(inner.len); this.ensure(inner.len);
    this.buf.set(inner.buf.subarray(0, inner.len), this.len); this.len += inner.len;
  }
  finish() { return this.buf.slice(0, this.len); }
}

const point2 = (w, [x, z]) => { w.double(1, x); w.double(2, z); };

function enumOf(table, v, field) {
  const n = table[v];
  if (n === undefined) throw new TypeError(`${field}: ${JSON.stringify(v)} is not one of ${Object.keys(table).join(', ')}`);
  return n;
}

function accuracy(w, a) {
  if (a.method != null) { w.tag(1, 0); w.varint(enumOf(METHOD, a.method, 'accuracy.method')); }
  if (a.iterations != null) { w.tag(2, 0); w.varint(a.iterations); }
  if (a.tolerance != null) w.double(3, a.tolerance);
  if (a.filter != null) { w.tag(4, 0); w.varint(enumOf(FILTER, a.filter, 'accuracy.filter')); }
  if (a.precision != null) { w.tag(5, 0); w.varint(enumOf(PRECISION, a.precision, 'accuracy.precision')); }
  if (a.time != null) { w.tag(6, 0); w.varint(enumOf(TIME, a.time, 'accuracy.time')); }
}

/** `swell.v1.SampleRequest` bytes for a request shaped like the JSON body. */
export function encodeSampleRequest(req) {
  const w = new Writer();
  if (req.t != null) w.double(1, req.t);
  if (req.origin != null) w.message(2, (m) => point2(m, req.origin));
  for (const p of req.points) w.message(3, (m) => point2(m, p));
  if (req.fields) w.packedVarints(4, req.fields.map((f) => enumOf(FIELD, f, 'fields')));
  if (req.accuracy != null) w.message(5, (m) => accuracy(m, req.accuracy));
  return w.finish();
}

/** `swell.v1.OrientationRequest` bytes. */
export function encodeOrientationRequest(req) {
  const w = new Writer();
  if (req.t != null) w.double(1, req.t);
  for (const b of req.bodies) {
    w.message(2, (m) => {
      m.message(1, (p) => point2(p, b.position));
      if (b.yaw != null) m.double(2, b.yaw);
      m.double(3, b.length);
      m.double(4, b.beam);
      for (const p of b.probes ?? []) m.message(5, (q) => point2(q, p));
    });
  }
  return w.finish();
}

class Reader {
  constructor(bytes) {
    this.b = bytes; this.pos = 0;
    this.dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  }
  done() { return this.pos >= this.b.length; }
  varint() {
    let v = 0; let mul = 1;
    for (let i = 0; i < 10; i++) {
      if (this.pos >= this.b.length) throw new RangeError('protobuf: truncated varint');
      const byte = this.b[this.pos++];
      v += (byte & 0x7f) * mul; mul *= 128;
      if (byte < 0x80) return v;
    }
    throw new RangeError('protobuf: varint too long');
  }
  double() {
    if (this.pos + 8 > this.b.length) throw new RangeError('protobuf: truncated double');
    const v = this.dv.getFloat64(this.pos, true); this.pos += 8; return v;
  }
  bytes() {
    const n = this.varint();
    if (this.pos + n > this.b.length) throw new RangeError('protobuf: truncated field');
    const s = this.b.subarray(this.pos, this.pos + n); this.pos += n; return s;
  }
  skip(wire) {
    if (wire === 0) this.varint();
    else if (wire === 1) this.pos += 8;
    else if (wire === 2) this.bytes();
    else if (wire === 5) this.pos += 4;
    else throw new RangeError(`protobuf: unsupported wire type ${wire}`);
  }
  /** Calls `fn(field, wire)` per field; `fn` returns false to have the field skipped. */
  each(fn) {
    while (!this.done()) {
      const key = this.varint();
      const field = Math.floor(key / 8); const wire = key & 7;
      if (fn(field, wire) === false) this.skip(wire);
    }
  }
  /** A repeated double field, packed (wire 2) or not (wire 1), appended to `into`. */
  doubles(wire, into) {
    if (wire === 1) { into.push(this.double()); return; }
    const r = new Reader(this.bytes());
    while (!r.done()) into.push(r.double());
  }
  bools(wire, into) {
    if (wire === 0) { into.push(this.varint() !== 0); return; }
    const r = new Reader(this.bytes());
    while (!r.done()) into.push(r.varint() !== 0);
  }
}

const utf8 = new TextDecoder();

function readVec(bytes, n) {
  const out = new Array(n).fill(0);
  const r = new Reader(bytes);
  r.each((f, w) => {
    if (w === 1 && f >= 1 && f <= n) { out[f - 1] = r.double(); return true; }
    return false;
  });
  return out;
}

/** Decodes `swell.v1.SampleResponse` into the JSON answer's shape (fields asked only). */
export function decodeSampleResponse(bytes) {
  const r = new Reader(bytes);
  const out = { t: 0 };
  const lists = { height: [], normal: [], displacement: [], jacobian: [], folded: [], residual: [] };
  const seen = new Set();
  r.each((f, w) => {
    switch (f) {
      case 1: out.t = r.double(); return true;
      case 2: r.doubles(w, lists.height); seen.add('height'); return true;
      case 3: lists.normal.push(readVec(r.bytes(), 3)); seen.add('normal'); return true;
      case 4: lists.displacement.push(readVec(r.bytes(), 3)); seen.add('displacement'); return true;
      case 5: r.doubles(w, lists.jacobian); seen.add('jacobian'); return true;
      case 6: r.bools(w, lists.folded); seen.add('folded'); return true;
      case 7: r.doubles(w, lists.residual); seen.add('residual'); return true;
      default: return false;
    }
  });
  for (const k of seen) out[k] = lists[k];
  return out;
}

/** Decodes `swell.v1.OrientationResponse`. */
export function decodeOrientationResponse(bytes) {
  const r = new Reader(bytes);
  const out = { t: 0, bodies: [] };
  r.each((f, w) => {
    if (f === 1 && w === 1) { out.t = r.double(); return true; }
    if (f === 2 && w === 2) {
      const b = { heave: 0, rotation: [0, 0, 0, 0], normal: [0, 0, 0], pitch: 0, roll: 0 };
      const br = new Reader(r.bytes());
      br.each((g, v) => {
        if (g === 1 && v === 1) { b.heave = br.double(); return true; }
        if (g === 2 && v === 2) { b.rotation = readVec(br.bytes(), 4); return true; }
        if (g === 3 && v === 2) { b.normal = readVec(br.bytes(), 3); return true; }
        if (g === 4 && v === 1) { b.pitch = br.double(); return true; }
        if (g === 5 && v === 1) { b.roll = br.double(); return true; }
        return false;
      });
      out.bodies.push(b);
      return true;
    }
    return false;
  });
  return out;
}

/** Decodes `swell.v1.HeightResponse`. */
export function decodeHeightResponse(bytes) {
  const r = new Reader(bytes);
  const out = { t: 0, height: 0 };
  r.each((f, w) => {
    if (f === 1 && w === 1) { out.t = r.double(); return true; }
    if (f === 2 && w === 1) { out.height = r.double(); return true; }
    return false;
  });
  return out;
}

/** Decodes `swell.v1.ErrorResponse` into `{code, message, field?}`. */
export function decodeErrorResponse(bytes) {
  const r = new Reader(bytes);
  const out = { code: '', message: '' };
  r.each((f, w) => {
    if (f !== 1 || w !== 2) return false;
    const e = new Reader(r.bytes());
    e.each((g, v) => {
      if (v !== 2) return false;
      const s = utf8.decode(e.bytes());
      if (g === 1) out.code = s; else if (g === 2) out.message = s; else if (g === 3) out.field = s;
      return true;
    });
    return true;
  });
  return out;
}
