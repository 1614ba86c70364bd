// HTTP client for a Swell server. Every method checks its arguments before any request
// (throwing `ArgumentError` naming the field) and turns the server's error answers into
// `SwellError` with the server's code, message and field.

import { ArgumentError, SwellError, TransportError } from './errors.js';
import {
  encodeSampleRequest, encodeOrientationRequest, decodeSampleResponse,
  decodeOrientationResponse, decodeHeightResponse, decodeErrorResponse,
} from './proto.js';
import { parseSpectrum } from './fft.js';

const PROTOBUF = 'application/x-protobuf';
const SCENE_ID = /^[a-z0-9-]{1,64}$/;
const FIELDS = ['height', 'normal', 'displacement', 'jacobian', 'residual'];
const LANGS = ['wgsl', 'glsl', 'glsl_es', 'hlsl', 'msl', 'hlsl_include', 'gdshaderinc'];
const ENTRIES = ['swell_vs', 'swell_probe_vs', 'swell_probe_fs'];
// An FFT layer's passes (docs/clients.md, FFT layers): these need `layer`.
const FFT_ENTRIES = ['swell_fft_vs', 'swell_fft_evolve', 'swell_fft_butterfly', 'swell_fft_evolve_cs', 'swell_fft_butterfly_cs'];
const ACCURACY = {
  method: ['newton', 'fixed_point'],
  filter: ['nearest', 'bilinear', 'bicubic'],
  precision: ['f64', 'f32'],
  time: ['grid', 'exact'],
};

// --- argument checks, shared with the WebSocket session -------------------------------------

export function checkSceneId(id) {
  if (typeof id !== 'string' || !SCENE_ID.test(id)) {
    throw new ArgumentError('scene', `scene id ${JSON.stringify(id)} must match [a-z0-9-]{1,64}`);
  }
  return id;
}

export function checkFinite(field, v) {
  if (typeof v !== 'number' || !Number.isFinite(v)) {
    throw new ArgumentError(field, `${field} must be a finite number, got ${String(v)}`);
  }
  return v;
}

function checkOptTime(t) {
  if (t !== undefined && t !== null) checkFinite('t', t);
}

function checkXZ(field, p) {
  if (!Array.isArray(p) && !(p instanceof Float64Array) || p.length !== 2) {
    throw new ArgumentError(field, `${field} must be [x, z], got ${JSON.stringify(p)}`);
  }
  checkFinite(`${field}[0]`, p[0]);
  checkFinite(`${field}[1]`, p[1]);
}

/** Checks a sample request (the JSON body of POST …/sample) and returns it. */
export function checkSample(req) {
  if (!req || typeof req !== 'object') throw new ArgumentError('request', 'a sample request is an object');
  checkOptTime(req.t);
  if (req.origin != null) checkXZ('origin', req.origin);
  if (!Array.isArray(req.points)) throw new ArgumentError('points', 'points must be an array of [x, z]');
  req.points.forEach((p, i) => checkXZ(`points[${i}]`, p));
  if (req.fields != null) {
    if (!Array.isArray(req.fields)) throw new ArgumentError('fields', 'fields must be an array of names');
    for (const f of req.fields) {
      if (!FIELDS.includes(f)) throw new ArgumentError('fields', `unknown field ${JSON.stringify(f)}: one of ${FIELDS.join(', ')}`);
    }
  }
  if (req.accuracy != null) {
    const a = req.accuracy;
    for (const [k, allowed] of Object.entries(ACCURACY)) {
      if (a[k] != null && !allowed.includes(a[k])) {
        throw new ArgumentError(`accuracy.${k}`, `accuracy.${k} = ${JSON.stringify(a[k])}: one of ${allowed.join(', ')}`);
      }
    }
    if (a.iterations != null && !(Number.isInteger(a.iterations) && a.iterations >= 0 && a.iterations <= 64)) {
      throw new ArgumentError('accuracy.iterations', `accuracy.iterations = ${a.iterations}: an integer in [0, 64]`);
    }
    if (a.tolerance != null && !(Number.isFinite(a.tolerance) && a.tolerance >= 0)) {
      throw new ArgumentError('accuracy.tolerance', `accuracy.tolerance = ${a.tolerance}: a finite number >= 0 (m)`);
    }
  }
  return req;
}

