// swell-client: the reference JavaScript client for Swell (Node 20+ and browsers, ES modules).
//
// - `SwellClient` (client.js): HTTP queries, JSON or protobuf, typed errors.
// - `SwellSession` (session.js): the WebSocket stream: queries by id, clock sync, tick
//   subscriptions with interest sets, reconnect with backoff and resubscribe.
// - `BodyInterpolator` (interp.js): body states rendered at server time minus a delay.
// - `Surface` (surface.js): local sine/Gerstner evaluation bit-identical to the server, and the
//   frame uniforms of the exported shaders.
// - `FftLayer`, `parseSpectrum` (fft.js): FFT layers from the exported spectrum.
// - `ParticleLayer`, `ImpactSet` (particles.js): wave particles and impact rings, to the
//   server's bits (with the model's exp/atan2/tanh ported in libm.js).
export { SwellClient, checkSceneId, checkSample, checkOrientation } from './client.js';
export { SwellSession, ClockSync, SCENE_GONE } from './session.js';
export { BodyInterpolator } from './interp.js';
export { Surface, normalOf, jacobianOf, DEFAULT_INVERSION } from './surface.js';
export { FftLayer, parseSpectrum, ifft2 } from './fft.js';
export { ParticleLayer, ImpactSet, Ring, canonicalCmp, MAX_RINGS_PER_POINT } from './particles.js';
export { ArgumentError, SwellError, TransportError } from './errors.js';
export { reducePhase, sinCos, roundTiesAway, bitsHex, fromBitsHex } from './math.js';
export {
  encodeSampleRequest, encodeOrientationRequest, decodeSampleResponse,
  decodeOrientationResponse, decodeHeightResponse, decodeErrorResponse,
} from './proto.js';