/** Checks an orientation request (the JSON body of POST …/orientation) and returns it. */
export function checkOrientation(req) {
  if (!req || typeof req !== 'object') throw new ArgumentError('request', 'an orientation request is an object');
  checkOptTime(req.t);
  if (!Array.isArray(req.bodies)) throw new ArgumentError('bodies', 'bodies must be an array');
  req.bodies.forEach((b, i) => {
    const f = `bodies[${i}]`;
    checkXZ(`${f}.position`, b.position);
    if (b.yaw != null) checkFinite(`${f}.yaw`, b.yaw);
    for (const k of ['length', 'beam']) {
      checkFinite(`${f}.${k}`, b[k]);
      if (!(b[k] > 0)) throw new ArgumentError(`${f}.${k}`, `${f}.${k} must be > 0 m, got ${b[k]}`);
    }
    if (b.probes != null) b.probes.forEach((p, j) => checkXZ(`${f}.probes[${j}]`, p));
  });
  return req;
}

// --- the client ---------------------------------------------------------------------------

/**
 * HTTP client. `new SwellClient('http://127.0.0.1:8080', {wire: 'protobuf'})`.
 * Options: `wire` ('json' default, or 'protobuf' for sample/orientation/height), `fetch` (an
 * implementation; default the global one), `adminToken` (only for the admin helpers).
 */
export class SwellClient {
  constructor(baseUrl, options = {}) {
    if (typeof baseUrl !== 'string' || !/^https?:\/\//.test(baseUrl)) {
      throw new ArgumentError('baseUrl', `baseUrl must be an http(s) URL, got ${JSON.stringify(baseUrl)}`);
    }
    if (options.wire != null && !['json', 'protobuf'].includes(options.wire)) {
      throw new ArgumentError('wire', `wire must be 'json' or 'protobuf', got ${JSON.stringify(options.wire)}`);
    }
    this.baseUrl = baseUrl.replace(/\/+$/, '');
    this.wire = options.wire ?? 'json';
    this.fetch = options.fetch ?? globalThis.fetch.bind(globalThis);
    this.adminToken = options.adminToken;
  }

  /** The WebSocket URL of a scene's stream. */
  streamUrl(scene) {
    return `${this.baseUrl.replace(/^http/, 'ws')}/v1/scenes/${checkSceneId(scene)}/stream`;
  }

  async _request(method, path, { body, contentType, accept, admin } = {}) {
    const headers = {};
    if (contentType) headers['content-type'] = contentType;
    if (accept) headers.accept = accept;
    if (admin) {
      if (!this.adminToken) throw new ArgumentError('adminToken', 'this call needs the admin token (options.adminToken)');
      headers.authorization = `Bearer ${this.adminToken}`;
    }
    let resp;
    try {
      resp = await this.fetch(this.baseUrl + path, { method, headers, body });
    } catch (e) {
      throw new TransportError(`${method} ${path}: ${e.message}`, e);
    }
    if (!resp.ok) {
      const ct = resp.headers.get('content-type') ?? '';
      let err = { code: 'http_' + resp.status, message: resp.statusText };
      try {
        if (ct.includes('protobuf')) err = decodeErrorResponse(new Uint8Array(await resp.arrayBuffer()));
        else err = (await resp.json()).error ?? err;
      } catch { /* keep the status line */ }
      throw new SwellError(resp.status, err.code, err.message, err.field);
    }
    return resp;
  }

  async _json(method, path, opts) {
    return (await this._request(method, path, opts)).json();
  }

  /** GET /v1/scenes: `{scenes: [{id, description, layers, tick_hz}]}`. */
  scenes() { return this._json('GET', '/v1/scenes'); }

  /** GET /v1/scenes/{id}: spec, derived (every built wave), model_version, spec_hash, clock. */
  scene(id) { return this._json('GET', `/v1/scenes/${checkSceneId(id)}`); }

  /** GET /v1/scenes/{id}/clock: `{t, tick, tick_hz, rate, paused, unix, generation}`. */
  clock(id) { return this._json('GET', `/v1/scenes/${checkSceneId(id)}/clock`); }

  /**
   * PUT /v1/scenes/{id}/clock (admin): seek (`t`), `rate` and/or `paused`, in that order; the
   * reading after the change (its `generation` one more than before).
   */
  setClock(id, { t, rate, paused } = {}) {
    const body = {};
    if (t !== undefined) body.t = checkFinite('t', t);
    if (rate !== undefined) body.rate = checkFinite('rate', rate);
    if (paused !== undefined) {
      if (typeof paused !== 'boolean') throw new ArgumentError('paused', 'paused must be a boolean');
      body.paused = paused;
    }
    return this._json('PUT', `/v1/scenes/${checkSceneId(id)}/clock`, { body: JSON.stringify(body), contentType: 'application/json', admin: true });
  }

  /** GET …/height: `{t, height}` at world (x, z); `t` omitted = the scene's now. */
  async height(id, x, z, { t } = {}) {
    checkSceneId(id); checkFinite('x', x); checkFinite('z', z); checkOptTime(t);
    const q = new URLSearchParams({ x: String(x), z: String(z) });
    if (t != null) q.set('t', String(t));
    const path = `/v1/scenes/${id}/height?${q}`;
    if (this.wire === 'protobuf') {
      const r = await this._request('GET', path, { accept: PROTOBUF });
      return decodeHeightResponse(new Uint8Array(await r.arrayBuffer()));
    }
    return this._json('GET', path);
  }

  /** POST …/sample: `{t, height: [...], normal?: [[x,y,z]...], ...}`. */
  async sample(id, req, { wire = this.wire } = {}) {
    checkSceneId(id); checkSample(req);
    const path = `/v1/scenes/${id}/sample`;
    if (wire === 'protobuf') {
      const r = await this._request('POST', path, { body: encodeSampleRequest(req), contentType: PROTOBUF, accept: PROTOBUF });
      return decodeSampleResponse(new Uint8Array(await r.arrayBuffer()));
    }
    return this._json('POST', path, { body: JSON.stringify(req), contentType: 'application/json' });
  }

  /** POST …/orientation: `{t, bodies: [{heave, rotation, normal, pitch, roll}]}`. */
  async orientation(id, req, { wire = this.wire } = {}) {
    checkSceneId(id); checkOrientation(req);
    const path = `/v1/scenes/${id}/orientation`;
    if (wire === 'protobuf') {
      const r = await this._request('POST', path, { body: encodeOrientationRequest(req), contentType: PROTOBUF, accept: PROTOBUF });
      return decodeOrientationResponse(new Uint8Array(await r.arrayBuffer()));
    }
    return this._json('POST', path, { body: JSON.stringify(req), contentType: 'application/json' });
  }

  /** GET …/shader?lang=&entry=: `{text, modelVersion, specHash, etag}`. */
  async shader(id, lang, { entry, layer } = {}) {
    checkSceneId(id);
    if (!LANGS.includes(lang)) throw new ArgumentError('lang', `lang ${JSON.stringify(lang)}: one of ${LANGS.join(', ')}`);
    const all = [...ENTRIES, ...FFT_ENTRIES];
    if (entry != null && !all.includes(entry)) throw new ArgumentError('entry', `entry ${JSON.stringify(entry)}: one of ${all.join(', ')}`);
    const fft = FFT_ENTRIES.includes(entry);
    if (fft !== (layer != null)) throw new ArgumentError('layer', fft ? `entry ${entry} needs the FFT layer's index` : 'layer is only for the FFT pass entry points');
    if (fft && !(Number.isInteger(layer) && layer >= 0)) throw new ArgumentError('layer', `layer must be a layer index, got ${JSON.stringify(layer)}`);
    const q = new URLSearchParams({ lang });
    if (entry) q.set('entry', entry);
    if (fft) q.set('layer', String(layer));
    const r = await this._request('GET', `/v1/scenes/${id}/shader?${q}`);
    return {
      text: await r.text(),
      modelVersion: Number(r.headers.get('swell-model-version')),
      specHash: r.headers.get('swell-spec-hash'),
      etag: r.headers.get('etag'),
    };
  }

  /** GET …/uniforms?t=&origin=x,z: `{t, origin, phases, block, ...}` as the server computes it. */
  uniforms(id, { t, origin } = {}) {
    checkSceneId(id); checkOptTime(t);
    const q = new URLSearchParams();
    if (t != null) q.set('t', String(t));
    if (origin != null) { checkXZ('origin', origin); q.set('origin', `${origin[0]},${origin[1]}`); }
    return this._json('GET', `/v1/scenes/${id}/uniforms?${q}`);
  }

  /** GET …/spectrum?layer=N, parsed (see fft.js `parseSpectrum`). */
  async spectrum(id, layer) {
    checkSceneId(id);
    if (!Number.isInteger(layer) || layer < 0) throw new ArgumentError('layer', `layer must be a layer index >= 0, got ${layer}`);
    const r = await this._request('GET', `/v1/scenes/${id}/spectrum?layer=${layer}`);
    return parseSpectrum(new Uint8Array(await r.arrayBuffer()));
  }

  /**
   * GET …/impacts[?t=]: `{t, impacts: [{tick, t, position, strength, radius}]}`, every impact
   * that can still be rippling at t (default the scene's now) or later, in canonical order.
   * Feed them, and the `impacts` of tick frames, to `surface.impacts` (particles.js ImpactSet).
   */
  impacts(id, { t } = {}) {
    checkSceneId(id); checkOptTime(t);
    return this._json('GET', `/v1/scenes/${id}/impacts${t != null ? `?t=${t}` : ''}`);
  }

  /**
   * POST …/impacts (admin): a splash `{position: [x, z], t?, strength, radius}` → `{tick, t,
   * body_tick?}` (202); `body_tick`, on a scene with bodies: the scene tick they feel it from
   * (tick frames carry it on the impact too).
   */
  addImpact(id, impact) {
    checkSceneId(id);
    if (!impact || typeof impact !== 'object') throw new ArgumentError('impact', 'an impact is an object');
    checkXZ('position', impact.position);
    checkOptTime(impact.t);
    checkFinite('strength', impact.strength);
    checkFinite('radius', impact.radius);
    return this._json('POST', `/v1/scenes/${id}/impacts`, { body: JSON.stringify(impact), contentType: 'application/json', admin: true });
  }

  /** GET …/bodies: `{tick, t, anchor_tick?, bodies: [...], felt_impacts?: [{body_tick, t, position, strength, radius}]}`. */
  bodies(id) { return this._json('GET', `/v1/scenes/${checkSceneId(id)}/bodies`); }

  /** GET …/bodies/{bid}. */
  body(id, bid) {
    checkSceneId(id);
    if (!Number.isSafeInteger(bid) || bid < 0) throw new ArgumentError('body', `body id must be an integer >= 0, got ${bid}`);
    return this._json('GET', `/v1/scenes/${id}/bodies/${bid}`);
  }

  // --- admin helpers (need options.adminToken; the viewer never calls these) ---------------

  /** POST …/bodies (admin): spawn a floating body; returns its state (201). */
  spawnBody(id, spec) {
    checkSceneId(id);
    if (!spec || typeof spec !== 'object') throw new ArgumentError('body', 'a body spec is an object');
    return this._json('POST', `/v1/scenes/${id}/bodies`, { body: JSON.stringify(spec), contentType: 'application/json', admin: true });
  }

  /** PUT /v1/scenes/{id} (admin): create or replace a scene. */
  putScene(id, spec) {
    checkSceneId(id);
    return this._json('PUT', `/v1/scenes/${id}`, { body: JSON.stringify(spec), contentType: 'application/json', admin: true });
  }

  /** DELETE /v1/scenes/{id} (admin): resolves when deleted (204). */
  async deleteScene(id) {
    checkSceneId(id);
    await this._request('DELETE', `/v1/scenes/${id}`, { admin: true });
  }
}
